"""The design optimizer's program compiled with and without XLA:CPU's small-while-loop hoisting
(a small loop compiled as one function, the threshold `use_compiled_loops` raises): the first
call (compile and optimize) and a second (optimize only) of `design_input`, for the built-in PMSM
(100 samples, two inputs) and the paper's motor (SD1's values, 500 samples), at a test's size
(2 starts x 5 steps) and at the defaults (8 x 300). `dcjax.analysis.design.UNHOISTED_WORK` is
the rule these figures set: a design of fewer starts x steps x samples compiles without it.

    .venv/bin/python -m experiments.bench_design_compile
"""

import platform
import time

import dcjax
from dcjax import datasets
from dcjax.analysis import design

dcjax.use_host_devices()
dcjax.use_compiled_loops()  # as the CLI (no compilation cache)

PMSM = dict(Rs=0.5, Ld=1.0e-3, Lq=1.5e-3, psi_m=0.05, J=1e-4, B=2e-3)
CASES = {
    "PMSM": lambda starts, steps: design.design_input(
        "pmsm",
        PMSM,
        duration=0.01,
        dt=1e-4,
        u_range={"ud": (-2.0, 2.0), "uq": (-6.0, 6.0)},
        given={"pp": 4.0, "Tl": 0.02},
        starts=starts,
        steps=steps,
    ),  # fmt: skip
    "SD1": lambda starts, steps: design.design_input(
        "dc", dict(datasets.true_params("SD1")), duration=0.05, dt=1e-4, u_range=(0.0, 220.0), hold=2.5e-3, starts=starts, steps=steps
    ),
}
SIZES = {"test size": (2, 5), "defaults": (8, 300)}


def timed(case, starts: int, steps: int) -> float:
    t0 = time.perf_counter()
    case(starts, steps)
    return time.perf_counter() - t0


def main():
    print(f"{platform.processor() or platform.machine()}, {dcjax.__version__}; seconds: first call (compile + optimize), second call")
    print(f"{'case':>6} {'size':>10} {'work':>9} {'hoisted':>15} {'not hoisted':>15}")
    for name, case in CASES.items():
        for size, (starts, steps) in SIZES.items():
            row = []
            for rule in (0, float("inf")):  # every design hoisted, none hoisted
                design.UNHOISTED_WORK = rule
                design._optimize.clear_cache()  # pyright: ignore[reportFunctionMemberAccess]
                design._optimize_unhoisted.clear_cache()  # pyright: ignore[reportFunctionMemberAccess]
                first = timed(case, starts, steps)
                second = timed(case, starts, steps)
                row.append(f"{first:6.2f} {second:6.2f}")
            n = 101 if name == "PMSM" else 501
            print(f"{name:>6} {size:>10} {starts * steps * n:9.1e} {row[0]:>15} {row[1]:>15}")


if __name__ == "__main__":
    main()
