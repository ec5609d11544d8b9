"""The searches a fit gets when none is asked for (issue: searches that stop when they are done,
item 2): each candidate default, with the stopping rule `dcjax.fitting.search.DEFAULT_STOP`, against
the defaults before it (fixed budgets), on the real and real-shaped cases.

Cases:
- servo: 476 servo logs (`bench_servo_fleet`'s, simulated by its NumPy map, not by dcjax), BAM's
  loss, its box: a joint fit of many recordings (`Search.many()`);
- dc128: the SD1 motor under 128 stepped voltages, simulated by `dcjax.io.numpy_simulator`, 0.5 %
  noise, `auto` ranges (`bench_many`'s): a joint fit of many recordings;
- emps: the real EMPS axis, closed loop (`bench_methods_real`'s, where the data are present): one
  recording (`Search.own()`);
- sd1noise: SD1's input and truth, simulated by the NumPy reference with 0.5 % noise, no sidecar:
  one's own recording (`Search.own()`);
- pmsm: the PMSM guide's kind of fit, three recordings from the NumPy reference
  (`tests/test_initial_noise.recordings`, 0.5 % noise), a short joint fit (`Search.own()`).

For each candidate: the whole fit's wall time (setup, compilation, search), the FEs of its runs,
how they ended, the OF, its relative gap to the best OF any row found, and the seconds from the
fit's start to its first iteration within `--tol` of that best (the search's iterations at their
measured rate). `default` is `dcjax.fit(search=None)`: what a user gets.

    python -m experiments.bench_defaults [--cases servo dc128 emps sd1noise pmsm] [--candidates ...]
"""

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

import dcjax
from dcjax.io.numpy_simulator import simulate_numpy

from .bench_many import curve, dc_case, emps_case, servo_case

STOP = dcjax.fitting.search.DEFAULT_STOP
CANDIDATES = {  # built when run (a CMA-ES strategy starts JAX, before `use_host_devices` could)
    "default": lambda many: None,  # dcjax.fit(search=None)
    "before": lambda many: dcjax.Search("de-best-1-bin", runs=2, budget=20_000) if many else dcjax.Search.paper(),  # stop 58's
    "cma-es x1 stop": lambda many: dcjax.Search("cma-es", runs=1, budget=20_000, stop=STOP),
    "cma-es x2 stop": lambda many: dcjax.Search("cma-es", runs=2, budget=20_000, stop=STOP),
    "de-best-1-bin x2 stop": lambda many: dcjax.Search("de-best-1-bin", runs=2, budget=20_000, stop=STOP),
    "paper stop": lambda many: None if many else dcjax.Search.own(),
}


def sd1_noise_case(seed: int = 0) -> dict:
    sd1 = dcjax.datasets.load("SD1")
    truth = sd1.metadata["true_params"]
    x = np.array([truth[p] for p in dcjax.DC.names])
    y = simulate_numpy(x, sd1.t, sd1.u_a)
    y = y + 0.005 * np.max(np.abs(y), axis=0) * np.random.default_rng(seed).standard_normal(y.shape)
    rec = dcjax.Recording(t=sd1.t, u_a=sd1.u_a, i_a=y[:, 0], omega=y[:, 1], name="own")
    return dict(data=rec, model="dc", params="table4", observation=None)


def pmsm_case() -> dict:
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))  # the reference simulator and the test's data
    import test_initial_noise

    return dict(data=test_initial_noise.recordings(0.005), model="pmsm", params=None, observation=None)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=["servo", "dc128", "emps", "sd1noise", "pmsm"])
    ap.add_argument("--candidates", nargs="+", default=list(CANDIDATES), choices=list(CANDIDATES))
    ap.add_argument("--tol", type=float, default=1e-3)
    ap.add_argument("--emps", default=str(Path(__file__).resolve().parents[2] / "shared" / "real" / "emps"))
    args = ap.parse_args()
    dcjax.use_host_devices()  # as the CLI starts
    dcjax.use_compiled_loops()
    makers = {"servo": servo_case, "dc128": dc_case, "emps": lambda: emps_case(Path(args.emps)), "sd1noise": sd1_noise_case,
              "pmsm": pmsm_case}  # fmt: skip
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores; the default's rule {STOP}; seed 0", flush=True)
    for name in args.cases:
        case = makers[name]()
        if case is None:
            print(f"\n{name}: no data")
            continue
        many = isinstance(case["data"], list) and sum(len(r) for r in case["data"]) >= dcjax.fitting.search.MANY_STEPS
        print(f"\n{name}: {len(case['data']) if isinstance(case['data'], list) else 1} recording(s)", flush=True)
        print(f"{'search':<24} {'wall':>7} {'FEs a run':>18} {'ended':>10} {'OF':>13} {'gap':>9} {'to 1e-3':>8}", flush=True)
        rows = []
        for cand in args.candidates:
            if cand == "paper stop" and many:
                continue
            search = CANDIDATES[cand](many)
            t0 = time.perf_counter()
            res = dcjax.fit(case["data"], case["model"], case["params"], search=search, observation=case["observation"])
            wall = time.perf_counter() - t0
            rows.append((cand, res, wall, *curve(res, wall)))
            print(f"  ({cand}: {res.search.method} x{res.search.runs}, {wall:.1f} s)", flush=True)
        best_of = min(float(r.of) for _, r, *_ in rows)
        for cand, res, wall, at, best in rows:
            fes = np.asarray(res.fes)
            ended = sorted({s.value for s in res.run_status})
            reached = np.flatnonzero(best <= best_of * (1 + args.tol))
            to = f"{at[reached[0]]:7.1f}s" if reached.size else f"{'-':>8}"
            span = f"{fes.min():,}" if fes.min() == fes.max() else f"{fes.min():,}..{fes.max():,}"
            print(f"{cand:<24} {wall:6.1f}s {span:>18} {'/'.join(ended):>10} {res.of:13.6e} {(res.of - best_of) / abs(best_of):9.1e} {to}",
                  flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
