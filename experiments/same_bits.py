"""Same bits: a hash of every run's OF and parameters of the paper's runs, to compare two checkouts.

    python -m experiments.same_bits                       # this checkout
    PYTHONPATH=/path/to/other/checkout python -m experiments.same_bits

Rows: the README's SD1 fit (50 runs, 140,000 FEs), MD1 (table8, RK4 ND 2, 4 runs), a joint
SD1+SD2 fit, LTMA and the LM polish; MD1 from its first samples, as the paper (and
these hashes since 0.2) start it. Equal hashes: bit-identical runs."""

import hashlib
import sys

import numpy as np

import dcjax
from dcjax import datasets
from experiments.cells import FIRST_SAMPLES


def show(tag: str, res) -> None:
    h = hashlib.sha256(np.asarray(res.run_of).tobytes() + np.asarray(res.run_params).tobytes()).hexdigest()[:16]
    print(f"{tag:<18} {h}  best OF {float(res.of)!r}", flush=True)


def main() -> None:
    print(f"dcjax {dcjax.__version__} from {dcjax.__file__}", file=sys.stderr)
    sd1, sd2, md1 = datasets.load("SD1"), datasets.load("SD2"), datasets.load("MD1")
    show("SD1-readme", dcjax.fit(sd1, search=dcjax.Search(runs=50, budget=140_000, seed=0)))
    show("MD1-table8-rk4nd2", dcjax.fit(md1, params="table8", integrator=dcjax.RK4(substeps=2), observation=FIRST_SAMPLES, search=dcjax.Search(runs=4, budget=140_000, seed=0)))  # fmt: skip
    show("joint-SD1-SD2", dcjax.fit([sd1, sd2], params="table4", search=dcjax.Search(runs=4, budget=28_000, seed=0)))
    show("LTMA", dcjax.fit(sd1, params="table4", search=dcjax.Search(runs=4, budget=28_000, seed=0, memory=dcjax.LTMA())))
    show("polish", dcjax.fit(sd1, params="table4", search=dcjax.Search(runs=2, budget=14_000, seed=0, polish=True)))


if __name__ == "__main__":
    main()
