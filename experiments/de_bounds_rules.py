"""Which bound handling and initialization reproduce the paper's 50/50 identical DE/rand/1/exp
runs on SD1 (Table 5)? Counts runs with OF <= 1e-15 and runs that end with a parameter stuck on
a bound, for each rule.

    .venv/bin/python experiments/de_bounds_rules.py [--runs 50]
"""

import argparse

import numpy as np

import dcjax
from dcjax import TABLE4, datasets, identify
from dcjax.strategies import DERand1Exp

dcjax.use_host_devices()  # one XLA CPU device per core, before any JAX computation
dcjax.use_compilation_cache()  # executables persist across runs (DCJAX_NO_CACHE=1: off)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--data", default="SD1")
    args = ap.parse_args()
    rec = datasets.load(args.data)
    hi = np.asarray(TABLE4.upper)
    print(f"{args.data}, DE/rand/1/exp, RK4, NP 70, 140,000 FEs, {args.runs} runs")
    print(f"{'bounds rule':12s} {'init':8s} {'OF<=1e-15':>10s} {'at upper bound':>15s} {'worst OF':>10s} {'run s':>6s}")
    for rule in ("redraw", "clip", "midpoint"):
        for init in ("uniform", "lhs"):
            r = identify(rec, method=DERand1Exp(bounds_rule=rule, init_rule=init), runs=args.runs, seed=0)
            at_hi = int(np.sum(np.any(np.isclose(r.run_params, hi, rtol=1e-9) & (r.run_of > 1e-15)[:, None], axis=1)))
            print(
                f"{rule:12s} {init:8s} {int(np.sum(r.run_of <= 1e-15)):>6d}/{args.runs} {at_hi:>15d} {r.run_of.max():10.2e} {r.timing['run_s']:6.1f}"
            )


if __name__ == "__main__":
    main()
