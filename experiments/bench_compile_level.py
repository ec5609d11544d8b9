"""XLA:CPU's LLVM optimisation level for the compiled runs: compile and search time at the default
(3) and at 2 (`dcjax.fitting.runs.QUICK_COMPILE`), and whether both give the same bits. The runs
pick level 2 where a search is short against its compilation (`compiler_options`); this prints
the figures behind that rule.

Each case is fitted at both levels in one process set up as the CLI starts (`use_compiled_loops`,
one device, no compilation cache): `compile` is the engine's own figure (tracing, lowering
and XLA of the whole run; each level compiles afresh), `search` the median of `--repeat` runs of
the compiled program.

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
from dcjax.fitting import runs

dcjax.use_compiled_loops()  # before any JAX computation, as the CLI (no compilation cache)


def cases() -> dict:
    sd1, sd2, md1 = datasets.load("SD1"), datasets.load("SD2"), datasets.load("MD1")
    return {
        "SD1 DE/rand/1/exp, 1 run": lambda: dcjax.fit(sd1, runs=1, budget=140_000, seed=0),
        "SD1 ABC, 1 run": lambda: dcjax.fit(sd1, method="abc", runs=1, budget=140_000, seed=0),
        "SD1 GA, 1 run": lambda: dcjax.fit(sd1, method="ga", runs=1, budget=140_000, seed=0),
        "SD1 TLBO, 1 run": lambda: dcjax.fit(sd1, method="tlbo", runs=1, budget=140_000, seed=0),
        "SD1 CMA-ES, 4 runs": lambda: dcjax.fit(sd1, method="cma-es", runs=4, budget=28_000, seed=0),
        "MD1 table8 RK4 ND 2, 4 runs": lambda: dcjax.fit(
            md1, params="table8", integrator=dcjax.RK4(substeps=2), runs=4, budget=140_000, seed=0
        ),  # fmt: skip
        "SD1+SD2 joint, 4 runs": lambda: dcjax.fit([sd1, sd2], params="table4", runs=4, budget=28_000, seed=0),
        "SD1 LTMA, 4 runs": lambda: dcjax.fit(sd1, params="table4", memory=dcjax.LTMA(), runs=4, budget=28_000, seed=0),
    }


def measure(fit, level: int, repeat: int) -> tuple[float, float, str]:
    runs.compiler_options = lambda work: {"xla_backend_optimization_level": level}
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

    def recorded(work):
        picked.append("2" if rule(work) else "3")
        return rule(work)

    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, 1 XLA device; compile once per level, search: median "
          f"of {args.repeat}")  # fmt: skip
    print(
        f"{'case':<30} {'compile 3':>9} {'compile 2':>9} {'ratio':>6} {'search 3':>9} {'search 2':>9} {'ratio':>6} {'bits':>5} {'rule':>5}"
    )
    for label, fit in cases().items():
        c3, s3, b3 = measure(fit, 3, args.repeat)
        c2, s2, b2 = measure(fit, 2, args.repeat)
        runs.compiler_options = recorded
        fit()
        print(f"{label:<30} {c3:8.2f}s {c2:8.2f}s {c2 / c3:6.2f} {s3:8.3f}s {s2:8.3f}s {s2 / s3:6.2f} {'same' if b3 == b2 else 'DIFF':>5} "
              f"{picked[-1]:>5}", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
