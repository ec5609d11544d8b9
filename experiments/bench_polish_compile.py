"""Compile time of the polish and of a Kalman filter's Hessian, each against what it replaced,
in one process with compiled loops (`dcjax.use_compiled_loops()`, as the `dcjax` command runs) and
no compilation cache:

- the Levenberg–Marquardt polish (`dcjax.fitting.polish`) compiled without XLA:CPU's fusion
  emitters (`dcjax.compiling.LEAN`, what `polish_jit` compiles with compiled loops) against XLA's
  own options: SD1 from 3 % off the truth, 2 starts one after another and 8 vmapped (as a fit
  polishes its runs, `polish_batch`); compile seconds, the
  median of 5 runs, and whether the two end on the same bits;
- the Hessian of a prediction-error fit's negative log-likelihood (the filter of
  `experiments.bench_prediction`'s record, 250 samples, 11 search entries) forward over forward
  (`jax.jacfwd(jax.jacfwd(.))`, `dcjax.analysis.uncertainty`) against `jax.hessian` (reverse
  inside); compile seconds, a run, and their largest relative difference.

    python -m experiments.bench_polish_compile
"""

import platform
import time
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

import dcjax
from dcjax.compiling import filter_jit
from dcjax.io import datasets
from dcjax.simulation.likelihood import filter_likelihood
from experiments.bench_prediction import record


def timed(fn, *args, repeat: int = 5) -> tuple[float, float, Any]:
    """(compile s, median run s, the result) of `fn` (a `filter_jit` function) at `args`."""
    t0 = time.perf_counter()
    run = fn.ahead(*args)
    compile_s = time.perf_counter() - t0
    out, times = None, []
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = jax.block_until_ready(run(*args))
        times.append(time.perf_counter() - t0)
    return compile_s, float(np.median(times)), out


def polish_rows() -> None:
    from dcjax.fitting.polish import polish
    from dcjax.simulation.joint import joint_problem

    rec, truth = datasets.load("SD1"), datasets.true_params("SD1")
    table4 = dcjax.DC().parameters("table4")
    target, space = joint_problem([dcjax.make_problem(rec)]), dcjax.Bounds(table4.lower, table4.upper, dcjax.DC.names)
    x = jnp.asarray([truth[n] for n in dcjax.DC.names])
    starts = x * (1 + 0.03 * jnp.asarray(np.random.default_rng(0).uniform(-1, 1, (8, x.shape[0]))))
    # as a fit polishes its runs (`polish_batch`): up to 4 one after another, more vmapped
    mapped = lambda opts: filter_jit(lambda xs, p, s: jax.lax.map(lambda x: polish(x, p, s), xs), options=opts)
    vmapped = lambda opts: filter_jit(jax.vmap(polish, in_axes=(0, None, None)), options=opts)
    for label, make, xs in (("2 runs (lax.map)", mapped, starts[:2]), ("8 runs (vmap)", vmapped, starts)):
        timed(make({"xla_backend_optimization_level": 1}), xs, target, space, repeat=1)  # the one-time costs of a first compile
        full = timed(make({}), xs, target, space)
        lean = timed(make(None), xs, target, space)
        same = bool(np.array_equal(np.asarray(lean[2].x), np.asarray(full[2].x)))
        print(f"polish, SD1, {label:<16} compile {full[0]:5.2f} s (XLA's options) -> {lean[0]:5.2f} s (LEAN); "
              f"run {1e3 * full[1]:7.2f} -> {1e3 * lean[1]:7.2f} ms; same bits: {same}")  # fmt: skip


def hessian_rows() -> None:
    obs = dcjax.Observation(hold={"u_a": "zoh"}, focus="prediction", initial={"i_a": 0.0, "omega": 0.0})
    res = dcjax.fit(record(0, 250), params="table4", search=dcjax.Search(runs=1, budget=300), observation=obs)
    likelihood, _ = filter_likelihood(res.target())
    space = res.space
    z = jnp.clip(space.to_unit(jnp.asarray([res.best_values[n] for n in res.names])), 0.0, 1.0)
    reverse = filter_jit(lambda z, f, s: jax.hessian(lambda v: f.objective(s.to_physical(v)))(z))
    forward = filter_jit(lambda z, f, s: jax.jacfwd(jax.jacfwd(lambda v: f.objective(s.to_physical(v))))(z))
    timed(filter_jit(lambda z, f: f.objective(z)), z, likelihood, repeat=1)  # the one-time costs of a first compile
    rev, fwd = timed(reverse, z, likelihood, space), timed(forward, z, likelihood, space)
    diff = float(np.max(np.abs(np.asarray(fwd[2]) - np.asarray(rev[2]))) / np.max(np.abs(np.asarray(rev[2]))))
    print(f"filter Hessian, 250 samples, {z.shape[0]} entries: compile {rev[0]:5.2f} s (jax.hessian) -> {fwd[0]:5.2f} s "
          f"(forward over forward); run {1e3 * rev[1]:6.2f} -> {1e3 * fwd[1]:6.2f} ms; largest relative difference {diff:.1e}")  # fmt: skip


def main() -> None:
    dcjax.use_compiled_loops()
    print(f"{platform.processor() or platform.machine()}, {jax.devices()[0].platform}; compiled loops, no compilation cache")
    polish_rows()
    hessian_rows()


if __name__ == "__main__":
    main()
