"""`dcjax.fitting.fit`: one entry point in lmfit/optimistix vocabulary over the engine.

    params = dcjax.DC().parameters("table8"); params["Tlc"].set(value=0.0, vary=False)
    result = dcjax.fit(recording, params=params, search=dcjax.Search(runs=50, polish=True), integrator=dcjax.RK4(substeps=5))

Configuration is typed: integrators (`Euler`, `RK4`, a user's own `Integrator`, `AutoSubsteps`),
the search (`dcjax.Search`: method, runs, budget, seed, memory, polish) and the observation (`dcjax.Observation`: loss, initial
states, offsets, delays) are small objects that carry their behaviour; what belongs to the data
(channel weights, the current limit, a joint fit's weights) lives with the recordings
(`with_weights`, `Recording.limit`); what belongs to the search (population size, F, CR, a
limit on the generations) with the strategy object (`dcjax.strategies.DERand1Exp(pop_size=40, f=0.5)`)."""

from collections.abc import Mapping, Sequence

from ..errors import ConfigError
from ..io.recording import Recording, as_recording
from ..models import Model
from ..models.parameters import Parameters
from ..simulation.integrators import AutoSubsteps, Integrator
from .observation import Observation
from .parameter_spec import ParameterSpec
from .planning import plan
from .result import FitResult
from .search import Search
from .sets import RecordingSet, fit_sets


def recordings_of(data, model=None) -> list[Recording]:
    """`data` as a non-empty list of recordings (one recording or pandas DataFrame, or a list of
    them; a DataFrame read by `Recording.from_dataframe` with `model`)."""
    items = [as_recording(r, model) for r in (list(data) if isinstance(data, (list, tuple)) else [data])]
    if not items or not all(isinstance(r, Recording) for r in items):
        raise ConfigError(
            "data must be a dcjax.Recording, a pandas DataFrame (its time a column t or the index) or a non-empty list of them"
        )
    return [r for r in items if isinstance(r, Recording)]


def fit(
    data: Recording | Sequence[Recording],
    model: Model | str | None = None,
    params: Parameters | ParameterSpec | str | None = None,
    search: Search | Mapping | None = None,
    *,
    observation: Observation | None = None,
    integrator: Integrator | AutoSubsteps | None = None,
    progress=None,
    **legacy,
) -> FitResult:
    """Fit `model` (default the paper's DC drive) to `data`: one recording, or a list of recordings
    of one drive (a joint fit: one parameter set, the OF the mean of theirs or the sum weighted by
    each recording's `joint_weight`).

    `params`: `Parameters` (ranges, fixed values, start values, precisions), a `ParameterSpec`
    (the same in short: a preset with ranges, known and start values), a preset name
    (`"table4"`, `"table8"`), `"auto"` (`dcjax.analysis.estimate.auto_bounds`: ranges from an
    equation-error first estimate, which also seeds the search), or None: the recordings'
    sidecar preset where they name one, else `"auto"`. A `Parameter(local=True)` gets one value
    per recording of a joint fit (`Tla[0]`, `Tla[1]`, ...); `params` may also hold `offset_*`,
    `delay_*`, `y0_*` entries (ranges, start values, `local`).

    `search`: a `dcjax.Search` (method, runs, budget, seed, memory, polish, stop); None:
    `Search.own()` (the paper's DE/rand/1/exp, 50 runs of at most 140,000 FEs, each ending once
    it has converged), or for a joint fit of many recordings `Search.many()` (`Search.for_steps`),
    and for the paper's data (a sidecar naming Table 4 or 8) every run spends its budget as in
    the paper (`Search.paper()`); a dict of changes to that default (`{"runs": 5}`, also
    `generations`; `{"stop": None}`: every run spends its budget); the result records the search
    it ran.
    `integrator`: `Euler(substeps=N)`, `RK4(substeps=N)` (the default, N = 1), a
    `dcjax.Integrator` of your own, or `AutoSubsteps(...)`. `observation`: the terms beyond the
    paper's (`dcjax.Observation`: the loss, initial states, sensor offsets, input delays, the
    compared states, held inputs). `progress`: True (a bar) or a callable taking the fraction done.
    The keywords of 0.3 (`method=`, `runs=`, `budget=`, `seed=`, `memory=`, `polish=`) still work,
    with a `DeprecationWarning`.

    The data checks (`dcjax.analysis.checks`) run on every recording first: an `error` finding
    (a dead or alternating channel) raises a one-line `DataError`; the warnings are in the
    result's `checks`."""
    recordings = recordings_of(data, model)
    nd = getattr(getattr(integrator, "integrator", integrator), "substeps", 1)
    default = Search.for_steps(sum(len(r) for r in recordings) * nd if len(recordings) > 1 else 0)
    p = plan(model, search, observation=observation, integrator=integrator, default=default, legacy=legacy)
    (result,) = fit_sets(p, [RecordingSet(recordings, params)], "each", "raise", progress)
    return result  # pyright: ignore[reportReturnType]  # "raise": never a FailedFit
