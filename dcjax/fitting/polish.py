"""Levenberg–Marquardt polish of an evolutionary result on the residual vector of eq. 24/27, over
the free parameters, with the bounds kept by a reparametrization.

The solver is Marquardt's damped Gauss-Newton with Nielsen's update of the damping (Madsen,
Nielsen & Tingleff, "Methods for non-linear least squares problems", 2004, Algorithm 3.16),
scaled by the diagonal of J^T J (Marquardt 1963), on the Jacobian of the simulation (`jax.jvp`
per free parameter, the residuals and the Jacobian from one pass). It is written here rather
than taken from optimistix because each iteration evaluates the simulation once: the compiled
polish of a two-input model (tests/test_matrix.py, PMSM) compiled in 1.3 s against
`optimistix.LevenbergMarquardt`'s 3.1 s, which traces the simulation four to five times."""

import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..compiling import filter_jit
from ..devices import COMPILED_LOOP_BYTES, compiled_loop_bytes
from ..gradients import forward_gradient, forward_mode
from ..models.space import Space
from ..simulation.joint import JointProblem, StackedJoint, joint_problem
from ..simulation.predictors import EKF
from ..simulation.problem import Problem


class PolishResult(eqx.Module):
    x: Float[Array, " P"]
    of_before: Float[Array, ""]
    of_after: Float[Array, ""]
    steps: Array
    converged: Array  # the step met the tolerances (False: stopped at max_steps, or no finite residual)


def _to_free(z, eps):
    """Unit-cube point -> unbounded variable, z = (sin(y) + 1) / 2 inverted (kept off the edge)."""
    return jnp.arcsin(2.0 * jnp.clip(z, eps, 1.0 - eps) - 1.0)


def _to_unit(y):
    """z = (sin(y) + 1) / 2 lies in [0, 1] for every y, so the bounds always hold."""
    return 0.5 * (jnp.sin(y) + 1.0)


def linearized(fn, y):
    """(r, J): the residuals at `y` and their Jacobian, one forward pass with a tangent per entry."""
    eye = jnp.eye(y.shape[0], dtype=y.dtype)
    r, jac = jax.vmap(lambda t: jax.jvp(fn, (y,), (t,)), out_axes=(None, 1))(eye)
    return r, jac


class _LM(eqx.Module):
    y: Array
    r: Array
    jac: Array
    cost: Array
    mu: Array
    nu: Array
    step: Array
    done: Array
    converged: Array


def levenberg_marquardt(
    fn, y0: Float[Array, " F"], rtol: float = 1e-12, atol: float = 1e-14, max_steps: int = 200, residuals: int | None = None
):
    """Minimize sum(fn(y)^2) from `y0`: (y, cost, steps, converged). A step h solves (J^T J + mu
    diag(J^T J)) h = -J^T r; it is taken where it lowers the cost, and mu follows the gain ratio
    (Nielsen). Converged: an accepted step within `atol + rtol |y|` in every entry, or a step
    that can no longer change y (mu so large that h vanishes), or a cost of zero. `residuals`:
    how many entries `fn` returns, where the caller knows it (else `fn` is traced once more to
    find out, for a simulation one more trace of its time loop)."""
    # The first pass of the loop linearizes at y0 (no step): the simulation's linearization is
    # traced once, inside the loop, not once before it and once in it (half the compile time).
    dim = y0.shape[0]
    m = jax.eval_shape(fn, y0).shape[0] if residuals is None else residuals
    start = _LM(
        y0,
        jnp.zeros(m, y0.dtype),
        jnp.zeros((m, dim), y0.dtype),
        jnp.asarray(jnp.inf, y0.dtype),
        jnp.asarray(0.0, y0.dtype),
        jnp.asarray(2.0),
        jnp.asarray(-1),
        jnp.asarray(False),
        jnp.asarray(False),
    )

    def body(s: _LM) -> _LM:
        first = s.step < 0
        a, g = s.jac.T @ s.jac, s.jac.T @ s.r
        d = jnp.maximum(jnp.diag(a), 1e-300)
        h = jnp.linalg.solve(a + s.mu * jnp.diag(d), -g)
        y_new = jnp.where(first, s.y, s.y + h)
        r_new, j_new = linearized(fn, y_new)
        cost_new = jnp.sum(r_new * r_new)
        predicted = h @ (s.mu * d * h - g)  # the model's reduction of the cost, > 0
        gain = (s.cost - cost_new) / jnp.where(predicted > 0, predicted, 1.0)
        ok = jnp.isfinite(cost_new) & (cost_new <= s.cost) & jnp.all(jnp.isfinite(h))
        small = jnp.all(jnp.abs(h) <= atol + rtol * jnp.abs(s.y))
        mu = jnp.where(ok, s.mu * jnp.maximum(1.0 / 3.0, 1.0 - (2.0 * gain - 1.0) ** 3), s.mu * s.nu)
        nu = jnp.where(ok, 2.0, 2.0 * s.nu)
        pick = lambda new, old: jnp.where(ok, new, old)
        converged = small | (ok & (cost_new == 0.0))
        stuck = ~jnp.all(jnp.isfinite(h)) | ~jnp.isfinite(mu)  # no step can be computed: nothing more to gain
        stepped = _LM(
            pick(y_new, s.y), pick(r_new, s.r), pick(j_new, s.jac), pick(cost_new, s.cost), mu, nu, s.step + 1, converged | stuck, converged
        )
        a0 = j_new.T @ j_new
        started = _LM(
            s.y, r_new, j_new, cost_new, 1e-3 * jnp.max(jnp.diag(a0)), s.nu, jnp.asarray(0), ~jnp.isfinite(cost_new), jnp.asarray(False)
        )
        return jax.tree.map(lambda x0, x1: jnp.where(first, x0, x1), started, stepped)

    end = jax.lax.while_loop(lambda s: ~s.done & (s.step < max_steps), body, start)
    return end.y, end.cost, end.step, end.converged


def polish(
    x: Float[Array, " P"],
    problem: Problem | list[Problem] | JointProblem | StackedJoint,
    space: Space,
    joint_weights: list[float] | None = None,
    rtol: float = 1e-12,
    atol: float = 1e-14,
    max_steps: int = 200,
    starts: int = 1,
) -> PolishResult:
    """Minimize sum(r(x)^2) (= OF) with `levenberg_marquardt` from `x` (physical units, all
    parameters) over the free parameters of `space`; fixed ones stay at their values. `problem`:
    one recording's, several (a joint fit, `joint_weights`), or a fit's `JointProblem` (its
    search vector: local parameters, fitted initial states, offsets, delays) or `StackedJoint`.

    Bounds: x = lower + (upper - lower) (sin(y) + 1) / 2, y unbounded. A start within 1e-12
    (relative) of a bound is moved that far inside. The result is only accepted when its OF is
    not larger than the start's; returns arrays only, so it vmaps. `converged` is False where
    the solver stopped at `max_steps` or found no finite residual. `starts`: how many starts are
    polished in the same program (`polish_batch`), which a prediction-error fit's choice of
    gradient weighs (`_quasi_newton`)."""
    eps = 1e-12
    target = (
        problem
        if isinstance(problem, JointProblem | StackedJoint)
        else joint_problem(problem if isinstance(problem, list) else [problem], joint_weights)
    )

    if _filters(target):
        return _quasi_newton(x, target, space, eps, rtol, atol, max_steps, starts)

    def fn(y):
        return target.residuals(space.to_physical(_to_unit(y)))

    r0 = target.residuals(x)  # the start's residuals: their count sizes the solver's state
    y, cost, steps, converged = levenberg_marquardt(fn, _to_free(space.to_unit(x), eps), rtol, atol, max_steps, r0.shape[0])
    of0 = jnp.sum(r0 * r0)
    x_new = space.to_physical(_to_unit(y))
    better = cost <= of0
    return PolishResult(jnp.where(better, x_new, x), of0, jnp.where(better, cost, of0), steps, converged)


def _filters(target) -> bool:
    """A prediction-error fit: its polish minimises the likelihood itself (least squares on the
    whitened innovations would inflate fitted noise, and stalled short of the optimum with the
    noise given: the composition matrix's joint cell)."""
    problems = target.problems if isinstance(target, JointProblem) else (target.stacked,)  # a StackedJoint holds them stacked
    return any(isinstance(p.predictor, EKF) for p in problems)


def evaluation_steps(target) -> int:
    """Integration steps of one evaluation of `target` (its recordings' samples, padded where
    stacked, times the sub-steps)."""
    if isinstance(target, StackedJoint):
        samples = int(np.prod(target.stacked.y_meas.shape[:2]))
        return samples * int(getattr(target.stacked.integrator, "substeps", 1))
    return sum(p.n * int(getattr(p.integrator, "substeps", 1)) for p in target.problems)


def _quasi_newton(x, target, space: Space, eps: float, rtol: float, atol: float, max_steps: int, starts: int) -> PolishResult:
    """A prediction-error fit's polish: BFGS (`optimistix.BFGS`) on the objective itself, the
    innovations' negative log-likelihood with its log det S (least squares on the whitened
    innovations would inflate the fitted noise to shrink them), bounds kept as in `polish`. Its
    gradient in forward mode where the evaluations of its `starts` are short
    (`dcjax.gradients.forward_mode`): the solver's loop then compiles in about a quarter of the time."""

    import optimistix as optx  # lazy: with lineax a tenth of a second of every dcjax import

    def objective(y):
        return target.objective(space.to_physical(_to_unit(y)))

    forward = forward_mode(len(space.free), evaluation_steps(target) * starts)
    differentiated = forward_gradient(objective) if forward else objective

    def fn(y, _):
        return differentiated(y)

    y0 = _to_free(space.to_unit(x), eps)
    sol = optx.minimise(fn, optx.BFGS(rtol=rtol, atol=atol), y0, max_steps=5 * max_steps, throw=False)
    of0, of1 = target.objective(x), sol.state.f_info.f  # the objective at the last accepted point, as the solver evaluated it
    better = jnp.isfinite(of1) & (of1 <= of0)
    x_new = space.to_physical(_to_unit(sol.value))
    done = sol.result == optx.RESULTS.successful
    return PolishResult(jnp.where(better, x_new, x), of0, jnp.where(better, of1, of0), sol.stats["num_steps"], done)


def _compiled(fn):
    """`fn` compiled without XLA:CPU's fusion emitters (`LEAN`) where the time loops are built as
    one function (`use_compiled_loops`, as the CLI, the experiments and the tests run), with XLA's
    own options elsewhere. With compiled loops both give the same bits (SD1 with 2 and 6 runs,
    MD1 RK4, a joint SD1+SD2 fit) and `LEAN` compiles in 0.6-0.7 of the time (SD1, 2 runs: 0.88 ->
    0.55 s; `python -m experiments.bench_polish_compile`) and runs as fast; with XLA's 1 KiB loops `LEAN` changes the last bits (an SD1
    polish at OF ~1e-26)."""
    lean, full = filter_jit(fn), filter_jit(fn, options={})

    @functools.wraps(fn)
    def call(*args):
        return (lean if compiled_loop_bytes() >= COMPILED_LOOP_BYTES else full)(*args)

    return call


polish_jit = _compiled(polish)
_polish_vmapped = _compiled(lambda xs, problem, space: jax.vmap(lambda x: polish(x, problem, space, starts=xs.shape[0]))(xs))
_polish_mapped = _compiled(lambda xs, problem, space: jax.lax.map(lambda x: polish(x, problem, space, starts=xs.shape[0]), xs))
FEW_RUNS = 4  # up to this many starts are polished one after another (`lax.map`): half the compile time of the vmapped loop


def polish_batch(xs: Float[Array, "R P"], problem, space: Space) -> PolishResult:
    """`polish` from every row of `xs`: vmapped over the rows (the solver's loop runs them all in
    one batch, 3-4x faster for 50 starts), or, for at most `FEW_RUNS` rows, one after another in
    one compiled loop (`lax.map`), which compiles in about half the time."""
    return (_polish_mapped if xs.shape[0] <= FEW_RUNS else _polish_vmapped)(xs, problem, space)
