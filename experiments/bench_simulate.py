"""Benchmark (issue 2): the simulation cost of one paper run, 140,000 RK4 simulations of SD1 in
populations of 70 (2000 calls), JAX against the straightforward NumPy implementation
(`dcjax.reference`), measured in the same process.

    .venv/bin/python experiments/bench_simulate.py [--numpy-calls 2000]
"""

import argparse
import platform
import time

import jax
import jax.numpy as jnp
import numpy as np

import dcjax
from dcjax import TABLE4, Params, datasets, make_problem, objective
from dcjax.reference import objective_numpy


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--calls", type=int, default=2000, help="population evaluations (70 each)")
    ap.add_argument("--numpy-calls", type=int, default=2000)
    args = ap.parse_args()
    rec = datasets.load("SD1")
    pops = np.asarray(TABLE4.to_physical(jax.random.uniform(jax.random.PRNGKey(0), (8, 70, 7))))
    print(f"machine: {platform.processor() or platform.machine()}, jax {jax.__version__}, devices {jax.devices()}")
    print(f"work: {args.calls} x 70 = {args.calls * 70:,} RK4 simulations of SD1 ({len(rec)} samples)")
    results = {}
    for unroll in (1, 2):
        prob = make_problem(rec, unroll=unroll)
        f = jax.jit(lambda x: objective(Params.from_array(x), prob))
        t0 = time.perf_counter()
        f(jnp.asarray(pops[0])).block_until_ready()
        compile_s = time.perf_counter() - t0
        xs = [jnp.asarray(p) for p in pops]
        t0 = time.perf_counter()
        for c in range(args.calls):
            out = f(xs[c % len(xs)])
        out.block_until_ready()
        run_s = time.perf_counter() - t0
        results[unroll] = run_s
        print(f"JAX  unroll={unroll}: compile {compile_s:.3f} s, run {run_s:.3f} s ({run_s / args.calls * 1e6:.1f} us per population)")
    t0 = time.perf_counter()
    for c in range(args.numpy_calls):
        objective_numpy(pops[c % len(pops)], rec.t, rec.u_a, rec.i_a, rec.omega)
    np_s = (time.perf_counter() - t0) * args.calls / args.numpy_calls
    note = "" if args.numpy_calls == args.calls else f" (extrapolated from {args.numpy_calls} calls)"
    print(f"NumPy reference: {np_s:.3f} s{note}")
    best = min(results.values())
    print(f"ratio NumPy / JAX (best unroll): {np_s / best:.1f}x")
    # Agreement of the two implementations on the same populations.
    prob = make_problem(rec)
    a = np.asarray(objective(Params.from_array(pops[0]), prob))
    b = objective_numpy(pops[0], rec.t, rec.u_a, rec.i_a, rec.omega)
    fin = np.isfinite(b)
    print(f"max relative OF difference JAX vs NumPy: {np.max(np.abs(a[fin] - b[fin]) / b[fin]):.2e}")


if __name__ == "__main__":
    main()
