"""Memory assistance run times (issue 15): MD1, RK4, ND = 5, Table 8, current limit 11.44 A, 2 runs,
DE/rand/1/exp, for no memory, STMA, LTMA with the hash index and the paper's linear LTMA-S2 and
LTMA-S1, at the paper's 2000 iterations (the default with or without memory). Run times exclude
compilation (every executable is compiled before the timed call).

    python -m experiments.bench_ltma [--runs 2] [--kinds none stma ltma-hash ltma-s2 ltma-s1]"""

import argparse

import dcjax

dcjax.use_host_devices()
dcjax.use_compiled_loops()

from dcjax import (  # noqa: E402
    MEMORIES,
    RK4,
    datasets,
    fit,
)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--kinds", nargs="*", default=["none", "stma", "ltma-hash", "ltma-s2", "ltma-s1"])
    args = ap.parse_args()
    rec = datasets.load("MD1")
    base = None
    for kind in args.kinds:
        mem = None if kind == "none" else MEMORIES[kind]
        kw = dict(params="table8", integrator=RK4(substeps=5), runs=args.runs, memory=mem)
        fit(rec.replace(limit=11.44), **kw)  # compiles
        r = fit(rec.replace(limit=11.44), **kw)
        base = base or r.timing["run_s"]
        dup = "-" if r.duplicates is None else f"{r.duplicates['percent']:.1f} %"
        print(
            f"{kind:10s} run {r.timing['run_s']:7.2f} s  ({r.timing['run_s'] / base:5.2f}x none)  duplicates {dup:>7s}  "
            f"iterations {r.iterations.tolist()}  FEs {r.fes.tolist()}  OF {r.of:.4e}",
            flush=True,
        )


if __name__ == "__main__":
    main()
