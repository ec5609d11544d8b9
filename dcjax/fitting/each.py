"""Many independent recordings, one fit each: `fit_each`, where a recording that fails to load,
check or prepare fails alone (`FailedFit`) and every other one is fitted, the recordings of one
structure in one compiled call."""

from collections.abc import Callable, Sequence
from pathlib import Path

from ..analysis.checks import ERROR, batch_findings, from_error
from ..errors import ConfigError
from ..io.loading import load_recording
from ..io.recording import Recording
from ..models.parameters import Parameters
from ..simulation.integrators import AutoSubsteps, Integrator
from ..strategies import Strategy
from ..strategies.memory import MemoryAssistance
from .engine import fit_setups
from .observation import Observation
from .result import FailedFit, FitResult
from .setup import plan


def fit_each(
    items: Sequence[Recording | str | Path],
    model=None,
    params: "Parameters | str | Sequence | Callable[[Recording], Parameters] | None" = None,
    method: "str | Strategy" = "de-rand-1-exp",
    *,
    load: Callable[[str], Recording] | None = None,
    observation: Observation | None = None,
    integrator: Integrator | AutoSubsteps | None = None,
    runs: int = 50,
    budget: int = 140_000,
    seed: int = 0,
    memory: MemoryAssistance | None = None,
    polish: bool = False,
    progress=None,
    checks: bool = True,
) -> list[FitResult | FailedFit]:
    """`dcjax.fit` on each recording on its own (not a joint fit), with the same options.

    `items`: recordings, or paths loaded with `load` (default `dcjax.load_recording` with the
    model). Every recording goes through the data checks (`dcjax.analysis.checks`, with the
    fleet's median peaks; `checks=False`: none); one that fails to load, has an `error` finding,
    or fails to prepare (its channels, its first estimate) gets a `FailedFit` with its one-line
    error and every other one is fitted; the findings are in each result's `checks`.
    `params`: as `fit` takes it, for every recording; a list with one entry per item; or a
    function of the loaded recording returning its `Parameters`. Recordings of one structure
    (length, channels, limit, free parameters, layout) are fitted in one compiled call, with the
    same results as one fit each (`dcjax.fitting.runs`), with `AutoSubsteps` and `progress` too.
    An error of the batched call itself (not of one recording) is raised."""
    p = plan(model, method, observation=observation, integrator=integrator, runs=runs, budget=budget, seed=seed, memory=memory,
             polish=polish)  # fmt: skip
    if isinstance(params, (list, tuple)) and len(params) != len(items):
        raise ConfigError(f"params: one entry per recording ({len(items)}), got {len(params)}")
    loader = load or (lambda path: load_recording(path, model=p.model))
    out: list = [None] * len(items)
    loaded: list = []
    for k, item in enumerate(items):
        source = None if isinstance(item, Recording) else str(item)
        try:  # one broken recording fails alone, whatever broke in loading it
            loaded.append((k, item if isinstance(item, Recording) else loader(str(item)), source))
        except Exception as e:
            out[k] = failed(item.name if isinstance(item, Recording) else Path(str(item)).stem, e, source)
    found = batch_findings([r for _, r, _ in loaded], p.model) if checks else [[] for _ in loaded]
    ready: list = []
    for (k, rec, source), findings in zip(loaded, found):
        errors = [f for f in findings if f.severity == ERROR]
        if errors:
            out[k] = FailedFit(rec.name, f"{errors[0].label}: {errors[0].message}", source, checks=findings)
            continue
        try:  # one broken recording fails alone, whatever broke in preparing it
            given = params[k] if isinstance(params, (list, tuple)) else params(rec) if callable(params) else params
            ready.append((k, p.setup([rec], given, findings=findings)))
        except Exception as e:
            out[k] = failed(rec.name, e, source, findings)
    for (k, _), res in zip(ready, fit_setups(p, [s for _, s in ready], progress)):
        out[k] = res
    return out


def failed(name: str, e: Exception, source: str | None, findings: list | None = None) -> FailedFit:
    """The `FailedFit` of a recording whose loading, checks or preparation raised `e`."""
    named = from_error(e)
    return FailedFit(name=name, error=(str(e).splitlines() or [type(e).__name__])[0], source=source,
                     checks=list(findings or []) + ([named] if named is not None else []))  # fmt: skip
