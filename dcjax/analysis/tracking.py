"""Parameters that drift through a recording, followed by an extended Kalman filter on the state
augmented with them (each a random walk, theta_{k+1} = theta_k + w_k, w_k ~ N(0, q_theta h_k)) and
a fixed-interval Rauch–Tung–Striebel smoother (Särkkä 2013, eqs. 8.2–8.3 on the EKF's
linearisation):

    C_k = P_{k|k} F_k' P_{k+1|k}^-1
    m_{k|N} = m_{k|k} + C_k (m_{k+1|N} - m_{k+1|k})      P_{k|N} = P_{k|k} + C_k (P_{k+1|N} - P_{k+1|k}) C_k'

The other parameters stay at the fit's values; the model's states carry the fit's process noise
(a prediction-error fit's q, else none), the sensors its sd (else the record's noise estimate,
`checks.noise_step`). A drift is the random walk's intensity per parameter (unit^2/s); by default
one that lets a parameter wander by a tenth of its value over the record."""

import dataclasses
import math
import warnings

import jax
import jax.numpy as jnp
import numpy as np

from ..compiling import filter_jit
from ..errors import ConfigError
from ..io.recording import Recording, as_recording
from ..simulation.adjustments import input_pieces
from ..simulation.integrate import advance_pieces, initial_state, sample_inputs
from ..simulation.joint import JointProblem
from ..simulation.predictors import EKF
from .checks import noise_step

DEFAULT_SHARE = 0.1  # the default drift: this share of the value over the record (1 sd); also the start's sd


@dataclasses.dataclass(frozen=True)
class Tracked:
    """`t` (N,), per tracked parameter (`names`) its smoothed value and sd at every sample (N, V);
    `filtered` the filter's causal estimate (N, V); the `drift` intensities used."""

    names: tuple[str, ...]
    t: np.ndarray
    values: np.ndarray
    sd: np.ndarray
    filtered: np.ndarray
    drift: dict[str, float]

    def table(self) -> tuple[list[str], np.ndarray]:
        """(columns, rows) of track.csv: t, then each parameter and its sd (`Ra`, `Ra_sd`)."""
        cols = ["t", *(c for n in self.names for c in (n, f"{n}_sd"))]
        data = np.column_stack([self.t, *(a for k in range(len(self.names)) for a in (self.values[:, k], self.sd[:, k]))])
        return cols, data


def _noise(target: JointProblem, x):
    """(q per state, r per output): a prediction-error fit's (its fitted noise where searched),
    else no process noise and the record's own sensor-noise estimate."""
    problem, adj = target.problems[0], target.adjustments(x, 0)
    model = problem.model
    if isinstance(problem.predictor, EKF):
        q = problem.predictor.process if adj is None or adj.process is None else adj.process
        r = problem.predictor.measurement if adj is None or adj.measurement is None else adj.measurement
        return np.asarray(q, float), np.asarray(r, float)
    y = np.asarray(problem.y_meas)
    peak = np.max(np.abs(y), axis=0)
    return np.zeros(len(model.states)), np.maximum([noise_step(y[:, j], 4) for j in range(y.shape[1])], 1e-9 * peak)


@filter_jit
def _smooth(z0, p0, qz, r, x_model, vary, target: JointProblem, x_vec):
    """The augmented filter and the RTS smoother: (smoothed means, covariances, filtered means)."""
    problem = target.problems[0]
    model = problem.model
    adj = target.adjustments(x_vec, 0)
    n_states = len(model.states)
    steady = problem.steady_inputs()
    u = sample_inputs(problem)
    m = u.shape[1]
    offset = jnp.zeros(len(model.outputs)) if adj is None or adj.offset is None else adj.offset
    rr = jnp.diag(r**2)

    def coefficients(z):
        return model.coefficients(model.as_dict(x_model.at[vary].set(z[n_states:])))

    def step(z, lengths, inputs):
        y = advance_pieces(coefficients(z), problem, tuple(z[s] for s in range(n_states)), lengths, inputs, steady)
        return jnp.concatenate([jnp.stack(y), z[n_states:]])

    def measure(z, u_k):
        out = model.compared(coefficients(z), tuple(u_k[j] for j in range(m)), tuple(z[s] for s in range(n_states)))
        return jnp.stack(out) + offset

    def update(z, p, y, u_k):
        h = jax.jacfwd(measure)(z, u_k)
        s = h @ p @ h.T + rr
        k = jnp.linalg.solve(s, h @ p).T
        ikh = jnp.eye(z.shape[0]) - k @ h
        return z + k @ (y - measure(z, u_k)), ikh @ p @ ikh.T + k @ rr @ k.T

    zf, pf = update(z0, p0, problem.y_meas[0], u[0])

    def forward(carry, xs):
        z, p = carry
        lengths, inputs, y, u_k, dt = xs
        f = jax.jacfwd(step)(z, lengths, inputs)
        zp, pp = step(z, lengths, inputs), f @ p @ f.T + jnp.diag(qz * dt)
        zu, pu = update(zp, 0.5 * (pp + pp.T), y, u_k)
        return (zu, 0.5 * (pu + pu.T)), (zu, pu, zp, pp, f)

    lengths, inputs = input_pieces(problem, adj)
    _, (zs, ps, zps, pps, fs) = jax.lax.scan(forward, (zf, pf), (lengths, inputs, problem.y_meas[1:], u[1:], problem.h))
    zs, ps = jnp.concatenate([zf[None], zs]), jnp.concatenate([pf[None], ps])

    def backward(carry, xs):
        zn, pn = carry
        z, p, zp, pp, f = xs
        c = p @ f.T @ jnp.linalg.pinv(pp, hermitian=True)  # P_{k|k} F' P_{k+1|k}^+ (singular where a state has no noise)
        zk, pk = z + c @ (zn - zp), p + c @ (pn - pp) @ c.T
        return (zk, 0.5 * (pk + pk.T)), (zk, pk)

    _, (zb, pb) = jax.lax.scan(backward, (zs[-1], ps[-1]), (zs[:-1], ps[:-1], zps, pps, fs), reverse=True)
    return jnp.concatenate([zb, zs[-1:]]), jnp.concatenate([pb, ps[-1:]]), zs


def track(result, recording: Recording, vary, drift: dict[str, float] | None = None, start_sd: dict[str, float] | None = None) -> Tracked:
    """Follow the parameters `vary` (names of the model's) through `recording` (module docstring):
    `drift` name -> the random walk's intensity (unit^2/s; default (0.1 |value|)^2 over the record's
    duration); `start_sd` name -> the sd of the start at the fit's value (default 0.1 |value|)."""
    model = result.model
    vary = tuple([vary] if isinstance(vary, str) else vary)
    bad = [n for n in vary if n not in model.names]
    if not vary or bad:
        raise ConfigError(f"vary: {', '.join(bad) or 'nothing'} is not a parameter of model {model.name} ({', '.join(model.names)})")
    drift, start_sd = dict(drift or {}), dict(start_sd or {})
    for what, given in (("drift", drift), ("start_sd", start_sd)):
        unknown = [n for n in given if n not in vary]
        if unknown:
            raise ConfigError(f"{what}: {', '.join(unknown)} is not tracked (vary: {', '.join(vary)})")
        for n, v in given.items():
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ConfigError(f"{what}: {n} must be a finite number >= 0, got {v!r}")
    rec = as_recording(recording, model)
    target = result.target([rec])
    x = jnp.asarray([result.best_values[n] for n in result.names], dtype=jnp.float64)
    x_model = jnp.asarray(target.model_x(x, 0))
    values = {n: float(x_model[model.names.index(n)]) for n in vary}
    duration = float(rec.t[-1] - rec.t[0]) or 1.0
    q_theta = {n: drift.get(n, (DEFAULT_SHARE * abs(values[n])) ** 2 / duration) for n in vary}
    sd0 = {n: start_sd.get(n, DEFAULT_SHARE * abs(values[n])) for n in vary}
    q, r = _noise(target, x)
    adj = target.adjustments(x, 0)
    y0 = initial_state(target.problems[0], (), None if adj is None else adj.y0)
    z0 = jnp.concatenate([jnp.stack(y0), jnp.asarray([values[n] for n in vary])])
    p0 = jnp.diag(jnp.asarray([*np.zeros(len(model.states)), *(sd0[n] ** 2 for n in vary)]))
    qz = jnp.asarray([*q, *(q_theta[n] for n in vary)])
    idx = jnp.asarray([model.names.index(n) for n in vary])
    zs, ps, zf = _smooth(z0, p0, qz, jnp.asarray(r), x_model, idx, target, x)
    k = len(model.states)
    sd = np.sqrt(np.clip(np.diagonal(np.asarray(ps), axis1=1, axis2=2)[:, k:], 0.0, None))
    tracked = Tracked(vary, np.asarray(rec.t), np.asarray(zs)[:, k:], sd, np.asarray(zf)[:, k:], q_theta)
    _warn_below_zero(tracked, result, rec.name)
    return tracked


def _non_negative(result, name: str) -> bool:
    """Whether the fit held `name` at or above 0: a positive parameter of its model, or a search range from 0 up."""
    if name in result.model.positive:
        return True
    lower = dict(zip(result.names, np.asarray(result.bounds.lower)))
    lo = lower.get(name, lower.get(f"{name}[0]"))
    return lo is not None and lo >= 0


def _warn_below_zero(tracked: Tracked, result, recording: str) -> None:
    """A one-line warning for each tracked parameter the fit held at or above 0 whose smoothed
    value goes below 0: no drift of the motor, the filter taking up what the model does not
    explain on this recording."""
    for k, n in enumerate(tracked.names):
        v = tracked.values[:, k]
        if _non_negative(result, n) and np.min(v) < 0:
            at = int(np.argmin(v))
            warnings.warn(
                f"track: {n} goes below 0 on {recording} (to {v[at]:.4g} at t = {tracked.t[at]:.4g} s), which the fit held at or "
                "above 0: the filter takes up what the model does not explain here, not a drift; check the fit on this "
                "recording (dcjax validate)",
                stacklevel=3,
            )


def plot_tracked(tracked: Tracked, path) -> None:
    """Each tracked parameter against time with its smoothed +-2 sd band and the filter's estimate."""
    from matplotlib.figure import Figure  # lazy: matplotlib adds ~0.3 s to importing dcjax

    from ..io.files import save_figure

    n = len(tracked.names)
    fig = Figure(figsize=(6.5, 2.4 * n))
    axes = fig.subplots(n, 1, squeeze=False)[:, 0]
    for k, (ax, name) in enumerate(zip(axes, tracked.names)):
        v, s = tracked.values[:, k], tracked.sd[:, k]
        ax.fill_between(tracked.t, v - 2 * s, v + 2 * s, color="0.85", label="+-2 sd (smoothed)")
        ax.plot(tracked.t, tracked.filtered[:, k], color="0.5", lw=0.7, label="filtered")
        ax.plot(tracked.t, v, "r-", lw=1.2, label="smoothed")
        ax.set(xlabel="t (s)", ylabel=name)
        ax.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path, dpi=90)


__all__ = ["Tracked", "plot_tracked", "track"]
