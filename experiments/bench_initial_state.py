"""The default initial state of noisy recordings (issue: honest uncertainty, item 4): three PMSM
recordings from the independent NumPy reference (`tests/test_initial_noise.recordings`: 0.5 %
noise on id, iq and omega, starting at rest), fitted (RK4 8 sub-steps, DE 2 runs x 60,000 FEs,
polished) with the default initial state (each noisy start fitted), from the first samples
(`initial=measured` for all three states) and from the first samples' local quadratic
(`initial=smoothed`). Prints, per noise seed, each parameter's error in its
linearised standard errors, then the RMS, the count beyond 2 and 3 and the largest, per setting.

    python -m experiments.bench_initial_state [--seeds 8]
"""

import argparse
import sys
from pathlib import Path

import numpy as np

import dcjax

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))  # the reference simulator and the test's data

import test_initial_noise as case

SETTINGS = {
    "default": None,
    "measured": dcjax.Observation(initial={s: "measured" for s in ("id", "iq", "omega")}),
    "smoothed": dcjax.Observation(initial={s: "smoothed" for s in ("id", "iq", "omega")}),
}


def main(argv=None):
    dcjax.use_compiled_loops()
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=8)
    args = ap.parse_args(argv)
    z = {tag: [] for tag in SETTINGS}
    for seed in range(args.seeds):
        recs = case.recordings(0.005, seed)
        line = []
        for tag, obs in SETTINGS.items():
            res = dcjax.fit(
                recs,
                "pmsm",
                observation=obs,
                integrator=dcjax.RK4(substeps=8),
                search=dcjax.Search(runs=2, budget=60_000, seed=0, polish=True),
            )
            u = res.uncertainty().uncertainties
            assert u is not None
            row = {n: (u.params[n] - v) / u.se[n] for n, v in case.TRUTH.items()}
            z[tag] += list(row.values())
            line.append(f"{tag}: " + " ".join(f"{n} {v:+.2f}" for n, v in row.items()))
        print(seed, "  ".join(line), flush=True)
    for tag, v in z.items():
        a = np.abs(v)
        print(f"{tag:>9}: {len(a)} errors, RMS {np.sqrt(np.mean(a**2)):.2f} standard errors, {np.sum(a > 2)} beyond 2, "
              f"{np.sum(a > 3)} beyond 3, largest {a.max():.2f}")  # fmt: skip


if __name__ == "__main__":
    main()
