"""Many independent recordings, one fit each: `fit_each`, where a recording that fails to load,
check or prepare fails alone (`FailedFit`) and every other one is fitted, the recordings of one
structure in one compiled call."""

from collections.abc import Callable, Mapping, Sequence
from functools import partial
from pathlib import Path

from ..errors import ConfigError
from ..io.loading import load_recording
from ..io.recording import Recording, as_recording
from ..models.parameters import Parameters
from ..simulation.integrators import AutoSubsteps, Integrator
from .observation import Observation
from .parameter_spec import ParameterSpec
from .planning import plan
from .result import FailedFit, FitResult
from .search import Search
from .sets import RecordingSet, fit_sets


def fit_each(
    items: Sequence[Recording | str | Path],
    model=None,
    params: "Parameters | ParameterSpec | str | Sequence | Callable[[Recording], Parameters] | None" = None,
    search: Search | Mapping | None = None,
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
    recording returning its `Parameters`. `search`: a `dcjax.Search` (None: `Search.own()`, the paper's search ending each run once it has
    converged, or where every file is the paper's `Search.paper()`; a dict: changes to it, as `fit` takes them).
    Recordings of one structure (length, channels, limit, free parameters, layout) are fitted in
    one compiled call, with the same results as one fit each (`dcjax.fitting.runs`), with
    `AutoSubsteps` and `progress` too. An error of the batched call itself (not of one recording)
    is raised."""
    p = plan(model, search, observation=observation, integrator=integrator, default=Search.own(), legacy=legacy)
    if isinstance(params, (list, tuple)) and len(params) != len(items):
        raise ConfigError(f"params: one entry per recording ({len(items)}), got {len(params)}")
    loader = load or (lambda path: load_recording(path, model=p.model))
    items = [as_recording(item, p.model) for item in items]  # a pandas DataFrame: Recording.from_dataframe
    sets = [
        RecordingSet(
            [item] if isinstance(item, Recording) else partial(_loaded, loader, str(item)),
            _params_of(params, k),
            item.name if isinstance(item, Recording) else Path(str(item)).stem,
            None if isinstance(item, Recording) else str(item),
        )
        for k, item in enumerate(items)
    ]
    return fit_sets(p, sets, "fleet" if checks else "none", on_error, progress)


def _loaded(loader: Callable[[str], Recording], path: str) -> list[Recording]:
    """The file at `path` as a set of one recording (`fit_sets` calls it: a failure fails alone)."""
    return [loader(path)]


def _params_of(params, k: int):
    """Item `k`'s parameters: its entry of a list, a function of its recording, else `params`."""
    if isinstance(params, (list, tuple)):
        return params[k]
    if callable(params):
        return lambda recordings: params(recordings[0])
    return params
