"""An adaptive reference solution of a model's ODE with diffrax, to judge the fixed-step
simulator (paper Section 5: "increase the number of divisions until no correction is present").

The inputs are interpolated linearly between samples (eq. 29), so the vector field has kinks at
the sample instants: they are passed to the step-size controller as `jump_ts`. The supply's limit
is the continuous counterpart of the simulator's clamp: at |y_limited| = limit the derivative
that would push further out is zero."""

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .adjustments import Adjustments
from .integrate import prepare
from .objectives import outputs_of, simulate
from .problem import Problem


def reference_simulate(
    params, problem: Problem, adjustments: Adjustments | None = None, rtol: float = 1e-10, atol: float = 1e-12, max_steps: int = 1_000_000
) -> Float[Array, "n s"]:
    """Every state at the sample instants, by `diffrax.Dopri8` with a PID controller (unbatched
    parameters). `adjustments`: a fitted initial state and input delays (u(t - d), its knots
    t_k + d passed as jump times too); an input in `problem.held` is its sample at or before t
    (a zero-order hold), eq. 29's linear interpolation otherwise."""
    import diffrax  # lazy: importing it is a third of dcjax's own import time (`dcjax.simulation.integrators`)

    model = problem.model
    c, y0 = prepare(params, problem)
    if adjustments is not None and adjustments.y0 is not None:
        y0 = tuple(adjustments.y0[..., s] for s in range(len(model.states)))
    t = jnp.concatenate([jnp.zeros(1), jnp.cumsum(problem.h)])
    u = jnp.concatenate([problem.u_start, problem.u_end[-1:]], axis=0)  # (n, m) inputs at the samples
    m = u.shape[1]
    delay = jnp.zeros(m) if adjustments is None or adjustments.delay is None else adjustments.delay
    delayed = () if adjustments is None or adjustments.delay is None else adjustments.delayed or tuple(range(m))
    k_lim = model.states.index(model.limited_state) if model.limited_state is not None and problem.limit is not None else None

    def read(s, j):
        at = s - delay[j]
        if j in problem.held:
            return u[jnp.clip(jnp.searchsorted(t, at, side="right") - 1, 0, t.shape[0] - 1), j]
        return jnp.interp(at, t, u[:, j])

    def field(s, y, _):
        dy = model.vector_field(c, tuple(read(s, j) for j in range(m)), tuple(y))
        if k_lim is not None:
            yk, dk, lim = y[k_lim], dy[k_lim], jnp.asarray(problem.limit)
            dk = jnp.where(((yk >= lim) & (dk > 0)) | ((yk <= -lim) & (dk < 0)), 0.0, dk)
            dy = dy[:k_lim] + (dk,) + dy[k_lim + 1 :]
        return jnp.stack(dy)

    jumps = jnp.sort(jnp.concatenate([t, *(t + delay[j] for j in delayed)]))
    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(field),
        diffrax.Dopri8(),
        t0=t[0],
        t1=t[-1],
        dt0=None,
        y0=jnp.stack(y0),
        saveat=diffrax.SaveAt(ts=t),
        stepsize_controller=diffrax.ClipStepSizeController(diffrax.PIDController(rtol=rtol, atol=atol), jump_ts=jumps),
        max_steps=max_steps,
    )
    return sol.ys  # pyright: ignore[reportReturnType]


reference_simulate_jit = jax.jit(reference_simulate, static_argnames=("max_steps",))


def simulation_error(params, problem: Problem, reference: Float[Array, "n s"], adjustments: Adjustments | None = None) -> float:
    """max over the measured channels of max_k |y_sim - y_ref| / max|y_measured| (a sensor
    offset adds to both alike)."""

    sim = outputs_of(params, problem, simulate(params, problem, adjustments))
    ref = outputs_of(params, problem, jnp.asarray(reference))
    peak = jnp.max(jnp.abs(problem.y_meas), axis=0)
    return float(jnp.max(jnp.max(jnp.abs(sim - ref), axis=-2) / peak))
