"""Automatic bounds against the paper's presets (issue: real recordings of an unknown motor):
the same runs with `bounds="auto"` and with the set's preset (Table 4 for SD1, Table 8 for
MD1–MD4), best and mean OF, runs at OF <= 1e-15, and the first estimate's error on SD1–SD4.

    .venv/bin/python -m experiments.bench_auto_bounds [--runs 10]
"""

import argparse
import time

import numpy as np

import dcjax
from dcjax import datasets
from dcjax.analysis.estimate import initial_estimate

dcjax.use_host_devices()
dcjax.use_compiled_loops()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=10)
    args = ap.parse_args()
    print("first estimate (no search), relative error to the true parameters:")
    for name in ("SD1", "SD2", "SD3", "SD4"):
        rec = datasets.load(name)
        est, truth = initial_estimate(rec), datasets.true_params(name)
        errs = {n: (est[n].value - v) / v if est[n].value is not None else float("nan") for n, v in truth.items()}
        print(f"  {name}: " + ", ".join(f"{n} {100 * e:+.1f}%" for n, e in errs.items()))
    print(f"\nbounds auto vs preset, {args.runs} runs each (DE/rand/1/exp, RK4, 140,000 FEs; ND 5 on MD):")
    for name in ("SD1", "MD1", "MD2", "MD3", "MD4"):
        rec = datasets.load(name)
        preset = rec.metadata["bounds"]
        nd = 5 if name.startswith("MD") else 1
        row = {}
        for b in (preset, "auto"):
            t0 = time.perf_counter()
            res = dcjax.fit(rec, params=b, integrator=dcjax.RK4(substeps=nd), search=dcjax.Search(runs=args.runs))
            row[b] = res
            ok = int(np.sum(res.run_of <= 1e-15))
            print(
                f"  {name} {b:>6}: best {res.stats['best']:.6e} mean {res.stats['mean']:.6e} OF<=1e-15 {ok}/{args.runs} "
                f"at bound {res.at_bound()} ({time.perf_counter() - t0:.1f} s)"
            )
        print(
            f"  {name} auto/preset: best {row['auto'].stats['best'] / row[preset].stats['best']:.4f}, mean {row['auto'].stats['mean'] / row[preset].stats['mean']:.4f}"
        )


if __name__ == "__main__":
    main()
