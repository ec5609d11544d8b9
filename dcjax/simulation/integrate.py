"""A model marched over the sample grid by its `Integrator` (Euler, eq. 11–12; RK4, eq. 14–23; or
a user's own) with `jax.lax.scan`, with ND sub-steps per interval (eq. 28), linear input interpolation (eq. 29)
and the supply's limit on one state (Section 4, Fig. 4). Generic over the `Model`."""

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from ..models.base import DiscreteModel
from .adjustments import input_pieces
from .integrators import Integrator
from .problem import Problem

State = tuple[Array, ...]


def advance(c, problem: Problem, y: State, h, ua: State, ub: State) -> State:
    """One sample interval: `problem.integrator.substeps` equal sub-steps (eq. 28) with the inputs
    linearly interpolated from `ua` to `ub` (eq. 29); after every sub-step the limited state is
    clamped."""
    return advance_with(problem.model, problem.integrator, problem.limit, c, y, h, ua, ub)


def advance_with(model, integrator: Integrator, limit, c, y: State, h, ua: State, ub: State) -> State:
    """`advance` with the settings spelled out (also used inside the Pallas kernel)."""

    if isinstance(model, DiscreteModel):  # its own map from one sample to the next (SampleMap)
        return model.clamp(model.update(c, ua, y, h), limit)

    def field(u, y):
        return model.vector_field(c, u, y)

    nd = integrator.substeps
    if nd == 1:
        return model.clamp(integrator.step(field, y, ua, ub, h), limit)

    hs = h / nd
    du = tuple((b - a) / nd for a, b in zip(ua, ub))

    def sub(j, y):
        u0 = tuple(a + d * j for a, d in zip(ua, du))
        u1 = tuple(a + d for a, d in zip(u0, du))
        return model.clamp(integrator.step(field, y, u0, u1, hs), limit)

    return jax.lax.fori_loop(0, nd, sub, y)


def advance_pieces(c, problem: Problem, y: State, lengths, inputs, steady: tuple = ()) -> State:
    """One sample interval as its pieces (`dcjax.simulation.adjustments.input_pieces`): each
    piece `advance`d with its own linear input (a piece's last value its end: a discrete-time
    map's pieces hold their start only); an input given as None is `steady` (its value there,
    `Problem.steady_inputs`)."""
    steady = steady or (None,) * len(inputs)
    for p in range(lengths.shape[-1]):
        ua = tuple(s if u is None else u[..., p, 0] for u, s in zip(inputs, steady))
        ub = tuple(s if u is None else u[..., p, -1] for u, s in zip(inputs, steady))
        y = advance(c, problem, y, lengths[..., p], ua, ub)
    return y


def prepare(params, problem: Problem):
    """(coefficients, initial state) of a parameter vector, dict or `Params` (batched or not)."""
    model = problem.model
    x = model.as_array(params)
    c = model.coefficients(model.as_dict(x))
    batch = x.shape[:-1]
    y = tuple(jnp.broadcast_to(problem.y0[s], batch) for s in range(len(model.states)))
    return c, y


def initial_state(problem: Problem, batch: tuple[int, ...], y0=None) -> State:
    """The initial state broadcast to `batch`: `y0` (*batch, S) where given, else the problem's."""
    src = problem.y0 if y0 is None else y0
    return tuple(jnp.broadcast_to(src[..., s], batch) for s in range(len(problem.model.states)))


def step_inputs(problem: Problem) -> Float[Array, "n-1 k"]:
    """One packed per-step input array: h, u_start (m), u_end (m) (one slice per step instead of
    several: measured 4-7 % faster). The Pallas kernel's layout; the scan reads `scan_inputs`."""
    return jnp.concatenate([problem.h[:, None], problem.u_start, problem.u_end], axis=1)


def scan_inputs(problem: Problem) -> Float[Array, "n-1 k"]:
    """What the time scan reads at each step, packed: h, the `varying` inputs at the interval's
    start and, where a step reads them (an ODE model, eq. 29), at its end. A steady input is read
    once (`Problem.steady_inputs`): the scan's loop carries (and XLA copies into it, every
    evaluation) only what changes."""
    cols = problem.varying
    ends = [problem.u_end[:, j] for j in cols] if problem.reads_ends else []
    return jnp.stack([problem.h, *(problem.u_start[:, j] for j in cols), *ends], axis=1)


def scan_values(problem: Problem, steady: tuple, x):
    """(h, ua, ub) of one row `x` of `scan_inputs`; `steady`: `problem.steady_inputs()`."""
    k = len(problem.varying)
    at = dict(zip(problem.varying, range(k)))
    ua = tuple(x[1 + at[j]] if v is None else v for j, v in enumerate(steady))
    if not problem.reads_ends:
        return x[0], ua, ua
    return x[0], ua, tuple(x[1 + k + at[j]] if v is None else v for j, v in enumerate(steady))


def simulate_scan(params, problem: Problem, adjustments=None) -> Float[Array, "*batch n s"]:
    """Every state of the model at the recording's sample instants, row 0 the initial state, as
    one `lax.scan` over the samples (`dcjax.simulate` picks this or the Pallas kernel).
    Batched parameters (leading axes) are marched in one scan: shape `(*batch, N, S)`.
    `adjustments` (`dcjax.simulation.adjustments.Adjustments`): a fitted initial state, delayed inputs."""
    c, y = prepare(params, problem)
    steady = problem.steady_inputs()

    def body(y, x):
        y = advance(c, problem, y, *scan_values(problem, steady, x))
        return y, jnp.stack(y, axis=-1)

    if adjustments is not None and (adjustments.y0 is not None or adjustments.delay is not None):
        batch = jnp.shape(problem.model.as_array(params))[:-1]
        y = initial_state(problem, batch, adjustments.y0)

        def body_adjusted(y, xs):
            lengths, inputs = xs
            y = advance_pieces(c, problem, y, lengths, inputs, steady)
            return y, jnp.stack(y, axis=-1)

        _, ys = jax.lax.scan(body_adjusted, y, input_pieces(problem, adjustments), unroll=problem.unroll)
    else:
        _, ys = jax.lax.scan(body, y, scan_inputs(problem), unroll=problem.unroll)
    out = jnp.concatenate([jnp.stack(y, axis=-1)[None], ys], axis=0)  # (N, *batch, S)
    return jnp.moveaxis(out, 0, -2)


def sample_inputs(problem: Problem) -> Float[Array, "n m"]:
    """The inputs at every sample as an output equation reads them: the recording's first sample,
    then each interval's end value (eq. 29's; an input held over the interval, and a
    discrete-time model's, its held value; no input delay)."""
    return jnp.concatenate([problem.u_start[:1], problem.u_end], axis=0)
