"""The 0.1 names, kept working over the 0.2 API; each warns (`DeprecationWarning`) on use.

| 0.1                                           | 0.2                                                        |
|-----------------------------------------------|------------------------------------------------------------|
| `identify(rec, integrator="rk4", nd=5, ...)`  | `fit(rec, integrator=RK4(substeps=5), ...)`                |
| `identify_each`, `identify_fleet`, `FleetResult` | `fit_each`                                              |
| `IdentificationResult`                        | `FitResult`                                                |
| `Params`, `PARAM_NAMES`                       | parameter vectors or dicts in `DC.names` order             |
| `TABLE4`, `TABLE8`, `bounds_preset(name)`     | `DC().parameters("table4")` (a `Parameters`)               |

`identify` gives the bits of the equivalent `fit`: it translates its arguments into the typed
objects (`Parameters`, a strategy, an integrator, a memory, recordings with their weights and
limit) and calls `fit`."""

import dataclasses
import inspect
import warnings
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .deprecation import warn_deprecated
from .errors import ConfigError
from .fitting.each import fit_each
from .fitting.engine import fit_setups
from .fitting.fit import fit
from .fitting.parameter_spec import parameters_of, resolve_parameters
from .fitting.planning import plan
from .fitting.problems import with_weights
from .fitting.result import FitResult
from .fitting.search import Search
from .io.recording import Recording
from .models import Model, get_model
from .models.bounds import Bounds, resolve_bounds
from .models.dc import NAMES, table4, table8
from .models.parameters import Parameters
from .simulation.integrators import AutoSubsteps, get_integrator
from .simulation.problem import check_positive_int
from .strategies import make_strategy
from .strategies.memory import get_memory

PARAM_NAMES: tuple[str, ...] = NAMES
TABLE4, TABLE8 = (Bounds(p.lower, p.upper, NAMES) for p in (table4(), table8()))


Leaf = Float[Array, "*batch"]  # a parameter's value, with any leading batch axes


class Params(eqx.Module):
    """The seven parameters of the paper's DC drive (Table 1) as a structured module (0.1).
    Leaves may carry leading batch axes."""

    Ra: Leaf
    La: Leaf
    cm: Leaf
    J: Leaf
    Tla: Leaf
    Tlb: Leaf
    Tlc: Leaf

    names: ClassVar[tuple[str, ...]] = NAMES

    @classmethod
    def from_array(cls, x: Float[ArrayLike, "*batch P"]) -> "Params":
        x = jnp.asarray(x, dtype=jnp.float64)
        if x.ndim == 0 or x.shape[-1] != len(NAMES):
            raise ConfigError(f"parameter vector must have {len(NAMES)} entries {NAMES}, got shape {x.shape}")
        return cls(*(x[..., k] for k in range(len(NAMES))))

    @classmethod
    def from_dict(cls, d: dict) -> "Params":
        missing = [n for n in NAMES if n not in d]
        if missing:
            raise ConfigError(f"missing parameters {missing}; need all of {NAMES}")
        return cls(*(jnp.asarray(d[n], dtype=jnp.float64) for n in NAMES))

    def to_array(self) -> Float[Array, "*batch P"]:
        return jnp.stack([getattr(self, n) for n in NAMES], axis=-1)

    def to_dict(self) -> dict[str, float]:
        return {n: float(np.asarray(getattr(self, n))) for n in NAMES}


def bounds_preset(name: str, model: Model | None = None) -> Bounds:
    """A named preset of `model` (default `DC`) as `Bounds`."""
    m = get_model(model)
    return Bounds(*m.bound_arrays(name), m.names)


def legacy_parameters(recordings, model: Model, bounds, fixed, x0, precision) -> tuple[Parameters, object]:
    """0.1's bounds/fixed/x0/precision as `Parameters` (and start rows that a `Parameters` cannot
    hold: a list of start vectors)."""
    if isinstance(bounds, str) and bounds.lower() == "auto":
        params = resolve_parameters("auto", recordings, model)[0]
        if x0 is not None:  # given start values replace the estimate's
            for p in params.values():
                p.value = None
    else:
        params = parameters_of(model, resolve_bounds(model, bounds))
    starts = None
    if isinstance(x0, dict):
        model.check_names(x0, "start value")
        for n, v in x0.items():
            params[n].set(value=v)
    elif x0 is not None:
        starts = x0
    for n, v in (fixed or {}).items():
        model.check_names([n], "fixed parameter")
        params[n].set(value=v, vary=False)
    if precision is not None:
        if isinstance(precision, dict):
            model.check_names(precision)
            given = precision
        else:
            arr = np.asarray(precision, float).reshape(-1)
            if arr.shape != (model.n_params,):
                raise ConfigError(f"precision needs {model.n_params} non-negative numbers {model.names}, got {precision!r}")
            given = dict(zip(model.names, arr))
        for n, v in given.items():
            params[n].set(precision=v)
    return params, starts


def _recordings(recording, model, weights, joint_weights, i_limit) -> list[Recording]:
    recs = list(recording) if isinstance(recording, (list, tuple)) else [recording]
    if not recs or not all(isinstance(r, Recording) for r in recs):
        raise ConfigError("recording must be a dcjax.Recording or a non-empty list of them")
    if joint_weights is not None:
        joint_weights = [float(w) for w in joint_weights]
        if len(joint_weights) != len(recs) or any(not w >= 0 for w in joint_weights) or sum(joint_weights) <= 0:
            raise ConfigError("joint_weights needs one non-negative weight per recording, not all zero")
    out = []
    for k, r in enumerate(recs):
        if i_limit is not None:
            r = r.replace(limit=float(i_limit))
        if weights is not None:
            w = [float(v) for v in weights]
            if len(w) != len(model.outputs):
                raise ConfigError(f"weights must be {len(model.outputs)} numbers (one per channel {model.outputs}), got {weights!r}")
            r = with_weights(r, dict(zip(model.outputs, w)))
        if joint_weights is not None:
            r = with_weights(r, joint_weight=joint_weights[k])
        out.append(r)
    return out


def identify(
    recording,
    method="de-rand-1-exp",
    integrator: str = "rk4",
    nd: int | str = 1,
    weights=None,
    bounds=None,
    runs: int = 50,
    budget: int = 140_000,
    seed: int = 0,
    polish: bool = False,
    pop_size: int = 70,
    i_limit: float | None = None,
    strategy_options: dict | None = None,
    joint_weights=None,
    nd_tol: float = 1e-4,
    nd_max: int = 64,
    memory: str | None = None,
    precision=None,
    generations: int | None = None,
    model=None,
    fixed=None,
    x0=None,
    progress=None,
) -> FitResult:
    """Deprecated (0.1): `dcjax.fit` with typed options; the same bits."""
    warn_deprecated("dcjax.identify(...)", "dcjax.fit(...) (integrator=dcjax.RK4(substeps=N), params=Parameters, ...)")
    m = get_model(model)
    if nd != "auto":
        check_positive_int("nd", nd)
    recs = _recordings(recording, m, weights, joint_weights, i_limit)
    params, starts = legacy_parameters(recs, m, bounds, fixed, x0, precision)
    strategy = _with_generations(make_strategy(method, pop_size=pop_size, **(strategy_options or {})), generations)
    integ = AutoSubsteps(get_integrator(integrator), nd_tol, nd_max) if nd == "auto" else get_integrator(integrator, nd)  # pyright: ignore[reportArgumentType]
    search = Search(strategy, runs, budget, seed, get_memory(memory), polish)
    if starts is not None:
        return _fit_with_starts(recs, m, params, starts, search, integ, progress)
    return fit(recs, m, params, search, integrator=integ, progress=progress)


def _with_generations(strategy, generations):
    """0.1's `generations=`: the strategy's own limit (0.2)."""
    if generations is None:
        return strategy
    check_positive_int("generations", generations)
    return dataclasses.replace(strategy, generations=int(generations))


def _fit_with_starts(recs, m, params, starts, search, integ, progress) -> FitResult:

    p = plan(m, search, integrator=integ)
    return fit_setups(p, [p.setup(recs, params, starts=starts)], progress)[0]


EACH_OPTIONS = tuple(
    "method integrator nd weights runs budget seed polish pop_size i_limit memory precision generations model fixed".split()
)


def identify_each(recordings, bounds=None, x0=None, **options) -> list[FitResult]:
    """Deprecated (0.1): `dcjax.fit_each`; the same bits. Raises what a recording raises."""
    warn_deprecated("dcjax.fitting.identify_each(...)", "dcjax.fit_each(...)")
    unknown = sorted(set(options) - set(EACH_OPTIONS))
    if unknown:
        raise ConfigError(f"identify_each: unknown option {', '.join(unknown)}; it takes {', '.join(EACH_OPTIONS)} (as identify)")
    defaults = {k: p.default for k, p in inspect.signature(identify).parameters.items()}  # identify's, spelled once
    o = {k: options.get(k, defaults[k]) for k in EACH_OPTIONS}
    method, integrator, nd, weights, runs, budget, seed, polish = (o[k] for k in EACH_OPTIONS[:8])
    pop_size, i_limit, memory, precision, generations, model, fixed = (o[k] for k in EACH_OPTIONS[8:])
    m = get_model(model)
    recs = [_recordings(r, m, weights, None, i_limit)[0] for r in recordings]
    bounds = list(bounds) if bounds is not None else [None] * len(recs)
    x0 = list(x0) if x0 is not None else [None] * len(recs)
    if len(bounds) != len(recs) or len(x0) != len(recs):
        raise ConfigError("bounds and x0 need one entry per recording")
    params = [legacy_parameters([r], m, b, fixed, s, precision)[0] for r, b, s in zip(recs, bounds, x0)]
    search = Search(
        _with_generations(make_strategy(method, pop_size=pop_size), generations), runs, budget, seed, get_memory(memory), polish
    )
    out = fit_each(recs, m, params, search, integrator=get_integrator(integrator, nd))
    for r in out:
        if not isinstance(r, FitResult):
            raise ConfigError(f"{r.name}: {r.error}")
    return out  # pyright: ignore[reportReturnType]


@dataclasses.dataclass
class FleetResult:
    """Deprecated (0.1): the fleet's table of best parameters beside each motor's full result."""

    params: np.ndarray  # (M, P) best of each motor's runs
    of: np.ndarray  # (M,)
    fes: np.ndarray  # (M, runs)
    timing: dict
    settings: dict
    names: tuple[str, ...] = ()
    results: list[FitResult] = dataclasses.field(default_factory=list, repr=False)

    def to_dicts(self) -> list[dict[str, float]]:
        return [dict(zip(self.names, map(float, x))) for x in self.params]


def identify_fleet(recordings: list[Recording], *, runs: int = 1, seed: int = 0, **options) -> FleetResult:
    """Deprecated (0.1): `dcjax.fit_each` of recordings of equal length."""
    warn_deprecated("dcjax.fitting.fleet.identify_fleet(...)", "dcjax.fit_each(...)")
    if not recordings or not all(isinstance(r, Recording) for r in recordings):
        raise ConfigError("recordings must be a non-empty list of dcjax.Recording")
    if len({len(r) for r in recordings}) != 1:
        raise ConfigError(f"fleet recordings must have equal length, got lengths {sorted({len(r) for r in recordings})}")
    if {r.limit is None for r in recordings} == {True, False}:
        raise ConfigError("either every recording of a fleet has a current limit or none has")
    if not isinstance(runs, int) or isinstance(runs, bool) or runs < 1:
        raise ConfigError(f"runs must be a positive integer, got {runs!r}")
    b = options.pop("bounds", None)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        results = identify_each(recordings, bounds=[b] * len(recordings), runs=runs, seed=seed, **options)
    first = results[0]
    run_s = first.timing.get("batch_run_s", first.timing["run_s"])
    return FleetResult(
        params=np.array([[r.best_values[k] for k in r.names] for r in results]),
        of=np.array([r.of for r in results]),
        fes=np.array([r.fes for r in results]),
        timing={
            "compile_s": first.timing["compile_s"],
            "run_s": run_s,
            "devices": first.timing["devices"],
            "motors_per_s": len(results) / run_s,
        },
        settings={**first.settings, "motors": len(results)},
        names=first.names,
        results=results,
    )


IdentificationResult = FitResult

# name -> (object, the 0.2 spelling) for `dcjax.__getattr__`
DEPRECATED = {
    "identify": (identify, "dcjax.fit"),
    "identify_each": (identify_each, "dcjax.fit_each"),
    "identify_fleet": (identify_fleet, "dcjax.fit_each"),
    "FleetResult": (FleetResult, "dcjax.fit_each's list of FitResult"),
    "IdentificationResult": (FitResult, "dcjax.FitResult"),
    "Params": (Params, "a parameter vector or dict in dcjax.DC.names order"),
    "PARAM_NAMES": (PARAM_NAMES, "dcjax.DC.names"),
    "TABLE4": (TABLE4, 'dcjax.DC().parameters("table4")'),
    "TABLE8": (TABLE8, 'dcjax.DC().parameters("table8")'),
    "bounds_preset": (bounds_preset, "model.parameters(name)"),
}
