"""`dcjax.fitting.fit`: one entry point in lmfit/optimistix vocabulary over the engine.

    params = dcjax.DC().parameters("table8"); params["Tlc"].set(value=0.0, vary=False)
    result = dcjax.fit(recording, params=params, method="de-rand-1-exp", integrator=dcjax.RK4(substeps=5), runs=50, polish=True)

Configuration is typed: integrators (`Euler`, `RK4`, a user's own `Integrator`, `AutoSubsteps`),
memories (`STMA`, `LTMA`, `IndexedLTMA`) and the observation (`dcjax.Observation`: loss, initial
states, offsets, delays) are small objects that carry their behaviour; what belongs to the data
(channel weights, the current limit, a joint fit's weights) lives with the recordings
(`with_weights`, `Recording.limit`); what belongs to the search (population size, F, CR, a
limit on the generations) with the strategy object (`dcjax.strategies.DERand1Exp(pop_size=40, f=0.5)`)."""

from collections.abc import Sequence

from ..analysis.checks import ERROR, recording_findings
from ..errors import ConfigError, DataError
from ..io.recording import Recording
from ..models import Model
from ..models.parameters import Parameters
from ..simulation.integrators import AutoSubsteps, Integrator
from ..strategies import Strategy
from ..strategies.memory import MemoryAssistance
from .engine import fit_setups
from .observation import Observation
from .result import FitResult
from .setup import plan


def recordings_of(data) -> list[Recording]:
    """`data` as a non-empty list of recordings (one recording, or a list of them)."""
    items = list(data) if isinstance(data, (list, tuple)) else [data]
    if not items or not all(isinstance(r, Recording) for r in items):
        raise ConfigError("data must be a dcjax.Recording or a non-empty list of them")
    return [r for r in items if isinstance(r, Recording)]


def fit(
    data: Recording | Sequence[Recording],
    model: Model | str | None = None,
    params: Parameters | str | None = None,
    method: str | Strategy = "de-rand-1-exp",
    *,
    observation: Observation | None = None,
    integrator: Integrator | AutoSubsteps | None = None,
    runs: int = 50,
    budget: int = 140_000,
    seed: int = 0,
    memory: MemoryAssistance | None = None,
    polish: bool = False,
    progress=None,
) -> FitResult:
    """Fit `model` (default the paper's DC drive) to `data`: one recording, or a list of recordings
    of one drive (a joint fit: one parameter set, the OF the mean of theirs or the sum weighted by
    each recording's `joint_weight`).

    `params`: `Parameters` (ranges, fixed values, start values, precisions), a preset name
    (`"table4"`, `"table8"`), `"auto"` (`dcjax.analysis.estimate.auto_bounds`: ranges from an
    equation-error first estimate, which also seeds the population), or None: the recordings'
    sidecar preset where they name one, else `"auto"`. `integrator`: `Euler(substeps=N)`,
    `RK4(substeps=N)` (the default, N = 1), a `dcjax.Integrator` of your own, or `AutoSubsteps(...)`.
    `method`: a strategy name or object (`dcjax.strategies.DERand1Exp(pop_size=70, generations=2000)`);
    `runs` independent runs of `budget` FEs (and at most the strategy's `generations` iterations;
    default as many as the budget buys without memory, paper Section 4.4), run r keyed by
    `fold_in(PRNGKey(seed), r)`. `memory`: `STMA()`, `LTMA(order=...)`, `IndexedLTMA()`. `polish`:
    Levenberg–Marquardt from every run's best. `progress`: True (a bar) or a callable taking the
    fraction done.

    `observation`: the terms beyond the paper's (`dcjax.Observation`): the loss (`"sse"`, eq.
    24/27, the default; `"l1"`; `"huber:DELTA"`; normalised by each channel's peak or not), the
    initial states (a number, `"measured"`, `"derivative"` or `"fit"`: a free `y0_<state>` per
    recording), sensor offsets (`offset_<channel>`), input delays (`delay_<input>`, s) and the
    states compared (`measure=("omega",)`: the speed alone; default the model's measured). A
    `Parameter(local=True)` of `params` gets one value per recording of a joint fit (`Tla[0]`,
    `Tla[1]`, ...); `params` may also hold `offset_*`, `delay_*`, `y0_*` entries (ranges, start
    values, `local`).

    The data checks (`dcjax.analysis.checks`) run on every recording first: an `error` finding
    (a dead or alternating channel) raises a one-line `DataError`; the warnings are in the
    result's `checks`."""
    recordings = recordings_of(data)
    p = plan(model, method, observation=observation, integrator=integrator, runs=runs, budget=budget, seed=seed, memory=memory,
             polish=polish)  # fmt: skip
    findings = recording_findings(recordings, p.model)
    errors = [f for f in findings if f.severity == ERROR]
    if errors:
        raise DataError(errors[0].check, errors[0].message)
    return fit_setups(p, [p.setup(recordings, params, findings=findings)], progress)[0]
