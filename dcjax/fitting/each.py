"""Many independent recordings, one fit each: `fit_each`, where a recording that fails to load,
check or prepare fails alone (`FailedFit`) and every other one is fitted, the recordings of one
structure in one compiled call."""

from collections.abc import Callable, Sequence
from pathlib import Path

from ..analysis.checks import ERROR, batch_findings, from_error
from ..errors import ConfigError, DataError
from ..io.loading import load_recording
from ..io.recording import Recording
from ..models.parameters import Parameters
from ..simulation.integrators import AutoSubsteps, Integrator
from .engine import fit_setups
from .observation import Observation
from .parameter_spec import ParameterSpec
from .result import FailedFit, FitResult
from .search import Search, search_of
from .setup import plan


def fit_each(
    items: Sequence[Recording | str | Path],
    model=None,
    params: "Parameters | ParameterSpec | str | Sequence | Callable[[Recording], Parameters] | None" = None,
    search: Search | None = None,
    *,
    observation: Observation | None = None,
    integrator: Integrator | AutoSubsteps | None = None,
    progress=None,
    load: Callable[[str], Recording] | None = None,
    checks: bool = True,
    on_error: str = "collect",
    **legacy,
) -> list[FitResult | FailedFit]:
    """`dcjax.fit` on each recording on its own (not a joint fit), with the same options.

    `items`: recordings, or paths loaded with `load` (default `dcjax.load_recording` with the
    model). Every recording goes through the data checks (`dcjax.analysis.checks`, with the
    fleet's median peaks; `checks=False`: none); one that fails to load, has an `error` finding,
    or fails to prepare (its channels, its first estimate) gets a `FailedFit` with its one-line
    error and every other one is fitted (`on_error="collect"`, the default; `"raise"`: the first
    such error is raised); the findings are in each result's `checks`. `params`: as `fit` takes
    it, for every recording; a list with one entry per item; or a function of the loaded
    recording returning its `Parameters`. `search`: a `dcjax.Search` (None: `Search.paper()`).
    Recordings of one structure (length, channels, limit, free parameters, layout) are fitted in
    one compiled call, with the same results as one fit each (`dcjax.fitting.runs`), with
    `AutoSubsteps` and `progress` too. An error of the batched call itself (not of one recording)
    is raised."""
    if on_error not in ("collect", "raise"):
        raise ConfigError(f"on_error must be 'collect' or 'raise', got {on_error!r}")
    p = plan(model, search_of(search, legacy, Search.paper()), observation=observation, integrator=integrator)
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
            out[k] = _failed_or_raise(on_error, item.name if isinstance(item, Recording) else Path(str(item)).stem, e, source)
    found = batch_findings([r for _, r, _ in loaded], p.model) if checks else [[] for _ in loaded]
    ready: list = []
    for (k, rec, source), findings in zip(loaded, found):
        errors = [f for f in findings if f.severity == ERROR]
        if errors:
            if on_error == "raise":
                raise DataError(errors[0].check, f"{rec.name}: {errors[0].message}")
            out[k] = FailedFit(rec.name, f"{errors[0].label}: {errors[0].message}", source, checks=findings)
            continue
        try:  # one broken recording fails alone, whatever broke in preparing it
            given = params[k] if isinstance(params, (list, tuple)) else params(rec) if callable(params) else params
            ready.append((k, p.setup([rec], given, findings=findings)))
        except Exception as e:
            out[k] = _failed_or_raise(on_error, rec.name, e, source, findings)
    for (k, _), res in zip(ready, fit_setups(p, [s for _, s in ready], progress)):
        out[k] = res
    return out


def _failed_or_raise(on_error: str, name: str, e: Exception, source, findings=None) -> "FailedFit":
    """A recording's error: its `FailedFit` (`on_error="collect"`), or raised again (`"raise"`)."""
    if on_error == "raise":
        raise e
    return failed(name, e, source, findings)


def failed(name: str, e: Exception, source: str | None, findings: list | None = None) -> FailedFit:
    """The `FailedFit` of a recording whose loading, checks or preparation raised `e`."""
    named = from_error(e)
    return FailedFit(
        name=name,
        error=(str(e).splitlines() or [type(e).__name__])[0],
        source=source,
        checks=list(findings or []) + ([named] if named is not None else []),
    )
