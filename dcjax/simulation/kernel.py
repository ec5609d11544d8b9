"""The population objective and the simulator as one Pallas kernel each: the whole time loop of a
block of candidates runs inside the kernel (one lane per candidate), instead of one XLA
operation per scan step. On a GPU that removes the per-step kernel launches that bound the scan
(issue 14); on CPU the same kernel runs in Pallas' interpret mode, which the tests compare with
the scan. Generic over the `Model`: the model's coefficients and vector field are traced inside
the kernel, with the problem's integrator (any `Integrator`: its `step` is traced inside the kernel), ND sub-steps, eq. 29 interpolation, the clamp, channel weights and
non-uniform time steps exactly as in `dcjax.simulation.integrate`."""

import functools
import os
import warnings

import jax
import jax.numpy as jnp
import numpy as np
from jax.experimental import pallas as pl
from jaxtyping import Array, Float

from ..io.recording import Recording
from ..models import DC
from .integrate import advance_with, step_inputs
from .problem import Problem, make_problem

BLOCK = 128  # candidates per kernel instance (lanes)


def kernel_mode() -> str | None:
    """How `objective`/`simulate` evaluate a population: `"compiled"` (the kernel, on a GPU
    backend by default), `"interpret"` (the kernel in Pallas' interpret mode, for checks on CPU)
    or None (the `lax.scan`). `DCJAX_KERNEL=0|1|interpret` overrides the default, read at trace time."""
    choice = os.environ.get("DCJAX_KERNEL", "auto").strip().lower()
    if choice in ("0", "off", "scan"):
        return None
    if choice == "interpret":
        return "interpret"
    if choice in ("1", "on"):
        return "compiled"
    return "compiled" if jax.default_backend() == "gpu" and kernel_compiles() else None


def kernel_compiles() -> bool:
    """Whether the objective kernel compiles and runs on this backend (tried once per process
    and backend, `_probe`). The Triton lowering in float64 has not been run on a real GPU by
    this project (no GPU was lent), so the default does not depend on it: where it fails, dcjax
    warns and evaluates with the `lax.scan` (`DCJAX_KERNEL=1` still forces the kernel)."""
    return _probe(jax.default_backend())


@functools.cache
def _probe(backend: str) -> bool:
    """One block of the paper's motor (SD1's parameters) on 64 samples of a 220 V step."""

    t = np.arange(64) * 1e-4
    rec = Recording(t=t, u_a=np.full_like(t, 220.0), i_a=np.ones_like(t), omega=np.ones_like(t))
    problem = make_problem(rec, model=DC())
    x = jnp.tile(jnp.asarray([42.5, 0.08, 0.4781, 2e-5, 0.01, 3.27e-5, 8.55e-8], jnp.float64), (BLOCK, 1))
    try:
        of = jax.jit(lambda x: objective_kernel(x, problem))(x)
        return bool(jnp.all(jnp.isfinite(of)))
    except Exception as e:  # a lowering or runtime error of the kernel, whatever its type
        warnings.warn(f"the Pallas kernel does not run here ({type(e).__name__}: {str(e)[:160]}); dcjax uses the lax.scan", stacklevel=3)
        return False


def _inputs(problem: Problem):
    xs = jnp.concatenate([step_inputs(problem), problem.y_meas[1:]], axis=1)  # (N-1, 1 + 2m + c)
    limit = jnp.reshape(jnp.asarray(jnp.inf if problem.limit is None else problem.limit, jnp.float64), (1,))
    return xs, problem.y_meas[0], problem.y0, problem.scale, limit


def _pad(x, block):
    p = x.shape[0]
    padded = -(-p // block) * block
    return jnp.pad(x, ((0, padded - p), (0, 0)), mode="edge"), p


def _setup(problem: Problem, x_ref, y0_ref, limit_ref, block: int):
    model = problem.model
    x = x_ref[...]
    c = model.coefficients(model.as_dict(x))
    y = tuple(jnp.full((block,), y0_ref[s]) for s in range(len(model.states)))
    limit = None if problem.limit is None else limit_ref[0]
    return model, c, y, limit


def _step(problem: Problem, model, c, y, limit, xs_ref, k):
    m = problem.u_start.shape[1]
    h = xs_ref[k, 0]
    ua = tuple(xs_ref[k, 1 + j] for j in range(m))
    ub = tuple(xs_ref[k, 1 + m + j] for j in range(m))
    return advance_with(model, problem.integrator, limit, c, y, h, ua, ub)


def objective_kernel(x: Float[Array, "P Pn"], problem: Problem, interpret: bool = False, block: int = BLOCK) -> Float[Array, " P"]:
    """Eq. 27 for every row of `x` (physical parameters, the model's order): the same numbers as
    `dcjax.objective`, computed by one Pallas kernel per block of `block` candidates."""
    xs, meas0, y0, scale, limit = _inputs(problem)
    xp, p = _pad(jnp.asarray(x, jnp.float64), block)
    n_steps, width = xs.shape
    m = problem.u_start.shape[1]
    outs = problem.model.output_index

    def kernel(x_ref, xs_ref, meas0_ref, y0_ref, scale_ref, limit_ref, out_ref):
        model, c, y, lim = _setup(problem, x_ref, y0_ref, limit_ref, block)

        def misfit(acc, y, meas):
            for j, o in enumerate(outs):
                acc = acc + scale_ref[j] * (y[o] - meas(j)) ** 2
            return acc

        acc = misfit(jnp.zeros((block,)), y, lambda j: meas0_ref[j])

        def body(k, carry):
            y, acc = carry
            y = _step(problem, model, c, y, lim, xs_ref, k)
            return y, misfit(acc, y, lambda j: xs_ref[k, 1 + 2 * m + j])

        _, acc = jax.lax.fori_loop(0, n_steps, body, (y, acc))
        out_ref[...] = jnp.where(jnp.isfinite(acc), acc, jnp.inf)

    full = lambda shape: pl.BlockSpec(shape, lambda i: (0,) * len(shape))
    of = pl.pallas_call(
        kernel,
        out_shape=jax.ShapeDtypeStruct((xp.shape[0],), jnp.float64),
        grid=(xp.shape[0] // block,),
        in_specs=[
            pl.BlockSpec((block, xp.shape[1]), lambda i: (i, 0)),
            full((n_steps, width)),
            full(meas0.shape),
            full(y0.shape),
            full(scale.shape),
            full((1,)),
        ],
        out_specs=pl.BlockSpec((block,), lambda i: (i,)),
        interpret=interpret,
    )(xp, xs, meas0, y0, scale, limit)
    return of[:p]


def simulate_kernel(x: Float[Array, "P Pn"], problem: Problem, interpret: bool = False, block: int = BLOCK) -> Float[Array, "P n s"]:
    """Every state at the sample instants for every row of `x`, as `dcjax.simulate`, by one
    Pallas kernel per block of candidates."""
    xs, _, y0, _, limit = _inputs(problem)
    xp, p = _pad(jnp.asarray(x, jnp.float64), block)
    n_steps, width = xs.shape
    n_states = len(problem.model.states)

    def kernel(x_ref, xs_ref, y0_ref, limit_ref, out_ref):
        model, c, y, lim = _setup(problem, x_ref, y0_ref, limit_ref, block)
        for s in range(n_states):
            out_ref[s, 0, :] = y[s]

        def body(k, y):
            y = _step(problem, model, c, y, lim, xs_ref, k)
            for s in range(n_states):
                out_ref[s, k + 1, :] = y[s]
            return y

        jax.lax.fori_loop(0, n_steps, body, y)

    full = lambda shape: pl.BlockSpec(shape, lambda i: (0,) * len(shape))
    traj = pl.pallas_call(
        kernel,
        out_shape=jax.ShapeDtypeStruct((n_states, n_steps + 1, xp.shape[0]), jnp.float64),
        grid=(xp.shape[0] // block,),
        in_specs=[pl.BlockSpec((block, xp.shape[1]), lambda i: (i, 0)), full((n_steps, width)), full(y0.shape), full((1,))],
        out_specs=pl.BlockSpec((n_states, n_steps + 1, block), lambda i: (0, 0, i)),
        interpret=interpret,
    )(xp, xs, y0, limit)
    return jnp.transpose(traj, (2, 1, 0))[:p]


objective_kernel_jit = jax.jit(objective_kernel, static_argnames=("interpret", "block"))
simulate_kernel_jit = jax.jit(simulate_kernel, static_argnames=("interpret", "block"))
