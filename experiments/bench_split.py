"""One run of a joint fit on every core (issue: speed at scale, item 3): the recordings split over
the host's devices (`dcjax.simulation.joint.SplitJoint`) against the whole run on one device, for
joint fits of growing size; the crossover sets `dcjax.fitting.runs.SPLIT_STEPS`.

Data: the servo logs of `experiments.bench_servo_fleet` (its NumPy map, 700 samples at 10 ms),
the first N of them; the fit as that bench's (`dcjax.Servo`, l1 loss, not normalised), one run of
CMA-ES (population 12) and of DE/rand/1/exp (70), `--budget` FEs each. Each case is fitted once
with the split forbidden (`SPLIT_STEPS` set above any fit) and once allowed (0), twice each,
alternating; the table gives the search seconds (the compiled run, without its compilation) and
their ratio, and whether the two fits reach the same OF to 1e-9.

    python -m experiments.bench_split [--logs 4 16 64 476] [--budget 1200]
"""

import argparse
import os
import platform

import dcjax
import dcjax.fitting.runs as runs_module
from experiments.bench_servo_fleet import SAMPLES, dcjax_fit, logs

dcjax.use_host_devices()  # as the CLI starts: one device per core
dcjax.use_compiled_loops()


def fit(goal, const, q, method: str, budget: int, split: bool):
    runs_module.SPLIT_STEPS = 0 if split else 1 << 62
    res, _ = dcjax_fit(goal, const, q, method, 1, budget, 0)
    return res.timing["run_s"], res.timing["devices"], res.of


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", type=int, nargs="+", default=[4, 16, 64, 476])
    ap.add_argument("--budget", type=int, default=1200)
    ap.add_argument("--methods", nargs="+", default=["cma-es", "de-rand-1-exp"])
    args = ap.parse_args()
    keep = runs_module.SPLIT_STEPS
    goal, const, q = logs(max(args.logs), 0)
    import jax

    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, {len(jax.devices())} devices; servo logs x {SAMPLES} "
          f"samples, 1 run, {args.budget} FEs (SPLIT_STEPS now {keep})")  # fmt: skip
    print(f"{'method':<14} {'logs':>5} {'steps/FE':>9} {'one device':>11} {'split':>9} {'ratio':>6} {'same OF':>8}")
    for method in args.methods:
        for n in args.logs:
            one, both = [], []
            for _ in range(2):
                t1, d1, f1 = fit(goal[:n], const[:n], q[:n], args.budget, False, search=dcjax.Search(method))
                t2, d2, f2 = fit(goal[:n], const[:n], q[:n], args.budget, True, search=dcjax.Search(method))
                one.append(t1)
                both.append(t2)
            same = abs(f1 - f2) <= 1e-9 * abs(f1)
            print(f"{method:<14} {n:5d} {n * SAMPLES:9d} {min(one):10.3f}s {min(both):8.3f}s {min(one) / min(both):5.2f}x "
                  f"{'yes' if same else 'no':>8}  ({d1} / {d2} devices)", flush=True)  # fmt: skip
    runs_module.SPLIT_STEPS = keep


if __name__ == "__main__":
    main()
