"""Paper Table 5 (and Table 6 for SD1): SD1–SD4 x GA, DE/rand/1/exp, DE/best/1/bin, TLBO, ABC,
50 independent runs each, RK4, NP = 70, 140,000 FEs. Prints B, W, M, SD of the OF beside the
paper's values, the runs with OF <= 1e-15 and the worst relative parameter error.

    .venv/bin/python experiments/table5_sd.py [--runs 50] [--store experiments/results/table5.jsonl]

Each finished (data set, method) is appended to the store at once; a restart skips them."""

import argparse
import json
import time
from pathlib import Path

import numpy as np

import dcjax
from dcjax import PARAM_NAMES, datasets, identify

dcjax.use_host_devices()  # one XLA CPU device per core, before any JAX computation
dcjax.use_compilation_cache()  # executables persist across runs (DCJAX_NO_CACHE=1: off)

try:
    from runstore import RunStore
except ImportError:  # run as a module
    from experiments.runstore import RunStore

METHODS = ["ga", "de-rand-1-exp", "de-best-1-bin", "tlbo", "abc"]
# Paper Table 5: (B, W, M, SD) per data set and method, from the transcription shared with report.py.
PAPER_TABLE5 = json.loads((Path(__file__).resolve().parent / "paper_tables.json").read_text())["table5"]["rows"]


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
            store.append(
                {
                    "key": key,
                    "data": name,
                    "method": m,
                    "run_of": r.run_of.tolist(),
                    "run_params": r.run_params.tolist(),
                    "fes": r.fes.tolist(),
                    "timing": r.timing,
                }
            )
            print(f"done {key}: run {r.timing['run_s']:.1f} s", flush=True)
    rows = {
        (r["data"], r["method"]): r for r in store.records() if r["key"].endswith(f"runs={args.runs}/budget={args.budget}/seed={args.seed}")
    }
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
