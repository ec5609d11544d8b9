"""`dcjax.fitting.fit`: one entry point in lmfit/optimistix vocabulary over the engine.

    params = dcjax.DC().parameters("table8"); params["Tlc"].set(value=0.0, vary=False)
    result = dcjax.fit(recording, params=params, method="de-rand-1-exp", integrator=dcjax.RK4(substeps=5), runs=50, polish=True)

Configuration is typed: integrators (`Euler`, `RK4`, a user's own `Integrator`, `AutoSubsteps`)
and memories (`STMA`, `LTMA`, `IndexedLTMA`) are small objects that carry their behaviour; what
belongs to the data (channel weights, the current limit, a joint fit's weights) lives with the
recordings (`with_weights`, `Recording.limit`); what belongs to the search (population size, F,
CR) with the strategy object (`dcjax.strategies.DERand1Exp(pop_size=40, f=0.5)`)."""

from collections.abc import Sequence

import numpy as np

from ..io.recording import Recording
from ..models import Model, get_model
from ..models.base import DiscreteModel
from ..models.parameters import Parameters
from ..simulation.integrators import RK4, AutoSubsteps, Integrator, integrator_for
from ..strategies import Strategy, make_strategy
from ..strategies.memory import MemoryAssistance
from .engine import Search, fit_setup, prepare
from .observation import Observation
from .result import FitResult
from .vector import resolve_parameters


def recordings_of(data) -> list[Recording]:
    """`data` as a non-empty list of recordings (one recording, or a list of them)."""
    items = list(data) if isinstance(data, (list, tuple)) else [data]
    if not items or not all(isinstance(r, Recording) for r in items):
        raise ValueError("data must be a dcjax.Recording or a non-empty list of them")
    return [r for r in items if isinstance(r, Recording)]


def search_of(method, runs, budget, generations, seed, memory, polish) -> Search:
    """The typed `Search` of `fit`'s options (a method name becomes its strategy, NP = 70)."""
    strategy = make_strategy(method) if not isinstance(method, Strategy) else method
    return Search(strategy, memory, runs, budget, generations, seed, polish)


def observation_of(model: Model, loss=None, initial=None, offsets=(), delays=(), polish: bool = False) -> Observation:
    """The typed `Observation` of `fit`'s options, checked against `model` (one-line errors)."""
    from ..simulation.losses import Loss, get_loss

    if loss is not None and not isinstance(loss, (str, Loss)):
        raise ValueError(f"loss must be sse, l1, huber:DELTA or a dcjax Loss (dcjax.L1(), dcjax.Huber(delta=0.1)), got {loss!r}")
    if initial is not None and not isinstance(initial, dict):
        raise ValueError(f"initial must be a state -> number|'measured'|'derivative'|'fit' mapping, got {initial!r}")
    for what, names in (("offsets", offsets), ("delays", delays)):
        if isinstance(names, str) or not all(isinstance(n, str) for n in names):
            raise ValueError(f"{what} must be a list of channel names, got {names!r}")
    obs = Observation(get_loss(loss), dict(initial or {}), tuple(offsets), tuple(delays)).check(model)
    if polish and not obs.loss.least_squares:
        raise ValueError(f"polish: Levenberg-Marquardt needs a least-squares loss (sse or huber); the {obs.loss.spec} loss has none")
    return obs


def check_integrator(integrator, model: Model | None = None) -> Integrator | AutoSubsteps:
    """The fit's integrator: the given one (default RK4), or a discrete-time model's `SampleMap`."""
    if isinstance(model, DiscreteModel):
        if isinstance(integrator, AutoSubsteps):
            raise ValueError(f"model {model.name} is a discrete-time model: AutoSubsteps (sub-steps) does not apply")
        return integrator_for(model, integrator)
    integrator = RK4() if integrator is None else integrator
    if not isinstance(integrator, (Integrator, AutoSubsteps)):
        raise ValueError(
            f"integrator must be dcjax.Euler(...), dcjax.RK4(...), a dcjax.Integrator of your own or dcjax.AutoSubsteps(...), got {integrator!r}"
        )
    return integrator


def fit(
    data: Recording | Sequence[Recording],
    model: Model | str | None = None,
    params: Parameters | str | None = None,
    method: str | Strategy = "de-rand-1-exp",
    *,
    integrator: Integrator | AutoSubsteps | None = None,
    runs: int = 50,
    budget: int = 140_000,
    generations: int | None = None,
    seed: int = 0,
    memory: MemoryAssistance | None = None,
    polish: bool = False,
    loss=None,
    initial: dict | None = None,
    offsets: Sequence[str] = (),
    delays: Sequence[str] = (),
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
    `method`: a strategy name or object (`dcjax.strategies.DERand1Exp(pop_size=70)`); `runs`
    independent runs of `budget` FEs, run r keyed by `fold_in(PRNGKey(seed), r)`; `generations`
    stops each run after that many iterations (default: as many as the budget buys without memory,
    paper Section 4.4). `memory`: `STMA()`, `LTMA(order=...)`, `IndexedLTMA()`. `polish`:
    Levenberg–Marquardt from every run's best. `progress`: True (a bar) or a callable taking the
    fraction done.

    Beyond the paper's terms (`dcjax.fitting.observation`, `dcjax.fitting.vector`): `loss` (`"sse"`,
    the default, eq. 24/27; `"l1"`; `"huber:DELTA"`; or `dcjax.SSE/L1/Huber(normalize="peak"|"none")`;
    "none" pools a joint fit's recordings by sample count), `initial` (state -> a number,
    `"measured"`, `"derivative"` or `"fit"`: a free `y0_<state>` per recording), `offsets`
    (measured channels with a free additive sensor offset `offset_<channel>`), `delays` (inputs
    with a free delay `delay_<input>` in seconds). A `Parameter(local=True)` of `params` gets one
    value per recording of a joint fit (`Tla[0]`, `Tla[1]`, ...); `params` may also hold
    `offset_*`, `delay_*`, `y0_*` entries (ranges, start values, `local`)."""
    recordings = recordings_of(data)
    m = get_model(model)
    integrator = check_integrator(integrator, m)
    search = search_of(method, runs, budget, generations, seed, memory, polish)
    observation = observation_of(m, loss, initial, offsets, delays, polish)
    resolved = resolve_parameters(params, recordings, m)
    if isinstance(integrator, AutoSubsteps):
        local = len(recordings) > 1 and any(p.local for p in resolved.values())
        if local or observation.fitted_states() or observation.offsets or observation.delays:
            raise ValueError("nd auto: not with local parameters, fitted initial states, offsets or delays; give the sub-steps (--nd N)")
        result = fit_auto_substeps(recordings, m, resolved, integrator, search, progress, observation)
    else:
        result = fit_setup(prepare(recordings, m, resolved, integrator, observation=observation), search, progress)
    result.checks = recording_findings(recordings, m)
    return result


def recording_findings(recordings: list[Recording], model: Model) -> list:
    """The data checks of every recording of a fit (`dcjax.analysis.checks`), each message
    prefixed with its recording's name in a joint fit."""
    import dataclasses

    from ..analysis.checks import check_recording

    out = []
    for r in recordings:
        for f in check_recording(r, model):
            out.append(f if len(recordings) == 1 else dataclasses.replace(f, message=f"{r.name}: {f.message}"))
    return out


def fit_auto_substeps(
    recordings, model, params: Parameters, auto: AutoSubsteps, search: Search, progress=None, observation: Observation | None = None
) -> FitResult:
    """Paper Section 5: fit at ND = 1; at its best parameters compare the simulation at ND = 1, 2,
    4, ... with an adaptive diffrax reference (`dcjax.simulation.diffrax_reference`) and take the
    first ND whose error (max over channels of max |y - y_ref| / max |y_measured|) is at most
    `auto.tol`; refit there, and repeat from that fit until the ND stays (at most 3 rounds).
    `settings["nd_auto"]` records the choice."""
    from ..simulation.diffrax_reference import reference_simulate_jit, simulation_error
    from ..simulation.problem import make_problem

    kind = type(auto.integrator)

    def fit_at(nd: int) -> FitResult:
        return fit_setup(prepare(recordings, model, params, kind(substeps=nd), observation=observation), search, progress)

    def errors_at(result: FitResult, nds):
        x = np.array([result.best_values[n] for n in model.names])
        refs = [reference_simulate_jit(x, p) for p in result.problems()]
        weights = tuple(result.settings["weights"])
        out = {}
        for nd in nds:
            obs = observation or Observation()
            probs = [make_problem(r, kind(substeps=nd), weights, model=model, initial=obs.initial_values(model, r)) for r in recordings]
            out[nd] = max(simulation_error(x, p, ref) for p, ref in zip(probs, refs))
        return out

    res = fit_at(1)
    candidates = [2**k for k in range(int(np.log2(auto.max_substeps)) + 1)]
    nd, rounds = 1, []
    for _ in range(3):  # a refit can move the parameters to where another ND is needed
        errors = errors_at(res, candidates)
        rounds.append({"fit_nd": nd, "errors": {str(k): v for k, v in errors.items()}})
        chosen = next((k for k in candidates if errors[k] <= auto.tol), None)
        if chosen is None:  # no ND meets tol: stop where doubling no longer halves the error
            stalled = [b for a, b in zip(candidates, candidates[1:]) if errors[b] > 0.5 * errors[a]]
            chosen = stalled[0] // 2 if stalled else candidates[-1]
        if chosen == nd:
            break
        nd = chosen
        res = fit_at(nd)
    final = errors_at(res, [nd])[nd]
    res.settings["nd_auto"] = {
        "tol": auto.tol,
        "max": auto.max_substeps,
        "chosen": nd,
        "converged": bool(final <= auto.tol),
        "reference_error": final,
        "errors_at_nd1_fit": rounds[0]["errors"],
        "rounds": rounds,
        "reference": "diffrax Dopri8, PID rtol 1e-10 atol 1e-12, jump_ts at the samples",
    }
    return res
