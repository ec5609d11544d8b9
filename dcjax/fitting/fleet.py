"""A fleet of motors: one identification per recording through the batch runner
(`dcjax.fitting.batch.identify_each`), with the motors split over every device JAX sees (and over the
processes of `jax.distributed`: every process passes the same recordings and gets the whole,
identical result). `FleetResult` is the fleet's table of best parameters beside each motor's full
result; `fit_each` is the same with a failed result for a recording that cannot be fitted."""

import dataclasses

import numpy as np

from ..io.recording import Recording
from .batch import identify_each
from .result import IdentificationResult


@dataclasses.dataclass
class FleetResult:
    params: np.ndarray  # (M, P) best of each motor's runs
    of: np.ndarray  # (M,)
    fes: np.ndarray  # (M, runs)
    timing: dict
    settings: dict
    names: tuple[str, ...] = ()
    results: list[IdentificationResult] = dataclasses.field(default_factory=list, repr=False)  # each motor's full result

    def to_dicts(self) -> list[dict[str, float]]:
        return [dict(zip(self.names, map(float, x))) for x in self.params]


def identify_fleet(recordings: list[Recording], *, runs: int = 1, seed: int = 0, **options) -> FleetResult:
    """One identification per recording (motor) of equal length in one compiled call;
    `options` are those of `identify_each` (method, integrator, nd, weights, bounds (one for all),
    budget, pop_size, polish, memory, precision, generations, model, fixed, i_limit). Run r of
    every motor uses key fold_in(PRNGKey(seed), r), as a fit of that motor alone, whatever the
    device count."""
    if not recordings or not all(isinstance(r, Recording) for r in recordings):
        raise ValueError("recordings must be a non-empty list of dcjax.Recording")
    n = {len(r) for r in recordings}
    if len(n) != 1:
        raise ValueError(f"fleet recordings must have equal length, got lengths {sorted(n)}")
    if {r.limit is None for r in recordings} == {True, False}:
        raise ValueError("either every recording of a fleet has a current limit or none has")
    if not isinstance(runs, int) or isinstance(runs, bool) or runs < 1:
        raise ValueError(f"runs must be a positive integer, got {runs!r}")
    bounds = options.pop("bounds", None)
    results = identify_each(recordings, bounds=[bounds] * len(recordings), runs=runs, seed=seed, **options)
    first = results[0]
    run_s = first.timing["batch_run_s"]
    return FleetResult(
        params=np.array([[r.best_values[k] for k in r.names] for r in results]),
        of=np.array([r.of for r in results]),
        fes=np.array([r.fes for r in results]),
        timing={
            "compile_s": first.timing["compile_s"],
            "run_s": run_s,
            "devices": first.timing["devices"],
            "motors_per_s": len(results) / run_s,
        },  # fmt: skip
        settings={**first.settings, "motors": len(results)},
        names=first.names,
        results=results,
    )
