"""The one path under `fit` and `fit_each`: sets of recordings (a joint fit's, or one recording
each) loaded, checked (`dcjax.analysis.checks`), prepared (`Plan.setup`) and fitted with one
plan (`fit_sets`); a set that fails to load, has an `error` finding or fails to prepare fails
alone (`FailedFit`) or raises, as the caller asks."""

import dataclasses
from collections.abc import Callable, Sequence

from ..analysis.checks import ERROR, Finding, batch_findings, from_error, recording_findings
from ..errors import ConfigError, DataError
from ..io.recording import Recording
from .engine import fit_setups
from .result import FailedFit, FitResult
from .search import papers_data
from .setup import Plan

ON_ERROR = ("collect", "raise")
CHECKS = ("each", "fleet", "none")


@dataclasses.dataclass(frozen=True)
class RecordingSet:
    """The recordings of one fit (or a function that loads them), its `params` (as `Plan.setup`
    takes them, or a function of the recordings returning them), the `name` of a set that fails
    to load (where given, a data-check error raised is prefixed with the recordings' names; None:
    the findings name their recordings already) and its `source` file."""

    recordings: Sequence[Recording] | Callable[[], Sequence[Recording]]
    params: object = None
    name: str | None = None
    source: str | None = None


def failed(name: str, e: Exception, source: str | None, findings: Sequence[Finding] = ()) -> FailedFit:
    """The `FailedFit` of a recording whose loading, checks or preparation raised `e`."""
    named = from_error(e)
    return FailedFit(
        name=name,
        error=(str(e).splitlines() or [type(e).__name__])[0],
        source=source,
        checks=list(findings) + ([named] if named is not None else []),
    )


def _findings(sets: list[list[Recording]], model, checks: str) -> list[list[Finding]]:
    """Each set's data-check findings (`fit_sets`' `checks`)."""
    if checks == "fleet":
        return batch_findings([recs[0] for recs in sets], model)
    return [recording_findings(recs, model) if checks == "each" else [] for recs in sets]


def fit_sets(
    plan: Plan, sets: Sequence[RecordingSet], checks: str = "each", on_error: str = "collect", progress=None
) -> list[FitResult | FailedFit]:
    """Each set's result in order. The data checks: `"each"` every set on its own
    (`recording_findings`), `"fleet"` sets of one recording against the fleet's medians too
    (`batch_findings`), `"none"`. A set that fails to load, has an `error` finding (a dead or
    alternating channel) or fails to prepare fails: `on_error="collect"` its `FailedFit`,
    `"raise"` the error (a `DataError` for a finding); the others are fitted together
    (`fit_setups`: those of one structure in one compiled call)."""
    if on_error not in ON_ERROR:
        raise ConfigError(f"on_error must be 'collect' or 'raise', got {on_error!r}")
    if checks not in CHECKS:
        raise ConfigError(f"checks must be one of {', '.join(CHECKS)}, got {checks!r}")
    out: list = [None] * len(sets)
    loaded = []
    for k, s in enumerate(sets):
        try:  # one broken recording fails alone, whatever broke in loading it
            loaded.append((k, s, list(s.recordings() if callable(s.recordings) else s.recordings)))
        except Exception as e:
            if on_error == "raise":
                raise
            out[k] = failed(s.name or "", e, s.source)
    plan = for_data(plan, [recs for _, _, recs in loaded])
    found = _findings([recs for _, _, recs in loaded], plan.model, checks)
    ready = []
    for j, (k, s, recs) in enumerate(loaded):
        findings = found[j]
        name = ", ".join(r.name for r in recs)
        errors = [f for f in findings if f.severity == ERROR]
        if errors:
            if on_error == "raise":
                raise DataError(errors[0].check, errors[0].message if s.name is None else f"{name}: {errors[0].message}")
            out[k] = FailedFit(name, f"{errors[0].label}: {errors[0].message}", s.source, checks=list(findings))
            continue
        try:  # one broken recording fails alone, whatever broke in preparing it
            params = s.params(recs) if callable(s.params) else s.params
            ready.append((k, plan.setup(recs, params, findings=findings)))
        except Exception as e:
            if on_error == "raise":
                raise
            out[k] = failed(name, e, s.source, findings)
    for (k, _), res in zip(ready, fit_setups(plan, [s for _, s in ready], progress)):
        out[k] = res
    return out


def for_data(plan: Plan, sets: Sequence[Sequence[Recording]]) -> Plan:
    """The plan for these sets of recordings: where every recording is the paper's (`papers_data`:
    its sidecar names one of the paper's presets) and the stopping rule was not asked for
    (`Plan.default_stop`), the paper's fixed budget (no stopping rule); else `plan`."""
    if not plan.default_stop or not sets or not all(papers_data(recs) for recs in sets):
        return plan
    return dataclasses.replace(plan, search=dataclasses.replace(plan.search, stop=None), default_stop=False)
