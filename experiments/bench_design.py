"""Does a designed input help, in fact and not only in the prediction? (issue: optimal input
design). A known motor is simulated (dcjax.io.numpy_simulator: the NumPy RK4, not dcjax's integrator; 10
sub-steps for SD1, 1 for the current-limited MD drive, whose clamp acts after every sub-step, so
another sub-step count would be a model error common to every input) under
the designed input and under the paper-style 220 V step of the same length, range and sample
rate (and the hand-made 20 ms-on coast-down), 1 % noise is added (of each channel's peak under
the step; the same sensor noise for every input), and each is refitted (DE/rand/1/exp + LM polish)
for several noise seeds; the table gives the mean actual relative error per parameter beside the
predicted relative standard error. The same on an emulated MD drive with its current limit.

    .venv/bin/python -m experiments.bench_design [--seeds 5] [--runs 4] [--predict-only]

It first designs, in the prediction only, a test that must beat both the coast-down and the step in
J, Tla, Tlb and Tlc (`baselines=`).
"""

import argparse
import time

import numpy as np

import dcjax
from dcjax import Recording, datasets
from dcjax.analysis.design import design_input, evaluate_input
from dcjax.io.numpy_simulator import simulate_numpy

dcjax.use_host_devices()
dcjax.use_compiled_loops()

NAMES = dcjax.DC.names


def measured(x, t, u, sigma, seed, i_limit, nd):
    y = simulate_numpy(x, t, u, nd=nd, i_limit=i_limit)
    rng = np.random.default_rng(seed)
    return y + rng.normal(size=y.shape) * sigma


def experiment(label, truth, inputs, duration, dt, u_range, hold, i_limit, bounds, seeds, runs, show, nd):
    x = np.array([truth[n] for n in NAMES])
    t = np.arange(int(round(duration / dt)) + 1) * dt
    t0 = time.perf_counter()
    design = design_input("dc", truth, duration=duration, dt=dt, u_range=u_range, hold=hold, limit=i_limit)
    print(
        f"\n{label}: design ({design.criterion}-optimal, hold {hold:g} s) in {time.perf_counter() - t0:.1f} s; levels {np.round(design.levels, 1).tolist()}"
    )
    profiles = {"designed": design.recording.u_a, **{k: f(t) for k, f in inputs.items()}}
    step = profiles["step"]
    sigma = 0.01 * np.max(np.abs(simulate_numpy(x, t, step, nd=nd, i_limit=i_limit)), axis=0)
    rows = {}
    for name, u in profiles.items():
        pred = evaluate_input(design, "dc", u)
        errs = []
        t1 = time.perf_counter()
        for seed in range(seeds):
            y = measured(x, t, u, sigma, seed, i_limit, nd)
            rec = Recording(t=t, u_a=u, i_a=y[:, 0], omega=y[:, 1], limit=i_limit, name=f"{name}-{seed}")
            res = dcjax.fit(rec, params=bounds, search=dcjax.Search(runs=runs, seed=seed, polish=True))
            errs.append([abs(res.params[n] - truth[n]) / abs(truth[n]) if truth[n] else abs(res.params[n]) for n in NAMES])
        rows[name] = (np.mean(errs, axis=0), pred)
        print(f"  {name}: {seeds} noisy refits in {time.perf_counter() - t1:.1f} s")
    print(f"  {'':8}" + "".join(f"{n:>22}" for n in show))
    for name, (err, pred) in rows.items():
        cells = []
        for n in show:
            k = NAMES.index(n)
            p = pred.relative_stderr().get(n)
            actual = f"{100 * err[k]:9.2f}%" if truth[n] else f"{err[k]:9.2e}"
            cells.append(f"{actual} ({'-' if p is None else f'{100 * p:.2f}%'})")
        print(f"  {name:8}" + "".join(f"{c:>22}" for c in cells))
    print(
        "  (mean actual relative error over the seeds, and in brackets the predicted relative std. error;"
        + " Tlc of the MD drive: mean absolute value, its truth is 0)" * (label.startswith("MD"))
    )
    return rows


def against_baselines(truth, show):
    """Predicted only: a design that must beat the coast-down and the step in every one of `show`
    (`baselines=`), hold 2.5 ms and 1 ms, against the two."""
    t = np.arange(501) * 1e-4
    coast, step = np.where(t < 0.02, 220.0, 0.0), np.full_like(t, 220.0)
    crit = ",".join(show)
    print(f"\nSD1 motor, designed against the coast-down and the step ({crit}; predicted relative std. errors, 1 % noise)")
    print(f"  {'':24}" + "".join(f"{n:>10}" for n in show))
    for hold in (2.5e-3, 1e-3):
        t0 = time.perf_counter()
        d = design_input("dc", truth, duration=0.05, dt=1e-4, u_range=(0.0, 220.0), hold=hold, criterion=crit, baselines=[coast, step])
        took = time.perf_counter() - t0
        rows = {f"designed, hold {hold * 1e3:g} ms": d, "coast-down": evaluate_input(d, "dc", coast), "step": evaluate_input(d, "dc", step)}
        for label, r in rows.items():
            print(f"  {label:24}" + "".join(f"{100 * r.relative_stderr()[n]:9.3f}%" for n in show))
        print(f"  largest log variance ratio to the best baseline {d.value:.5f} (< 0: beats both in all four); {took:.1f} s")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--runs", type=int, default=4)
    ap.add_argument("--predict-only", action="store_true", help="only the design against the coast-down (no refits)")
    args = ap.parse_args()
    sd1 = datasets.true_params("SD1")
    against_baselines(sd1, ("J", "Tla", "Tlb", "Tlc"))
    if args.predict_only:
        return
    experiment(
        "SD1 motor, 0.05 s at 1e-4 s, 0-220 V",
        sd1,
        {"step": lambda t: np.full_like(t, 220.0), "coast": lambda t: np.where(t < 0.02, 220.0, 0.0)},
        0.05, 1e-4, (0.0, 220.0), 2.5e-3, None, "table4", args.seeds, args.runs, ("J", "Tla", "Tlb", "Tlc"), 10,
    )  # fmt: skip
    md = dict(datasets.load("MD4").metadata["true_params"])
    experiment(
        "MD4 emulated drive (true parameters of data/MD4.json), 2 s at 1e-3 s, 0-220 V, current limit 11.44 A",
        md,
        {"step": lambda t: np.full_like(t, 220.0), "coast": lambda t: np.where(t < 0.8, 220.0, 0.0)},
        2.0, 1e-3, (0.0, 220.0), 0.1, 11.44, "table8", args.seeds, args.runs, ("J", "Tla", "Tlb", "Tlc"), 1,
    )  # fmt: skip


if __name__ == "__main__":
    main()
