"""One SD1 run with the paper's settings (DE/rand/1/exp, NP 70, 140,000 FEs, RK4, ND 1): the
run time of nine compiled runs (seeds 0-8) after one compiling run, min and median. Run it from
two checkouts (PYTHONPATH=<checkout>) in alternation to compare versions.

    .venv/bin/python -m experiments.bench_one_run [label]
"""

import statistics
import sys

import dcjax
from dcjax import datasets

dcjax.use_host_devices()
dcjax.use_compiled_loops()


def main():
    label = sys.argv[1] if len(sys.argv) > 1 else dcjax.__version__
    rec = datasets.load("SD1")
    # `fit` where the checkout has it (0.2), else `identify`: the same script times the 0.1 commit (3056edf).
    one = (
        (lambda s: dcjax.fit(rec, params="table4", search=dcjax.Search(runs=1, seed=s)))
        if hasattr(dcjax, "fit")
        else (lambda s: dcjax.identify(rec, runs=1, seed=s))
    )
    one(99)  # compiles
    t = [one(s).timing["run_s"] for s in range(9)]
    print(f"{label}: one SD1 DE run (140,000 FEs, RK4): min {min(t):.4f} s, median {statistics.median(t):.4f} s")


if __name__ == "__main__":
    main()
