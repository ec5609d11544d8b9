"""The objective function, paper eq. 24 and its weighted form eq. 27."""

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from ..compiling import compiled_when_eager
from ..errors import ConfigError
from ..io.recording import Recording, as_recording
from .adjustments import Adjustments, input_pieces
from .integrate import advance, advance_pieces, initial_state, prepare, sample_inputs, scan_inputs, scan_values, simulate_scan
from .kalman import kalman_filter, prediction_error
from .kernel import BLOCK, kernel_mode, objective_kernel, simulate_kernel
from .losses import SSE
from .predictors import EKF
from .problem import Problem, make_problem

__all__ = ["Problem", "make_problem", "simulate", "simulate_outputs", "objective", "residuals", "population_objective"]


def _plain(problem: Problem, adjustments: Adjustments | None) -> bool:
    """The paper's case: eq. 24/27 (SSE over peak-normalised channels), nothing adjusted."""
    return (
        adjustments is None
        and type(problem.loss) is SSE
        and problem.loss.normalize == "peak"
        and problem.mask is None
        and not problem.model.has_output_equation
    )


def as_problem(problem: "Problem | Recording", model=None) -> Problem:
    """`problem`, or a recording made one for simulation alone (`make_problem(recording,
    model=model, measured=False)`: its inputs and constants suffice, with the default RK4)."""
    problem = as_recording(problem, model, measured=False)  # a pandas DataFrame: Recording.from_dataframe
    if isinstance(problem, Recording):
        return make_problem(problem, model=model, measured=False)
    if model is not None:
        raise ConfigError("model: give it with a recording; a Problem holds its own model")
    return problem


def simulate(params, problem: "Problem | Recording", adjustments: Adjustments | None = None, *, model=None) -> Float[Array, "*batch n s"]:
    """Every state of the model at the recording's sample instants; row 0 is the initial state.

    `params`: a parameter vector (…, P) in the model's `names` order, a name -> value dict or a
    `Params`. Batched parameters (leading axes) are marched in one scan and the result has shape
    `(*batch, N, S)`. `jax.vmap` over `params` gives the same. A population (P, n) goes through
    the Pallas kernel where `dcjax.simulation.kernel.kernel_mode()` says so (on a GPU).
    `adjustments`: a fitted initial state and input delays (`dcjax.simulation.adjustments`; the
    states are returned without sensor offsets). `problem` may also be a `Recording` (its
    inputs and constants suffice) with `model=` (default: the paper's DC drive)."""
    problem = as_problem(problem, model)
    x = problem.model.as_array(params)
    mode = kernel_mode()
    if mode is not None and adjustments is None and x.ndim == 2:
        return simulate_kernel(x, problem, interpret=mode == "interpret", block=BLOCK if mode == "compiled" else 8)
    return _simulate(x, problem, adjustments)


@compiled_when_eager
def _simulate(x, problem: Problem, adjustments: Adjustments | None):
    if problem.integrator.per_member and x.ndim >= 2:
        return jax.vmap(lambda xi, ai: _simulate(xi, problem, ai))(x, adjustments)
    return simulate_scan(x, problem, adjustments)


# Populations of 8 * LANES members or more are padded to a multiple of LANES (repeating the last
# member), so the vectorized loop over members has no scalar tail: 72 members cost less than 70.
# Smaller ones are not (the padding would cost more than the tail; `compacted` evaluates rows of
# one member under `vmap`). LANES = 1 turns it off.
LANES = 8


def _block(x, mode: str) -> int:
    return BLOCK if mode == "compiled" else min(BLOCK, max(8, x.shape[0]))


def _finite_or_inf(of):
    return jnp.where(jnp.isfinite(of), of, jnp.inf)


def objective(params, problem: Problem, adjustments: Adjustments | None = None) -> Float[Array, "*batch"]:
    """Eq. 27 (eq. 24 for unit weights), over the model's measured channels y_c:

        OF = 1/N sum_k sum_c w_c ((y_c,k - y*_c,k) / max|y*_c|)^2

    over all N samples of the recording (k = 0 is the initial state). The sum is accumulated
    inside the time scan, so no trajectory is stored. A non-finite simulation (La or J at 0,
    overflow) gives +inf, never NaN. Batched `params` give one OF per member. A population (P, n)
    goes through the Pallas kernel where `dcjax.simulation.kernel.kernel_mode()` says so (on a GPU).

    Another `problem.loss` (`dcjax.simulation.losses`) scores each residual with its rho, and
    `adjustments` (batched like `params`) fit the initial state, sensor offsets and input delays;
    both are evaluated by the scan (the kernel computes eq. 24/27 only)."""
    x = problem.model.as_array(params)
    mode = kernel_mode()
    if mode is not None and _plain(problem, adjustments) and x.ndim == 2 and not isinstance(problem.predictor, EKF):
        return objective_kernel(x, problem, interpret=mode == "interpret", block=_block(x, mode))
    return _objective(x, problem, adjustments)


@compiled_when_eager
def _objective(x, problem: Problem, adjustments: Adjustments | None):
    """`objective` of a parameter array, by the scan."""
    if isinstance(problem.predictor, EKF):  # prediction error: the innovations' likelihood (`dcjax.simulation.kalman`)
        return prediction_error(x, problem, problem.predictor, adjustments)
    plain = _plain(problem, adjustments)
    if x.ndim >= 2 and problem.integrator.per_member:  # an adaptive step per member, not one for the population
        return jax.vmap(lambda xi, ai: _objective(xi, problem, ai))(x, adjustments)
    if x.ndim == 2 and x.shape[0] >= 8 * LANES and x.shape[0] % LANES:  # whole vector lanes, no scalar tail
        p = x.shape[0]
        pad = lambda a: jnp.pad(a, ((0, -p % LANES),) + ((0, 0),) * (a.ndim - 1), mode="edge")
        return _objective(pad(x), problem, jax.tree.map(pad, adjustments))[:p]
    if not plain:
        return _finite_or_inf(_scored_scan(x, problem, adjustments))
    c, y = prepare(x, problem)
    steady = problem.steady_inputs()
    inputs = scan_inputs(problem)
    width = inputs.shape[1]
    outs = problem.model.output_index
    scale = [problem.scale[j] for j in range(len(outs))]

    def misfit(acc, y, meas):
        for j, (o, s) in enumerate(zip(outs, scale)):
            acc = acc + s * (y[o] - meas[j]) ** 2
        return acc

    acc = misfit(0.0, y, problem.y_meas[0])

    def body(carry, x):
        y, acc = carry
        y = advance(c, problem, y, *scan_values(problem, steady, x))
        return (y, misfit(acc, y, x[width:])), None

    xs = jnp.concatenate([inputs, problem.y_meas[1:]], axis=1)
    (_, acc), _ = jax.lax.scan(body, (y, acc), xs, unroll=problem.unroll)
    return _finite_or_inf(acc)


def _scored_scan(x, problem: Problem, adjustments: Adjustments | None):
    """The objective with the problem's loss and the adjustments, accumulated inside the scan."""
    c, _ = prepare(x, problem)
    adj = adjustments if adjustments is not None else Adjustments()
    y = initial_state(problem, x.shape[:-1], adj.y0)
    model, loss = problem.model, problem.loss
    norm = problem.norm if problem.norm is not None else jnp.ones_like(problem.scale)
    offset = [None if adj.offset is None else adj.offset[..., j] for j in range(len(model.outputs))]

    def misfit(acc, y, u, meas, weight):
        for j, out in enumerate(model.compared(c, u, y)):
            off = offset[j]
            e = out - meas[j] if off is None else out + off - meas[j]
            term = loss.term(e, problem.scale[j], norm[j])
            acc = acc + (term if weight is None else weight * term)
        return acc

    mask = problem.mask
    steady = problem.steady_inputs()
    u = sample_inputs(problem) if model.has_output_equation else None  # an output equation reads the inputs at the sample

    def body(carry, xs):
        y, acc = carry
        lengths, inputs, meas, weight, u_k = xs
        y = advance_pieces(c, problem, y, lengths, inputs, steady)
        return (y, misfit(acc, y, _row(u_k), meas, weight)), None

    acc = misfit(0.0, y, _row(None if u is None else u[0]), problem.y_meas[0], None)
    xs = (*input_pieces(problem, adj), problem.y_meas[1:], None if mask is None else mask[1:], None if u is None else u[1:])
    (_, acc), _ = jax.lax.scan(body, (y, acc), xs, unroll=problem.unroll)
    return acc


def _row(u_k) -> tuple:
    return () if u_k is None else tuple(u_k[j] for j in range(u_k.shape[-1]))


def outputs_of(params, problem: Problem, states: Float[Array, "*batch n s"]) -> Float[Array, "*batch n c"]:
    """The compared outputs (`Model.compared`, in `model.outputs` order) of a state trajectory
    `states` simulated at `params`, without sensor offsets."""
    model = problem.model
    if not model.has_output_equation:
        return jnp.stack([states[..., o] for o in model.output_index], axis=-1)
    c, _ = prepare(params, problem)
    m, n_states = problem.u_start.shape[1], len(model.states)

    def at(u_k, y_k):
        return jnp.stack(model.compared(c, tuple(u_k[j] for j in range(m)), tuple(y_k[..., s] for s in range(n_states))), axis=-1)

    out = jax.vmap(at)(sample_inputs(problem), jnp.moveaxis(states, -2, 0))  # (N, *batch, C)
    return jnp.moveaxis(out, 0, -2)


def simulate_outputs(
    params, problem: "Problem | Recording", adjustments: Adjustments | None = None, *, model=None
) -> Float[Array, "*batch n c"]:
    """The model's compared outputs (`model.outputs`) at the sample instants, as the sensors read
    them (with the fitted offsets of `adjustments`): the states through the output equation, or
    the measured states themselves. `problem` may be a `Recording` with `model=` (`simulate`)."""
    problem = as_problem(problem, model)
    out = outputs_of(params, problem, simulate(params, problem, adjustments))
    off = None if adjustments is None else adjustments.offset
    return out if off is None else out + off[..., None, :]


def population_objective(x: Float[Array, "P D"], problem: Problem) -> Float[Array, " P"]:
    """OF of every row of `x` (physical units, the model's `names` order)."""
    return objective(x, problem)


def residuals(params, problem: Problem, adjustments: Adjustments | None = None) -> Float[Array, "*batch cn"]:
    """Residual vector r with sum(r**2) == objective: sqrt(w_c/N)(y_c - y*_c)/max|y*_c| for every
    sample of the first channel, then the next channel (another loss: sign(a) sqrt(w_c/N rho(a)),
    `Loss.residual`). Used by the Levenberg–Marquardt polish and the uncertainty analysis. With a
    state estimator (`EKF`): its normalised innovations L_k^-1 nu_k over sqrt(N), channel by
    channel (the likelihood's quadratic part, its noise held)."""
    if isinstance(problem.predictor, EKF):
        w = kalman_filter(params, problem, problem.predictor, adjustments).whitened
        mask = jnp.ones(problem.n) if problem.mask is None else problem.mask
        w = w * mask[:, None] / jnp.sqrt(jnp.sum(mask))
        return jnp.concatenate([w[..., j] for j in range(w.shape[-1])], axis=-1)
    sim = simulate_outputs(params, problem, adjustments)
    loss = problem.loss
    norm = problem.norm if problem.norm is not None else jnp.ones_like(problem.scale)
    out = []
    for j in range(sim.shape[-1]):
        r = loss.residual(sim[..., j] - problem.y_meas[:, j], problem.scale[j], norm[j])
        out.append(r if problem.mask is None else problem.mask * r)
    return jnp.concatenate(out, axis=-1)
