"""Optimal input design through the differentiable simulator: which test to run next.

For an input profile u(t) and parameters theta, the Fisher information of the measured channels
y_c(t_k) with independent Gaussian noise sigma_c is

    F = sum_c sum_k s_c,k^T s_c,k / sigma_c^2,      s_c,k = d y_c(t_k) / d log theta   (relative)

(`jax.jacfwd` through the integrator, scaled by the parameters' values, so the criterion does
not depend on units). Its inverse is the Cramér–Rao bound on the covariance of the relative
parameters. The input is piecewise constant, one level per hold interval, u = u_min + (u_max -
u_min) z with z in [0, 1]; the levels are optimized by projected Adam (optax, z clipped to
[0, 1] after each step, so bang-bang profiles are reached exactly) on the gradient of the
criterion, vmapped over several starts (mid-range, a full step, a coast-down, a square wave,
random levels), and the best start is kept:

- `"d"` (default): maximize log det F over the free parameters (D-optimal);
- `"a"`: minimize trace F^-1, the sum of relative variances (A-optimal);
- names (`"J,Tla,Tlb,Tlc"`): minimize the sum of the logarithms of those parameters' relative
  variances (each counts by its factor of improvement; a sum of the variances themselves
  would be ruled by the largest).

The supply's current limit is the model's clamp inside the simulation, so a designed profile
respects it by construction (the clamped current carries no information the optimizer could
exploit beyond the limit)."""

import dataclasses
import math
from collections.abc import Mapping, Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..compiling import LEAN, compiled_when_eager, filter_jit
from ..errors import ConfigError
from ..io.recording import Recording
from ..models import Model, get_model
from ..simulation.problem import Problem
from .information import (
    criterion_value,
    information,
    input_channels,
    null_parameters,
    predicted_stderr,
    simulate_jit,
    template_problem,
    with_input,
)

OBSERVATION_PREFIXES = ("y0_", "offset_", "delay_")  # a fit's observation parameters (`dcjax.Observation`)

DEFAULT_NOISE = 0.01  # sigma_c as a fraction of the channel's peak where no fit residual says otherwise


@dataclasses.dataclass
class Design:
    """A designed input and what it is predicted to give."""

    recording: Recording  # t, every input (designed and given), and the responses simulated at `params`
    levels: np.ndarray  # (segments,) the level of each hold interval; (segments, D) for D designed inputs
    hold: float
    criterion: str
    value: float  # the criterion at the design (log det F for "d", the variance sum otherwise)
    stderr: dict[str, float]  # predicted standard errors (physical units) of the free parameters
    noise: dict[str, float]  # sigma per measured channel
    params: dict[str, float]
    free: tuple[str, ...]
    scale: dict[str, float]  # what "relative" means per parameter (default |value|)
    unidentifiable: list[str]  # parameters in a null direction of F (the model structure hides them)
    inputs: tuple[str, ...] = ()  # the designed inputs (default: the model's first)
    given: dict = dataclasses.field(default_factory=dict)  # the other inputs: name -> (N,) samples or a constant

    def relative_stderr(self) -> dict[str, float]:
        """Standard errors over each parameter's scale (its value, or the scale given for one at 0)."""
        return {n: self.stderr[n] / self.scale[n] for n in self.free}


def design_input(
    model: Model | str | None,
    params: dict[str, float],
    *,
    duration: float,
    dt: float,
    u_range: "tuple[float, float] | Mapping[str, tuple[float, float]]",
    hold: float | None = None,
    limit: float | None = None,
    criterion: str = "d",
    noise: dict[str, float] | None = None,
    fixed: tuple[str, ...] = (),
    scale: dict[str, float] | None = None,
    baselines: Sequence[np.ndarray] = (),
    given: Mapping[str, "float | np.ndarray"] | None = None,
    starts: int = 8,
    steps: int = 300,
    seed: int = 0,
) -> Design:
    """Design an input of `duration` s sampled every `dt` s, piecewise constant over `hold` s
    (default duration / 20), for `model` at `params` (name -> value; `fixed` names are known and
    not designed for), under the supply's `limit`.

    Every input of the model not in `given` is designed; `given` holds the others, each a constant
    (a per-recording constant such as a motor's pole pairs) or (N,) samples on the design's grid
    (an input kept as a baseline recording has it). `u_range`: (u_min, u_max) for every designed
    input, or a mapping input -> (u_min, u_max) naming each.
    `scale`: what "relative" means for a parameter (default its |value|; give one for a parameter
    fitted at 0, else it is left out).
    `criterion`: "d", "a" or comma-separated parameter names (module docstring). `noise`: sigma
    per measured channel (default 1 % of the channel's peak under a full step to u_max; never
    below 1e-12). `baselines`: the designed inputs of tests one would run otherwise ((N,) for one
    designed input, (N, D) for D), which the design must improve on in every parameter of the
    criterion (all free ones for "d" and "a"): it then minimizes the largest log ratio of a
    relative variance to the baselines' best, started from each baseline's levels (`_Criterion`).
    `starts` Adam runs of `steps` steps, the random starts from `seed`."""
    m = get_model(model)
    given = _given(m, given)
    names = tuple(c for c in m.inputs if c not in given)
    if hasattr(params, "items"):  # a fit's params: its y0_, offset_, delay_ entries are not the model's
        params = {k: params[k] for k in params if k in m.names or not str(k).startswith(OBSERVATION_PREFIXES)}
    n, lo, hi, per = _grid(m, params, duration, dt, u_range, hold, names)
    free_names, scales, weights = _free(m, params, criterion, fixed, scale)
    segments = max(1, (n - 1) // per)  # whole hold intervals; the last level also holds the final samples
    t = np.arange(n) * dt
    given = {c: v if np.ndim(v) == 0 else _on_grid(v, n, f"given input {c}") for c, v in given.items()}
    x = jnp.asarray([float(params[k]) for k in m.names])
    free = jnp.asarray([m.names.index(k) for k in free_names])
    sc = jnp.asarray([scales[k] for k in free_names])
    if limit is not None and not m.has_limit:
        raise ConfigError(f"limit: model {m.name} clamps no state (it has no Model.limited_state or clamp of its own)")
    base = template_problem(m, params, t, np.tile(hi, (n, 1)), limit, given, names)  # a full step: its peaks set the default noise
    sigma = _noise(m, base, noise)
    crit = criterion if criterion in ("d", "a") else "names"
    z0 = _starts(segments, len(names), starts, seed)
    columns = tuple(m.inputs.index(c) for c in names)
    loss = _Criterion(
        base, x, free, sigma, sc, jnp.asarray(weights), None, crit, segments, per, tuple(map(float, lo)), tuple(map(float, hi)), columns
    )
    us = [_on_grid(b, n, "baselines: each input", len(names)).reshape(n, len(names)) for b in baselines]
    if us:  # the search minimises the largest log variance ratio to the baselines' best, from each baseline's levels
        loss = eqx.tree_at(
            lambda c: c.reference, loss, jnp.min(_log_variances(loss, jnp.asarray(np.stack(us))), axis=0), is_leaf=lambda v: v is None
        )
        levels = np.array([np.clip((u[::per][:segments] - lo) / (hi - lo), 0.0, 1.0) for u in us])
        z0 = jnp.concatenate([jnp.asarray(levels), z0])[: max(starts, len(us))]
    optimize = _optimize if int(z0.shape[0]) * int(steps) * n >= UNHOISTED_WORK else _optimize_unhoisted
    zs, fs = optimize(loss, z0, int(steps), 0.02)
    fs = np.asarray(fs)
    k = int(np.argmin(np.where(np.isfinite(fs), fs, np.inf)))
    u = np.asarray(loss.profile(zs[k]))
    value = -float(fs[k]) if crit == "d" and not us else float(fs[k])
    if us:  # the design against the baselines themselves, all through one function
        u, value = _against_baselines(loss, u, us)
    return summarize(
        m, params, t, u, limit, free_names, sigma, criterion, value, per * dt, {k: scales[k] for k in free_names}, given, names
    )


def _given(m: Model, given) -> dict:
    """The inputs not designed, checked: known names, and at least one input left to design."""
    given = dict(given or {})
    bad = [c for c in given if c not in m.inputs]
    if bad:
        raise ConfigError(f"given: unknown input(s) {bad}; model {m.name} has inputs {', '.join(m.inputs)}")
    if m.inputs and all(c in given for c in m.inputs):
        raise ConfigError(f"given: every input of model {m.name} is given ({', '.join(m.inputs)}); leave at least one to design")
    return given


def _grid(m: Model, params, duration, dt, u_range, hold, names: tuple[str, ...]) -> tuple[int, np.ndarray, np.ndarray, int]:
    """Checked number of samples, each designed input's range (lower, upper arrays) and samples per hold interval of a design."""
    m.check_names(params)
    missing = [k for k in m.names if k not in params]
    if missing:
        raise ConfigError(f"params must give every parameter of model {m.name}; missing {', '.join(missing)}")
    if not m.inputs:
        raise ConfigError(f"model {m.name} has no input to design")
    for what, v in (("duration", duration), ("dt", dt)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ConfigError(f"{what} must be a positive number of seconds, got {v!r}")
    n = int(round(duration / dt)) + 1
    if n < 10:
        raise ConfigError(f"duration / dt gives {n} samples; need at least 10")
    if isinstance(u_range, Mapping):
        bad = [c for c in u_range if c not in names]
        if bad:
            raise ConfigError(f"u_range: {bad} not designed; the designed inputs are {', '.join(names)}")
        lacking = [c for c in names if c not in u_range]
        if lacking:
            raise ConfigError(f"u_range: no range for the designed input(s) {', '.join(lacking)} (give (u_min, u_max) for each)")
        ranges = [u_range[c] for c in names]
    else:
        ranges = [u_range] * len(names)
    lo, hi = np.zeros(len(names)), np.zeros(len(names))
    for k, (c, r) in enumerate(zip(names, ranges)):
        try:
            lo[k], hi[k] = float(r[0]), float(r[1])
        except (TypeError, ValueError, IndexError):
            raise ConfigError(f"u_range of {c} must be (u_min, u_max), got {r!r}") from None
        if not (math.isfinite(lo[k]) and math.isfinite(hi[k]) and lo[k] < hi[k]):
            raise ConfigError(f"u_range of {c} must be (u_min, u_max) with u_min < u_max, got {r!r}")
    hold = duration / 20 if hold is None else float(hold)
    per = int(round(hold / dt))
    if per < 1 or per >= n:
        raise ConfigError(f"hold must lie between dt ({dt:g} s) and the duration ({duration:g} s), got {hold!r}")
    return n, lo, hi, per


def _free(m: Model, params, criterion, fixed, scale) -> tuple[tuple[str, ...], dict[str, float], np.ndarray]:
    """The parameters designed for, every parameter's scale, and the criterion's weight of each free one."""
    m.check_names(fixed, "fixed parameter")
    m.check_names(scale or {}, "scale of parameter")
    scales = {k: abs(float(params[k])) for k in m.names}
    scales.update({k: abs(float(v)) for k, v in (scale or {}).items()})
    free_names = tuple(k for k in m.names if k not in fixed and scales[k] > 0)
    if not free_names:
        raise ConfigError("no free parameter with a non-zero value or scale to design for")
    if criterion in ("d", "a"):
        return free_names, scales, np.ones(len(free_names))
    chosen = [c.strip() for c in str(criterion).split(",") if c.strip()]
    m.check_names(chosen)
    bad = [c for c in chosen if c not in free_names]
    if bad:
        raise ConfigError(f"criterion names {bad} are fixed or zero; free are {', '.join(free_names)}")
    return free_names, scales, np.array([1.0 if k in chosen else 0.0 for k in free_names])


def _on_grid(u, n: int, what: str, d: int | None = None) -> np.ndarray:
    """`u` as (n,) samples (`d` None) or (n, d) for d designed inputs, finite."""
    u = np.asarray(u, float)
    if d is not None and d > 1:
        ok = u.shape == (n, d)
        shape = f"({n}, {d})"
    else:
        u = u.reshape(-1) if u.ndim == 2 and u.shape[1:] == (1,) else u
        ok = u.shape == (n,)
        shape = f"{n}"
    if not ok or not np.all(np.isfinite(u)):
        raise ConfigError(f"{what} must be {shape} finite values on the design's grid, got shape {u.shape}")
    return u if d is None else u.reshape(n, -1)


_information = filter_jit(information)


class _Criterion(eqx.Module):
    """What the design minimizes, as a function of the levels z in [0, 1] (one per hold interval):
    the criterion of `criterion_value`, or, with `reference` (the log relative variances of the
    baselines, their best per parameter), max_j w_j log(var_j / var_ref,j), smoothed for the gradient
    by a log-sum-exp at `SMOOTH` (the exact maximum is what is kept)."""

    base: Problem
    x: jax.Array
    free: jax.Array
    sigma: jax.Array
    scale: jax.Array
    weights: jax.Array
    reference: jax.Array | None
    crit: str = eqx.field(static=True)
    segments: int = eqx.field(static=True)
    per: int = eqx.field(static=True)
    lo: tuple[float, ...] = eqx.field(static=True)  # per designed input
    hi: tuple[float, ...] = eqx.field(static=True)
    columns: tuple[int, ...] = eqx.field(static=True, default=(0,))  # the designed inputs' columns among the model's inputs

    @compiled_when_eager
    def profile(self, z: jax.Array) -> jax.Array:
        """(N, D) inputs of the levels z (segments, D) (an eager call: one program, not its few
        operations each compiled)."""
        n = self.base.y_meas.shape[0]
        lo, hi = jnp.asarray(self.lo), jnp.asarray(self.hi)
        u = lo + (hi - lo) * jnp.clip(z, 0.0, 1.0)
        return jnp.repeat(u, self.per, axis=0, total_repeat_length=n)  # the last level repeated to the end: never a short last level

    def information(self, u: jax.Array) -> jax.Array:
        """F under the designed inputs `u` (N, D)."""
        return information(with_input(self.base, u, self.columns), self.x, self.free, self.sigma, self.scale)

    def log_variances(self, u: jax.Array) -> jax.Array:
        """log relative variances (the diagonal of F^-1, regularised) of the free parameters under inputs `u`."""
        F = self.information(u)
        reg = 1e-12 * jnp.trace(F) / F.shape[0] * jnp.eye(F.shape[0])
        return jnp.log(jnp.maximum(jnp.diag(jnp.linalg.inv(F + reg)), 1e-300))

    def __call__(self, z: jax.Array) -> tuple[jax.Array, jax.Array]:
        if self.reference is None:
            f = criterion_value(self.information(self.profile(z)), self.crit, self.weights)
            return f, f
        excess = jnp.where(self.weights > 0, self.log_variances(self.profile(z)) - self.reference, -jnp.inf)
        return SMOOTH * jax.nn.logsumexp(excess / SMOOTH), jnp.max(excess)


SMOOTH = 0.01  # temperature (in log variance) of the smoothed maximum of a design against baselines


def _against_baselines(loss: _Criterion, u: np.ndarray, baselines: list[np.ndarray]) -> tuple[np.ndarray, float]:
    """(inputs, value) of the design `u` or, where it is not better, of the best baseline: the log
    relative variances of all from one vmapped call, so that rounding cannot make a baseline worse
    than itself; value max_j w_j log(var_j / min_baselines var_j) (<= 0 for a single baseline)."""
    rows = np.stack([u, *baselines])
    logvar = np.asarray(_log_variances(loss, jnp.asarray(rows)))
    excess = np.where(np.asarray(loss.weights) > 0, logvar - logvar[1:].min(axis=0), -np.inf).max(axis=1)
    k = int(np.argmin(np.where(np.isfinite(excess), excess, np.inf)))
    return rows[k], float(excess[k])


@filter_jit
def _log_variances(loss: _Criterion, inputs: jax.Array) -> jax.Array:
    """`_Criterion.log_variances` of each of the inputs (R, N, D) (vmapped)."""
    return jax.vmap(loss.log_variances)(inputs)


def _adam(loss: _Criterion, z0: jax.Array, steps: int, rate: float) -> tuple[jax.Array, jax.Array]:
    """Projected Adam from each row of `z0` (vmapped): the best levels by the exact criterion met
    on the way, and that value."""
    import optax  # lazy: 0.1 s of every dcjax import (and command) that designs no input

    opt = optax.adam(rate)

    def run(z):
        def body(carry, _):
            z, state, best_z, best_f = carry
            (_, f), g = jax.value_and_grad(loss, has_aux=True)(z)
            g = jnp.where(jnp.isfinite(g), g, 0.0)
            better = jnp.isfinite(f) & (f < best_f)
            best_z, best_f = jnp.where(better, z, best_z), jnp.where(better, f, best_f)
            upd, state = opt.update(g, state, z)
            z = jnp.clip(jnp.asarray(optax.apply_updates(z, upd)), 0.0, 1.0)  # projected onto the range
            return (z, state, best_z, best_f), None

        # steps + 1 passes: the last one meets the levels of the last step (its own step unused), so
        # the program holds the criterion once, not a second copy after the loop: the tests' PMSM
        # design traces, lowers and compiles in 0.8-0.86 of the time (a quarter fewer program
        # lines), to the same levels (`python -m experiments.bench_design_program`)
        (_, _, best_z, best_f), _ = jax.lax.scan(body, (z, opt.init(z), z, jnp.asarray(jnp.inf, z.dtype)), None, length=steps + 1)
        return best_z, best_f

    return jax.vmap(run)(z0)


_optimize = filter_jit(_adam)
# XLA:CPU compiles a small while loop as one function (`small-while-loop-hoisting`, the threshold
# `use_compiled_loops` raises): the design's reverse pass through the sensitivities then compiles
# slowly and optimizes fast. Below UNHOISTED_WORK starts x steps x samples the compilation saved
# outweighs the slower steps (2 x 5 x 101: a PMSM's design in 4.3 s against 7.2, SD1's in 2.2
# against 3.3; without it each unit of work costs ~3-5 us more, with it the compilation ~1-3 s
# more: SD1's defaults, 1.2e6, take 5.3 s with it and 8.4 without; the break-even, ~3e5 for SD1
# and ~6e5 for the PMSM, has a margin of ten):
# `python -m experiments.bench_design_compile`.
_optimize_unhoisted = filter_jit(_adam, options=LEAN | {"xla_disable_hlo_passes": "small-while-loop-hoisting"})
UNHOISTED_WORK = 20_000


def _noise(m: Model, prob: Problem, noise) -> jax.Array:
    peaks = np.max(np.abs(np.asarray(prob.y_meas)), axis=0)
    out = []
    for j, c in enumerate(m.outputs):
        v = (noise or {}).get(c)
        v = DEFAULT_NOISE * peaks[j] if v is None else float(v)
        if not (math.isfinite(v) and v > 0):
            v = 1e-12
        out.append(max(v, 1e-12))
    if noise:
        m_bad = [c for c in noise if c not in m.outputs]
        if m_bad:
            raise ConfigError(f"noise: unknown channel(s) {m_bad}; model {m.name} measures {', '.join(m.outputs)}")
    return jnp.asarray(out)


def _starts(segments: int, inputs: int, starts: int, seed: int) -> jax.Array:
    """Adam's starts as fractions of each input's range, (starts, segments, inputs): mid-range,
    full on, on for 40 % then off (a coast-down), a square wave (a quarter period later for each
    further input, so no two inputs start alike), then random levels."""
    k = np.arange(segments)[:, None] + np.arange(inputs)[None, :]
    z = [
        np.full((segments, inputs), 0.5),
        np.ones((segments, inputs)),
        np.tile((k[:, :1] < max(1, (2 * segments) // 5)).astype(float), (1, inputs)),
        (k % 4 < 2).astype(float),
    ]
    rng = np.random.default_rng(seed)
    while len(z) < max(starts, 1):
        z.append(rng.uniform(0.0, 1.0, (segments, inputs)))
    return jnp.asarray(np.array(z[: max(starts, 1)]))


def summarize(
    m: Model,
    params,
    t,
    u,
    i_limit,
    free_names,
    sigma,
    criterion,
    value,
    hold,
    scale: dict[str, float],
    given=None,
    inputs: Sequence[str] | None = None,
) -> Design:
    """The `Design` of the designed inputs `u` ((N,) or (N, D); default the model's first input)
    on grid `t`, the other inputs `given`: responses, information, predicted errors."""
    given = dict(given or {})
    names = tuple(inputs) if inputs is not None else tuple(c for c in m.inputs if c not in given) if given else m.inputs[:1]
    chans = input_channels(m, t, u, given, names)
    prob = template_problem(m, params, t, np.column_stack([chans[c] for c in names]), i_limit, given, names)
    x = jnp.asarray([float(params[k]) for k in m.names])
    free = jnp.asarray([m.names.index(k) for k in free_names])
    sc = np.array([scale[k] for k in free_names])
    F = np.asarray(_information(prob, x, free, sigma, jnp.asarray(sc)))
    se = predicted_stderr(F, sc)
    sim = np.asarray(simulate_jit(x, prob))
    constants = {c: float(v) for c, v in given.items() if np.ndim(v) == 0}
    rec = Recording(
        t=t,
        channels={**{c: v for c, v in chans.items() if c not in constants}, **{s: sim[:, k] for k, s in enumerate(m.states)}},
        limit=i_limit,
        name="design",
        constants=constants or None,
    )
    per = max(1, int(round(hold / (t[1] - t[0]))))
    levels = np.column_stack([chans[c] for c in names])[::per][: max(1, (len(t) - 1) // per)]
    return Design(
        recording=rec,
        levels=levels[:, 0] if len(names) == 1 else levels,
        hold=float(hold),
        criterion=str(criterion),
        value=float(value),
        stderr=dict(zip(free_names, map(float, se))),
        noise=dict(zip(m.outputs, map(float, np.asarray(sigma)))),
        params={k: float(params[k]) for k in m.names},
        free=tuple(free_names),
        scale=dict(scale),
        unidentifiable=null_parameters(F, tuple(free_names)),
        inputs=names,
        given=given,
    )


def evaluate_input(design: Design, model: Model | str | None, u, t: np.ndarray | None = None) -> Design:
    """The same parameters, noise and criterion under other inputs: `u` the designed inputs ((N,)
    or (N, D) on the design's grid, with the design's other inputs), or a mapping of every input
    that is not a constant of the design (on the design's grid, or on `t`; the constants are
    the design's): predicted standard errors to compare a design with a recording's own inputs."""
    m = get_model(model)
    t = design.recording.t if t is None else np.asarray(t, float)
    sigma = jnp.asarray([design.noise[c] for c in m.outputs])
    names = design.inputs or m.inputs[:1]
    if isinstance(u, Mapping):
        constants = {c: v for c, v in design.given.items() if np.ndim(v) == 0}
        missing = [c for c in m.inputs if c not in u and c not in constants]
        if missing:
            raise ConfigError(f"evaluate_input: no samples of input(s) {', '.join(missing)}")
        given = {**constants, **{c: np.asarray(u[c], float) for c in m.inputs if c in u and c not in names}}
        u = np.column_stack([np.asarray(u[c], float) for c in names])
    else:
        given = design.given
    return summarize(
        m,
        design.params,
        t,
        u,
        design.recording.limit,
        design.free,
        sigma,
        design.criterion,
        math.nan,
        design.hold,
        design.scale,
        given,
        names,
    )
