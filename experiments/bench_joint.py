"""Compilation of a joint fit (issue 28): one recording, 16 equal-length recordings (stacked:
one vmapped objective) and 16 recordings of unequal lengths (one scan each, as every joint fit
compiled before), each in a fresh process with the compilation cache off; `compile` is the
engine's own figure (`result.timing["compile_s"]`: tracing, lowering and XLA of the whole run).

    python -m experiments.bench_joint [--runs 2] [--budget 14000] [--local]
"""

import argparse
import json
import os
import subprocess
import sys


def child(count: int, unequal: bool, runs: int, budget: int, local: bool) -> dict:
    import numpy as np

    import dcjax

    sd1 = dcjax.datasets.load("SD1")
    truth = sd1.metadata["true_params"]
    recs = []
    for k in range(count):
        n = len(sd1) - (k if unequal else 0)
        base = sd1.replace(t=sd1.t[:n], channels={c: v[:n] for c, v in sd1.channels.items()}, name=f"r{k}", metadata={})
        y = np.asarray(dcjax.simulate(dict(truth, Tla=0.005 * (1 + k)), dcjax.make_problem(base)))
        recs.append(base.replace(channels={**base.channels, "i_a": y[:, 0], "omega": y[:, 1]}))
    params = dcjax.DC().parameters("table4")
    params["Tla"].set(local=local)
    res = dcjax.fit(recs, params=params, runs=runs, budget=budget)
    return {"compile_s": res.timing["compile_s"], "run_s": res.timing["run_s"], "of": res.of}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--budget", type=int, default=14_000)
    ap.add_argument("--local", action="store_true", help="Tla local (one value per recording)")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        count, unequal = args.child.split(",")
        print(json.dumps(child(int(count), unequal == "1", args.runs, args.budget, args.local)))
        return
    env = {**os.environ, "DCJAX_NO_CACHE": "1"}
    rows = {}
    for label, spec in (("1 recording", "1,0"), ("16 equal-length (stacked)", "16,0"), ("16 unequal lengths (one scan each)", "16,1")):
        cmd = [sys.executable, "-m", "experiments.bench_joint", "--child", spec, "--runs", str(args.runs), "--budget", str(args.budget)]
        p = subprocess.run(cmd + (["--local"] if args.local else []), capture_output=True, text=True, env=env, check=True)
        rows[label] = json.loads(p.stdout.strip().splitlines()[-1])
    one = rows["1 recording"]["compile_s"]
    print(f"joint fit, {args.runs} runs x {args.budget} FEs, Tla {'local' if args.local else 'shared'}, fresh processes, cache off")
    print(f"{'recordings':<36} {'compile':>9} {'x one':>7} {'run':>8}")
    for label, r in rows.items():
        print(f"{label:<36} {r['compile_s']:8.2f}s {r['compile_s'] / one:7.2f} {r['run_s']:7.2f}s")


if __name__ == "__main__":
    main()
