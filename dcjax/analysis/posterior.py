"""Posterior sampling of a fit's search vector with NUTS (blackjax) through the differentiable simulator.

The posterior is p(x | data) ∝ L(x) p(x): L the fit's likelihood under its loss's noise model
(`dcjax.simulation.likelihood`: Gaussian for SSE, Laplace for L1, Huber for Huber; each channel's
scale from the residuals at the optimum, held), p(x) the prior of the search space: uniform in
each free entry's range, log-uniform where it is searched on a log scale (`Parameter(scale="log")`),
or a parameter's own `Parameter(prior=...)` within the same range (`dcjax.models.priors`).
Initial states, offsets and delays that the fit fitted are sampled with the model's parameters.

NUTS runs on theta in R^F with z = tri(theta), the triangle wave of period 2 (z = theta on [0, 1],
2 - theta on [1, 2], ...) and z the unit-cube coordinate of `Space`: the target on theta is the
even periodic extension of the posterior in z, whose unit Jacobian keeps the prior uniform and
makes the box's walls reflecting. A logit map instead would stretch a parameter whose posterior
touches a bound (a load torque at 0) into an exponential tail that NUTS crosses with trees of a
thousand steps. Chains start at the optimum, jittered by the Laplace approximation (the Fisher
information of the noise model, plus 12 I for the uniform prior's variance 1/12 in z), whose
covariance also seeds the dense mass matrix of Stan's window adaptation (`nuts_chain`: blackjax's
`window_adaptation` to the bit, its warm-up and the draws one loop over one NUTS kernel, compiled
once). Diagnostics are Vehtari et al. (2021)'s rank-normalised split R-hat and bulk and tail ESS
(`sample_size`: Stan's and ArviZ's estimators, in NumPy). blackjax rather than numpyro: dcjax already has a log
density as a pure JAX function of a vector, which is blackjax's whole interface (no model DSL), and
its kernels map or vmap over chains."""

import dataclasses
import time
from collections.abc import Mapping

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from ..compiling import filter_jit
from ..errors import ConfigError, check_seed
from ..extras import optional_module
from ..io.files import write_atomic
from ..models.priors import Prior, prior_from_spec
from ..models.space import Space
from ..simulation.joint import JointProblem
from ..simulation.likelihood import NoiseModel, filter_likelihood, fit_noise, likelihood_target, noise_free, noise_names, whitened_residuals
from ..simulation.losses import Loss
from . import sample_size
from .nuts_chain import ChainState, chain_steps, initial_chains
from .reflection import reflecting_verlet

# The step size's target acceptance in the warm-up (Stan's adapt_delta; blackjax's default 0.8).
# SD1 with 1 % noise on log parameters (a curved posterior), 4 x 1000 draws, seeds 0-3: at 0.8
# 56-154 divergent draws, R-hat up to 1.048 and bulk ESS 83-209 in three of four seeds; at 0.9
# 0-12, <= 1.008 and 413-692 (bulk ESS/s 70-100 against 17-39). On Table 4's Gaussian-like
# posterior 0.9 costs 6.4 leapfrog steps a draw against 5.9 (5206 against 6242 ESS/s).
TARGET_ACCEPTANCE = 0.9
WALL_TOL = 1e-9  # how far outside the unit cube (in z) rounding may leave a reflected position


@dataclasses.dataclass(frozen=True)
class Posterior:
    """Draws of the free entries of a fit's search vector, (chains, draws, F) in physical units,
    with their diagnostics and the noise model they were drawn under."""

    names: tuple[str, ...]
    draws: np.ndarray  # (chains, draws, F)
    optimum: dict[str, float]
    rhat: dict[str, float]
    ess_bulk: dict[str, float]
    ess_tail: dict[str, float]
    divergences: int
    steps: float  # mean leapfrog steps per draw
    acceptance: float
    likelihood: str  # "Gaussian", "Laplace", "Huber"
    noise: dict[str, float]  # "recording:channel" -> the noise scale in the channel's units
    wall: dict[str, float]  # seconds: "warmup" (with the compilation of warmup and sampling), "sampling" (the draws alone)
    seed: int
    priors: dict[str, str] = dataclasses.field(default_factory=dict)  # name -> prior spec where not uniform in the range
    result_sha256: str | None = None  # of the result.json sampled, where saved with it (`save`)
    # per draw (chains, draws): diverging, n_steps, acceptance_rate, energy, tree_depth, lp (the log
    # density of the whitened draw), step_size: ArviZ's sample_stats (`to_arviz`)
    sample_stats: dict[str, np.ndarray] = dataclasses.field(default_factory=dict, repr=False)

    def to_arviz(self, observed_data: "Mapping[str, np.ndarray] | None" = None):
        """The draws as ArviZ data (ArviZ >= 1.0: an `xarray.DataTree` from `arviz.from_dict`; 0.x:
        `InferenceData`): `posterior` (a variable per free entry), `sample_stats` (per draw:
        energy, diverging, tree_depth, n_steps, step_size, acceptance_rate, lp) and, where given,
        `observed_data` (name -> array, e.g. the recording's channels). Needs ArviZ
        (`dcjax[notebook]`)."""
        az = optional_module("arviz", "Posterior.to_arviz")
        groups = {"posterior": {n: self.draws[..., k] for k, n in enumerate(self.names)}, "sample_stats": dict(self.sample_stats)}
        if observed_data:
            groups["observed_data"] = {k: np.asarray(v) for k, v in observed_data.items()}
        if int(str(az.__version__).split(".")[0]) >= 1:
            return az.from_dict(groups)
        return az.from_dict(**groups)

    def interval(self, name: str, prob: float = 0.9) -> tuple[float, float]:
        """The central `prob` interval of `name`'s draws (all chains)."""
        d = self.draws[..., self.names.index(name)].ravel()
        return float(np.quantile(d, (1 - prob) / 2)), float(np.quantile(d, (1 + prob) / 2))

    @property
    def mean(self) -> dict[str, float]:
        return {n: float(self.draws[..., k].mean()) for k, n in enumerate(self.names)}

    @property
    def sd(self) -> dict[str, float]:
        return {n: float(self.draws[..., k].std(ddof=1)) for k, n in enumerate(self.names)}

    @property
    def ess_per_second(self) -> float:
        """The least bulk ESS over the parameters per second of sampling (warmup excluded)."""
        return min(self.ess_bulk.values()) / max(self.wall["sampling"], 1e-12)

    def table(self, linearised: dict[str, tuple[float, float]] | None = None) -> str:
        """One row per sampled entry: optimum, posterior mean and sd, 90 % interval, the linearised
        90 % interval beside it where given, R-hat, bulk and tail ESS."""
        w = max(6, *(len(n) for n in self.names))
        head = f"{'param':>{w}} {'optimum':>12} {'mean':>12} {'sd':>10} {'90 % posterior':>27}"
        head += f" {'90 % linearised':>27}" if linearised is not None else ""
        lines = [head + f" {'R-hat':>6} {'ESS bulk':>8} {'ESS tail':>8}"]
        mean, sd = self.mean, self.sd
        for n in self.names:
            lo, hi = self.interval(n)
            row = f"{n:>{w}} {self.optimum[n]:12.6g} {mean[n]:12.6g} {sd[n]:10.3g} [{lo:12.6g}, {hi:12.6g}]"
            if linearised is not None:
                a, b = linearised.get(n, (np.nan, np.nan))
                row += f" [{a:12.6g}, {b:12.6g}]" if np.isfinite(a) and np.isfinite(b) else f" {'-':>27}"
            lines.append(row + f" {self.rhat[n]:6.3f} {self.ess_bulk[n]:8.0f} {self.ess_tail[n]:8.0f}")
        c, d = self.draws.shape[:2]
        lines.append(
            f"{c} chains x {d} draws (NUTS): {self.divergences} divergent, {self.steps:.1f} leapfrog steps a draw, "
            f"acceptance {self.acceptance:.2f}; warmup {self.wall['warmup']:.1f} s, sampling {self.wall['sampling']:.1f} s "
            f"({self.ess_per_second:.1f} bulk ESS/s, the least over the parameters)"
        )
        noise = ", ".join(f"{k} {v:.3g}" for k, v in self.noise.items())
        scales = (
            f", noise scale per channel (from the residuals at the optimum): {noise}"
            if noise
            else " (its noise sampled with the parameters)"
        )
        lines.append(f"likelihood: {self.likelihood}{scales}")
        own = "".join(f", {n} {p}" for n, p in self.priors.items())
        lines.append(f"prior: uniform in each search range (log-uniform on a log scale){own and ', except' + own[1:]}")
        return "\n".join(lines)

    def save(self, path, result_sha256: str | None = None) -> None:
        """The draws and diagnostics as an .npz (arrays `draws` (chains, draws, F), `names`, ...),
        written atomically; `result_sha256`: the sha256 of the result.json sampled (`dcjax report`
        takes a posterior.npz beside a result for it only where they match)."""

        def write(tmp):
            with open(tmp, "wb") as f:
                self._savez(f, result_sha256)

        write_atomic(path, write)

    def _savez(self, f, result_sha256) -> None:
        np.savez(
            f,
            result_sha256=np.array(result_sha256 or self.result_sha256 or ""),
            draws=self.draws,
            names=np.array(self.names),
            rhat=np.array([self.rhat[n] for n in self.names]),
            ess_bulk=np.array([self.ess_bulk[n] for n in self.names]),
            ess_tail=np.array([self.ess_tail[n] for n in self.names]),
            optimum=np.array([self.optimum[n] for n in self.names]),
            divergences=self.divergences,
            seed=self.seed,
            steps=self.steps,
            acceptance=self.acceptance,
            wall=np.array([self.wall["warmup"], self.wall["sampling"]]),
            likelihood=self.likelihood,
            noise_names=np.array(list(self.noise)),
            noise=np.array(list(self.noise.values())),
            prior_names=np.array(list(self.priors), dtype=str),
            priors=np.array(list(self.priors.values()), dtype=str),
            **{f"stat_{k}": v for k, v in self.sample_stats.items()},  # pyright: ignore[reportArgumentType]
        )

    @classmethod
    def load(cls, path) -> "Posterior":
        """A `Posterior` saved by `save` (posterior.npz of `dcjax sample`)."""
        try:
            d = np.load(path, allow_pickle=False)
            names = tuple(str(n) for n in d["names"])
            draws = np.asarray(d["draws"], float)
        except (OSError, ValueError, KeyError) as e:
            raise ConfigError(f"{path}: not a posterior.npz of dcjax sample ({e})") from None
        if draws.ndim != 3 or draws.shape[-1] != len(names):
            raise ConfigError(f"{path}: draws of shape {draws.shape} do not match its {len(names)} names")

        def named(key):
            return dict(zip(names, map(float, d[key])))

        def scalar(key, default=np.nan):
            return d[key].item() if key in d else default

        wall = d["wall"] if "wall" in d else (np.nan, np.nan)
        post = cls(
            names=names,
            draws=draws,
            optimum=named("optimum"),
            rhat=named("rhat"),
            ess_bulk=named("ess_bulk"),
            ess_tail=named("ess_tail"),
            divergences=int(scalar("divergences")),
            steps=float(scalar("steps")),
            acceptance=float(scalar("acceptance")),
            likelihood=str(scalar("likelihood")),
            noise=dict(zip(map(str, d["noise_names"]), map(float, d["noise"]))),
            wall={"warmup": float(wall[0]), "sampling": float(wall[1])},
            seed=int(scalar("seed")),
            priors=dict(zip(map(str, d["prior_names"]), map(str, d["priors"]))) if "priors" in d else {},
            sample_stats={k[len("stat_") :]: np.asarray(d[k]) for k in d.files if k.startswith("stat_")},
        )
        return dataclasses.replace(post, result_sha256=str(d["result_sha256"]) or None if "result_sha256" in d else None)


class Whitening(eqx.Module):
    """z = center + chol theta: the Laplace approximation's coordinates, in which the posterior
    is near N(0, I) (the unit cube's coordinates of a fit differ by 1e4 and more in scale)."""

    center: jax.Array
    chol: jax.Array

    def z(self, theta):
        return self.center + self.chol @ theta

    def walls(self):
        """(A, b) of the unit cube 0 <= z <= 1 as A theta + b >= 0."""
        return jnp.concatenate([self.chol, -self.chol]), jnp.concatenate([self.center, 1.0 - self.center])


class PriorTerm(eqx.Module):
    """sum_k log p_k(x_k) over the parameters with their own prior, + log x_k for a log-scale one
    (its density against the log-uniform base measure, dx/dz = x ln(max/min)); 0 for none."""

    priors: tuple[Prior, ...]
    index: tuple[int, ...] = eqx.field(static=True)  # positions in the full search vector
    log: tuple[bool, ...] = eqx.field(static=True)

    def __call__(self, x):
        total = jnp.zeros((), x.dtype)
        for p, k, lg in zip(self.priors, self.index, self.log):
            total = total + p.log_density(x[k]) + (jnp.log(x[k]) if lg else 0.0)
        return total


def prior_term(space: Space, priors: "Mapping[str, Prior | str] | None") -> PriorTerm:
    """The `PriorTerm` of `priors` (name -> `Prior` or spec) over `space`'s free entries."""
    priors = dict(priors or {})
    bad = [n for n in priors if n not in space.free_names]
    if bad:
        raise ConfigError(f"prior: {', '.join(bad)} is not a sampled parameter; the sampled ones are {', '.join(space.free_names)}")
    index = tuple(space.names.index(n) for n in priors)
    parsed = tuple(jax.tree.map(jnp.asarray, prior_from_spec(p)) for p in priors.values())  # arrays: a new value, no recompile
    return PriorTerm(parsed, index, tuple(k in space.log for k in index))


def _physical(space: Space, white: Whitening, theta):
    return space.to_physical(jnp.clip(white.z(theta), 0.0, 1.0))


def log_posterior(theta, likelihood: JointProblem, noise: NoiseModel, space: Space, white: Whitening, prior: PriorTerm | None = None):
    """log L(x(z(theta))) + the parameters' own priors (the base prior is uniform in z, the
    Jacobian constant); -inf outside the box or where not finite. `likelihood`: the fit's target
    as `likelihood_target` makes it (its objective -log L up to log L at zero residuals)."""
    z = white.z(theta)
    x = space.to_physical(jnp.clip(z, 0.0, 1.0))
    at_zero = noise.log_likelihood(jnp.zeros_like(noise.scale))
    lp = at_zero - likelihood.objective(x) + (0.0 if prior is None else prior(x))
    inside = jnp.all((z >= -WALL_TOL) & (z <= 1.0 + WALL_TOL))  # the reflecting step never leaves (to rounding)
    return jnp.where(jnp.isfinite(lp) & inside, lp, -jnp.inf)


def _laplace(z0, target: JointProblem, noise: NoiseModel, space: Space, prior: PriorTerm):
    """The Laplace covariance in z: (J^T J + 12 I + P)^-1, J of the whitened residuals (the
    uniform prior's variance 1/12 bounds a direction the data leave free), P the own priors'
    curvature (diagonal, its positive part); a Kalman filter's likelihood: its Hessian for J^T J."""
    if any(p.predictor.filters for p in target.problems):  # the filter's likelihood (`filter_likelihood`): its Hessian
        # forward over forward: compiles in about half the time of `jax.hessian` (`_nll_hessian`)
        hess = jax.jacfwd(jax.jacfwd(lambda z: target.objective(space.to_physical(z))))(z0)
        data = 0.5 * (hess + hess.T)
    else:
        jac = jax.jacfwd(lambda z: whitened_residuals(space.to_physical(z), target, noise))(z0)
        data = jac.T @ jac
    curv = -jnp.diag(jax.hessian(lambda z: prior(space.to_physical(z)))(z0))
    info = data + 12.0 * jnp.eye(z0.shape[0]) + jnp.diag(jnp.maximum(jnp.where(jnp.isfinite(curv), curv, 0.0), 0.0))
    return jnp.linalg.inv(info)


@filter_jit
def _start(x, target: JointProblem, noise: NoiseModel, space: Space, prior: PriorTerm, seed, chains: int):
    """The chains' start in one program: the priors' log densities at the optimum `x` (each must be
    finite), the Laplace whitening (`_laplace`) at it, `chains` starts drawn from it (`_inside`
    the box) and each chain's warm-up and draws keys."""
    densities = jnp.stack([jnp.zeros(())] + [p.log_density(x[k]) for p, k in zip(prior.priors, prior.index)])[1:]
    z0 = jnp.clip(space.to_unit(x), 0.0, 1.0)
    white = Whitening(z0, jnp.linalg.cholesky(_laplace(z0, target, noise, space, prior)))
    k_init, k_warm, k_draw = jax.random.split(jax.random.key(seed), 3)
    starts = _inside(white, jax.random.normal(k_init, (chains, z0.shape[0]), dtype=x.dtype))
    return densities, white, starts, (jax.random.split(k_warm, chains), jax.random.split(k_draw, chains))


def _over_chains(fn, mesh, chained: int, *args):
    """`fn` over the leading (chains) axis of the first `chained` arguments, the rest shared; on a
    mesh each device runs its share of the chains (`shard_map`). On a CPU a device's chains run
    one after another (`lax.map`: a chain's program, and its draws to the bit, do not depend on
    how many chains share its device), elsewhere side by side (`vmap`): a
    vmapped NUTS batch waits each draw for its longest trajectory, and XLA:CPU's gradient of 2 or
    4 chains side by side costs more than one chain's times their number (SD1: 34.5 us one, 44 us
    a chain in a batch; `experiments/BENCHMARKS.md`, sampler against the peers)."""
    lead = (0,) * chained + (None,) * (len(args) - chained)
    one_by_one = (mesh.devices.flat[0] if mesh is not None else jax.devices()[0]).platform == "cpu"

    def batched(*a):
        if one_by_one:
            return jax.lax.map(lambda c: fn(*c, *a[chained:]), a[:chained])
        return jax.vmap(fn, in_axes=lead)(*a)

    if mesh is None:
        return batched(*args)
    dynamic, static = eqx.partition(args, eqx.is_array)
    split, whole = PartitionSpec("chains"), PartitionSpec()
    specs = (split,) * chained + (whole,) * (len(args) - chained)
    local = jax.shard_map(lambda *d: batched(*eqx.combine(d, static)), mesh=mesh, in_specs=specs, out_specs=split, check_vma=False)
    return local(*dynamic)


def chain_mesh(chains: int) -> Mesh | None:
    """The devices the chains are split over: the most devices that divide `chains` evenly
    (`dcjax.use_host_devices()` makes one per core); None for one."""
    devices = jax.devices()
    n = max(d for d in range(1, len(devices) + 1) if chains % d == 0)
    return Mesh(np.array(devices[:n]), ("chains",)) if n > 1 else None


@filter_jit
def _chains(
    keys: tuple,
    chain: ChainState,
    likelihood: JointProblem,
    noise: NoiseModel,
    space: Space,
    white: Whitening,
    prior: PriorTerm,
    start,
    stop,
    warmup: int,
    draws: int,
    mesh,
):
    """Steps [start, stop) of every chain (`nuts_chain.chain_steps`: `warmup` steps of Stan's window
    adaptation, then `draws` draws): one executable for the warm-up's call and the draws'."""

    def one(key_warm, key_draw, chain, likelihood, noise, space, white, prior, start, stop):
        def logdensity(e):
            return log_posterior(e, likelihood, noise, space, white, prior)

        integrator = reflecting_verlet(*white.walls())
        return chain_steps(logdensity, integrator, (key_warm, key_draw), chain, start, stop, warmup, draws, TARGET_ACCEPTANCE)

    return _over_chains(one, mesh, 3, *keys, chain, likelihood, noise, space, white, prior, start, stop)


def sample(
    x,
    target: JointProblem,
    space: Space,
    loss: Loss,
    draws: int = 1000,
    chains: int = 4,
    warmup: int = 1000,
    seed: int = 0,
    priors: "Mapping[str, Prior | str] | None" = None,
) -> Posterior:
    """NUTS draws of the free entries of search vector `x` (the fit's optimum) under `loss`'s
    likelihood and `space`'s prior (`priors`: name -> `Prior` or spec, replacing the uniform one
    within the range); `seed` fixes every bit. The chains run in one program, split over the
    devices where there are several (`chain_mesh`; `_over_chains`)."""
    for name, v, least in (("draws", draws, 1), ("chains", chains, 1), ("warmup", warmup, 0)):
        if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < least:
            raise ConfigError(f"{name} must be an integer >= {least}, got {v!r}")
    check_seed(seed, "seed")
    if space.dim == 0:
        raise ConfigError("every parameter is fixed: nothing to sample")
    x = jnp.asarray(x, dtype=jnp.float64)
    prior = prior_term(space, priors)
    filters = any(p.predictor.filters for p in target.problems)
    if filters:  # a prediction-error fit: the Kalman filter's likelihood, its noise in the vector
        likelihood, noise = filter_likelihood(target)
    else:
        noise = fit_noise(x, target, loss)
        noise_free(target, noise)
        likelihood = likelihood_target(target, noise)
    densities, white, starts, keys = _start(x, likelihood if filters else target, noise, space, prior, np.int64(seed), int(chains))
    for d, k in zip(np.asarray(densities), prior.index):
        if not np.isfinite(d):
            raise ConfigError(f"prior of {space.names[k]}: zero density at the fit's value {float(x[k]):g}")
    t0 = time.perf_counter()
    mesh = chain_mesh(chains)
    shared = (likelihood, noise, space, white, prior)
    chain = initial_chains(starts)
    if mesh is not None:  # placed as the warm-up's call returns it: the draws' call takes the same executable
        chain = jax.device_put(chain, NamedSharding(mesh, PartitionSpec("chains")))
    chain, _ = _chains(keys, chain, *shared, np.int64(0), np.int64(warmup), int(warmup), int(draws), mesh)
    jax.block_until_ready(chain)
    t1 = time.perf_counter()
    _, records = _chains(keys, chain, *shared, np.int64(warmup), np.int64(warmup + draws), int(warmup), int(draws), mesh)
    jax.block_until_ready(records)
    t2 = time.perf_counter()
    free = np.asarray(_free_draws(records[0], space, white))
    _, (div, steps, acc, energy), (depth, lp) = jax.tree.map(np.asarray, records)
    names = space.free_names
    rhat = [sample_size.rhat(free[..., k]) for k in range(len(names))]
    ess_bulk = [sample_size.ess_bulk(free[..., k]) for k in range(len(names))]
    ess_tail = [sample_size.ess_tail(free[..., k]) for k in range(len(names))]
    return Posterior(
        names=names,
        draws=free,
        optimum={n: float(v) for n, v in zip(names, np.asarray(x)[list(space.free)])},
        rhat=dict(zip(names, map(float, rhat))),
        ess_bulk=dict(zip(names, map(float, ess_bulk))),
        ess_tail=dict(zip(names, map(float, ess_tail))),
        divergences=int(np.sum(div)),
        steps=float(np.mean(steps)),
        acceptance=float(np.mean(acc)),
        likelihood="Kalman filter (Gaussian innovations)" if filters else loss.likelihood,
        noise=noise_names(target, noise),
        wall={"warmup": t1 - t0, "sampling": t2 - t1},
        seed=int(seed),
        priors={n: prior_from_spec(p).spec for n, p in (priors or {}).items()},
        sample_stats={
            "diverging": np.asarray(div, bool),
            "n_steps": np.asarray(steps, np.int64),
            "acceptance_rate": np.asarray(acc, float),
            "energy": np.asarray(energy, float),
            "tree_depth": np.asarray(depth, np.int64),
            "lp": np.asarray(lp, float),
            "step_size": np.broadcast_to(np.asarray(chain.tuning.tuned_step_size, float)[:, None], np.shape(div)).copy(),
        },
    )


@filter_jit
def _free_draws(pos, space: Space, white: Whitening):
    """The draws' free entries in physical units, (chains, draws, F): one small compiled program
    (their diagnostics are NumPy's, `sample_size`: blackjax's R-hat compiled ~1 s of XLA for each
    new shape of draws)."""
    return jax.vmap(jax.vmap(lambda e: _physical(space, white, e)))(pos)[..., jnp.asarray(space.free)]


def _inside(white: Whitening, theta):
    """Each start theta_c moved towards 0 (the optimum) until z(theta_c) lies in the box."""

    def one(t):
        shrink = jnp.array([0.5**k for k in range(40)] + [0.0])
        ok = jax.vmap(lambda f: jnp.all((white.z(f * t) >= 0.0) & (white.z(f * t) <= 1.0)))(shrink)
        return shrink[jnp.argmax(ok)] * t

    return jax.vmap(one)(theta)


__all__ = ["Posterior", "PriorTerm", "log_posterior", "prior_term", "sample"]
