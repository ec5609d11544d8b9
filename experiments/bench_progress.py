"""Overhead of progress reporting (issue 13): `fit` on SD1 (DE/rand/1/exp, RK4, 140,000 FEs,
50 runs, one CPU device per core) with and without `progress` (`PROGRESS_CHUNKS` chunks), alternated, run times
only (compilation excluded; every executable is compiled before the timed calls).

    .venv/bin/python -m experiments.bench_progress"""

import statistics

import numpy as np

import dcjax

dcjax.use_host_devices()
dcjax.use_compiled_loops()

from dcjax import datasets, fit  # noqa: E402
from dcjax.fitting.runs import PROGRESS_CHUNKS  # noqa: E402


def main(repeats: int = 6, runs: int = 50):
    rec = datasets.load("SD1")
    plain, chunked = [], []
    for mode in (None, lambda f: None):  # compile both paths first
        fit(rec, params="table4", progress=mode, search=dcjax.Search(runs=runs, seed=0))
    for r in range(repeats):
        a = fit(rec, params="table4", search=dcjax.Search(runs=runs, seed=r))
        b = fit(rec, params="table4", progress=lambda f: None, search=dcjax.Search(runs=runs, seed=r))
        assert np.array_equal(a.run_of, b.run_of), "progress changed the result"
        plain.append(a.timing["run_s"])
        chunked.append(b.timing["run_s"])
        print(f"seed {r}: without progress {a.timing['run_s']:.3f} s, with progress {b.timing['run_s']:.3f} s")
    m0, m1 = statistics.median(plain), statistics.median(chunked)
    ratio = statistics.median(b / a for a, b in zip(plain, chunked))
    print(
        f"median run time: without {m0:.3f} s, with {m1:.3f} s; median of paired ratios {ratio:.3f} "
        f"-> overhead {100 * (ratio - 1):+.1f} % ({runs} runs, {len(__import__('jax').devices())} CPU devices, "
        f"{PROGRESS_CHUNKS} chunks)"
    )


if __name__ == "__main__":
    main()
