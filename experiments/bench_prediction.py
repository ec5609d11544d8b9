"""Output error against prediction error under a disturbance inside the loop (issue 56 (a)): the
paper's motor (SD1's parameters) under a voltage stepped every 5 ms and held between samples, a
white load torque (omega's random walk of intensity q = 4e4 (rad/s)^2/s) and sensor noise of sd
0.012 A and 2.2 rad/s (about 0.5 % of the peaks),
simulated by an Euler–Maruyama integrator written here in NumPy (128 sub-steps a sample; no dcjax).
Per noise seed, both fits with the same search and `uncertainty()`: each parameter's error in
its reported standard errors (z), and over the seeds how often the 90 % interval (+-1.645 se)
holds the truth.

    python -m experiments.bench_prediction [--seeds 30] [--samples 1500] [--runs 1] [--budget 12000]
"""

import argparse
import time

import numpy as np

import dcjax
from dcjax.io import datasets

TRUTH = datasets.true_params("SD1")
Q = (0.0, 4e4)
NAMES = ("Ra", "La", "cm", "J")


def field(p, u, y):
    i, w = y
    return np.array([(u - p["Ra"] * i - p["cm"] * w) / p["La"], (p["cm"] * i - p["Tla"] - p["Tlb"] * w - p["Tlc"] * w * w) / p["J"]])


def record(seed: int, n: int, sensors: tuple[float, float] = (0.012, 2.2)) -> dcjax.Recording:
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 1e-4
    u = np.repeat(rng.uniform(40.0, 220.0, n // 50 + 1), 50)[:n]
    y, out, sub = np.zeros(2), np.zeros((n, 2)), 128
    for k in range(1, n):
        hs = (t[k] - t[k - 1]) / sub
        for _ in range(sub):
            y = y + hs * field(TRUTH, u[k - 1], y) + np.sqrt(np.asarray(Q) * hs) * rng.standard_normal(2)
        out[k] = y
    z = out + np.asarray(sensors) * rng.standard_normal(out.shape)
    return dcjax.Recording(t=t, u_a=u, i_a=z[:, 0], omega=z[:, 1], name=f"pn{seed}")


def fit(rec: dcjax.Recording, focus: str, runs: int, budget: int) -> dict[str, float]:
    obs = dcjax.Observation(hold={"u_a": "zoh"}, focus=focus, initial={"i_a": 0.0, "omega": 0.0})
    res = dcjax.fit(rec, params="table4", search=dcjax.Search(runs=runs, budget=budget, polish=True), observation=obs).uncertainty()
    u = res.uncertainties
    assert u is not None
    return {n: (res.best_values[n] - TRUTH[n]) / u.se[n] for n in NAMES}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--samples", type=int, default=1500)
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--budget", type=int, default=12_000)
    a = ap.parse_args()
    z = {"simulation": [], "prediction": []}
    wall = {"simulation": 0.0, "prediction": 0.0}
    for seed in range(a.seeds):
        rec = record(seed, a.samples)
        for focus in z:
            t0 = time.perf_counter()
            z[focus].append(fit(rec, focus, a.runs, a.budget))
            wall[focus] += time.perf_counter() - t0
        print(f"seed {seed:2d}: " + "   ".join(f"{f} " + " ".join(f"{n} {z[f][-1][n]:+5.1f}" for n in NAMES) for f in z), flush=True)
    print(f"\n{a.seeds} seeds, {a.samples} samples, {a.runs} run(s) x {a.budget} FEs + polish; z = (fit - truth) / reported std. error")
    for focus, rows in z.items():
        zs = np.array([[r[n] for n in NAMES] for r in rows])
        cover = np.mean(np.abs(zs) <= 1.645, axis=0)
        within3 = np.mean(np.all(np.abs(zs) <= 3, axis=1))
        print(
            f"  {focus:<10} 90 % coverage " + ", ".join(f"{n} {100 * c:.0f} %" for n, c in zip(NAMES, cover))
            + f"; all four within 3 se in {100 * within3:.0f} % of the seeds; max |z| {np.abs(zs).max():.1f}; {wall[focus] / a.seeds:.1f} s a fit"
        )  # fmt: skip


if __name__ == "__main__":
    main()
