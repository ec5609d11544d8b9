"""Compilation time against the number of runs (issue: speed at scale, Done-when (b)): the runs are
a batch dimension of one compiled program, so `--runs 4` should compile in about the time of
`--runs 1`. Each configuration of `experiments.bench_joint` (one SD1-like recording; 24 of equal
length, stacked; 16 of lengths 501 down to 201, padded into one scan at this budget (`joint_buckets`); the issue's 476 servo logs of
`bench_servo_fleet`, DE and CMA-ES, a seventh of the budget) is fitted at `runs` 1 and 4 in fresh
processes set up as the CLI starts (`use_host_devices`, `use_compiled_loops`)
with the compilation cache off; `compile` is the engine's own figure
(`result.timing["compile_s"]`: tracing, lowering and XLA of the whole run), the median of
`--repeat` processes.

    python -m experiments.bench_compile_runs [--budget 14000] [--repeat 3]
"""

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys

CONFIGS = {"1 recording": "1,0", "24 equal-length (stacked)": "24,0", "16 lengths 501..201 (padded, joint_buckets)": "16,20",
           "476 servo logs (stacked), DE": "servo,de-rand-1-exp", "476 servo logs (stacked), CMA-ES": "servo,cma-es"}  # fmt: skip


CHILD = """
import json, sys
import dcjax
dcjax.use_host_devices()  # as the CLI starts: one XLA host device per core, compiled loops
dcjax.use_compiled_loops()
if sys.argv[1].startswith("servo,"):  # the issue's data: bench_servo_fleet's logs, as bench_many fits them
    from experiments.bench_many import servo_case
    case = servo_case()
    res = dcjax.fit(case["data"], case["model"], case["params"], dcjax.Search(sys.argv[1].split(",")[1], runs=int(sys.argv[2]),
                    budget=int(sys.argv[3]) // 7), observation=case["observation"])
    print(json.dumps({"compile_s": res.timing["compile_s"]}))
else:
    from experiments.bench_joint import child
    count, step = map(int, sys.argv[1].split(","))
    print(json.dumps(child(count, step, int(sys.argv[2]), int(sys.argv[3]), False)))
"""


def compile_s(spec: str, runs: int, budget: int) -> float:
    cmd = [sys.executable, "-c", CHILD, spec, str(runs), str(budget)]
    p = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "DCJAX_NO_CACHE": "1"}, check=True)
    return json.loads(p.stdout.strip().splitlines()[-1])["compile_s"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=int, default=14_000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores; DE, {args.budget} FEs a run, cache off, "
          f"median of {args.repeat} fresh processes")  # fmt: skip
    print(f"{'recordings':<36} {'runs 1':>8} {'runs 4':>8} {'ratio':>6}")
    for label, spec in CONFIGS.items():
        one, four = ([compile_s(spec, r, args.budget) for _ in range(args.repeat)] for r in (1, 4))
        a, b = statistics.median(one), statistics.median(four)
        print(f"{label:<36} {a:7.2f}s {b:7.2f}s {b / a:6.2f}   ({one} / {four})", flush=True)


if __name__ == "__main__":
    main()
