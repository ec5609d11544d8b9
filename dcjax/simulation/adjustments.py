"""Per-candidate adjustments of one recording's simulation and comparison, searched with the
model's parameters (issue 28): a fitted initial state, additive sensor offsets on measured
channels and fractional delays of inputs.

A delay d (seconds) of input u replaces u(t) by u(t - d), the same eq. 29 interpolation of the
samples shifted in time (held at its first sample before the recording starts; an input held
between samples, `Problem.held`, is shifted as the step it is). The delayed
input is linear between its own knots t_j + d, which fall inside the sample intervals: an ODE
model's interval is split at those knots (`input_pieces`), so every piece has a linear input and
the integration is as exact as on an undelayed interval. A discrete-time model reads its inputs
at the sample instants only: u(t_k - d) there. An offset o_c is added to the simulated channel
before the comparison: y_c + o_c - y*_c."""

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from ..models.base import DiscreteModel
from .problem import Problem


class Adjustments(eqx.Module):
    """`y0`: (*batch, S) the whole initial state (None: the problem's); `offset`: (*batch, C) per
    measured channel (None: none); `delay`: (*batch, M) seconds per input (None: none), of which
    the inputs `delayed` (static; empty: every input) may be non-zero; `process` (*batch, S) and
    `measurement` (*batch, C): the noise of a state estimator (`dcjax.simulation.predictors.EKF`)
    searched with the parameters (None: the predictor's own)."""

    y0: Float[Array, "*batch s"] | None = None
    offset: Float[Array, "*batch c"] | None = None
    delay: Float[Array, "*batch m"] | None = None
    delayed: tuple[int, ...] = eqx.field(static=True, default=())
    process: Float[Array, "*batch s"] | None = None  # a state estimator's process intensities (None: the predictor's own)
    measurement: Float[Array, "*batch c"] | None = None  # and its sensors' sd


def sample_times(problem: Problem) -> Float[Array, " n"]:
    """The sample instants relative to the first, from the problem's steps."""
    return jnp.concatenate([jnp.zeros(1), jnp.cumsum(problem.h)])


def _samples(problem: Problem) -> Float[Array, "n m"]:
    return jnp.concatenate([problem.u_start, problem.u_end[-1:]], axis=0)


def _batch_last(a):
    """(*batch, n) -> (n, *batch)."""
    return jnp.moveaxis(a, -1, 0)


def input_pieces(problem: Problem, adjustments: "Adjustments | None" = None):
    """Each sample interval as pieces with a linear input: `(lengths, inputs)`, `lengths` (n-1,
    *batch, K) and `inputs` a tuple over the model's inputs of (n-1, *batch, K, 2) values at each
    piece's start and end.

    Without a delay one piece, the interval and its samples (eq. 29; a held input's start value
    twice; a discrete-time map's start alone, (n-1, 1, 1); a steady input None). With delays (an
    ODE model) the interval [t_{k-1}, t_k] is split at the knots t_j + d of every delayed input
    that fall inside it (`Problem.knots` per input; a slot without a knot has length 0), and each
    input is read as u(tau - d) at the pieces' ends (a held input: its sample before tau - d at
    the piece's middle, constant over the piece). A discrete-time model: one piece, its inputs
    read at t_{k-1} - d and t_k - d."""

    m = problem.u_start.shape[1]
    delay = None if adjustments is None else adjustments.delay
    if delay is None:  # a steady input: None (read once, `Problem.steady_inputs`); a discrete-time map's: its start only
        ends = problem.reads_ends
        return problem.h[:, None], tuple(
            None
            if j in problem.steady
            else (jnp.stack([problem.u_start[:, j], problem.u_end[:, j]], axis=-1) if ends else problem.u_start[:, j, None])[:, None]
            for j in range(m)
        )
    t, u = sample_times(problem), _samples(problem)
    batch = delay.shape[:-1]
    if isinstance(problem.model, DiscreteModel):
        read = [_batch_last(_read(j in problem.held, t, u[:, j], t - delay[..., j, None])) for j in range(m)]  # (n, *batch)
        h = jnp.broadcast_to(problem.h.reshape((-1,) + (1,) * len(batch)), (problem.h.shape[0], *batch))
        return h[..., None], tuple(jnp.stack([r[:-1], r[1:]], axis=-1)[..., None, :] for r in read)
    delayed = adjustments.delayed or tuple(range(m))  # pyright: ignore[reportOptionalMemberAccess]
    start = t[:-1].reshape((-1,) + (1,) * len(batch))  # (n-1, 1...)
    end = t[1:].reshape((-1,) + (1,) * len(batch))
    knots = []
    for j in delayed:
        d = delay[..., j]  # (*batch)
        first = jnp.searchsorted(t, start - d, side="right")  # the first sample whose delayed knot lies after the start
        for s in range(problem.knots):
            i = first + s
            at = jnp.where(i < t.shape[0], t[jnp.minimum(i, t.shape[0] - 1)] + d, jnp.inf)
            knots.append(jnp.clip(at, start, end))
    inner = jnp.sort(jnp.stack(knots, axis=-1), axis=-1)  # (n-1, *batch, K-1)
    ends = jnp.concatenate(
        [jnp.broadcast_to(start, inner.shape[:-1])[..., None], inner, jnp.broadcast_to(end, inner.shape[:-1])[..., None]], axis=-1
    )
    inputs = []
    for j in range(m):
        d = delay[..., j].reshape((1, *batch, 1))
        if j in problem.held:  # constant over each piece: the sample before the piece's middle
            v = _read(True, t, u[:, j], 0.5 * (ends[..., :-1] + ends[..., 1:]) - d)
            inputs.append(jnp.stack([v, v], axis=-1))
        else:
            v = jnp.interp(ends - d, t, u[:, j])
            inputs.append(jnp.stack([v[..., :-1], v[..., 1:]], axis=-1))
    return jnp.diff(ends, axis=-1), tuple(inputs)


def _read(held: bool, t, u_j, at):
    """u_j at the times `at`: eq. 29's interpolation (held at the first sample before the start),
    or for a held input the sample at or before `at`."""
    if not held:
        return jnp.interp(at, t, u_j)
    return u_j[jnp.clip(jnp.searchsorted(t, at, side="right") - 1, 0, t.shape[0] - 1)]
