"""Issue 6 on the emulated MD analogues: uncertainty and identifiability of each RK fit
(DE/rand/1/exp + LM polish), and a joint fit of MD1 + MD2 + MD3 against the separate fits
(paper Section 4.2.5: one drive, one parameter set).

    .venv/bin/python experiments/md_uncertainty_joint.py [--runs 10] [--nd 1]
"""

import argparse

import numpy as np

import dcjax
from dcjax import PARAM_NAMES, identify, load_csv
from dcjax.datasets import DATA_DIR
from dcjax.uncertainty import consistency

dcjax.use_host_devices()  # one XLA CPU device per core, before any JAX computation
dcjax.use_compilation_cache()  # executables persist across runs (DCJAX_NO_CACHE=1: off)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--nd", type=int, default=1)
    args = ap.parse_args()
    recs = {n: load_csv(DATA_DIR / f"{n}.csv") for n in ("MD1", "MD2", "MD3", "MD4")}
    fits, unc = {}, {}
    for name, rec in recs.items():
        r = identify(rec, bounds="table8", nd=args.nd, runs=args.runs, seed=0, polish=True)
        fits[name], unc[name] = r, r.uncertainty()
        print(f"\n{name} (RK{args.nd if args.nd > 1 else ''}, OF {r.of:.4e}); true: {rec.metadata['true_params']}")
        print(unc[name].table())
    print("\nConsistency of the separate fits of MD1-MD3 (one drive, no load):")
    for p, c in consistency({n: unc[n] for n in ("MD1", "MD2", "MD3")}).items():
        z = "" if c["max_z"] is None else f", max z {c['max_z']:.1f}"
        print(f"  {p:4s} values {np.round(c['values'], 4).tolist()} spread {100 * c['spread']:.0f} %{z}: {c['verdict']}")
    joint = identify([recs[n] for n in ("MD1", "MD2", "MD3")], bounds="table8", nd=args.nd, runs=args.runs, seed=0, polish=True)
    print(f"\nJoint MD1 + MD2 + MD3 (mean OF {joint.of:.4e})")
    print(joint.uncertainty().table())
    truth = recs["MD1"].metadata["true_params"]
    print("\nSeparate vs joint (relative error to the emulator's true value; Tlb, Tlc absolute):")
    print(f"  {'':6s} " + " ".join(f"{p:>9s}" for p in PARAM_NAMES))
    for label, params in [(n, fits[n].params) for n in ("MD1", "MD2", "MD3")] + [("joint", joint.params)]:
        cells = []
        for p in PARAM_NAMES:
            cells.append(f"{params[p]:9.2e}" if p in ("Tlb", "Tlc") else f"{100 * (params[p] / truth[p] - 1):+8.1f}%")
        print(f"  {label:6s} " + " ".join(cells))
    la = np.array([fits[n].params["La"] for n in ("MD1", "MD2", "MD3")])
    print(f"\nLa over MD1-MD3: {la.round(3).tolist()} (spread {100 * (la.max() - la.min()) / la.mean():.0f} % of the mean)")


if __name__ == "__main__":
    main()
