"""Paper Table 5 (and Table 6 for SD1): SD1–SD4 x GA, DE/rand/1/exp, DE/best/1/bin, TLBO, ABC,
50 independent runs each, RK4, NP = 70, 140,000 FEs. Prints B, W, M, SD of the OF beside the
paper's values, the runs with OF <= 1e-15 and the worst relative parameter error.

    .venv/bin/python experiments/table5_sd.py [--runs 50] [--store experiments/results/table5.jsonl]

Each finished (data set, method) is appended to the store at once; a restart skips them."""

import argparse
import time

import numpy as np

from dcjax import PARAM_NAMES, datasets, identify

try:
    from runstore import RunStore
except ImportError:  # run as a module
    from experiments.runstore import RunStore

METHODS = ["ga", "de-rand-1-exp", "de-best-1-bin", "tlbo", "abc"]
# Paper Table 5: (B, W, M, SD) per data set and method.
PAPER_TABLE5 = {
    "SD1": {"ga": (3.2054e-4, 4.3669e-1, 1.0765e-1, 1.1031e-1), "de-rand-1-exp": (4.8980e-19, 4.8980e-19, 4.8980e-19, 2.0882e-27),
            "de-best-1-bin": (4.8980e-19, 2.5072e-2, 6.6203e-4, 3.6637e-3), "tlbo": (3.9564e-15, 2.7757e-10, 1.6827e-11, 4.7340e-11),
            "abc": (6.8520e-10, 1.6968e-7, 3.4562e-8, 4.3330e-8)},
    "SD2": {"ga": (7.8123e-5, 1.8151e-1, 5.2484e-2, 5.0508e-2), "de-rand-1-exp": (6.2556e-19, 6.2556e-19, 6.2556e-19, 3.5547e-27),
            "de-best-1-bin": (6.2556e-19, 4.6771e-2, 9.3542e-4, 6.5479e-3), "tlbo": (7.8460e-13, 7.3488e-9, 5.1639e-10, 1.0976e-9),
            "abc": (1.0932e-9, 2.1087e-7, 4.1001e-8, 4.5495e-8)},
    "SD3": {"ga": (6.9449e-5, 2.8716e-1, 7.4399e-2, 6.716e-2), "de-rand-1-exp": (4.6666e-19, 4.6666e-19, 4.6666e-19, 2.2635e-27),
            "de-best-1-bin": (4.6666e-19, 4.6005e-2, 2.3516e-3, 9.1419e-3), "tlbo": (1.9151e-12, 2.6491e-9, 3.3533e-10, 5.0565e-10),
            "abc": (6.1774e-11, 2.1340e-9, 5.2114e-10, 4.4003e-10)},
    "SD4": {"ga": (3.6061e-3, 2.8045e-1, 1.3085e-1, 8.1103e-2), "de-rand-1-exp": (3.0248e-19, 3.0248e-19, 3.0248e-19, 1.1859e-27),
            "de-best-1-bin": (3.0248e-19, 8.7846e-2, 4.4826e-3, 1.3509e-2), "tlbo": (4.523e-16, 4.2365e-9, 1.5931e-10, 6.8381e-10),
            "abc": (9.7925e-9, 4.1963e-7, 1.3155e-7, 9.5220e-8)},
}


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--budget", type=int, default=140_000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--store", default="experiments/results/table5.jsonl")
    args = ap.parse_args()
    store = RunStore(args.store)
    t_start = time.perf_counter()
    for name in PAPER_TABLE5:
        rec = datasets.load(name)
        for m in METHODS:
            key = f"{name}/{m}/runs={args.runs}/budget={args.budget}/seed={args.seed}"
            if key in store.done():
                continue
            r = identify(rec, method=m, runs=args.runs, budget=args.budget, seed=args.seed)
            store.append({"key": key, "data": name, "method": m, "run_of": r.run_of.tolist(),
                          "run_params": r.run_params.tolist(), "fes": r.fes.tolist(), "timing": r.timing})
            print(f"done {key}: run {r.timing['run_s']:.1f} s", flush=True)
    rows = {(r["data"], r["method"]): r for r in store.records() if r["key"].endswith(f"runs={args.runs}/budget={args.budget}/seed={args.seed}")}
    print(f"\nTable 5 ({args.runs} runs; paper: 50 runs). Each cell: dcjax | paper")
    for name, paper in PAPER_TABLE5.items():
        truth = np.array([datasets.true_params(name)[p] for p in PARAM_NAMES])
        print(f"\n{name}")
        print(f"  {'method':15s} {'B':>21s} {'W':>21s} {'M':>21s} {'SD':>21s}  OF<=1e-15  max rel err (mean params)")
        means = {}
        for m in METHODS:
            r = rows[(name, m)]
            f = np.asarray(r["run_of"])
            ours = (f.min(), f.max(), f.mean(), f.std())
            means[m] = f.mean()
            cells = " ".join(f"{o:9.3e}|{p:9.3e}" for o, p in zip(ours, paper[m]))
            err = np.max(np.abs(np.mean(r["run_params"], axis=0) - truth) / truth)
            print(f"  {m:15s} {cells}  {int(np.sum(f <= 1e-15)):3d}/{f.size}    {err:.2e}")
        order = sorted(means, key=means.get)
        print(f"  ranking by mean OF: {' < '.join(order)}")
    print("\nTable 6 (SD1, mean parameters over runs):")
    truth = datasets.true_params("SD1")
    for k, p in enumerate(PARAM_NAMES):
        vals = " ".join(f"{np.mean(np.asarray(rows[('SD1', m)]['run_params'])[:, k]):11.4e}" for m in METHODS)
        print(f"  {p:4s} true {truth[p]:10.4e} | {vals}   ({', '.join(METHODS)})")
    print(f"\nwall time this invocation: {time.perf_counter() - t_start:.0f} s")


if __name__ == "__main__":
    main()
