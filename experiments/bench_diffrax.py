"""The adaptive integrator `dcjax.Diffrax` against the fixed-step RK4 on SD1 (issue: a researcher's
own model): each one's largest error against an adaptive Dopri8 reference at rtol 1e-10 (the
truth's trajectory, relative to each channel's peak) and the time of one population objective
(70 members uniform in Table 4's ranges, seed 0; best of 5 after the compilation), in one process.

    python -m experiments.bench_diffrax
"""

import platform
import time

import jax
import jax.numpy as jnp
import numpy as np

import dcjax
from dcjax import datasets
from dcjax.simulation.diffrax_reference import reference_simulate_jit

dcjax.use_compiled_loops()


def main():
    rec, truth = datasets.load("SD1"), datasets.true_params("SD1")
    lo, hi = dcjax.DC().bound_arrays("table4")
    X = jnp.asarray(lo + (hi - lo) * np.random.default_rng(0).uniform(size=(70, 7)))
    print(f"{platform.processor() or platform.machine()}, {jax.devices()[0].platform}, SD1 ({len(rec)} samples), population of 70")
    base = None
    for integ in (dcjax.RK4(), dcjax.RK4(substeps=8), dcjax.Diffrax(), dcjax.Diffrax(rtol=1e-6, atol=1e-8)):
        prob = dcjax.make_problem(rec, integ)
        ref = np.asarray(reference_simulate_jit(truth, prob))
        sim = np.asarray(dcjax.simulate(truth, prob))
        err = float(np.max(np.abs(sim - ref) / np.max(np.abs(ref), axis=0)))
        f = jax.jit(lambda x, p=prob: dcjax.objective(x, p))
        t0 = time.perf_counter()
        f(X).block_until_ready()
        first = time.perf_counter() - t0
        times = []
        for _ in range(5):
            t0 = time.perf_counter()
            f(X).block_until_ready()
            times.append(time.perf_counter() - t0)
        best = min(times)
        base = base or best
        print(f"{integ!r:40s} error {err:.1e}  objective {1e3 * best:7.2f} ms ({best / base:5.1f}x RK4)  first call {first:.1f} s")


if __name__ == "__main__":
    main()
