"""The methods at equal wall time on many-recording fits (issue: speed at scale, item 4): what a
joint fit of hundreds of recordings should search with when the command line is given no
`--method`, `--runs` or `--budget` (`dcjax.Search.for_steps`).

Cases (each method one run unless named x2, seed 0; with fewer runs than devices a run of a large
joint fit splits its recordings over its share of them):
- 476 servo logs: `bench_servo_fleet`'s logs (its NumPy map, not dcjax's), BAM's loss, its box;
- 128 DC recordings: the SD1 motor (Table 4's truth) under 128 stepped voltages (2 to 5 levels in
  20..220 V), 501 samples at 0.1 ms, simulated by `dcjax.io.numpy_simulator` (RK4), 0.5 % Gaussian
  noise of each channel's peak; `auto` ranges (the command line's default), the sse of eq. 24;
- EMPS (real, one recording): `bench_methods_real`'s closed-loop case, where the data are present.

For each method the best OF at a quarter, half and all of the case's wall time `T` (from the
fit's start: setup and compilation included; the search's iterations at their measured rate), and
the seconds and FEs a run to its first iteration within `--tol` of the best OF any method found.

    python -m experiments.bench_many [--cases servo dc emps] [--seconds 12]
"""

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

import dcjax
from dcjax.io.numpy_simulator import simulate_numpy

from .bench_servo_fleet import dcjax_case, logs

METHODS = ("cma-es", "cma-es x2", "de-best-1-bin", "de-rand-1-exp", "tlbo", "ga", "abc")


def servo_case(n: int = 476) -> dict:
    recs, box, obs = dcjax_case(*logs(n))
    return dict(data=recs, model="servo", params=box, observation=obs)


def dc_recordings(n: int = 128, noise: float = 0.005, seed: int = 0) -> list[dcjax.Recording]:
    """The SD1 motor (Table 4's truth) under `n` stepped voltages (2 to 5 levels in 20..220 V, at
    rest for 2 ms), 501 samples at 0.1 ms, simulated by the NumPy reference (RK4), Gaussian noise
    of `noise` of each channel's peak."""
    rng = np.random.default_rng(seed)
    truth = dcjax.datasets.true_params("SD1")
    x = np.array([truth[p] for p in dcjax.DC.names])
    t = 1e-4 * np.arange(501)
    recs = []
    for k in range(n):
        levels = rng.uniform(20.0, 220.0, rng.integers(2, 6))
        u = np.repeat(levels, -(-len(t) // len(levels)))[: len(t)] * (t >= 0.002)
        y = simulate_numpy(x, t, u)
        y = y + noise * np.max(np.abs(y), axis=0) * rng.standard_normal(y.shape)
        recs.append(dcjax.Recording(t=t, u_a=u, i_a=y[:, 0], omega=y[:, 1], name=f"run{k}"))
    return recs


def dc_case(n: int = 128, seed: int = 0) -> dict:
    return dict(data=dc_recordings(n, seed=seed), model="dc", params="auto", observation=None)


def emps_case(emps: Path) -> dict | None:
    if not (emps / "DATA_EMPS.mat").is_file():
        return None
    from .bench_methods_real import cases

    case = cases(emps)["EMPS closed loop (real)"]
    return dict(case, observation=None)


def curve(res, wall: float):
    """(seconds from the fit's start, best OF) after each iteration of each run (the runs ran side by side)."""
    h = np.asarray(res.history, float)
    iters = np.sum(np.isfinite(h), axis=1).max()
    per = res.timing["run_s"] * max(1, res.timing.get("batch", 1)) / max(1, iters)
    start = wall - per * iters
    best = np.fmin.accumulate(np.nanmin(np.where(np.isfinite(h), h, np.inf), axis=0))[:iters]
    return start + per * np.arange(1, iters + 1), best


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=["servo", "dc", "emps"])
    ap.add_argument("--seconds", type=float, default=12.0, help="T: the wall time every method is given on every case")
    ap.add_argument("--methods", nargs="+", default=list(METHODS))
    ap.add_argument("--tol", type=float, default=1e-3, help="relative: 'to best' is the first iteration within this of the case's best OF")
    ap.add_argument("--emps", default=str(Path(__file__).resolve().parents[2] / "shared" / "real" / "emps"))
    args = ap.parse_args()
    dcjax.use_host_devices()  # as the CLI starts
    dcjax.use_compiled_loops()
    makers = {"servo": servo_case, "dc": dc_case, "emps": lambda: emps_case(Path(args.emps))}
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores; T = {args.seconds:g} s; seed 0")
    for name in args.cases:
        case = makers[name]()
        if case is None:
            print(f"\n{name}: no data")
            continue
        n = len(case["data"]) if isinstance(case["data"], list) else 1
        T = args.seconds
        print(f"\n{name}: {n} recording(s); best OF at T/4, T/2, T (from the fit's start); FEs a run")
        probe = dcjax.fit(
            case["data"], case["model"], case["params"], search=dcjax.Search("cma-es", runs=1, budget=600), observation=case["observation"]
        )
        budget = int(2 * T * 600 / probe.timing["run_s"])  # FEs a run: CMA-ES's search alone would fill 2 T
        print(f"{'method':<15} {'T/4':>11} {'T/2':>11} {'T':>11} {'compile':>8} {'FEs':>8} {'to best':>8} {'FEs':>8}")
        rows = []
        for spec in args.methods:
            method, _, x2 = spec.partition(" x")
            runs = int(x2) if x2 else 1
            t0 = time.perf_counter()
            res = dcjax.fit(case["data"], case["model"], case["params"], search=dcjax.Search(method, runs=runs, budget=budget, seed=0), observation=case["observation"])  # fmt: skip
            rows.append((spec, res, *curve(res, time.perf_counter() - t0)))
        best_of = min(float(np.min(b)) for *_, b in rows)
        for spec, res, at, best in rows:
            marks = [best[at <= f * T][-1] if np.any(at <= f * T) else np.nan for f in (0.25, 0.5, 1.0)]
            reached = np.flatnonzero(best <= best_of * (1 + args.tol))
            pop = int(np.max(res.fes)) / len(best)  # FEs an iteration
            to = f"{at[reached[0]]:7.1f}s {int(pop * (reached[0] + 1)):8d}" if reached.size else f"{'-':>8} {'-':>8}"
            short = " (ended before T)" if at[-1] < T else ""
            print(f"{spec:<15} " + " ".join(f"{v:11.4e}" for v in marks) + f" {res.timing['compile_s']:7.1f}s {int(np.max(res.fes)):8d} {to}{short}",
                  flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
