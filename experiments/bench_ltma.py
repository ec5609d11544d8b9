"""Memory assistance run times (issue 15): MD1, RK4, ND = 5, Table 8, current limit 11.44 A, 2 runs,
DE/rand/1/exp, for no memory, STMA, LTMA-S2 (linear search) and LTMA with the hash index, at
equal iterations (`--generations 1999`, the paper's Time % convention) or with the CLI's default
(memory runs go on while the budget lasts, up to 20x the iterations). Run times exclude
compilation (every executable is compiled before the timed call).

    python experiments/bench_ltma.py [--generations 1999 | --generations 0]   (0: the CLI default)"""

import argparse

import dcjax

dcjax.use_host_devices()

from dcjax import datasets, identify  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--generations", type=int, default=1999)
    ap.add_argument("--kinds", nargs="*", default=["none", "stma", "ltma-hash", "ltma-s2"])
    args = ap.parse_args()
    rec = datasets.load("MD1")
    gens = args.generations or None
    base = None
    for kind in args.kinds:
        mem = None if kind == "none" else kind
        kw = dict(runs=2, nd=5, bounds="table8", i_limit=11.44, memory=mem, generations=gens)
        identify(rec, **kw)
        r = identify(rec, **kw)
        base = base or r.timing["run_s"]
        dup = "-" if r.duplicates is None else f"{r.duplicates['percent']:.1f} %"
        print(
            f"{kind:10s} run {r.timing['run_s']:7.2f} s  ({r.timing['run_s'] / base:5.2f}x none)  duplicates {dup:>7s}  "
            f"iterations {r.iterations.tolist()}  FEs {r.fes.tolist()}  OF {r.of:.4e}",
            flush=True,
        )


if __name__ == "__main__":
    main()
