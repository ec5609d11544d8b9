"""Per-candidate adjustments of one recording's simulation and comparison, searched with the
model's parameters (issue 28): a fitted initial state, additive sensor offsets on measured
channels and fractional delays of inputs.

A delay d (seconds) of input u replaces u(t) by u(t - d), read from the samples by linear
interpolation (eq. 29's interpolation, on the sample grid) and held at its first value before
the recording starts; the delayed samples are then interpolated within each interval as usual.
An offset o_c is added to the simulated channel before the comparison: y_c + o_c - y*_c."""

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from .problem import Problem


class Adjustments(eqx.Module):
    """`y0`: (*batch, S) the whole initial state (None: the problem's); `offset`: (*batch, C) per
    measured channel (None: none); `delay`: (*batch, M) seconds per input (None: none)."""

    y0: Float[Array, "*batch s"] | None = None
    offset: Float[Array, "*batch c"] | None = None
    delay: Float[Array, "*batch m"] | None = None


def sample_times(problem: Problem) -> Float[Array, " n"]:
    """The sample instants relative to the first, from the problem's steps."""
    return jnp.concatenate([jnp.zeros(1), jnp.cumsum(problem.h)])


def delayed_inputs(problem: Problem, delay: Float[Array, "*batch m"]):
    """(u_start, u_end) as tuples over the inputs, each (n-1, *batch): input j delayed by
    `delay[..., j]` seconds (module docstring)."""
    t = sample_times(problem)
    u = jnp.concatenate([problem.u_start, problem.u_end[-1:]], axis=0)  # (n, m)
    starts, ends = [], []
    for j in range(u.shape[1]):
        d = delay[..., j]
        q = t - d[..., None]  # (*batch, n)
        ud = jnp.interp(q, t, u[:, j])
        ud = jnp.moveaxis(ud, -1, 0)  # (n, *batch)
        starts.append(ud[:-1])
        ends.append(ud[1:])
    return tuple(starts), tuple(ends)


def step_input_columns(problem: Problem, delay: Float[Array, "*batch m"] | None = None):
    """(u_start, u_end) as tuples over the inputs: delayed by `delay` where given, else the
    problem's own columns."""
    if delay is not None:
        return delayed_inputs(problem, delay)
    m = problem.u_start.shape[1]
    return tuple(problem.u_start[:, j] for j in range(m)), tuple(problem.u_end[:, j] for j in range(m))
