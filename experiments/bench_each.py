"""`dcjax fit --each` on a synthetic lab folder (`experiments.synthetic_fleet`): the split of the
wall time the command prints as its last line, and the share of the work outside the compiled
search (loading, checks, first estimate, writing, plots). Each configuration runs in a fresh
process with the compilation cache off (DCJAX_NO_CACHE=1), so `compile` is a cold start.

`--lengths LO HI`: the clean files only, of distinct lengths spaced geometrically from LO to HI
samples (a folder of many lengths: `fit_each` pads close lengths into shared buckets of grid
lengths, `dcjax.simulation.joint.length_buckets`), and the share of the wall spent compiling.
`--again`: then a second folder of similar files (each length 1-2 % longer, other data) with the
persistent compilation cache the first one filled (`DCJAX_CACHE_DIR`, a fresh folder; the first
run is still a cold start): what the second folder compiles.

    python -m experiments.bench_each [--clean 20 75] [--runs 2] [--plots summary each] [--lengths 400 1600 [--again]]
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from experiments.synthetic_fleet import write_fleet


def run(files: list[str], out: Path, runs: int, plots: str, cache: Path | None = None) -> tuple[float, dict[str, float]]:
    env = {**os.environ, "DCJAX_NO_CACHE": "1"} if cache is None else {**os.environ, "DCJAX_CACHE_DIR": str(cache), "DCJAX_NO_CACHE": ""}
    cmd = [sys.executable, "-m", "dcjax", "fit", "--each", *files, "--bounds", "auto", "--runs", str(runs), "--plots", plots]
    t0 = time.perf_counter()
    p = subprocess.run([*cmd, "--out", str(out), "--overwrite", "--no-progress"], capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    last = p.stdout.strip().splitlines()[-1]
    return wall, {k: float(v) for k, v in re.findall(r"([a-z+]+) ([0-9.]+) s", last)}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--clean", type=int, nargs="+", default=[20, 75])
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--plots", nargs="+", default=["summary", "each"])
    ap.add_argument("--lengths", type=int, nargs=2, default=None, metavar=("LO", "HI"))
    ap.add_argument("--again", action="store_true", help="with --lengths: a second folder of similar files from the first's cache")
    args = ap.parse_args()
    if args.again and args.lengths is None:
        raise SystemExit("--again needs --lengths")
    for clean in args.clean:
        with tempfile.TemporaryDirectory() as tmp:
            lengths = None if args.lengths is None else sorted({int(n) for n in np.geomspace(*args.lengths, clean).round()})
            if lengths is not None and len(lengths) != clean:
                raise SystemExit(f"--lengths {args.lengths}: {clean} distinct lengths do not fit between them")
            kinds = write_fleet(Path(tmp) / "data", clean=clean, samples=665, broken=lengths is None, lengths=lengths)
            files = [str(Path(tmp) / "data" / f"{k}.csv") for k in kinds]
            if args.again:
                again(Path(tmp), files, lengths, clean, args.runs, args.plots[0])
                continue
            for plots in args.plots:
                wall, parts = run(files, Path(tmp) / f"out-{plots}", args.runs, plots)
                outside = parts["load+checks"] + parts["estimate"] + parts["write+plots"]
                split = ", ".join(f"{k} {v:.1f} s" for k, v in parts.items())
                what = f"{clean} clean" if lengths is None else f"{len(set(lengths))} lengths {lengths[0]}-{lengths[-1]}"
                print(f"{len(files)} files ({what}), --runs {args.runs}, --plots {plots}: wall {wall:.1f} s (process); {split}; "
                      f"outside the search {100 * outside / sum(parts.values()):.0f} %, compile {100 * parts['compile'] / sum(parts.values()):.0f} %",
                      flush=True)  # fmt: skip


def again(tmp: Path, files: list[str], lengths: list[int], clean: int, runs: int, plots: str) -> None:
    """The folder from an empty persistent cache, then a similar one (lengths 1-2 % longer, seed 1) from it."""
    cache = tmp / "cache"
    similar = (np.asarray(lengths) * np.linspace(1.01, 1.02, len(lengths))).round().astype(int).tolist()
    kinds = write_fleet(tmp / "similar", clean=clean, samples=665, broken=False, lengths=similar, seed=1)
    for label, folder in (
        ("first folder, empty cache", files),
        ("similar folder, the first's cache", [str(tmp / "similar" / f"{k}.csv") for k in kinds]),
    ):
        wall, parts = run(folder, tmp / f"out-{label[:5]}", runs, plots, cache)
        split = ", ".join(f"{k} {v:.1f} s" for k, v in parts.items())
        print(f"{label}: {len(folder)} files, --runs {runs}: wall {wall:.1f} s (process); {split}; "
              f"compile {100 * parts['compile'] / sum(parts.values()):.0f} %", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
