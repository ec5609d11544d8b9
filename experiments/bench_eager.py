"""Eager calls of the simulation and the objective (`dcjax.compiling.compiled_when_eager`): a
notebook's `dcjax.simulate(params, recording)` or `objective(x, problem)` compiled as one program,
against the same functions run operation by operation (what they did before: their undecorated
bodies, `__wrapped__`). Each variant in a fresh process (the first call's compilations are not
shared), the compilation cache off; the first call, then the median of `--repeat` calls.

    python -m experiments.bench_eager [--repeat 20]
"""

import argparse
import json
import os
import subprocess
import sys

CODE = """
import json, sys, time
import numpy as np
import dcjax
from dcjax.io import datasets
from dcjax.simulation import objectives as O
from dcjax.simulation.problem import make_problem

eager = sys.argv[1] == "eager"
simulate = O._simulate.__wrapped__ if eager else O._simulate
objective = O._objective.__wrapped__ if eager else O._objective
rec = datasets.load("SD1")
truth = datasets.true_params("SD1")
model = dcjax.DC()
problem = make_problem(rec)
x = model.as_array(truth)
pop = x * (1 + 0.01 * np.random.default_rng(0).standard_normal((64, x.shape[0])))
out = {}
for name, call in (("simulate", lambda: simulate(x, problem, None)), ("objective of 64", lambda: objective(pop, problem, None))):
    t0 = time.perf_counter(); call().block_until_ready(); first = time.perf_counter() - t0
    times = []
    for _ in range(int(sys.argv[2])):
        t0 = time.perf_counter(); call().block_until_ready(); times.append(time.perf_counter() - t0)
    out[name] = (first, float(np.median(times)))
print(json.dumps(out))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=20)
    a = ap.parse_args()
    env = dict(os.environ, DCJAX_NO_CACHE="1")
    rows = {}
    for variant in ("eager", "compiled"):
        run = subprocess.run([sys.executable, "-c", CODE, variant, str(a.repeat)], capture_output=True, text=True, env=env, check=True)
        rows[variant] = json.loads(run.stdout.strip().splitlines()[-1])
    print(f"SD1 (the paper's data), one process per variant, first call / median of {a.repeat}:")
    for name in rows["eager"]:
        (f0, m0), (f1, m1) = rows["eager"][name], rows["compiled"][name]
        print(f"  {name:<16} op by op {f0 * 1e3:8.1f} / {m0 * 1e3:7.2f} ms   one program {f1 * 1e3:8.1f} / {m1 * 1e3:7.2f} ms"
              f"   first {f0 / f1:4.1f}x, again {m0 / m1:5.1f}x faster")  # fmt: skip


if __name__ == "__main__":
    main()
