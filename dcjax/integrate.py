"""Euler (eq. 11–12) and classic RK4 (eq. 14–23) marched over the sample grid with
`jax.lax.scan`, with ND sub-steps per interval (eq. 28), linear voltage interpolation
(eq. 29) and the supply's current limit (Section 4, Fig. 4)."""

from collections.abc import Callable

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .model import Coefficients, vector_field
from .params import Params
from .problem import Problem


def euler_step(k: Coefficients, i, w, h, u0, u_half, u1):
    """Eq. 11–12: y(k+1) = y(k) + h f(t(k), y(k)); u at the start of the step."""
    di, dw = vector_field(k, u0, i, w)
    return i + h * di, w + h * dw


def rk4_step(k: Coefficients, i, w, h, u0, u_half, u1):
    """Eq. 14–23: classic RK4 with u at t, t + h/2 (interpolated) and t + h."""
    hh = 0.5 * h
    k1, l1 = vector_field(k, u0, i, w)
    k2, l2 = vector_field(k, u_half, i + hh * k1, w + hh * l1)
    k3, l3 = vector_field(k, u_half, i + hh * k2, w + hh * l2)
    k4, l4 = vector_field(k, u1, i + h * k3, w + h * l3)
    h6 = h / 6.0
    return i + h6 * (k1 + 2.0 * (k2 + k3) + k4), w + h6 * (l1 + 2.0 * (l2 + l3) + l4)


STEPS: dict[str, Callable] = {"euler": euler_step, "rk4": rk4_step}


def advance(k: Coefficients, problem: Problem, i, w, h, ua, ub):
    """One sample interval: `nd` equal sub-steps (eq. 28) with u linearly interpolated from
    `ua` to `ub` (eq. 29); after every computed current, |i| is clamped to the limit."""
    step = STEPS[problem.integrator]
    nd = problem.nd
    limit = problem.i_limit

    def clamp(i):
        return i if limit is None else jnp.clip(i, -limit, limit)

    if nd == 1:
        i, w = step(k, i, w, h, ua, 0.5 * (ua + ub), ub)
        return clamp(i), w

    hs = h / nd
    du = (ub - ua) / nd

    def sub(j, carry):
        i, w = carry
        u0 = ua + du * j
        i, w = step(k, i, w, hs, u0, u0 + 0.5 * du, u0 + du)
        return clamp(i), w

    return jax.lax.fori_loop(0, nd, sub, (i, w))


def _initial_state(params: Params, problem: Problem):
    shape = jnp.shape(params.Ra)
    return jnp.broadcast_to(problem.i0, shape), jnp.broadcast_to(problem.w0, shape)


def simulate(params: Params, problem: Problem) -> Float[Array, "*batch n 2"]:
    """Current and speed at the recording's sample instants; row 0 is the initial state.

    `params` may be batched (leaves of shape `(P,)`): the whole population is marched in one
    scan and the result has shape `(P, N, 2)`. `jax.vmap` over `params` gives the same."""
    k = Coefficients.from_params(params)
    i, w = _initial_state(params, problem)

    def body(carry, x):
        i, w = advance(k, problem, *carry, *x)
        return (i, w), (i, w)

    _, (i_s, w_s) = jax.lax.scan(body, (i, w), (problem.h, problem.u_start, problem.u_end), unroll=problem.unroll)
    traj_i = jnp.concatenate([i[None], i_s], axis=0)
    traj_w = jnp.concatenate([w[None], w_s], axis=0)
    out = jnp.stack([traj_i, traj_w], axis=-1)  # (N, *batch, 2)
    return jnp.moveaxis(out, 0, -2)
