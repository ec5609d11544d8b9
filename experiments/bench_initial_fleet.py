"""The initial-state default across a fleet (issue: searches that stop when they are done, item 4):
N recordings of one DC motor (SD1's, Table 4's truth) under N stepped voltages, each starting at
rest for 2 ms, simulated by the independent NumPy reference (`dcjax.io.numpy_simulator`, RK4), with
Gaussian sensor noise of `--noise` of each channel's peak (`bench_many.dc_recordings`). Each recording fitted on its own (`dcjax.fit_each`, Table 4's
ranges, `--runs` runs of the default search) with the default initial state (a noisy state's start
fitted: `y0_<state>` within its first sample +- 8 noise sd), from the first samples
(`initial=measured`) and from the first 11 samples' local quadratic at t0 (`initial=smoothed`). Prints per parameter the bias (mean relative error) and the spread (sd of
the relative errors) of each setting, and how many fitted starts ended at their range's bound.

    python -m experiments.bench_initial_fleet [--recordings 50] [--noise 0.005] [--runs 4]
"""

import argparse
import os
import platform
import time
import warnings

import numpy as np

import dcjax

from .bench_many import dc_recordings

SETTINGS = {
    "default (fit noisy starts)": None,
    "measured": dcjax.Observation(initial={"i_a": "measured", "omega": "measured"}),
    "smoothed": dcjax.Observation(initial={"i_a": "smoothed", "omega": "smoothed"}),
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--recordings", type=int, default=50)
    ap.add_argument("--noise", type=float, default=0.005)
    ap.add_argument("--runs", type=int, default=4)
    args = ap.parse_args()
    dcjax.use_host_devices()  # as the CLI starts
    dcjax.use_compiled_loops()
    recs, truth = dc_recordings(args.recordings, args.noise), dcjax.datasets.true_params("SD1")
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores; {args.recordings} recordings, noise {args.noise:g} "
          f"of peak, {args.runs} runs each (the default search otherwise)")  # fmt: skip
    names = ("Ra", "La", "cm", "J", "Tla")
    print(f"{'setting':<28} " + " ".join(f"{n + ' bias':>10} {n + ' sd':>9}" for n in names) + f" {'at bound':>9} {'wall':>7}")
    for tag, obs in SETTINGS.items():
        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = dcjax.fit_each(recs, "dc", "table4", search={"runs": args.runs}, observation=obs)
        wall = time.perf_counter() - t0
        err = np.array([[(r.best_values[n] - truth[n]) / truth[n] for n in names] for r in res])
        bound = sum(1 for w in caught if "y0_" in str(w.message) and "bound" in str(w.message))
        print(f"{tag:<28} " + " ".join(f"{b:10.2e} {s:9.2e}" for b, s in zip(err.mean(0), err.std(0))) + f" {bound:9d} {wall:6.1f}s",
              flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
