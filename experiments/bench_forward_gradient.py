"""The prediction-error polish (BFGS on the EKF's likelihood, `dcjax.fitting.polish`) with its
gradient in reverse mode against forward mode (`dcjax.gradients.forward_gradient`): its compile
and run time (the polish's own figure, `FitResult.polish["time_s"]`, compile included), its steps
and the objective it ends at, per record length. `dcjax.gradients.forward_mode` chooses
forward mode below `FORWARD_WORK` (free parameters x integration steps an evaluation).

Each case is fitted in a fresh process per mode (each compiles afresh; no compilation cache), on
`experiments.bench_prediction`'s records (the paper's motor under a disturbance, NumPy
Euler-Maruyama), DE 1 run x 3000 FEs from the same seed, then the polish.

    python -m experiments.bench_forward_gradient [--samples 500 2000 8000]
"""

import argparse
import json
import subprocess
import sys

CHILD = """
import json, sys
import dcjax
dcjax.use_compiled_loops()
from dcjax import gradients
from experiments.bench_prediction import record
n, mode = int(sys.argv[1]), sys.argv[2]
gradients.FORWARD_WORK = float("inf") if mode == "forward" else 0.0
rec = record(0, n)
obs = dcjax.Observation(hold={"u_a": "zoh"}, focus="prediction", initial={"i_a": 0.0, "omega": 0.0})
res = dcjax.fit(rec, params="table4", search=dcjax.Search(runs=1, budget=3000, seed=0, polish=True), observation=obs)
p = res.polish
print(json.dumps({"time_s": p["time_s"], "steps": p["steps"][0], "of": p["of_after"][0], "free": len(res.best_values)}))
"""


def run(n: int, mode: str) -> dict:
    env = {"DCJAX_NO_CACHE": "1"}
    import os

    out = subprocess.run([sys.executable, "-c", CHILD, str(n), mode], capture_output=True, text=True, env={**os.environ, **env}, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--samples", type=int, nargs="+", default=[500, 2000, 8000])
    a = ap.parse_args()
    print(
        f"{'samples':>8} {'P x samples':>10} {'reverse s':>10} {'forward s':>10} {'ratio':>6} {'steps rev/fwd':>14} {'OF reverse':>22} {'OF forward':>22}"
    )
    for n in a.samples:
        rev, fwd = run(n, "reverse"), run(n, "forward")
        print(
            f"{n:>8} {fwd['free'] * n:>10} {rev['time_s']:>10.2f} {fwd['time_s']:>10.2f} {fwd['time_s'] / rev['time_s']:>6.2f}"
            f" {rev['steps']:>6}/{fwd['steps']:<7} {rev['of']:>22.16g} {fwd['of']:>22.16g}",
            flush=True,
        )


if __name__ == "__main__":
    main()
