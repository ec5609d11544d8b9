"""Compilation of a joint fit (issue 28): one recording; 16 equal-length recordings (stacked:
one vmapped objective); 16 of close lengths (501 down to 486 samples: padded, one scan); 16 of
lengths far apart (501 down to 201: one scan per length, as every joint fit compiled before);
each in a fresh process with the compilation cache off; `compile` is the engine's own figure
(`result.timing["compile_s"]`: tracing, lowering and XLA of the whole run).

    python -m experiments.bench_joint [--runs 2] [--budget 14000] [--local]
"""

import argparse
import json
import os
import statistics
import subprocess
import sys


def child(count: int, step: int, runs: int, budget: int, local: bool) -> dict:
    import numpy as np

    import dcjax

    sd1 = dcjax.datasets.load("SD1")
    truth = sd1.metadata["true_params"]
    recs = []
    for k in range(count):
        n = len(sd1) - step * k
        base = sd1.replace(t=sd1.t[:n], channels={c: v[:n] for c, v in sd1.channels.items()}, name=f"r{k}", metadata={})
        y = np.asarray(dcjax.simulate(dict(truth, Tla=0.005 * (1 + k)), dcjax.make_problem(base)))
        recs.append(base.replace(channels={**base.channels, "i_a": y[:, 0], "omega": y[:, 1]}))
    params = dcjax.DC().parameters("table4")
    params["Tla"].set(local=local)
    res = dcjax.fit(recs, params=params, search=dcjax.Search(runs=runs, budget=budget))
    return {"compile_s": res.timing["compile_s"], "run_s": res.timing["run_s"], "of": res.of}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--budget", type=int, default=14_000)
    ap.add_argument("--local", action="store_true", help="Tla local (one value per recording)")
    ap.add_argument("--repeat", type=int, default=3, help="fresh processes per configuration (the median is shown)")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        count, step = args.child.split(",")
        print(json.dumps(child(int(count), int(step), args.runs, args.budget, args.local)))
        return
    env = {**os.environ, "DCJAX_NO_CACHE": "1"}
    rows = {}
    for label, spec in (("1 recording", "1,0"), ("16 equal-length (stacked)", "16,0"), ("16 lengths 501..486 (padded)", "16,1"),
                        ("16 lengths 501..201 (a scan each)", "16,20")):  # fmt: skip
        cmd = [sys.executable, "-m", "experiments.bench_joint", "--child", spec, "--runs", str(args.runs), "--budget", str(args.budget)]
        runs = []
        for _ in range(args.repeat):
            p = subprocess.run(cmd + (["--local"] if args.local else []), capture_output=True, text=True, env=env, check=True)
            runs.append(json.loads(p.stdout.strip().splitlines()[-1]))
        rows[label] = {k: statistics.median(r[k] for r in runs) for k in ("compile_s", "run_s")} | {
            "all": [round(r["compile_s"], 2) for r in runs]
        }
    one = rows["1 recording"]["compile_s"]
    print(f"joint fit, {args.runs} runs x {args.budget} FEs, Tla {'local' if args.local else 'shared'}, fresh processes, cache off, "
          f"median of {args.repeat}")  # fmt: skip
    print(f"{'recordings':<36} {'compile':>9} {'x one':>7} {'run':>8}  compile of each process")
    for label, r in rows.items():
        print(f"{label:<36} {r['compile_s']:8.2f}s {r['compile_s'] / one:7.2f} {r['run_s']:7.2f}s  {r['all']}")


if __name__ == "__main__":
    main()
