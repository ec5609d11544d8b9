"""The search a fit gets where none is asked for (the command line without `--method`, `--runs`,
`--budget`): the paper's (DE/rand/1/exp, 50 runs of 140,000 FEs) for a fit whose evaluation is
short, and a shorter DE/best/1/bin search for a joint fit of many recordings, where the paper's would
take hours (476 servo logs: 50 x 140,000 evaluations of 1.1 ms). Chosen at equal wall time on
476 servo logs, 128 DC recordings and the real EMPS axis: `python -m experiments.bench_many`
(`experiments/BENCHMARKS.md`)."""

import dataclasses


@dataclasses.dataclass(frozen=True)
class SearchDefaults:
    """A method's name, its runs and FEs a run."""

    method: str
    runs: int
    budget: int


PAPER_SEARCH = SearchDefaults("de-rand-1-exp", 50, 140_000)
MANY_SEARCH = SearchDefaults("de-best-1-bin", 2, 20_000)
MANY_STEPS = 50_000  # integration steps of one evaluation from which a fit is "of many recordings" (100 of 500 samples)


def search_defaults(steps: int) -> SearchDefaults:
    """`MANY_SEARCH` where one evaluation integrates at least `MANY_STEPS` steps (the recordings'
    samples times the sub-steps), else `PAPER_SEARCH`."""
    return MANY_SEARCH if steps >= MANY_STEPS else PAPER_SEARCH


__all__ = ["MANY_SEARCH", "MANY_STEPS", "PAPER_SEARCH", "SearchDefaults", "search_defaults"]
