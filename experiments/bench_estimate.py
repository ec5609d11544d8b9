"""The first estimate of a model without `regression()` (issue: a researcher's own model): a motor
bench's twelve torque-step records (20 s at 1 kHz, 0.2 % noise, made here by a plain NumPy RK4
with 10 sub-steps) and a 3-parameter friction model file, J dw/dt = T - Tc sgn(w) - B w.

Prints the `--each` split line (`estimate` is the first estimates' time, their compilation is in
`compile`), the estimate per file outside the CLI for the linear form found with JAX and for the
Levenberg–Marquardt fallback (the same model with its smoothing width a 4th parameter: not
linear after any factor), and, with `--against DIR` (an earlier `--out` of the same command), the
largest relative change of any fitted parameter.

    python -m experiments.bench_estimate [--runs 2] [--keep DIR] [--against DIR]
"""

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

TRUTH = {"J": 0.012, "Tc": 0.045, "B": 0.018}
WIDTH = 0.05
MODEL = '''import jax.numpy as jnp
import dcjax


class Friction(dcjax.Model):
    """J dw/dt = T - Tc sgn(w) - B w, sgn smoothed over 0.05 rad/s."""

    names = ("J", "Tc", "B")
    units = {"J": "kg m^2", "Tc": "N m", "B": "N m s/rad"}
    states = ("omega",)
    inputs = ("T",)
    precision = {"J": 1e-9, "Tc": 1e-9, "B": 1e-9}

    def vector_field(self, c, u, y):
        (w,) = y
        return ((u[0] - c["Tc"] * w / jnp.sqrt(w * w + 0.05**2) - c["B"] * w) / c["J"],)


class FrictionWidth(Friction):
    """The same with the smoothing width a parameter (not linear after any one factor)."""

    names = ("J", "Tc", "B", "ws")
    precision = {"J": 1e-9, "Tc": 1e-9, "B": 1e-9, "ws": 1e-9}

    def vector_field(self, c, u, y):
        (w,) = y
        return ((u[0] - c["Tc"] * w / jnp.sqrt(w * w + c["ws"] ** 2) - c["B"] * w) / c["J"],)
'''


def write_bench(folder: Path, files: int = 12, samples: int = 20001, h: float = 1e-3) -> list[Path]:
    """The records, all simulated at once (RK4, 10 sub-steps, the torque linear between samples)."""
    rng = np.random.default_rng(1)
    t = h * np.arange(samples)
    levels = rng.uniform(-0.4, 0.4, size=(files, 10))
    T = levels[:, np.minimum((t / 2.0).astype(int), 9)]  # (files, samples)

    def f(w, torque):
        return (torque - TRUTH["Tc"] * w / np.sqrt(w * w + WIDTH**2) - TRUTH["B"] * w) / TRUTH["J"]

    w = np.zeros((files, samples))
    sub, hs = 10, h / 10
    for i in range(samples - 1):
        x = w[:, i]
        for s in range(sub):
            ta, tm, tb = (T[:, i] + a * (T[:, i + 1] - T[:, i]) for a in (s / sub, (s + 0.5) / sub, (s + 1) / sub))
            k1 = f(x, ta)
            k2 = f(x + hs / 2 * k1, tm)
            k3 = f(x + hs / 2 * k2, tm)
            k4 = f(x + hs * k3, tb)
            x = x + hs / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        w[:, i + 1] = x
    w += 0.002 * np.std(w, axis=1, keepdims=True) * rng.standard_normal(w.shape)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "friction.py").write_text(MODEL)
    paths = []
    for k in range(files):
        p = folder / f"step{k:02d}.csv"
        np.savetxt(p, np.column_stack([t, T[k], w[k]]), delimiter=",", header="t,T,omega", comments="", fmt="%.10g")
        paths.append(p)
    return paths


def estimate_seconds(folder: Path, paths: list[Path], cls: str) -> tuple[float, float]:
    """(first file incl. compilation, median of the others) of `initial_estimate`, in this process."""
    sys.path.insert(0, str(folder))
    import dcjax
    from dcjax.analysis.estimate import initial_estimate

    model = getattr(__import__("friction"), cls)()
    times = []
    for p in paths:
        rec = dcjax.load_recording(p, model=model)
        t0 = time.perf_counter()
        initial_estimate(rec, model)
        times.append(time.perf_counter() - t0)
    return times[0], float(np.median(times[1:]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--keep", help="write the records and the results here (default a temporary folder)")
    ap.add_argument("--against", help="an earlier --out folder of the same command: the largest relative parameter change")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(args.keep or tmp)
        t0 = time.perf_counter()
        paths = write_bench(root / "data")
        print(f"12 records of 20 s at 1 kHz written by the NumPy RK4 in {time.perf_counter() - t0:.0f} s")
        for cls in ("Friction", "FrictionWidth"):
            first, rest = estimate_seconds(root / "data", paths[:4], cls)
            print(f"initial_estimate, {cls}: first file {first:.2f} s (with compilation), then {rest:.2f} s a file")
        out = root / "out"
        cmd = [sys.executable, "-m", "dcjax", "fit", "--each", *map(str, paths), "--model", f"{root / 'data' / 'friction.py'}:Friction"]
        cmd += ["--runs", str(args.runs), "--out", str(out), "--overwrite", "--no-progress"]
        t0 = time.perf_counter()
        p = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, "DCJAX_NO_CACHE": "1"})
        last = p.stdout.strip().splitlines()[-1] if p.stdout.strip() else p.stderr
        parts = {k: float(v) for k, v in re.findall(r"([a-z+]+) ([0-9.]+) s", last)}
        print(f"dcjax fit --each (12 files, --runs {args.runs}), wall {time.perf_counter() - t0:.0f} s: {last}")
        if parts:
            print(f"  estimate {parts['estimate'] / 12:.2f} s a file; estimate / search {parts['estimate'] / parts['search']:.3f}")
        fitted = {q.parent.name: json.loads(q.read_text())["params"] for q in out.glob("*/result.json")}
        worst = max(abs(v / TRUTH[n] - 1) for ps in fitted.values() for n, v in ps.items())
        print(f"  largest error against the truth: {100 * worst:.3f} %")
        if args.against:
            before = {q.parent.name: json.loads(q.read_text())["params"] for q in Path(args.against).glob("*/result.json")}
            change = max(abs(fitted[k][n] / before[k][n] - 1) for k in fitted if k in before for n in fitted[k])
            print(f"  largest relative change against {args.against}: {change:.2e}")


if __name__ == "__main__":
    main()
