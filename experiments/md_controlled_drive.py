"""Controlled drive on the emulated MD1–MD4 analogues (the paper's MD data are not public):
DE/rand/1/exp, 50 runs, bounds of Table 8, with EM, EM5, EM10, RK, RK5, RK10 (Tables 9–17 and
24–27), stationary points with the RK fits (eq. 25–26, Table 18) and cross-validation of the RK
fits of MD1–MD3 (Fig. 12).

    .venv/bin/python experiments/md_controlled_drive.py [--runs 50] [--store experiments/results/md.jsonl]

Each finished (data set, integrator, ND) is appended to the store at once; a restart skips it."""

import argparse
import time

import numpy as np

import dcjax
from dcjax import PARAM_NAMES, identify, load_csv
from dcjax.datasets import DATA_DIR
from dcjax.validation import cross_validation, stationary_check

dcjax.use_host_devices()  # one XLA CPU device per core, before any JAX computation
dcjax.use_compilation_cache()  # executables persist across runs (DCJAX_NO_CACHE=1: off)

try:
    from runstore import RunStore
except ImportError:
    from experiments.runstore import RunStore

VARIANTS = [("EM", "euler", 1), ("EM5", "euler", 5), ("EM10", "euler", 10), ("RK", "rk4", 1), ("RK5", "rk4", 5), ("RK10", "rk4", 10)]
TABLE18_TIMES = {"MD1": [2, 4, 6, 8, 10], "MD2": [2, 4, 6, 8, 10], "MD3": [2, 4, 6, 7, 8], "MD4": [4, 6, 8, 10, 12]}
# Paper Table 24 (MD1, DE/rand/1/exp, means): Ra and Tla per variant; known Ra 5.66, Tla ~0.9.
PAPER_T24 = {
    "EM": (11.56, 3.13e-16),
    "EM5": (5.63, 0.796),
    "EM10": (4.94, 0.800),
    "RK": (5.06, 0.799),
    "RK5": (4.25, 0.803),
    "RK10": (4.25, 0.803),
}


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--store", default="experiments/results/md.jsonl")
    args = ap.parse_args()
    store = RunStore(args.store)
    recs = {n: load_csv(DATA_DIR / f"{n}.csv") for n in ("MD1", "MD2", "MD3", "MD4")}
    t_start = time.perf_counter()
    for name, rec in recs.items():
        for label, integ, nd in VARIANTS:
            key = f"{name}/{label}/runs={args.runs}/seed={args.seed}"
            if key in store.done():
                continue
            r = identify(rec, method="de-rand-1-exp", integrator=integ, nd=nd, bounds="table8", runs=args.runs, seed=args.seed)
            store.append(
                {
                    "key": key,
                    "data": name,
                    "variant": label,
                    "run_of": r.run_of.tolist(),
                    "run_params": r.run_params.tolist(),
                    "timing": r.timing,
                }
            )
            print(f"done {key}: run {r.timing['run_s']:.1f} s", flush=True)
    res = {(r["data"], r["variant"]): r for r in store.records() if r["key"].endswith(f"runs={args.runs}/seed={args.seed}")}

    print(f"\nTables 24-27 analogue ({args.runs} runs, DE/rand/1/exp, Table 8 bounds). Mean parameters; true values last.")
    for name, rec in recs.items():
        truth = rec.metadata["true_params"]
        print(f"\n{name}  ({len(rec)} points)")
        print(f"  {'':5s} {'OF best':>10s} {'OF SD':>9s} " + " ".join(f"{p:>10s}" for p in PARAM_NAMES))
        for label, _, _ in VARIANTS:
            r = res[(name, label)]
            f = np.asarray(r["run_of"])
            m = np.mean(r["run_params"], axis=0)
            print(f"  {label:5s} {f.min():10.4e} {f.std():9.2e} " + " ".join(f"{v:10.4g}" for v in m))
        print(f"  {'true':5s} {'':10s} {'':9s} " + " ".join(f"{truth[p]:10.4g}" for p in PARAM_NAMES))
        print(
            "  rel. error of RK:  "
            + ", ".join(
                f"{p} {100 * (np.mean(res[(name, 'RK')]['run_params'], axis=0)[k] - truth[p]) / truth[p]:+.1f}%"
                for k, p in enumerate(PARAM_NAMES)
                if p in ("Ra", "cm", "J", "Tla")
            )
        )
    print("\nMD1 beside paper Table 24 (Ra, Tla):")
    for label, _, _ in VARIANTS:
        m = np.mean(res[("MD1", label)]["run_params"], axis=0)
        pr, pt = PAPER_T24[label]
        print(f"  {label:5s} dcjax Ra {m[0]:6.2f} Tla {m[4]:9.3g}   paper Ra {pr:6.2f} Tla {pt:9.3g}")

    def rk_fit(name):
        return dict(zip(PARAM_NAMES, np.mean(res[(name, "RK")]["run_params"], axis=0)))

    print("\nTable 18 analogue (stationary points, RK fits):")
    for name, rec in recs.items():
        for row in stationary_check(rk_fit(name), rec, times=TABLE18_TIMES[name]):
            print(
                f"  {name} t={row['t']:6.2f} i={row['i_meas']:6.3f} w={row['w_meas']:6.1f} u={row['u_meas']:6.1f} "
                f"u_calc={row['u_calc']:6.1f} ({row['u_dev_pct']:4.1f} %) i_calc={row['i_calc']:6.3f} ({row['i_dev_pct']:5.1f} %)"
            )

    names = ["MD1", "MD2", "MD3"]
    rn, fn, m = cross_validation({n: rk_fit(n) for n in names}, {n: recs[n] for n in names})
    print("\nFig. 12 analogue: OF of recording (row) with the RK fit of (column); ratio to the diagonal")
    print("        " + " ".join(f"{'R_' + n:>12s}" for n in fn))
    for a, r in enumerate(rn):
        print(f"  {r:5s} " + " ".join(f"{m[a, b]:9.3e}({m[a, b] / m[a, a]:3.1f})" for b in range(len(fn))))
    print(f"\nwall time this invocation: {time.perf_counter() - t_start:.0f} s")


if __name__ == "__main__":
    main()
