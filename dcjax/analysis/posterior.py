"""Posterior sampling of a fit's search vector with NUTS (blackjax) through the differentiable simulator.

The posterior is p(x | data) ∝ L(x) p(x): L the fit's likelihood under its loss's noise model
(`dcjax.simulation.likelihood`: Gaussian for SSE, Laplace for L1, Huber for Huber; each channel's
scale from the residuals at the optimum, held), p(x) the prior of the search space: uniform in
each free entry's range, log-uniform where it is searched on a log scale (`Parameter(scale="log")`).
Initial states, offsets and delays that the fit fitted are sampled with the model's parameters.

NUTS runs on theta in R^F with z = tri(theta), the triangle wave of period 2 (z = theta on [0, 1],
2 - theta on [1, 2], ...) and z the unit-cube coordinate of `Space`: the target on theta is the
even periodic extension of the posterior in z, whose unit Jacobian keeps the prior uniform and
makes the box's walls reflecting. A logit map instead would stretch a parameter whose posterior
touches a bound (a load torque at 0) into an exponential tail that NUTS crosses with trees of a
thousand steps. Chains start at the optimum, jittered by the Laplace approximation (the Fisher
information of the noise model, plus 12 I for the uniform prior's variance 1/12 in z), whose
covariance also seeds the dense mass matrix of Stan's window adaptation
(`blackjax.window_adaptation`). Diagnostics are Vehtari et al. (2021)'s rank-normalised split R-hat,
bulk and tail ESS (`blackjax.diagnostics`). blackjax rather than numpyro: dcjax already has a log
density as a pure JAX function of a vector, which is blackjax's whole interface (no model DSL), and
its kernels vmap over chains."""

import dataclasses
import time

import blackjax
import blackjax.diagnostics as diag
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from blackjax.adaptation.base import get_filter_adapt_info_fn

from ..models.space import Space
from ..simulation.joint import JointProblem
from ..simulation.likelihood import NoiseModel, channel_sums, fit_noise, whitened_residuals
from ..simulation.losses import Loss
from .reflection import reflecting_verlet

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
    wall: dict[str, float]  # seconds: "warmup" (with its compilation), "sampling"
    seed: int

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
        lines.append(f"{c} chains x {d} draws (NUTS): {self.divergences} divergent, {self.steps:.1f} leapfrog steps a draw, "
                     f"acceptance {self.acceptance:.2f}; warmup {self.wall['warmup']:.1f} s, sampling {self.wall['sampling']:.1f} s "
                     f"({self.ess_per_second:.1f} bulk ESS/s, the least over the parameters)")  # fmt: skip
        noise = ", ".join(f"{k} {v:.3g}" for k, v in self.noise.items())
        lines.append(f"likelihood: {self.likelihood}, noise scale per channel (from the residuals at the optimum): {noise}")
        return "\n".join(lines)

    def save(self, path) -> None:
        """The draws and diagnostics as an .npz (arrays `draws` (chains, draws, F), `names`, ...)."""
        np.savez(path, draws=self.draws, names=np.array(self.names), rhat=np.array([self.rhat[n] for n in self.names]),
                 ess_bulk=np.array([self.ess_bulk[n] for n in self.names]), ess_tail=np.array([self.ess_tail[n] for n in self.names]),
                 optimum=np.array([self.optimum[n] for n in self.names]), divergences=self.divergences, seed=self.seed,
                 likelihood=self.likelihood, noise_names=np.array(list(self.noise)), noise=np.array(list(self.noise.values())))  # fmt: skip


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


def _physical(space: Space, white: Whitening, theta):
    return space.to_physical(jnp.clip(white.z(theta), 0.0, 1.0))


def log_posterior(theta, target: JointProblem, noise: NoiseModel, space: Space, white: Whitening):
    """log L(x(z(theta))) (the prior is uniform in z, the Jacobian constant); -inf outside the
    box or where not finite."""
    z = white.z(theta)
    lp = noise.log_likelihood(channel_sums(space.to_physical(jnp.clip(z, 0.0, 1.0)), target))
    inside = jnp.all((z >= -WALL_TOL) & (z <= 1.0 + WALL_TOL))  # the reflecting step never leaves (to rounding)
    return jnp.where(jnp.isfinite(lp) & inside, lp, -jnp.inf)


@eqx.filter_jit
def _laplace(z0, target: JointProblem, noise: NoiseModel, space: Space):
    """The Laplace covariance in z: (J^T J + 12 I)^-1, J of the whitened residuals (the prior's
    variance 1/12 bounds a direction the data leave free)."""
    jac = jax.jacfwd(lambda z: whitened_residuals(space.to_physical(z), target, noise))(z0)
    info = jac.T @ jac + 12.0 * jnp.eye(z0.shape[0])
    return jnp.linalg.inv(info)


@eqx.filter_jit
def _warmup(keys, starts, target: JointProblem, noise: NoiseModel, space: Space, white: Whitening, steps: int):
    def logdensity(e):
        return log_posterior(e, target, noise, space, white)

    adapt = blackjax.window_adaptation(blackjax.nuts, logdensity, is_mass_matrix_diagonal=False, integrator=reflecting_verlet(*white.walls()),
                                       adaptation_info_fn=get_filter_adapt_info_fn())  # fmt: skip

    def one(key, start):
        (state, params), _ = adapt.run(key, start, num_steps=steps)  # pyright: ignore[reportCallIssue]
        return state, params

    return jax.vmap(one)(keys, starts)


@eqx.filter_jit
def _draw(keys, states, params, target: JointProblem, noise: NoiseModel, space: Space, white: Whitening, draws: int):
    def logdensity(e):
        return log_posterior(e, target, noise, space, white)

    def chain(key, state, p):
        kernel = blackjax.nuts(logdensity, **p, integrator=reflecting_verlet(*white.walls()))

        def step(s, k):
            s, info = kernel.step(k, s)
            return s, (s.position, info.is_divergent, info.num_integration_steps, info.acceptance_rate)

        return jax.lax.scan(step, state, jax.random.split(key, draws))[1]

    return jax.vmap(chain)(keys, states, params)


def sample(
    x, target: JointProblem, space: Space, loss: Loss, draws: int = 1000, chains: int = 4, warmup: int = 1000, seed: int = 0
) -> Posterior:
    """NUTS draws of the free entries of search vector `x` (the fit's optimum) under `loss`'s
    likelihood and `space`'s prior; `seed` fixes every bit."""
    for name, v, least in (("draws", draws, 1), ("chains", chains, 1), ("warmup", warmup, 0)):
        if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < least:
            raise ValueError(f"{name} must be an integer >= {least}, got {v!r}")
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool):
        raise ValueError(f"seed must be an integer, got {seed!r}")
    if space.dim == 0:
        raise ValueError("every parameter is fixed: nothing to sample")
    x = jnp.asarray(x, dtype=jnp.float64)
    noise = fit_noise(x, target, loss)
    z0 = jnp.clip(space.to_unit(x), 0.0, 1.0)
    cov = _laplace(z0, target, noise, space)
    k_init, k_warm, k_draw = jax.random.split(jax.random.key(int(seed)), 3)
    white = Whitening(z0, jnp.linalg.cholesky(cov))
    starts = _inside(white, jax.random.normal(k_init, (chains, z0.shape[0]), dtype=jnp.float64))
    t0 = time.perf_counter()
    states, params = _warmup(jax.random.split(k_warm, chains), starts, target, noise, space, white, int(warmup))
    jax.block_until_ready(states)
    t1 = time.perf_counter()
    pos, div, steps, acc = _draw(jax.random.split(k_draw, chains), states, params, target, noise, space, white, int(draws))
    free, rhat, ess_bulk, ess_tail = map(np.asarray, _diagnostics(pos, space, white))
    t2 = time.perf_counter()
    names = space.free_names
    return Posterior(
        names=names,
        draws=free,
        optimum={n: float(x[k]) for n, k in zip(names, space.free)},
        rhat=dict(zip(names, map(float, rhat))),
        ess_bulk=dict(zip(names, map(float, ess_bulk))),
        ess_tail=dict(zip(names, map(float, ess_tail))),
        divergences=int(np.sum(div)),
        steps=float(np.mean(steps)),
        acceptance=float(np.mean(acc)),
        likelihood=loss.likelihood,
        noise=_noise_names(target, noise),
        wall={"warmup": t1 - t0, "sampling": t2 - t1},
        seed=int(seed),
    )


@eqx.filter_jit
def _diagnostics(pos, space: Space, white: Whitening):
    """The draws' free entries in physical units, (chains, draws, F), their split R-hat (NaN for one
    chain), bulk and tail ESS: one compiled program (blackjax's diagnostics run eagerly compile
    some 200 small ones on each new shape)."""
    free = jax.vmap(jax.vmap(lambda e: _physical(space, white, e)))(pos)[..., jnp.asarray(space.free)]
    rhat = diag.rhat(free) if free.shape[0] > 1 else jnp.full(free.shape[-1], jnp.nan)
    return free, jnp.atleast_1d(rhat), jnp.atleast_1d(diag.ess_bulk(free)), jnp.atleast_1d(diag.ess_tail(free))


def _inside(white: Whitening, theta):
    """Each start theta_c moved towards 0 (the optimum) until z(theta_c) lies in the box."""

    def one(t):
        shrink = jnp.array([0.5**k for k in range(40)] + [0.0])
        ok = jax.vmap(lambda f: jnp.all((white.z(f * t) >= 0.0) & (white.z(f * t) <= 1.0)))(shrink)
        return shrink[jnp.argmax(ok)] * t

    return jax.vmap(one)(theta)


def _noise_names(target: JointProblem, noise: NoiseModel) -> dict[str, float]:
    """'recording:channel' -> tau in the channel's units (tau / norm)."""
    out = {}
    scale, active = np.asarray(noise.scale), np.asarray(noise.active)
    for r, p in enumerate(target.problems):
        norm = np.ones(scale.shape[1]) if p.norm is None else np.asarray(p.norm)
        for j, c in enumerate(p.model.outputs):
            if active[r, j]:
                out[f"{r}:{c}" if len(target.problems) > 1 else c] = float(scale[r, j] / norm[j])
    return out


__all__ = ["Posterior", "log_posterior", "sample"]
