"""Levenberg–Marquardt polish (optimistix) of an evolutionary result on the residual vector of
eq. 24/27, over the free parameters, with the bounds kept by a reparametrization."""

import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx
from jaxtyping import Array, Float

from ..models.space import Space
from ..simulation.joint import JointProblem, joint_problem
from ..simulation.problem import Problem


class PolishResult(eqx.Module):
    x: Float[Array, " P"]
    of_before: Float[Array, ""]
    of_after: Float[Array, ""]
    steps: Array
    converged: Array  # the solver met its tolerances (False: stopped at max_steps, or failed)


def _to_free(z, eps):
    """Unit-cube point -> unbounded variable, z = (sin(y) + 1) / 2 inverted (kept off the edge)."""
    return jnp.arcsin(2.0 * jnp.clip(z, eps, 1.0 - eps) - 1.0)


def _to_unit(y):
    """z = (sin(y) + 1) / 2 lies in [0, 1] for every y, so the bounds always hold."""
    return 0.5 * (jnp.sin(y) + 1.0)


def polish(
    x: Float[Array, " P"],
    problem: Problem | list[Problem] | JointProblem,
    space: Space,
    joint_weights: list[float] | None = None,
    rtol: float = 1e-12,
    atol: float = 1e-14,
    max_steps: int = 200,
) -> PolishResult:
    """Minimize sum(r(x)^2) (= OF) with `optx.LevenbergMarquardt` from `x` (physical units, all
    parameters) over the free parameters of `space`; fixed ones stay at their values. `problem`:
    one recording's, several (a joint fit, `joint_weights`), or a fit's `JointProblem` (its
    search vector: local parameters, fitted initial states, offsets, delays).

    Bounds: x = lower + (upper - lower) (sin(y) + 1) / 2, y unbounded. A start within 1e-12
    (relative) of a bound is moved that far inside. The result is only accepted when its OF is
    not larger than the start's; returns arrays only (no `optx.Solution`), so it vmaps.
    `converged` is False where the solver stopped at `max_steps` or failed (`sol.result`)."""
    eps = 1e-12
    target = (
        problem if isinstance(problem, JointProblem) else joint_problem(problem if isinstance(problem, list) else [problem], joint_weights)
    )

    def of(x):
        r = target.residuals(x)
        return jnp.sum(r * r)

    def fn(y, _):
        return target.residuals(space.to_physical(_to_unit(y)))

    y0 = _to_free(space.to_unit(x), eps)
    sol = optx.least_squares(fn, optx.LevenbergMarquardt(rtol=rtol, atol=atol), y0, max_steps=max_steps, throw=False)
    x_new = space.to_physical(_to_unit(sol.value))
    of0 = of(x)
    of1 = of(x_new)
    better = of1 <= of0
    converged = sol.result == optx.RESULTS.successful
    return PolishResult(jnp.where(better, x_new, x), of0, jnp.where(better, of1, of0), sol.stats["num_steps"], converged)


polish_jit = eqx.filter_jit(polish)
polish_batch = eqx.filter_jit(jax.vmap(polish, in_axes=(0, None, None)))
