"""A batch of recordings in one compiled call on a CPU: its recordings one after another
(`lax.map`, what `dcjax.fitting.runs` does on a CPU) against side by side (`vmap`, what it does on
an accelerator, `runs.side_by_side`): the call's compile and search seconds and whether both give
every recording the same runs to the bit.

Data: SD1 cut to `--lengths` (default 310, 320, ..., 500 samples: one bucket of close lengths,
the folder of issue 53's item 3; one length: that recording alone, no batch), fitted as `dcjax fit --each f*.csv --bounds table4 --runs 2
--budget 20000` fits it (`Search.many`, two host devices, compiled loops). Each fit runs in a
fresh process with the compilation cache off (a cold compile), the two ways alternating
`--rounds` times.

    python -m experiments.bench_members [--rounds 3] [--runs 2] [--budget 20000]
"""

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys

CHILD = """
import hashlib, json, sys
import numpy as np
import dcjax
from dcjax import datasets
from dcjax.fitting import runs
dcjax.use_host_devices()
dcjax.use_compiled_loops()
lengths, n_runs, budget, side = json.loads(sys.argv[1])
if side:
    runs.side_by_side = lambda mesh: True
sd1 = datasets.load("SD1")
cut = lambda n: sd1.replace(t=sd1.t[:n], channels={c: v[:n] for c, v in sd1.channels.items()}, name=f"f{n}")
res = dcjax.fit_each([cut(n) for n in lengths], params="table4", search=dcjax.Search.many(runs=n_runs, budget=budget))
bits = hashlib.sha256(b"".join(np.asarray(r.run_params).tobytes() + np.asarray(r.run_of).tobytes() for r in res)).hexdigest()[:12]
timing = res[0].timing  # one recording: no batch, its own run
print(json.dumps({"compile": timing["compile_s"], "search": timing.get("batch_run_s", timing["run_s"]), "bits": bits}))
"""


def fit(lengths: list[int], runs: int, budget: int, side: bool) -> dict:
    env = {**os.environ, "DCJAX_NO_CACHE": "1"}
    p = subprocess.run([sys.executable, "-c", CHILD, json.dumps([lengths, runs, budget, side])], capture_output=True, text=True, env=env)
    if p.returncode != 0:
        raise SystemExit(p.stderr.strip().splitlines()[-1])
    return json.loads(p.stdout.strip().splitlines()[-1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lengths", type=int, nargs="+", default=list(range(310, 501, 10)))
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--budget", type=int, default=20_000)
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores; {len(args.lengths)} recordings "
          f"{min(args.lengths)}-{max(args.lengths)} samples, {args.runs} runs x {args.budget} FEs", flush=True)  # fmt: skip
    seen: dict[str, list[dict]] = {"one after another": [], "side by side": []}
    for _ in range(args.rounds):
        for way in seen:
            out = fit(args.lengths, args.runs, args.budget, way == "side by side")
            seen[way].append(out)
            print(f"  {way:17s}: compile {out['compile']:.2f} s, search {out['search']:.2f} s, bits {out['bits']}", flush=True)
    for way, outs in seen.items():
        c, s = (statistics.median(o[k] for o in outs) for k in ("compile", "search"))
        print(f"{way:17s}: median compile {c:.2f} s, search {s:.2f} s", flush=True)
    bits = {o["bits"] for outs in seen.values() for o in outs}
    print("same bits both ways:", "yes" if len(bits) == 1 else f"no ({sorted(bits)})")


if __name__ == "__main__":
    main()
