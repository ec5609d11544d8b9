"""A velocity Verlet step that reflects off the walls of a box: Hamiltonian Monte Carlo on a
posterior truncated to a polytope {theta : A theta + b >= 0} (Pakman & Paninski 2014; Afshar &
Domke 2015, "Reflection, refraction, and Hamiltonian Monte Carlo").

The drift moves theta along the velocity v = M^-1 p; where it meets a wall a_i theta + b_i = 0
first, the momentum is reflected elastically in the metric, p' = p - 2 (a_i . v) / (a_i M^-1 a_i)
a_i, which keeps the kinetic energy and reverses the velocity's component across the wall, and the
drift goes on for the rest of the step. That is the exact flow of a particle in the box, so the
step stays volume-preserving and time-reversible (NUTS's requirements), and a posterior whose
mass lies against a bound (a load torque at 0) is sampled without a trajectory ever leaving it,
where a hard -inf outside would end most trajectories as divergent, and a logit map would stretch
the bound into an exponential tail."""

from collections.abc import Callable

import jax
import jax.numpy as jnp
from blackjax.mcmc.integrators import IntegratorState

MAX_REFLECTIONS = 64  # per drift; a step that needs more stops there (the energy check then rejects it)


def _drift(theta, p, dt, walls: tuple, velocity: Callable):
    """theta moved for time dt along M^-1 p, reflecting off the walls A theta + b >= 0 (dt < 0:
    backwards, as NUTS integrates half its trajectories; the reflection is the same involution)."""
    A, b = walls
    sign = jnp.sign(dt)

    def cond(c):
        return (c[2] > 0.0) & (c[3] < MAX_REFLECTIONS)

    def body(c):
        th, mom, left, n = c
        v = sign * velocity(mom)
        g, rate = A @ th + b, A @ v
        t_hit = jnp.where(rate < 0.0, jnp.maximum(g, 0.0) / jnp.where(rate < 0.0, -rate, 1.0), jnp.inf)
        i = jnp.argmin(t_hit)
        hit = t_hit[i] < left
        step = jnp.where(hit, t_hit[i], left)
        a = A[i]
        reflected = mom - 2.0 * (a @ velocity(mom)) / (a @ velocity(a)) * a
        return th + step * v, jnp.where(hit, reflected, mom), jnp.where(hit, left - step, 0.0), n + 1

    th, mom, _, _ = jax.lax.while_loop(cond, body, (theta, p, jnp.abs(jnp.asarray(dt, theta.dtype)), 0))
    return th, mom


def reflecting_verlet(A, b) -> Callable:
    """A blackjax integrator factory (`integrator=` of `blackjax.nuts`) for the box A theta + b >= 0."""

    def integrator(logdensity_fn: Callable, kinetic_energy_fn: Callable):
        value_and_grad = jax.value_and_grad(logdensity_fn)
        velocity = jax.grad(lambda m: kinetic_energy_fn(m))

        def one_step(state: IntegratorState, step_size) -> IntegratorState:
            p = state.momentum + 0.5 * step_size * state.logdensity_grad
            theta, p = _drift(state.position, p, step_size, (A, b), velocity)
            logdensity, grad = value_and_grad(theta)
            return IntegratorState(theta, p + 0.5 * step_size * grad, logdensity, grad)

        return one_step

    return integrator
