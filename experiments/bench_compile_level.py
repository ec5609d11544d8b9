"""XLA:CPU's compiler options for the compiled runs: compile and search time at XLA's defaults
(LLVM level 3, fusion emitters on), at level 2 (`dcjax.compiling.QUICK`), and at level 2 without
the fusion emitters (`QUICK | LEAN`, what `dcjax.fitting.runs.QUICK_COMPILE` is), and whether each
gives the defaults' bits. One setup's runs pick the last where a search is short against its
compilation (`compiler_options`); this prints the figures behind that rule.

Each case is fitted under each option set in one process set up as the CLI starts
(`use_compiled_loops`, one device, no compilation cache): `compile` is the engine's own figure
(tracing, lowering and XLA of the whole run; each option set compiles afresh), `search` the
median of `--repeat` runs of the compiled program.

    python -m experiments.bench_compile_level [--repeat 5]
"""

import argparse
import hashlib
import os
import platform
import statistics

import numpy as np

import dcjax
from dcjax import datasets
from dcjax.compiling import LEAN, QUICK
from dcjax.fitting import runs

from .bench_servo_fleet import dcjax_case, logs

dcjax.use_compiled_loops()  # before any JAX computation, as the CLI (no compilation cache)


def cases() -> dict:
    sd1, sd2, md1 = datasets.load("SD1"), datasets.load("SD2"), datasets.load("MD1")
    recs, box, servo_obs = dcjax_case(*logs(476))  # bench_servo_fleet's logs: a search between COMPILE_FES / 3 and COMPILE_FES
    servo = (recs, "servo", box)
    return {
        "SD1 DE/rand/1/exp, 1 run": lambda: dcjax.fit(sd1, search=dcjax.Search(runs=1, budget=140_000, seed=0)),
        "SD1 ABC, 1 run": lambda: dcjax.fit(sd1, search=dcjax.Search("abc", runs=1, budget=140_000, seed=0)),
        "SD1 GA, 1 run": lambda: dcjax.fit(sd1, search=dcjax.Search("ga", runs=1, budget=140_000, seed=0)),
        "SD1 TLBO, 1 run": lambda: dcjax.fit(sd1, search=dcjax.Search("tlbo", runs=1, budget=140_000, seed=0)),
        "SD1 CMA-ES, 4 runs": lambda: dcjax.fit(sd1, search=dcjax.Search("cma-es", runs=4, budget=28_000, seed=0)),
        "MD1 table8 RK4 ND 2, 4 runs": lambda: dcjax.fit(
            md1, params="table8", integrator=dcjax.RK4(substeps=2), search=dcjax.Search(runs=4, budget=140_000, seed=0)
        ),  # fmt: skip
        "SD1+SD2 joint, 4 runs": lambda: dcjax.fit([sd1, sd2], params="table4", search=dcjax.Search(runs=4, budget=28_000, seed=0)),
        "SD1 LTMA, 4 runs": lambda: dcjax.fit(
            sd1, params="table4", search=dcjax.Search(runs=4, budget=28_000, seed=0, memory=dcjax.LTMA())
        ),
        "SD1 RK4 ND 8, 1 run": lambda: dcjax.fit(
            sd1, params="table4", integrator=dcjax.RK4(substeps=8), search=dcjax.Search(runs=1, budget=140_000, seed=0)
        ),
        "476 servo logs CMA-ES, 1 run": lambda: dcjax.fit(
            *servo, "cma-es", observation=servo_obs, search=dcjax.Search(runs=1, budget=2_000, seed=0)
        ),
    }


OPTIONS = {"default": {}, "level 2": QUICK, "level 2 lean": QUICK | LEAN}


def measure(fit, options: dict, repeat: int) -> tuple[float, float, str]:
    runs.compiler_options = lambda work, plain=True: options
    runs.EXECUTABLES.clear()
    first = fit()
    search = statistics.median([fit().timing["run_s"] for _ in range(repeat)])
    bits = hashlib.sha256(np.asarray(first.run_of).tobytes() + np.asarray(first.run_params).tobytes()).hexdigest()[:12]
    return first.timing["compile_s"], search, bits


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    rule, picked = runs.compiler_options, []

    def recorded(work, plain=True):
        options = rule(work, plain)
        picked.append("default" if options is None else "level 2 lean" if "xla_cpu_use_fusion_emitters" in options else "level 2")
        return options

    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, 1 XLA device; compile once per option set, search: "
          f"median of {args.repeat}; ratios and bits against XLA's defaults")  # fmt: skip
    head = f"{'case':<30}" + "".join(f" {'compile ' + k:>15} {'search ' + k:>14} {'bits':>5}" for k in OPTIONS)
    print(head + f" {'rule':>13}")
    for label, fit in cases().items():
        row, base = f"{label:<30}", None
        for options in OPTIONS.values():
            c, s, b = measure(fit, options, args.repeat)
            base = base or (c, s, b)
            row += f" {c:6.2f}s ({c / base[0]:4.2f}) {s:6.3f}s ({s / base[1]:4.2f}) {'same' if b == base[2] else 'DIFF':>5}"
        runs.compiler_options = recorded
        fit()
        print(row + f" {picked[-1]:>13}", flush=True)


if __name__ == "__main__":
    main()
