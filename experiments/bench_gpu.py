"""Benchmark for issue 14, per device: DE/rand/1/exp on SD1 (RK4, NP = 70, 140,000 FEs) with 1,
50 and 1000 runs; fleets of simulated motors; and one population objective evaluation by the
Pallas kernel against the `lax.scan`. Prints a table naming the device.

    python -m experiments.bench_gpu                      # the issue's sizes (meant for a GPU)
    python -m experiments.bench_gpu --runs 1 50 --motors 20 --populations 70   # a CPU-sized run

On CPU the kernel exists only in interpret mode (a correctness tool, not a speed path), so the
kernel row is skipped there."""

import argparse
import time

import jax
import jax.numpy as jnp
import numpy as np

import dcjax

dcjax.use_host_devices()
dcjax.use_compiled_loops()

from dcjax import DC, Recording, datasets, fit, fit_each, make_problem  # noqa: E402
from dcjax.io.numpy_simulator import simulate_numpy  # noqa: E402
from dcjax.simulation.kernel import objective_kernel_jit  # noqa: E402
from dcjax.simulation.objectives import objective  # noqa: E402


def best_of(f, *args, repeats=5):
    jax.block_until_ready(f(*args))
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        jax.block_until_ready(f(*args))
        times.append(time.perf_counter() - t)
    return min(times)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, nargs="*", default=[1, 50, 1000])
    ap.add_argument("--motors", type=int, nargs="*", default=[1000, 10000])
    ap.add_argument("--populations", type=int, nargs="*", default=[128, 70_016])
    ap.add_argument("--budget", type=int, default=140_000)
    args = ap.parse_args()
    dev = jax.devices()
    print(
        f"device: {dev[0].device_kind} x {len(dev)} ({jax.default_backend()}), jax {jax.__version__}, kernel mode {dcjax.simulation.kernel.kernel_mode()}"
    )
    sd1 = datasets.load("SD1")
    print("| work | compile s | run s | result |\n|---|---|---|---|")
    for runs in args.runs:
        r = fit(sd1, params="table4", search=dcjax.Search(runs=runs, budget=args.budget, seed=0))
        ok = int(np.sum(r.run_of <= 1e-15))
        print(f"| SD1, {runs} runs | {r.timing['compile_s']:.2f} | {r.timing['run_s']:.3f} | {ok}/{runs} at OF <= 1e-15 |")
    truth = np.array([datasets.true_params("SD1")[p] for p in DC.names])
    for motors in args.motors:
        x = truth * np.random.default_rng(0).uniform(0.6, 1.4, (motors, 7))
        t = np.arange(501) * 1e-4
        u = np.full_like(t, 220.0)
        traj = simulate_numpy(x, t, u)
        recs = [Recording(t=t, u_a=u, i_a=traj[k, :, 0], omega=traj[k, :, 1]) for k in range(motors)]
        f = fit_each(recs, params="table4", search=dcjax.Search(runs=1, budget=args.budget, seed=0))
        t0 = f[0].timing  # type: ignore[union-attr]
        ofs = np.array([r.of for r in f])  # type: ignore[union-attr]
        print(
            f"| fleet, {motors} motors | {t0['compile_s']:.2f} | {t0['batch_run_s']:.3f} | {motors / t0['batch_run_s']:.1f} motors/s, {int(np.sum(ofs <= 1e-15))} at OF <= 1e-15 |"
        )
    prob = make_problem(sd1)
    for p in args.populations:
        box = DC().parameters("table4")
        xp = box.lower + jax.random.uniform(jax.random.PRNGKey(0), (p, 7)) * (box.upper - box.lower)
        with_scan = jax.jit(lambda x: _scan_objective(x, prob))
        t_scan = best_of(with_scan, xp)
        if jax.default_backend() == "gpu":
            t_kernel = best_of(lambda x: objective_kernel_jit(x, prob), xp)
            diff = float(jnp.nanmax(jnp.abs(objective_kernel_jit(xp, prob) - with_scan(xp)) / jnp.abs(with_scan(xp))))
            print(
                f"| objective of {p} members | - | kernel {1e3 * t_kernel:.3f} ms, scan {1e3 * t_scan:.3f} ms | ratio {t_scan / t_kernel:.1f}x, max rel diff {diff:.1e} |"
            )
        else:
            print(f"| objective of {p} members (scan) | - | {1e3 * t_scan:.3f} ms | kernel: GPU only |")


def _scan_objective(x, prob):
    import os

    old = os.environ.get("DCJAX_KERNEL")
    os.environ["DCJAX_KERNEL"] = "0"  # read at trace time: this traces the scan
    try:
        return objective(x, prob)
    finally:
        if old is None:
            del os.environ["DCJAX_KERNEL"]
        else:
            os.environ["DCJAX_KERNEL"] = old


if __name__ == "__main__":
    main()
