"""The compiled-loop threshold (`dcjax.use_compiled_loops(max_bytes)`): XLA:CPU builds a while loop
whose state is at most `max_bytes` as one function, else it dispatches the body's kernels one at a
time. A `lax.scan`'s state holds the whole arrays it slices, so a stacked joint fit's time loop
(every recording's samples) passes a small threshold where one recording's does not.

For each threshold, in a fresh process set up as the CLI starts (one host device per core,
compiled loops; the evaluations on the first device): one SD1 DE run (the paper's setting, 1 run
x 140,000 FEs, search seconds); one evaluation of 70 members on 16 stacked SD1-length recordings
(`StackedJoint`) and on the same 16 as separate scans; 50 generations of CMA-ES's 12 members on
the 476 servo logs of `bench_servo_fleet` (ms a generation, the objective in a `fori_loop`);
the median of `--repeat` calls each.

    python -m experiments.bench_loop_bytes [--bytes 131072 1048576 16777216] [--repeat 20]
"""

import argparse
import json
import os
import platform
import subprocess
import sys

CHILD = """
import json, sys, time
import numpy as np
import dcjax
dcjax.use_host_devices()
dcjax.use_compiled_loops(int(sys.argv[1]))
import jax, jax.numpy as jnp
from dcjax.fitting.planning import plan
from dcjax.simulation.joint import joint_problem, stacked_target
repeat = int(sys.argv[2])

def median(f, *a):
    jax.block_until_ready(f(*a))
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter(); jax.block_until_ready(f(*a)); ts.append(time.perf_counter() - t0)
    return float(np.median(ts))

out = {}
sd1 = dcjax.datasets.load("SD1")
out["SD1 DE run, s"] = dcjax.fit(sd1, params="table4", search=dcjax.Search(runs=1, budget=140_000, seed=0)).timing["run_s"]
truth = sd1.metadata["true_params"]
probs = []
for k in range(16):
    y = np.asarray(dcjax.simulate(dict(truth, Tla=0.005 * (1 + k)), dcjax.make_problem(sd1)))
    probs.append(dcjax.make_problem(sd1.replace(channels={**sd1.channels, "i_a": y[:, 0], "omega": y[:, 1]})))
stacked = jax.tree.map(jnp.asarray, stacked_target(joint_problem(probs)))
x0 = np.array([truth[n] for n in dcjax.DC.names])
x = jnp.asarray(x0 * np.random.default_rng(0).uniform(0.9, 1.1, (70, 7)))
out["16 stacked x 70, ms"] = 1e3 * median(jax.jit(lambda tg, x: tg.objective(x)), stacked, x)
out["16 scans x 70, ms"] = 1e3 * median(jax.jit(lambda x: sum(dcjax.objective(x, p) for p in probs)), x)
from experiments.bench_servo_fleet import BOX, dcjax_case, logs
recs, box, obs = dcjax_case(*logs(476))
servo = jax.tree.map(jnp.asarray, stacked_target(plan("servo", "cma-es", observation=obs).setup(recs, box).target))
lo, hi = np.array([v[0] for v in BOX.values()]), np.array([v[1] for v in BOX.values()])
xs = jnp.asarray(lo + (hi - lo) * np.random.default_rng(0).uniform(0.2, 0.8, (12, 5)))

@jax.jit
def generations(tg, x0):
    return jax.lax.fori_loop(0, 50, lambda i, x: x + 1e-12 * tg.objective(x)[:, None], x0)

out["476 servo logs x 12, ms a generation"] = 1e3 * median(generations, servo, xs) / 50
print(json.dumps(out))
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bytes", type=int, nargs="+", default=[1 << 17, 1 << 20, 1 << 24])
    ap.add_argument("--repeat", type=int, default=20)
    args = ap.parse_args()
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores; median of {args.repeat} calls, a fresh process each")
    rows = {}
    for b in args.bytes:
        p = subprocess.run([sys.executable, "-c", CHILD, str(b), str(args.repeat)], capture_output=True, text=True, check=True,
                           env={**os.environ, "DCJAX_NO_CACHE": "1"})  # fmt: skip
        rows[b] = json.loads(p.stdout.strip().splitlines()[-1])
    names = list(next(iter(rows.values())))
    print(f"{'max_bytes':>10} " + " ".join(f"{n:>38}" for n in names))
    for b, r in rows.items():
        print(f"{b:>10} " + " ".join(f"{r[n]:38.3f}" for n in names), flush=True)


if __name__ == "__main__":
    main()
