"""Issue 53's folder of 20 close lengths under XLA:CPU's other compiler options: SD1 cut to 310,
320, ..., 500 samples, `dcjax fit --each f*.csv --bounds table4 --runs 2 --budget 20000` with no
compilation cache, each option set added to the short search's options
(`dcjax.fitting.runs.QUICK_COMPILE`), each in a new process, the sets alternating. Prints the
command's split line, compile's share of it, and whether summary.csv has the default's bytes.

    python -m experiments.bench_each_options [--rounds 2]
"""

import argparse
import contextlib
import hashlib
import io
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

OPTIONS = {
    "short search (today)": {},
    "LLVM level 1": {"xla_backend_optimization_level": 1},
    "codegen in one part": {"xla_cpu_parallel_codegen_split_count": 1},
    "no concurrency scheduler": {"xla_cpu_enable_concurrency_optimized_scheduler": False},
    "copies without region analysis": {"xla_cpu_copy_insertion_use_region_analysis": False},
    "AVX2 at most": {"xla_cpu_max_isa": "AVX2"},
    "128-bit vectors": {"xla_cpu_prefer_vector_width": 128},
}


def folder(where: Path) -> list[str]:
    rows = (Path(__file__).parents[1] / "data" / "SD1.csv").read_text().splitlines(keepends=True)
    for n in range(310, 501, 10):
        (where / f"f{n}.csv").write_text("".join(rows[: n + 1]))
    return sorted(str(p) for p in where.glob("f*.csv"))


def one(options: dict, files: list[str], out: str) -> None:
    """In this (new) process: the command with `options` added to the short search's; one JSON line."""
    from dcjax import cli
    from dcjax.fitting import runs

    runs.QUICK_COMPILE = runs.QUICK_COMPILE | options
    text = io.StringIO()
    with contextlib.redirect_stdout(text), contextlib.redirect_stderr(io.StringIO()):
        rc = cli.entry(["fit", "--each", *files, "--bounds", "table4", "--runs", "2", "--budget", "20000", "--out", out])
    split = text.getvalue().splitlines()[-1].split(": ", 1)[1]
    seconds = {name: float(value) for name, value, _ in (part.split(" ") for part in split.split(", "))}
    digest = hashlib.sha256((Path(out) / "summary.csv").read_bytes()).hexdigest()[:12] if rc == 0 else f"rc {rc}"
    print(json.dumps({"seconds": seconds, "summary": digest}))


def main():
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--one", nargs=3, help=argparse.SUPPRESS)  # options (JSON), files folder, out
    args = ap.parse_args()
    if args.one:
        options, where, out = args.one
        return one(json.loads(options), sorted(str(p) for p in Path(where).glob("f*.csv")), out)
    env = {**os.environ, "DCJAX_NO_CACHE": "1"}
    with tempfile.TemporaryDirectory() as tmp:
        folder(Path(tmp))
        print(f"{os.cpu_count()} cores; split line (s) and compile's share; summary.csv against the first set's")
        reference = None
        for r in range(args.rounds):
            for k, (label, options) in enumerate(OPTIONS.items()):
                out = str(Path(tmp) / f"out-{r}-{k}")  # a folder of its own: the command never writes into an earlier one
                cmd = [sys.executable, "-m", "experiments.bench_each_options", "--one", json.dumps(options), tmp, out]
                got = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=Path(__file__).parents[1])
                if got.returncode or not got.stdout.strip():
                    print(f"{label:<32} failed: {(got.stderr.strip().splitlines() or [''])[-1][:120]}")
                    continue
                row = json.loads(got.stdout.strip().splitlines()[-1])
                s, reference = row["seconds"], reference or row["summary"]
                share = s["compile"] / sum(s.values())
                same = "same" if row["summary"] == reference else "OTHER"
                print(f"{label:<32} compile {s['compile']:.1f} search {s['search']:.1f} write+plots {s['write+plots']:.1f}"
                      f"  {share:5.1%}  {same}", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
