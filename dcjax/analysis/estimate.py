"""A first estimate without a search: equation-error (inverse-model) least squares, IDIM-LS.

The measured states are low-pass filtered forward and backward (zero phase, Butterworth), their
derivatives taken by central differences, and the model's state equations fitted to them:

    m_e dy_e/dt = f_e(theta, y, u)        for every state equation e

- a model linear in its parameters, each equation after one parameter's factor m_e (written
  out by `Model.regression`, both DC models, or found from the vector field with JAX by
  `linear_form`), is solved by weighted linear least squares, each equation weighted by
  1 / rms(m_e dy_e/dt) (its inertial term, so the weights do not depend on the parameters'
  overall scale), re-weighted a few times;
- any other model by Levenberg–Marquardt (optimistix) on the derivative residual
  (dy/dt - f(theta, y, u)) / rms(dy/dt) at LM_ROWS rows at most, non-negative parameters as
  theta = phi^2: from 64 starts at the middle cutoff (vmapped; the range midpoints and points
  log-uniform over six decades, fixed seed), at the other cutoffs from that answer.

A state the recording lacks but that is the derivative of a measured one (`Model.derivative_of`,
velocity of a measured position) is obtained by the same filtered differentiation; one whose rate
no parameter enters and the recorded states drive (an angle, dth/dt = w1 - w2) by integrating it
from 0 (`linear_form.integrated_states`). On the EMPS
benchmark with the authors' settings (100 Hz, order 4, 50 border samples, decimation by 10) this
is their `Script_IDIM_LS.m`.

The result is a `Parameters`: values, standard errors (s^2 (A^T W A)^-1 of the regression) and
automatic search ranges (`auto_range`)."""

import math
import warnings
from collections.abc import Mapping

import jax
import jax.numpy as jnp
import numpy as np

from ..compiling import filter_jit, on_device
from ..errors import ConfigError
from ..io.recording import Recording
from ..models import DiscreteModel, Model, get_model
from ..models.bounds import Bounds
from ..models.parameters import Parameter, Parameters
from ..simulation.integrators import RK4
from ..simulation.joint import grid_length, paddable, padded
from ..simulation.objectives import objective
from ..simulation.problem import make_problem
from .linear_form import integrated_states, linear_masses, linear_regression

CUTOFFS = np.array([0.4, 0.2, 0.1, 0.05, 0.025])  # candidate cutoffs, fractions of the sampling rate
LM_STARTS = 63  # random LM starts of a model not linear in its parameters (besides the midpoints)
LM_ROWS = 2000  # equation-error rows LM reads at most
LM_STEPS = 100  # LM steps from each start (the vmapped starts run until the slowest stops)
DETERMINED = 0.5  # relative standard error up to which a parameter counts as seen by the regression
DECADE = 10.0


def _border(fs: float, cutoff: float, n: int) -> int:
    """Samples dropped at each end: the filter's time scale, fs / cutoff, at most a tenth of them."""
    return min(int(math.ceil(fs / cutoff)), n // 10)


def _output_errors(recording: Recording, model: Model, xs: list[np.ndarray]) -> np.ndarray:
    """OF (eq. 24) of simulating each `x` on the recording (RK4, 2 sub-steps; one population
    evaluation); +inf where a simulation blows up or `x` is not finite."""
    x = np.array(xs, float)
    ok = np.all(np.isfinite(x), axis=1)
    x[~ok] = x[ok][0] if ok.any() else 1.0
    problem = make_problem(recording, None if isinstance(model, DiscreteModel) else RK4(substeps=2), model=model)
    if paddable(problem):  # masked to a power-of-two length: a folder of many lengths compiles a few programs
        problem = padded(problem, grid_length(problem.n))
    f = np.asarray(_objective_jit(on_device(x), problem))
    return np.where(ok & np.isfinite(f), f, np.inf)


_objective_jit = filter_jit(objective)  # one compilation per recording shape, not one per cutoff


def _filtered(x: np.ndarray, fs: float, cutoff: float, order: int) -> np.ndarray:
    from scipy.signal import butter, filtfilt  # lazy: scipy adds 0.1-0.6 s to importing dcjax

    if cutoff >= 0.5 * fs:
        return x.copy()
    b, a = butter(order, cutoff / (0.5 * fs))[:2]  # pyright: ignore[reportOptionalSubscript]
    return filtfilt(b, a, x)


def _uniform(recording: Recording) -> float:
    return float(np.median(np.diff(recording.t)))


def uniformly_sampled(recording: Recording) -> Recording:
    """The recording itself where its sample time is constant (to 0.1 %), else every channel
    interpolated linearly onto a grid of its median sample time (the filter and the central
    differences assume one)."""
    dt = np.diff(recording.t)
    h = float(np.median(dt))
    if np.max(np.abs(dt - h)) <= 1e-3 * h:
        return recording
    t = recording.t[0] + h * np.arange(int(np.floor((recording.t[-1] - recording.t[0]) / h)) + 1)
    return recording.replace(t=t, channels={k: np.interp(t, recording.t, v) for k, v in recording.channels.items()})


def filtered_states(recording: Recording, model: Model, cutoff: float | None = None, order: int = 4):
    """(y, dy): every state of `model` and its derivative from the recording, filtered at
    `cutoff` Hz (default a tenth of the sampling rate)."""
    h = _uniform(recording)
    fs = 1.0 / h
    cutoff = 0.1 * fs if cutoff is None else float(cutoff)
    if not cutoff > 0:
        raise ConfigError(f"cutoff must be a positive frequency in Hz, got {cutoff!r}")
    y: dict[str, np.ndarray] = {}
    for s in model.states:
        if s in recording.channels:
            y[s] = _filtered(np.asarray(recording[s]), fs, cutoff, order)
    for s in model.states:  # velocity of a measured position, acceleration of a derived velocity...
        src = model.derivative_of.get(s)
        if s not in y and src is not None and src in y:
            y[s] = np.gradient(y[src], h)
    inputs = {c: np.asarray(recording[c]) for c in model.inputs if c in recording.channels or c in recording.constants}
    y |= integrated_states(model, y, inputs, h)  # a shaft's twist from the speeds either side of it
    missing = [s for s in model.states if s not in y]
    if missing:
        raise ConfigError(
            f"{recording._where()}initial_estimate needs every state of model {model.name} measured, the derivative of a measured one "
            "or the integral of a rate no parameter enters; "
            f"missing {', '.join(missing)} (the recording has {', '.join(recording.channels)}): a model says which state is the time "
            f"derivative of a measured one with Model.derivative_of ({{{missing[0]!r}: NAME}}); else give every parameter's range "
            f"(params[{model.names[0]!r}].set(min=LO, max=HI))"
        )
    dy = {s: np.gradient(y[s], h) for s in model.states}
    return y, dy


def _rows(recording, model, cutoff, order, border, decimate):
    y, dy = filtered_states(recording, model, cutoff, order)
    u = {c: np.asarray(recording[c]) for c in model.inputs}
    n = len(recording)
    b = int(border)
    if 2 * b >= n - 3:
        raise ConfigError(f"{recording._where()}border {b} leaves too few of {n} samples")
    cut = slice(b, n - b if b else None)
    y, dy, u = ({k: v[cut] for k, v in d.items()} for d in (y, dy, u))
    return y, dy, u, int(decimate)


def _decimated(x: np.ndarray, q: int) -> np.ndarray:
    if q <= 1:
        return x
    from scipy.signal import decimate  # lazy: scipy adds 0.1-0.6 s to importing dcjax

    return decimate(x, q)


def _scaled_lstsq(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least squares with the columns scaled to unit norm (the DC regressors span ~10 decades),
    and the covariance s^2 (A^T A)^-1 of the solution."""
    norm = np.linalg.norm(A, axis=0)
    norm = np.where(norm > 0, norm, 1.0)
    As = A / norm
    sol, *_ = np.linalg.lstsq(As, b, rcond=None)
    res = b - As @ sol
    s2 = float(res @ res) / max(1, A.shape[0] - A.shape[1])
    cov = np.linalg.pinv(As.T @ As) * s2 / np.outer(norm, norm)
    return sol / norm, cov


def _linear_estimate(model: Model, blocks, q: int, known: Mapping[str, float] | None = None):
    """Weighted linear least squares over the equations, the `known` parameters' terms moved to
    the right-hand side; returns (theta, stderr, scale_upper)."""
    names = model.names
    P = len(names)
    fixed = {names.index(n): float(v) for n, v in (known or {}).items()}
    mats, rhss, masses = [], [], []
    for cols, rhs, mass in blocks:
        model.check_names(cols, "regression column")
        A = np.zeros((len(rhs), P))
        for k, c in cols.items():
            A[:, names.index(k)] = np.broadcast_to(c, rhs.shape)
        rhs = np.asarray(rhs, float) - sum((v * A[:, k] for k, v in fixed.items()), np.zeros(len(rhs)))
        A[:, list(fixed)] = 0.0
        mats.append(np.column_stack([_decimated(A[:, k], q) for k in range(P)]))
        rhss.append(_decimated(rhs, q))
        masses.append(names.index(mass) if mass is not None else None)
    seen = np.flatnonzero(np.any(np.concatenate(mats) != 0, axis=0))
    theta = np.full(P, np.nan)
    for k, v in fixed.items():
        theta[k] = v
    weights = [1.0] * len(mats)
    for _ in range(6):  # re-weight by each equation's inertial term at the current estimate
        A = np.concatenate([w * M[:, seen] for w, M in zip(weights, mats)])
        b = np.concatenate([w * r for w, r in zip(weights, rhss)])
        theta[seen], _ = _scaled_lstsq(A, b)
        new = []
        for M, r, m in zip(mats, rhss, masses):  # an equation without a mass: its rate's scale
            term = r if m is None else theta[m] * M[:, m]
            rms = float(np.sqrt(np.mean(term**2))) if np.all(np.isfinite(term)) else 0.0
            new.append(1.0 / rms if rms > 0 else 1.0)
        if np.allclose(new, weights, rtol=1e-6):
            break
        weights = new
    A = np.concatenate([w * M[:, seen] for w, M in zip(weights, mats)])
    b = np.concatenate([w * r for w, r in zip(weights, rhss)])
    theta[seen], cov = _scaled_lstsq(A, b)
    stderr = np.full(P, np.nan)
    stderr[seen] = np.sqrt(np.maximum(np.diag(cov), 0.0))
    stderr[list(fixed)] = 0.0
    # A parameter's term cannot outweigh its equation: |theta_k| max|A_k| <= the equation's
    # largest term (peak torque over peak speed for Tlb, over its square for Tlc).
    upper = np.full(P, np.inf)
    for M, r in zip(mats, rhss):
        terms = [np.max(np.abs(r))] + [
            abs(theta[j]) * np.max(np.abs(M[:, j])) for j in range(P) if np.isfinite(theta[j]) and np.any(M[:, j])
        ]
        peak = max(terms)
        for k in range(P):
            colmax = np.max(np.abs(M[:, k]))
            if colmax > 0:
                upper[k] = min(upper[k], peak / colmax) if np.isfinite(upper[k]) else peak / colmax
    return theta, stderr, upper


def _derivative_residual(model: Model, phi, data):
    """(dy/dt - f(theta, y, u)) / rms(dy/dt), stacked over the states; theta = phi^2 where
    non-negative, the known ones' values where `known` marks them. A discrete-time model's rate
    is (update(c, u, y, dt) - y) / dt at the rows' dt."""
    Y, U, DY, scale, nn, dt, known, values = data
    p = model.as_dict(jnp.where(known, values, jnp.where(nn, phi * phi, phi)))
    c = model.coefficients(p)
    if isinstance(model, DiscreteModel):
        f = tuple((a - b) / dt for a, b in zip(model.update(c, U, Y, dt), Y))
    else:
        f = model.vector_field(c, U, Y)
    return jnp.concatenate([s * (d - fi) for s, d, fi in zip(scale, DY, f)])


@filter_jit
def _lm_solve(model: Model, phi0, data):
    """Vmapped LM from every start (one compilation per model and data shape); (solutions, costs)."""
    import optimistix as optx  # lazy: optimistix adds ~0.2 s to importing dcjax

    solver = optx.LevenbergMarquardt(rtol=1e-10, atol=1e-12)
    residual = lambda phi, d: _derivative_residual(model, phi, d)
    phis = jax.vmap(lambda p0: optx.least_squares(residual, solver, p0, args=data, max_steps=LM_STEPS, throw=False).value)(phi0)
    return phis, jax.vmap(lambda p: jnp.sum(residual(p, data) ** 2))(phis)


@filter_jit
def _lm_linearised(model: Model, phi, data):
    """(theta, the derivative residual, its Jacobian in theta) at LM's solution `phi` (theta =
    phi^2 where non-negative), compiled once per model and data shape: traced op by op they took
    ~0.02 s an estimate (476 servo logs' first estimates spent 100 s on them)."""
    nonneg, known, values = data[4], data[6], data[7]
    theta = jnp.where(known, values, jnp.where(nonneg, phi * phi, phi))
    jac = jax.jacfwd(lambda t: _derivative_residual(model, jnp.where(nonneg, jnp.sqrt(jnp.abs(t)), t), data))(theta)
    return theta, _derivative_residual(model, phi, data), jac


def _lm_rows(n: int) -> np.ndarray:
    """At most LM_ROWS of `n` equation-error rows, evenly spread: each row is its own equation
    (the filter already smoothed the states), so a long recording's LM costs what a short one's
    does, and recordings of any length from LM_ROWS up share one compiled LM."""
    return np.unique(np.linspace(0, n - 1, min(n, LM_ROWS)).astype(int))


def _lm_estimate(
    model: Model, y, dy, u, q: int, start: Parameters, dt: float, seed: np.ndarray | None = None, known: Mapping[str, float] | None = None
):
    """Levenberg–Marquardt on the normalized derivative residual (models not linear in theta);
    from `seed` alone where given (another cutoff's estimate), else from many starts; the
    `known` parameters held at their values."""
    names = model.names
    fixed = np.array([n in (known or {}) for n in names])
    lo, hi = start.lower, start.upper
    nonneg = np.array([p.positive for p in start.values()]) | (np.isfinite(lo) & (lo >= 0))
    # LM from one start finds local minima: start from the given values, the ranges' midpoints and
    # LM_STARTS points log-uniform over six decades below each range's width (a fixed seed).
    frac = np.vstack([np.full(len(names), 0.5), 10.0 ** (-6.0 * np.random.default_rng(0).uniform(size=(LM_STARTS, len(names))))])
    width = np.where(np.isfinite(hi - lo), hi - lo, 1.0)
    x0 = np.where(np.isfinite(lo), lo, 0.0) + frac * width
    given = np.array([p.value is not None for p in start.values()])
    x0 = np.where(given, np.array([p.value if p.value is not None else 0.0 for p in start.values()]), x0)
    x0 = x0 if seed is None else np.asarray(seed, float)[None]
    phi0 = np.where(nonneg, np.sqrt(np.abs(x0)), x0)
    rows = _lm_rows(len(_decimated(next(iter(dy.values())), q)))
    DY = tuple(jnp.asarray(_decimated(dy[s], q)[rows]) for s in model.states)
    data = (
        tuple(jnp.asarray(_decimated(y[s], q)[rows]) for s in model.states),
        tuple(jnp.asarray(_decimated(u[c], q)[rows]) for c in model.inputs),
        DY,
        tuple(jnp.asarray(1.0 / max(float(jnp.sqrt(jnp.mean(d * d))), 1e-300)) for d in DY),
        jnp.asarray(nonneg),
        jnp.asarray(dt * q, jnp.float64),  # the rows' sample interval (a discrete-time model's update takes it)
        jnp.asarray(fixed),
        jnp.asarray([float((known or {}).get(n, 0.0)) for n in names], jnp.float64),
    )
    phis, cost = _lm_solve(model, jnp.asarray(phi0), data)
    cost = np.where(np.isfinite(np.asarray(cost)), np.asarray(cost), np.inf)
    x, r, J = map(np.asarray, _lm_linearised(model, phis[int(np.argmin(cost))], data))
    J = np.where(fixed[None, :], 0.0, J)
    s2 = float(r @ r) / max(1, r.size - len(names) + int(fixed.sum()))
    stderr = np.where(fixed, 0.0, np.sqrt(np.maximum(np.diag(np.linalg.pinv(J.T @ J)) * s2, 0.0)))
    return x, stderr, np.full(len(names), np.inf)


LOG_SPAN = 1e-6  # the lower end of an automatic log-scale range that would start at 0, relative to its upper end


def auto_range(value: float, stderr: float, nonneg: bool, scale_upper: float, preset: tuple[float, float] | None) -> tuple[float, float]:
    """The automatic search range of one parameter:

    - seen by the regression (finite value, positive where the parameter is non-negative,
      relative std. error <= 50 %): a decade either side, [v/10, 10 v], widened to v +- 3 stderr
      and never below 0 for a non-negative parameter (a signed one: v +- 9|v| +- 3 stderr);
    - not seen: [0, U] (signed: [-U, U]) with U the recording's own scale for it (its term
      cannot outweigh its equation's largest term; for Tlb peak torque / peak speed, for Tlc
      peak torque / peak speed^2), at least 10 |v|;
    - and where the model has a bounds preset (`preset`), the range is widened to hold it too:
      the equation error of coarsely sampled or noisy data can be biased far beyond its
      standard error (on the 7.5 Hz MD analogues La came out 5-14x too large), so `auto` never
      searches less than the preset, and extends it where the estimate lies outside."""
    lo, hi = _estimate_range(value, stderr, nonneg, scale_upper)
    if preset is None:
        return lo, hi
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return preset
    return min(lo, preset[0]), max(hi, preset[1])


def _estimate_range(value: float, stderr: float, nonneg: bool, scale_upper: float) -> tuple[float, float]:
    se = stderr if np.isfinite(stderr) else np.inf
    seen = np.isfinite(value) and (value > 0 or not nonneg) and value != 0 and se <= DETERMINED * abs(value)
    if seen:
        if nonneg:
            return max(0.0, min(value / DECADE, value - 3 * se)), max(value * DECADE, value + 3 * se)
        w = (DECADE - 1) * abs(value) + 3 * se
        return value - w, value + w
    upper = scale_upper
    if np.isfinite(value):
        upper = max(upper, DECADE * abs(value)) if np.isfinite(upper) else upper
    if not (np.isfinite(upper) and upper > 0):
        return -math.inf, math.inf
    return (0.0, upper) if nonneg else (-upper, upper)


def _linear_form(recording: Recording, model: Model, order: int, start: Parameters, dt: float) -> "str | list[int] | None":
    """How the state equations are linear in theta: "own" (the model's `regression()` gives its
    blocks), the factors `linear_form.linear_masses` finds for every equation (probed once on the
    recording's filtered rows) or None (Levenberg–Marquardt on the derivative residual)."""
    y, dy = filtered_states(recording, model, None, order)
    u = {c: np.asarray(recording[c]) for c in model.inputs}
    if model.regression(y, dy, u) is not None:
        return "own"
    return linear_masses(model, y, u, dt, start)


def initial_estimate(
    recording: Recording,
    model: Model | str | None = None,
    *,
    cutoff: float | None = None,
    order: int = 4,
    border: int | None = None,
    decimate: int = 1,
    start: Parameters | None = None,
    known: Mapping[str, float] | None = None,
) -> Parameters:
    """Equation-error least squares estimate of `model`'s parameters from `recording` (module
    docstring). `cutoff` (Hz) and `order` of the zero-phase Butterworth filter; by default the
    estimate is made at 0.4, 0.2, 0.1, 0.05 and 0.025 times the sampling rate and the one whose
    simulation fits the recording best (OF, eq. 24) is kept. `border` samples dropped at each end
    (default the filter's time scale, fs / cutoff); `decimate` the regression rows (scipy.signal.decimate, zero phase) as IDIM-LS
    does. `start`: the LM start and sign conventions for a model without `regression` (default
    the model's preset). `known`: parameters whose values are known (a fit's fixed ones), held at
    them: a direction the data do not see is then pinned as the fit pins it. Returns
    `Parameters`: value, stderr, and `min`/`max` by `auto_range`."""
    m = get_model(model)
    known = dict(known or {})
    m.check_names(known, "known")
    bad = {n: v for n, v in known.items() if not (isinstance(v, (int, float, np.number)) and not isinstance(v, bool) and math.isfinite(v))}
    if bad:
        raise ConfigError(f"known: {', '.join(f'{n}={v!r}' for n, v in bad.items())}: a known value must be a finite number")
    if not isinstance(recording, Recording):
        raise ConfigError("recording must be a dcjax.Recording")
    scored = recording
    recording = uniformly_sampled(recording)
    for name, v in (("order", order), ("decimate", decimate)):
        if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < 1:
            raise ConfigError(f"{name} must be a positive integer, got {v!r}")
    fs = 1.0 / _uniform(recording)
    if cutoff is not None and not (isinstance(cutoff, (int, float, np.number)) and cutoff > 0):
        raise ConfigError(f"cutoff must be a positive frequency in Hz, got {cutoff!r}")
    if border is not None and (not isinstance(border, (int, np.integer)) or isinstance(border, bool) or border < 0):
        raise ConfigError(f"border must be a non-negative integer, got {border!r}")
    base = start if start is not None else m.parameters()
    nonneg = np.array([p.positive or (math.isfinite(p.min) and p.min >= 0) for p in base.values()])

    form = _linear_form(recording, m, order, base, 1.0 / fs)
    linear = form is not None
    masses = form if isinstance(form, list) else None
    n_samples = len(recording)

    seeds: list[np.ndarray] = []  # LM: the many starts at the middle cutoff, the others from its estimate

    def solve(c):  # the LM path keeps one border for every cutoff: one compilation, not five
        b = border if border is not None else _border(fs, c if linear or cutoff is not None else float(CUTOFFS.min() * fs), n_samples)
        y, dy, u, q = _rows(recording, m, c, order, b, decimate)
        blocks = m.regression(y, dy, u) if form == "own" else linear_regression(m, y, dy, u, 1.0 / fs, base, masses) if masses else None
        if blocks is not None:
            return _linear_estimate(m, blocks, q, known)
        est = _lm_estimate(m, y, dy, u, q, base, 1.0 / fs, seeds[0] if seeds else None, known)
        seeds.append(est[0])
        return est

    if cutoff is not None:
        theta, stderr, upper = solve(float(cutoff))
    else:  # the cutoff whose estimate simulates the recording best (output error, eq. 24)
        middle = solve(float(CUTOFFS[2] * fs))
        tried = [(c, middle if k == 2 else solve(c)) for k, c in enumerate(CUTOFFS * fs)]
        scores = _output_errors(scored, m, [np.where(nonneg, np.maximum(est[0], 0.0), est[0]) for _, est in tried])
        theta, stderr, upper = tried[int(np.argmin(scores))][1]
    out = []
    for k, n in enumerate(m.names):
        b = base[n]
        preset = (b.min, b.max) if math.isfinite(b.min) and math.isfinite(b.max) else None
        lo, hi = auto_range(float(theta[k]), float(stderr[k]), bool(nonneg[k]), float(upper[k]), preset)
        if b.scale == "log" and not lo > 0 and hi > 0:
            lo = hi * LOG_SPAN  # a log-scale search needs min > 0: six decades below the range's top
        v = float(theta[k])
        value = v if np.isfinite(v) and (v >= 0 or not nonneg[k]) else None
        se = float(stderr[k]) if np.isfinite(stderr[k]) else None
        out.append(
            Parameter(
                n,
                value=value,
                min=lo,
                max=hi,
                unit=m.units.get(n, ""),
                precision=b.precision,
                stderr=se,
                positive=b.positive,
                scale=b.scale,
            )
        )
    return Parameters(out)


# `auto_bounds` estimates at most this many recordings of a joint fit, spread evenly over it.
AUTO_RECORDINGS = 8


def estimated_recordings(recordings: list[Recording]) -> list[Recording]:
    """The recordings `auto_bounds` estimates: all, or `AUTO_RECORDINGS` spread evenly over a
    longer list, the first and the last among them."""
    n = len(recordings)
    if n <= AUTO_RECORDINGS:
        return list(recordings)
    return [recordings[k] for k in np.unique(np.round(np.linspace(0, n - 1, AUTO_RECORDINGS)).astype(int))]


def auto_bounds(recordings: "Recording | list[Recording]", model: Model | str | None = None, known: Mapping[str, float] | None = None):
    """`bounds="auto"`: (Bounds, start values, the estimates) from `initial_estimate` of the
    recordings (`estimated_recordings`: of a joint fit of more than `AUTO_RECORDINGS`, that many
    spread over it) — the union of their ranges, and the first recording's values as start
    values (they seed the initial population). The recordings of a joint fit share the model's
    parameters and each range reaches a decade either side of its estimate, while a nonlinear
    model's estimate is a Levenberg–Marquardt from 64 starts (~0.3 s a servo log: 476 logs
    took 4 minutes of a command-line fit). `known`: parameters held at their values in the
    estimates (`initial_estimate`)."""

    m = get_model(model)
    recs = recordings if isinstance(recordings, (list, tuple)) else [recordings]
    ests = []
    for r in estimated_recordings(list(recs)):
        try:
            ests.append(initial_estimate(r, m, known=known))
        except Exception as e:  # a state neither measured nor a derivative, a singular regression: the preset, said once
            if not m.preset_names:
                raise ConfigError(f"bounds auto: {e}") from None
            warnings.warn(f"bounds auto: {e}; using the model's preset {m.preset_names[0]} for {r.name or 'this recording'}", stacklevel=2)
            ests.append(m.parameters())
    lo = np.min([e.lower for e in ests], axis=0)
    hi = np.max([e.upper for e in ests], axis=0)
    bad = [n for n, a, b in zip(m.names, lo, hi) if not (math.isfinite(a) and math.isfinite(b))]
    if bad:
        raise ConfigError(
            f"bounds auto: no range for {', '.join(bad)} (not seen by the regression and model {m.name} has no preset); give them: params[NAME].set(min=LO, max=HI)"
        )
    start = {n: v for n, v in ests[0].start.items() if lo[m.names.index(n)] <= v <= hi[m.names.index(n)]}
    return Bounds(lo, hi, m.names), start, ests
