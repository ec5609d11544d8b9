"""Benchmark (issue 2): the simulation cost of one paper run, 140,000 RK4 simulations of SD1 in
populations of 70 (2000 calls), JAX against the straightforward NumPy implementation
(`dcjax.io.numpy_simulator`), measured in the same process.

    .venv/bin/python -m experiments.bench_simulate [--numpy-calls 2000]
"""

import argparse
import platform
import time

import jax
import jax.numpy as jnp
import numpy as np

import dcjax
from dcjax import DC, datasets, make_problem, objective
from dcjax.io.numpy_simulator import objective_numpy
from dcjax.simulation.integrate import prepare, rk4_step

dcjax.use_host_devices()  # one XLA CPU device per core, before any JAX computation
dcjax.use_compiled_loops()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--calls", type=int, default=2000, help="population evaluations (70 each)")
    ap.add_argument("--numpy-calls", type=int, default=2000)
    args = ap.parse_args()
    rec = datasets.load("SD1")
    box = DC().parameters("table4")
    pops = np.asarray(box.lower + jax.random.uniform(jax.random.PRNGKey(0), (8, 70, 7)) * (box.upper - box.lower))
    print(f"machine: {platform.processor() or platform.machine()}, jax {jax.__version__}, devices {jax.devices()}")
    print(f"work: {args.calls} x 70 = {args.calls * 70:,} RK4 simulations of SD1 ({len(rec)} samples)")
    results = {}
    for unroll in (1, 2):
        prob = make_problem(rec, unroll=unroll)
        f = jax.jit(lambda x, prob=prob: objective(x, prob))
        t0 = time.perf_counter()
        f(jnp.asarray(pops[0])).block_until_ready()
        compile_s = time.perf_counter() - t0
        xs = [jnp.asarray(p) for p in pops]
        run_s = np.inf
        for _ in range(3):  # best of 3: single passes vary by up to ~30 % on this machine
            t0 = time.perf_counter()
            for c in range(args.calls):
                out = f(xs[c % len(xs)])
            out.block_until_ready()
            run_s = min(run_s, time.perf_counter() - t0)
        results[unroll] = run_s
        print(
            f"JAX  unroll={unroll}: compile {compile_s:.3f} s, run {run_s:.3f} s, best of 3 ({run_s / args.calls * 1e6:.1f} us per population)"
        )
    t0 = time.perf_counter()
    for c in range(args.numpy_calls):
        objective_numpy(pops[c % len(pops)], rec.t, rec.u_a, rec.i_a, rec.omega)
    np_s = (time.perf_counter() - t0) * args.calls / args.numpy_calls
    note = "" if args.numpy_calls == args.calls else f" (extrapolated from {args.numpy_calls} calls)"
    print(f"NumPy reference: {np_s:.3f} s{note}")
    best = min(results.values())
    print(f"ratio NumPy / JAX (best unroll): {np_s / best:.1f}x")
    # Non-uniform support costs nothing on uniform grids: the general objective (h read per step
    # from the packed input) against a variant with h baked in as a compile-time constant.
    prob = make_problem(rec)
    h_const = float(rec.t[1] - rec.t[0])

    def objective_const_h(p, problem):
        model = problem.model
        c, y = prepare(p, problem)
        xs = jnp.concatenate([problem.u_start, problem.u_end, problem.y_meas[1:]], axis=1)
        s0, s1 = problem.scale[0], problem.scale[1]

        def body(carry, x):
            y, acc = carry
            y = rk4_step(model, c, y, h_const, (x[0],), (0.5 * (x[0] + x[1]),), (x[1],))
            return (y, acc + s0 * (y[0] - x[2]) ** 2 + s1 * (y[1] - x[3]) ** 2), None

        (_, acc), _ = jax.lax.scan(body, (y, jnp.zeros_like(y[0])), xs)
        return acc

    times = {}
    for label, fn in (("general (per-step h)", objective), ("constant h", objective_const_h)):
        f = jax.jit(lambda x, fn=fn: fn(x, prob))
        f(jnp.asarray(pops[0])).block_until_ready()
        best = np.inf
        for _ in range(3):
            t0 = time.perf_counter()
            for c in range(500):
                out = f(jnp.asarray(pops[c % len(pops)]))
            out.block_until_ready()
            best = min(best, (time.perf_counter() - t0) / 500)
        times[label] = best
        print(f"uniform SD1 grid, {label}: {best * 1e6:.1f} us per population (best of 3 x 500)")
    print(f"general / constant-h: {times['general (per-step h)'] / times['constant h']:.3f}")
    # Agreement of the two implementations on the same populations.
    prob = make_problem(rec)
    a = np.asarray(objective(pops[0], prob))
    b = objective_numpy(pops[0], rec.t, rec.u_a, rec.i_a, rec.omega)
    fin = np.isfinite(b)
    print(f"max relative OF difference JAX vs NumPy: {np.max(np.abs(a[fin] - b[fin]) / b[fin]):.2e}")


if __name__ == "__main__":
    main()
