"""Benchmark (issue 3, paper Table 19): run times of the evolutionary methods on SD1 with RK4,
NP = 70, 140,000 FEs, and scipy's differential_evolution on the same objective in NumPy.

    .venv/bin/python -m experiments.bench_identify            # everything (~4 min on 2 cores)
    .venv/bin/python -m experiments.bench_identify --skip-scipy

Each section runs in a fresh subprocess with the XLA CPU device count it states, because the
device count is fixed when JAX starts: one device is fastest for a single run, two devices
(one per core, dcjax's default) for batched runs."""

import argparse
import json
import os
import resource
import subprocess
import sys
import time

import dcjax

dcjax.use_host_devices()  # one XLA CPU device per core, before any JAX computation
dcjax.use_compiled_loops()

METHODS = ["ga", "de-rand-1-exp", "de-best-1-bin", "tlbo", "abc"]


def _single(method: str, repeats: int = 3) -> dict:
    import jax

    from dcjax import DC, datasets, make_problem, objective
    from dcjax.strategies import make_strategy, run

    prob = make_problem(datasets.load("SD1"))
    box = DC().parameters("table4")
    fn = lambda z: objective(box.lower + z * (box.upper - box.lower), prob)
    s = make_strategy(method)
    f = jax.jit(lambda k: run(s, k, fn, 140_000, 7))
    t0 = time.perf_counter()
    c = f.lower(jax.random.PRNGKey(0)).compile()
    compile_s = time.perf_counter() - t0
    times = []
    for r in range(repeats):
        t0 = time.perf_counter()
        out = jax.block_until_ready(c(jax.random.PRNGKey(r)))
        times.append(time.perf_counter() - t0)
    return {"method": method, "compile_s": compile_s, "run_s": sorted(times)[len(times) // 2], "of": float(out.best_f)}


def _batched(method: str, runs: int = 50) -> dict:
    import numpy as np

    from dcjax import datasets, fit

    r = fit(datasets.load("SD1"), params="table4", search=dcjax.Search(method, runs=runs, seed=0))
    return {
        "method": method,
        "runs": runs,
        "devices": r.timing["devices"],
        "compile_s": r.timing["compile_s"],
        "run_s": r.timing["run_s"],
        "mean_of": r.stats["mean"],
        "runs_below_1e-15": int(np.sum(r.run_of <= 1e-15)),
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def _scipy() -> dict:
    from scipy.optimize import differential_evolution

    from dcjax import DC, datasets
    from dcjax.io.numpy_simulator import objective_numpy

    rec = datasets.load("SD1")
    lo, hi = DC().parameters("table4").lower, DC().parameters("table4").upper

    def f(x):  # vectorized: x has shape (7, S)
        return objective_numpy(x.T, rec.t, rec.u_a, rec.i_a, rec.omega)

    t0 = time.perf_counter()
    res = differential_evolution(
        f,
        list(zip(lo, hi)),
        strategy="rand1exp",
        mutation=0.6,
        recombination=0.8,
        popsize=10,
        maxiter=2000,
        tol=0,
        polish=False,
        vectorized=True,
        updating="deferred",
        seed=0,
    )
    # With vectorized=True scipy's nfev counts calls, each evaluating the whole population.
    return {"run_s": time.perf_counter() - t0, "of": float(res.fun), "nfev": int(res.nfev) * 70}


def _child(section: str, arg: str) -> dict:
    fn = {"single": _single, "batched": _batched, "scipy": lambda _: _scipy()}[section]
    return fn(arg)


XLA_LOOP_DEFAULT = "--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=1024"


def _spawn(section: str, arg: str, devices: int, compiled_loops: bool = True) -> dict:
    """`arg` in a fresh process with `devices` XLA CPU devices; `compiled_loops=False` pins XLA's
    default 1 KiB small-loop threshold, so `dcjax.use_compiled_loops()` leaves it alone."""
    flags = f"--xla_force_host_platform_device_count={devices}" + ("" if compiled_loops else f" {XLA_LOOP_DEFAULT}")
    env = dict(os.environ, XLA_FLAGS=flags)
    p = subprocess.run([sys.executable, __file__, "--child", section, arg], capture_output=True, text=True, env=env)
    if p.returncode != 0:
        raise RuntimeError(p.stderr)
    return json.loads(p.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--child", nargs=2)
    ap.add_argument("--skip-scipy", action="store_true")
    args = ap.parse_args()
    if args.child:
        print(json.dumps(_child(*args.child)))
        return
    n = os.cpu_count()
    print(f"SD1, RK4, NP = 70, 140,000 FEs per run; {n} cores")
    print("\nOne run (jit, 1 XLA device; median of 3 seeds):")
    single = {}
    for m in METHODS:
        single[m] = r = _spawn("single", m, 1)
        print(f"  {m:15s} compile {r['compile_s']:5.2f} s  run {r['run_s']:6.3f} s  OF {r['of']:.3e}")
    plain = _spawn("single", "de-rand-1-exp", 1, compiled_loops=False)
    de_run = single["de-rand-1-exp"]["run_s"]
    print(
        f"  de-rand-1-exp without dcjax.use_compiled_loops(): compile {plain['compile_s']:5.2f} s  run {plain['run_s']:6.3f} s"
        f"  ({plain['run_s'] / de_run:.2f}x the run above)"
    )
    print(f"\n50 runs batched (identify, vmap over runs, sharded over {n} XLA devices):")
    for m in METHODS:
        r = _spawn("batched", m, n)
        print(
            f"  {m:15s} compile {r['compile_s']:5.2f} s  run {r['run_s']:6.2f} s  ({r['run_s'] / 50:.3f} s/run)"
            f"  mean OF {r['mean_of']:.3e}  OF<=1e-15: {r['runs_below_1e-15']}/50  peak RSS {r['peak_rss_mb']:.0f} MB"
        )
    r1 = _spawn("batched", "de-rand-1-exp", 1)
    print(f"  de-rand-1-exp on 1 device: compile {r1['compile_s']:.2f} s  run {r1['run_s']:.2f} s")
    if not args.skip_scipy:
        s = _spawn("scipy", "-", 1)
        de = single["de-rand-1-exp"]["run_s"]
        print(
            f"\nscipy differential_evolution(rand1exp, NumPy objective, vectorized): {s['run_s']:.1f} s, {s['nfev']} FEs, OF {s['of']:.3e}"
        )
        print(
            f"ratio scipy / dcjax one DE/rand/1/exp run: {s['run_s'] / de:.0f}x (without compiled loops: {s['run_s'] / plain['run_s']:.0f}x)"
        )


if __name__ == "__main__":
    main()
