"""A fit's K-step-ahead predictions on a record (`validate(..., predict=K)`): the record filtered by
the fit's extended Kalman filter to sample i - K, then simulated K intervals open loop
(`dcjax.simulation.kalman.predict`), with the normalised innovations' calibration (mean,
variance, whiteness: N(0, 1) and white for a right model with the right noise) as the check.

A prediction-error fit predicts with its own filter and fitted noise. A simulation-error fit has
no noise model: its process intensities (of the measured states) and sensor sd are estimated on
the record with the parameters fixed (BFGS on their logarithms, `estimate_noise`), and said so."""

import dataclasses

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..compiling import filter_jit
from ..gradients import forward_gradient, forward_mode
from ..simulation.joint import JointProblem
from ..simulation.kalman import kalman_filter, predict, prediction_error
from ..simulation.objectives import simulate_outputs
from ..simulation.predictors import EKF
from .checks import noise_step
from .metrics import whiteness


@dataclasses.dataclass(frozen=True)
class Prediction:
    """`outputs` (N, C) the K-step-ahead prediction, `whitened` (N, C) the normalised innovations,
    `noise` (q_<state>, r_<output> -> value) the filter's noise and whether it was `estimated`."""

    outputs: np.ndarray
    whitened: np.ndarray
    noise: dict[str, float]
    estimated: bool


def calibration(whitened: np.ndarray, names: tuple[str, ...]) -> dict[str, dict[str, float]]:
    """Per output the normalised innovations' mean, variance and whiteness (`metrics.whiteness`)."""
    return {c: {"mean": float(np.mean(w)), "variance": float(np.var(w)), "whiteness": whiteness(w)} for c, w in zip(names, whitened.T)}


def _filter_noise(model, ekf: EKF, adj) -> dict[str, float]:
    q = np.asarray(ekf.process if adj is None or adj.process is None else adj.process, float)
    r = np.asarray(ekf.measurement if adj is None or adj.measurement is None else adj.measurement, float)
    return {**{f"q_{s}": float(v) for s, v in zip(model.states, q) if v > 0}, **{f"r_{c}": float(v) for c, v in zip(model.outputs, r)}}


@filter_jit
def _predict(x, problem, ekf: EKF, adj, steps: int):
    return predict(x, problem, ekf, steps, adj), kalman_filter(x, problem, ekf, adj).whitened


SENSOR_DECADES = 1.5  # an estimated sensor sd stays within 10^(+-1.5) of the record's noise estimate


def _noise_of(z, template: EKF, states, r_lo, r_hi) -> EKF:
    """q = exp(z_q) for `states`; r = r_lo (r_hi / r_lo)^sigmoid(z_r): within its bounds (a sensor
    sd free to vanish lets process noise take every misfit)."""
    k = states.shape[0]
    r = r_lo * (r_hi / r_lo) ** jax.nn.sigmoid(z[k:])
    return eqx.tree_at(lambda e: (e.process, e.measurement), template, (template.process.at[states].set(jnp.exp(z[:k])), r))


@filter_jit
def _fit_noise(z0, x, problem, template: EKF, adj, states: jax.Array, r_lo, r_hi):
    import optimistix as optx  # lazy: with lineax a tenth of a second of every dcjax import

    def nll(z):
        return prediction_error(x, problem, _noise_of(z, template, states, r_lo, r_hi), adj)

    steps = problem.n * int(getattr(problem.integrator, "substeps", 1))
    differentiated = forward_gradient(nll) if forward_mode(z0.shape[0], steps) else nll
    return optx.minimise(lambda z, _: differentiated(z), optx.BFGS(rtol=1e-8, atol=1e-8), z0, max_steps=300, throw=False).value


def estimate_noise(target: JointProblem, x, starts: tuple[str, ...]) -> EKF:
    """An EKF for the record of `target` (one) at the search vector `x`, its noise fitted with the
    parameters fixed: a process intensity per measured state (from a thousandth of the open-loop
    residual's differences' variance per second) and each sensor's sd (from the record's own noise
    estimate, `checks.noise_step`, and kept within 10^(+-1.5) of it)."""
    problem = target.problems[0]
    model, adj, mx = problem.model, target.adjustments(x, 0), target.model_x(x, 0)
    measured = tuple(s for s in model.states if s in model.outputs)
    y = np.asarray(problem.y_meas)
    e = y - np.asarray(simulate_outputs(mx, problem, adj))
    h = float(np.median(np.asarray(problem.h)))
    peak = np.max(np.abs(y), axis=0)
    noise = np.maximum([noise_step(y[:, j], 4) for j in range(y.shape[1])], 1e-9 * peak)
    r_lo, r_hi = jnp.asarray(noise * 10**-SENSOR_DECADES), jnp.asarray(noise * 10**SENSOR_DECADES)
    q0 = np.maximum(np.var(np.diff(e, axis=0), axis=0) / h * 1e-3, 1e-12 * peak**2)
    template = EKF.of(model, measurement=dict(zip(model.outputs, noise)), measured_start=starts)
    states = jnp.asarray([model.states.index(s) for s in measured], dtype=int)
    z0 = jnp.asarray([*np.log([q0[model.outputs.index(s)] for s in measured]), *np.zeros(len(noise))])  # r: the estimate itself
    z = _fit_noise(z0, mx, problem, template, adj, states, r_lo, r_hi)
    return _noise_of(z, template, states, r_lo, r_hi)


def predicted(result, target: JointProblem, x, steps: int) -> Prediction:
    """The `steps`-ahead prediction of `target`'s record (module docstring)."""
    problem = target.problems[0]
    model, adj, mx = problem.model, target.adjustments(x, 0), target.model_x(x, 0)
    ekf, estimated = problem.predictor, False
    if not isinstance(ekf, EKF):
        rec_starts = tuple(s for s in model.states if s in model.outputs and s not in result.observation.fitted_states())
        ekf, estimated = estimate_noise(target, x, rec_starts), True
        problem = eqx.tree_at(lambda p: p.predictor, problem, ekf)
    outputs, whitened = _predict(mx, problem, ekf, adj, steps)
    return Prediction(np.asarray(outputs), np.asarray(whitened), _filter_noise(model, ekf, adj), estimated)


__all__ = ["Prediction", "calibration", "estimate_noise", "predicted"]
