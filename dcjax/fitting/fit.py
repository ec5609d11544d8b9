"""`dcjax.fitting.fit`: one entry point in lmfit/optimistix vocabulary over the engine `identify`.

    params = dcjax.DC().parameters("table8"); params["Tlc"].set(value=0.0, vary=False)
    result = dcjax.fit(recording, params=params, method="de-rand-1-exp", integrator=dcjax.RK4(substeps=5), runs=50, polish=True)

Configuration is typed: integrators (`Euler`, `RK4`, `AutoSubsteps`) and memories (`STMA`, `LTMA`,
`IndexedLTMA`) are small objects; what belongs to the data (channel weights, the current limit,
a joint fit's weights) lives with the recordings (`with_weights`, `Recording.limit`); what
belongs to the search (population size, F, CR) with the strategy object (`dcjax.strategies.DERand1Exp(pop_size=40, f=0.5)`)."""

from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import Literal

import equinox as eqx

from ..io.recording import Recording
from ..models import Model, get_model
from ..models.parameters import Parameters
from ..strategies import Strategy
from .identify import identify
from .result import IdentificationResult


class Integrator(eqx.Module):
    """Fixed-step integration of the model between samples with `substeps` equal sub-steps (eq. 28)."""

    substeps: int = 1
    name = ""


class Euler(Integrator):
    """Forward Euler (paper eq. 11–12)."""

    name = "euler"


class RK4(Integrator):
    """Classical Runge–Kutta (paper eq. 14–23)."""

    name = "rk4"


class AutoSubsteps(eqx.Module):
    """The sub-steps chosen against an adaptive diffrax reference (paper Section 5): fit at 1, take
    the first of 1, 2, 4, ... `max_substeps` within `tol` of the reference (relative to each
    channel's peak), refit there."""

    integrator: Integrator = RK4()
    tol: float = 1e-4
    max_substeps: int = 64


class Memory(eqx.Module):
    """Memory assistance (paper Section 4.4): a candidate within the parameters' precisions of a
    record is not simulated."""

    @property
    def kind(self) -> str:
        raise NotImplementedError


class STMA(Memory):
    """Short-term memory: the previous iteration's population."""

    @property
    def kind(self) -> str:
        return "stma"


class LTMA(Memory):
    """Long-term memory: the whole history, searched oldest first (S1) or newest first (S2)."""

    order: Literal["oldest", "newest"] = "newest"

    @property
    def kind(self) -> str:
        if self.order not in ("oldest", "newest"):
            raise ValueError(f"LTMA order must be 'oldest' or 'newest', got {self.order!r}")
        return "ltma-s1" if self.order == "oldest" else "ltma-s2"


class IndexedLTMA(Memory):
    """Long-term memory indexed by precision-grid cells (an open-addressing table)."""

    @property
    def kind(self) -> str:
        return "ltma-hash"


# The typed options by the names the CLI, the sidecars and the experiments' store spell them.
INTEGRATORS: Mapping[str, type[Integrator]] = MappingProxyType({"euler": Euler, "rk4": RK4})
MEMORIES: Mapping[str, Memory] = MappingProxyType({m.kind: m for m in (STMA(), LTMA(order="oldest"), LTMA(order="newest"), IndexedLTMA())})


def with_weights(recording: Recording, weights: Mapping[str, float] | None = None, joint_weight: float | None = None) -> Recording:
    """The recording with its objective weights: `weights` per measured channel (eq. 27's w1, w2;
    default all 1, eq. 24) and, in a joint fit, its `joint_weight` (default equal shares)."""
    meta = dict(recording.metadata)
    if weights is not None:
        meta["weights"] = {str(k): float(v) for k, v in weights.items()}
    if joint_weight is not None:
        meta["joint_weight"] = float(joint_weight)
    return recording.replace(metadata=meta)


def channel_weights(recordings: list[Recording], model: Model):
    given = [r.metadata.get("weights") for r in recordings]
    if all(g is None for g in given):
        return None
    if any(g != given[0] for g in given):
        raise ValueError("the recordings of a joint fit must carry the same channel weights")
    w = dict(given[0])  # pyright: ignore[reportArgumentType]
    bad = [c for c in w if c not in model.outputs]
    if bad:
        raise ValueError(f"weights: unknown channel(s) {bad}; model {model.name} compares {', '.join(model.outputs)}")
    return tuple(float(w.get(c, 1.0)) for c in model.outputs)


def search_options(params, recordings: list[Recording], model: Model) -> dict:
    """identify's bounds/fixed/x0/precision from `params` (None: each recording's sidecar preset,
    else "auto"; a preset name; "auto"; or `Parameters`)."""
    if params is None:
        named = {r.metadata.get("bounds") for r in recordings}
        preset = named.pop() if len(named) == 1 else None
        params = preset if preset in model.preset_names else "auto"
    if isinstance(params, str):
        return {"bounds": params}
    if not isinstance(params, Parameters):
        raise ValueError(
            f"params must be None, 'auto', a preset name {sorted(model.preset_names)} or dcjax.Parameters, got {type(params).__name__}"
        )
    params.check(model.names, model.name)
    fixed = params.fixed
    lo, hi = params.lower.copy(), params.upper.copy()
    for k, n in enumerate(model.names):
        if n in fixed and not lo[k] <= fixed[n] <= hi[k]:  # a known value outside (or without) a range
            lo[k] = hi[k] = fixed[n]
    precision = {n: p.precision for n, p in params.items() if p.precision is not None}  # the rest: the model's
    return {"bounds": (lo, hi), "fixed": fixed or None, "x0": params.start or None, "precision": precision or None}


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
    memory: Memory | None = None,
    polish: bool = False,
    progress=None,
) -> IdentificationResult:
    """Fit `model` (default the paper's DC drive) to `data`: one recording, or a list of recordings
    of one drive (a joint fit: one parameter set, the OF the mean of theirs or the sum weighted by
    each recording's `joint_weight`).

    `params`: `Parameters` (ranges, fixed values, start values, precisions), a preset name
    (`"table4"`, `"table8"`), `"auto"` (`dcjax.analysis.estimate.auto_bounds`: ranges from an
    equation-error first estimate, which also seeds the population), or None: the recordings'
    sidecar preset where they name one, else `"auto"`. `integrator`: `Euler(substeps=N)`,
    `RK4(substeps=N)` (the default, N = 1) or `AutoSubsteps(...)`. `method`: a strategy name or object
    (`dcjax.strategies.DERand1Exp(pop_size=70)`); `runs` independent runs of `budget` FEs, run r
    keyed by `fold_in(PRNGKey(seed), r)`; `generations` stops each run after that many iterations
    (default: as many as the budget buys without memory, paper Section 4.4). `memory`: `STMA()`, `LTMA(order=...)`,
    `IndexedLTMA()`. `polish`: Levenberg–Marquardt from every run's best. `progress`: True (a
    bar) or a callable taking the fraction done."""
    items = list(data) if isinstance(data, (list, tuple)) else [data]
    if not items or not all(isinstance(r, Recording) for r in items):
        raise ValueError("data must be a dcjax.Recording or a non-empty list of them")
    recordings: list[Recording] = [r for r in items if isinstance(r, Recording)]
    m = get_model(model)
    jw = [r.metadata.get("joint_weight") for r in recordings]
    joint = None if all(w is None for w in jw) else [1.0 if w is None else float(w) for w in jw]
    return identify(
        recordings,
        weights=channel_weights(recordings, m),
        joint_weights=joint,
        model=m,
        progress=progress,
        **engine_options(method, integrator, memory, polish, runs, budget, seed, generations),
        **search_options(params, recordings, m),
    )


def engine_options(method, integrator, memory, polish, runs: int, budget: int, seed: int, generations: int | None = None) -> dict:
    """`identify`'s spelling of the typed options (integrator and memory objects, a strategy)."""
    integrator = RK4() if integrator is None else integrator
    if isinstance(integrator, AutoSubsteps):
        steps = {"integrator": integrator.integrator.name, "nd": "auto", "nd_tol": integrator.tol, "nd_max": integrator.max_substeps}
    elif isinstance(integrator, Integrator) and integrator.name:
        steps = {"integrator": integrator.name, "nd": integrator.substeps}
    else:
        raise ValueError(f"integrator must be dcjax.Euler(...), dcjax.RK4(...) or dcjax.AutoSubsteps(...), got {integrator!r}")
    if memory is not None and not isinstance(memory, Memory):
        raise ValueError(f"memory must be None, dcjax.STMA(), dcjax.LTMA(order=...) or dcjax.IndexedLTMA(), got {memory!r}")
    pop = method.pop_size if isinstance(method, Strategy) else 70
    return dict(method=method, runs=runs, budget=budget, seed=seed, polish=bool(polish), pop_size=pop, generations=generations,
                memory=None if memory is None else memory.kind, **steps)  # fmt: skip
