"""`identify`: independent evolutionary runs on one recording (or a joint set), batched into
one compiled call, with an optional Levenberg–Marquardt polish (paper Sections 2–5)."""

import itertools
import time
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import PartitionSpec

from ..io.recording import Recording
from ..models import Model, get_model
from ..models.bounds import Bounds, resolve_bounds
from ..models.precision import physical_precision, unit_precision
from ..models.space import Space, make_space
from ..simulation.kernel import kernel_mode
from ..simulation.objectives import objective
from ..simulation.problem import check_positive_int, make_problem
from ..strategies import Strategy, make_strategy
from ..strategies.base import FitnessFn, hyperparameters, iteration_limit, run_batch, structure_key, with_hyperparameters
from ..strategies.memory import MEMORY_KINDS
from .result import IdentificationResult, model_spec
from .runner import ExecutableCache, fold_keys, leaf_signature, mesh_of, padded_size, shard

# The last few executables by (strategy, settings, argument shapes): consecutive cells of a sweep
# (other weights, bounds or recordings of equal length) reuse them.
EXECUTABLES = ExecutableCache(size=6)
PROGRESS_CHUNKS = 20


def _tqdm_progress(total: int):
    """A callback that moves a tqdm bar (on stderr) to `fraction * total`; `None` closes it."""
    from tqdm import tqdm

    bar = tqdm(total=total, unit="it", desc="iterations (all runs)", leave=False, dynamic_ncols=True)

    def report(fraction):
        if fraction is None:
            bar.close()
            return
        bar.update(int(round(fraction * total)) - bar.n)

    return report


def _fitness(space, problems, jw) -> FitnessFn:
    def of(z):
        x = space.to_physical(z)
        return sum(w * objective(x, prob) for w, prob in zip(jw, problems))

    return of  # pyright: ignore[reportReturnType]


def _per_device(fn, mesh, n_args: int, memory=True):
    """On several devices, each device runs its own vmapped batch of runs (shard_map): compaction
    stays local to the device (memory), and a device's loop does not wait for the others'. The
    first argument is split along the runs."""
    if memory is None or mesh is None:
        return fn
    spec, rep = PartitionSpec("runs"), PartitionSpec()
    return jax.shard_map(fn, mesh=mesh, in_specs=(spec, *[rep] * (n_args - 1)), out_specs=spec, check_vma=False)


class ProgressMeter:
    """One call's progress: the compiled runs report each device's runs' fractions done (a
    `jax.debug.callback`, once per device and chunk, outside the vmap over runs, in any order),
    and the meter calls `target` with the fraction of all runs done."""

    def __init__(self, target: Callable[[float], object], total: int):
        self.target, self.total = target, total
        self.done: dict[int, np.ndarray] = {}

    def report(self, device, done) -> None:
        old = self.done.get(int(device))  # unordered callbacks: keep the furthest state seen of every run
        self.done[int(device)] = np.asarray(done) if old is None else np.maximum(old, done)
        self.target(float(sum(np.sum(d) for d in self.done.values()) / self.total))  # devices not heard from: not started


_TOKENS = itertools.count(1)
_METERS: dict[int, ProgressMeter] = {}  # the meters of the calls running now, by the token each passes its executable


def _report(token, device, done) -> None:
    meter = _METERS.get(int(token))
    if meter is not None:
        meter.report(device, done)


def _batched_runs(strategy, budget, memory, generations, jw, mesh, dim, progress: bool = False):
    """All runs as one function of (keys, problems, space, precision, x0): data are arguments,
    not constants, so recordings of equal length (and other weights or bounds) reuse one
    executable. Each device runs its share of the runs with `run_batch`; with `progress` it
    reports the fraction done `PROGRESS_CHUNKS` times (`jax.debug.callback`, same results)."""
    t_max = iteration_limit(strategy, budget, generations)

    def device_runs(keys, problems, space, prec, x0, hyper, token):
        report = None
        if progress:
            device = jax.lax.axis_index("runs") if mesh is not None else 0
            report = lambda done: jax.debug.callback(_report, token, device, done)
        return run_batch(
            with_hyperparameters(strategy, hyper), keys, _fitness(space, problems, jw), budget, dim, memory, prec, generations, x0,
            report=report, report_every=max(1, -(-t_max // PROGRESS_CHUNKS)),
        )  # fmt: skip

    return jax.jit(_per_device(device_runs, mesh, 7))


def start_values(x0, model: Model, space: Space) -> np.ndarray | None:
    """Start values as unit-cube rows (K, D) of the free parameters, NaN where not given. `x0`:
    a name -> value mapping, a list of them, or full parameter vectors (K, P)."""
    if x0 is None:
        return None
    rows = x0 if isinstance(x0, (list, tuple)) and x0 and isinstance(x0[0], dict) else [x0] if isinstance(x0, dict) else None
    if rows is None:
        full = np.atleast_2d(np.asarray(x0, dtype=np.float64))
        if full.shape[-1] != model.n_params:
            raise ValueError(f"x0 must be name -> value mappings or vectors of {model.n_params} values {model.names}")
        rows = [dict(zip(model.names, r)) for r in full]
    lo, hi = np.asarray(space.lower), np.asarray(space.upper)
    out = np.full((len(rows), space.dim), np.nan)
    for i, row in enumerate(rows):
        model.check_names(row, "start value")
        for n, v in row.items():
            if n in space.fixed:
                continue
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise ValueError(f"start value of {n} must be a number, got {v!r}") from None
            j = space.free_names.index(n)
            if not lo[j] <= v <= hi[j]:
                raise ValueError(f"start value {n}={v:g} lies outside its bounds [{lo[j]:g}, {hi[j]:g}]")
            out[i, j] = (v - lo[j]) / (hi[j] - lo[j])
    return out


def _search_space(recordings, model, bounds, fixed, x0):
    """(bounds, space, start values, start values in the unit cube); `bounds="auto"` estimates
    the ranges (`dcjax.analysis.estimate.auto_bounds`) and, where no `x0` is given, seeds the search with
    the estimate."""
    if isinstance(bounds, str) and bounds.lower() == "auto":
        from ..analysis.estimate import auto_bounds

        bounds, start, _ = auto_bounds(recordings, model)
        x0 = x0 if x0 is not None else {n: v for n, v in start.items() if n not in (fixed or {})} or None
    b = resolve_bounds(model, bounds)
    space = make_space(model, b, fixed)
    return b, space, x0, start_values(x0, model, space)


def _check_search(runs, budget, pop_size, seed, memory, generations) -> None:
    for name, v in (("runs", runs), ("budget", budget), ("pop_size", pop_size)):
        check_positive_int(name, v)
    if budget < pop_size:
        raise ValueError(f"budget ({budget}) must be at least one population ({pop_size})")
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool):
        raise ValueError(f"seed must be an integer, got {seed!r}")
    if memory is not None and memory not in MEMORY_KINDS:
        raise ValueError(f"memory must be None or one of {MEMORY_KINDS}, got {memory!r}")
    if generations is not None:
        check_positive_int("generations", generations)


def _run_all(strategy, budget, memory, generations, jw, space, data, runs: int, seed: int, progress):
    """Every run in one compiled call (each device its share), with progress reports; returns the
    runs' outputs (padding dropped) and the timing."""
    problems, prec, z0 = data
    devices = jax.devices() if runs > 1 else jax.devices()[:1]
    mesh = mesh_of(devices, "runs")
    keys = shard(fold_keys(seed, padded_size(runs, devices)), mesh, "runs")
    token = next(_TOKENS)
    args = (keys, problems, space, prec, None if z0 is None else jnp.asarray(z0), hyperparameters(strategy), jnp.asarray(token, jnp.int64))
    cache_key = (structure_key(strategy), budget, memory, generations, tuple(jw), len(devices), kernel_mode(), leaf_signature(args))
    show = progress is not None and progress is not False
    t0 = time.perf_counter()
    compiled, reused = EXECUTABLES.get(
        (*cache_key, show), lambda: _batched_runs(strategy, budget, memory, generations, tuple(jw), mesh, space.dim, show), args
    )
    t1 = time.perf_counter()
    report = (progress if callable(progress) else _tqdm_progress(runs * iteration_limit(strategy, budget, generations))) if show else None
    if report is not None:
        _METERS[token] = ProgressMeter(report, int(keys.shape[0]))
    try:
        out = jax.block_until_ready(compiled(*args))
        jax.effects_barrier()
        if report is not None:
            report(1.0)
    finally:
        _METERS.pop(token, None)
        if show and not callable(progress):
            report(None)  # pyright: ignore[reportOptionalCall]
    t2 = time.perf_counter()
    compile_s, run_s = t1 - t0, t2 - t1
    out = jax.tree.map(lambda a: a[:runs], out)
    return out, {"compile_s": compile_s, "run_s": run_s, "devices": len(devices), "reused_executable": reused}


def _polish(run_x, problems, space, jw):
    """Levenberg–Marquardt from every run's best: (parameters, OFs, what the polish did)."""
    from .polish import polish_batch

    t0 = time.perf_counter()
    pol = jax.block_until_ready(polish_batch(jnp.asarray(run_x), problems, space, jw))
    info = {
        "of_before": np.asarray(pol.of_before).tolist(),
        "of_after": np.asarray(pol.of_after).tolist(),
        "steps": np.asarray(pol.steps).tolist(),
        "time_s": time.perf_counter() - t0,
    }
    return np.asarray(pol.x), np.asarray(pol.of_after), info


_PASSED_ON = ("method", "integrator", "weights", "bounds", "runs", "budget", "seed", "polish", "pop_size", "i_limit", "strategy_options",
              "joint_weights", "memory", "precision", "generations", "model", "fixed", "x0")  # fmt: skip


def _source(r: Recording):
    """Where a recording came from (its loader's record, else its name), with the limit fitted."""
    src = r.metadata.get("source", {"name": r.name})
    return {**src, "limit": r.limit} if isinstance(src, dict) else src


def _settings(recordings, model, strategy, space, b, given: dict) -> dict:
    """What a result records of its configuration (`given`: identify's arguments)."""
    method, integrator, nd, weights, x0 = (given[k] for k in ("method", "integrator", "nd", "weights", "x0"))
    runs, budget, seed, pop_size, polish = (given[k] for k in ("runs", "budget", "seed", "pop_size", "polish"))
    i_limit, memory, precision, generations, joint_weights = (
        given[k] for k in ("i_limit", "memory", "precision", "generations", "joint_weights")
    )
    name = method if isinstance(method, str) else type(method).__name__
    return {
        "recording": recordings[0].name if len(recordings) == 1 else [r.name for r in recordings],
        "data": [_source(r) for r in recordings],
        "model": model_spec(model),
        "joint_weights": joint_weights,
        "method": name,
        "integrator": integrator,
        "nd": nd,
        "weights": [float(w) for w in (weights if weights is not None else [1.0] * len(model.outputs))],
        "bounds": {"lower": np.asarray(b.lower).tolist(), "upper": np.asarray(b.upper).tolist()},
        "fixed": space.fixed,
        "x0": None if x0 is None else (x0 if isinstance(x0, (dict, list)) else np.asarray(x0).tolist()),
        "runs": runs,
        "budget": budget,
        "seed": seed,
        "pop_size": pop_size,
        "polish": polish,
        "i_limit": i_limit,
        "memory": memory,
        "precision": None if memory is None else physical_precision(precision, model).tolist(),
        "generations": generations,
        "strategy": repr(strategy),
        "ndata": int(sum(len(r) * len(model.outputs) for r in recordings)),
    }


def identify(
    recording: Recording | list[Recording],
    method: str | Strategy = "de-rand-1-exp",
    integrator: str = "rk4",
    nd: int | str = 1,
    weights: tuple[float, ...] | None = None,
    bounds: Bounds | str | tuple | dict | None = None,
    runs: int = 50,
    budget: int = 140_000,
    seed: int = 0,
    polish: bool = False,
    pop_size: int = 70,
    i_limit: float | None = None,
    strategy_options: dict | None = None,
    joint_weights: list[float] | None = None,
    nd_tol: float = 1e-4,
    nd_max: int = 64,
    memory: str | None = None,
    precision=None,
    generations: int | None = None,
    model: Model | str | None = None,
    fixed: dict[str, float] | None = None,
    x0=None,
    progress=None,
) -> IdentificationResult:
    """Identify the parameters of `model` (default: the paper's DC drive, `Ra, La, cm, J, Tla,
    Tlb, Tlc`) from `recording`.

    `runs` independent runs of `method` (paper defaults: NP = 70, 140,000 FEs) are `vmap`ped into
    one compiled call; run r uses `jax.random.fold_in(PRNGKey(seed), r)`, so a run does not depend
    on how many others are made. `bounds`: a `Bounds`, a preset name of the model (`"table4"`, the
    default, or `"table8"`), a `(lower, upper)` pair, or a name -> (lower, upper) mapping over the
    default preset. `fixed` (name -> value): known parameters, not searched (the strategies see
    only the free ones). `x0`: start values (name -> value, or a list of them) that replace the
    first members of every run's initial population. `polish=True` runs Levenberg–Marquardt from
    every run's best.

    Joint fit: a list of recordings of one drive (each with its own voltage, limit and initial
    state) shares the parameters; the OF is the mean of their OFs, or the weighted sum with
    `joint_weights` (Section 4.2.5's argument that MD1–MD3 must give one parameter set).

    `nd="auto"` (paper Section 5): fit at ND = 1, then choose the smallest ND (1, 2, 4, ... up to
    `nd_max`) whose simulation at that fit is within `nd_tol` (relative to each channel's peak) of
    an adaptive diffrax reference solve, and refit there (repeated, at most 3 rounds, while a refit
    asks for another ND); `settings["nd_auto"]` records the chosen ND, its reference error at the
    final fit and the error of every ND tried in each round.

    `memory` (Section 4.4): `None`, `"stma"`, `"ltma-s1"` or `"ltma-s2"`; a candidate within
    `precision` (physical units, default the model's: Table 29, see `dcjax.strategies.memory`)
    of a record is not simulated and costs no FE. A run makes as many iterations as without
    memory (`generations` overrides): the paper's Tables 30–33 compare equal iteration counts,
    1999 DE steps after the initial population = 70 x 2000 candidates.

    `progress`: `True` shows a tqdm bar of the iterations done (over all runs), a callable is
    called with the fraction done (0..1), `PROGRESS_CHUNKS` times during the run, from inside the
    compiled loop (same results as without progress)."""
    recordings = recording if isinstance(recording, (list, tuple)) else [recording]
    if not recordings or not all(isinstance(r, Recording) for r in recordings):
        raise ValueError("recording must be a dcjax.Recording or a non-empty list of them")
    model = get_model(model)
    if joint_weights is not None:
        joint_weights = [float(w) for w in joint_weights]
        if len(joint_weights) != len(recordings) or any(not w >= 0 for w in joint_weights) or sum(joint_weights) <= 0:
            raise ValueError("joint_weights needs one non-negative weight per recording, not all zero")
    if nd == "auto":
        given = locals()
        return _identify_auto_nd(recordings, nd_tol=nd_tol, nd_max=nd_max, **{k: given[k] for k in _PASSED_ON})
    _check_search(runs, budget, pop_size, seed, memory, generations)
    assert not isinstance(nd, str)
    b, space, x0, z0 = _search_space(recordings, model, bounds, fixed, x0)
    prec = None if memory is None else jnp.asarray(unit_precision(precision, space, model))
    strategy = make_strategy(method, pop_size=pop_size, **(strategy_options or {}))
    problems = [make_problem(r, model=model, integrator=integrator, nd=nd, weights=weights, i_limit=i_limit) for r in recordings]
    jw = joint_weights or [1.0 / len(problems)] * len(problems)

    out, timing = _run_all(strategy, budget, memory, generations, jw, space, (problems, prec, z0), runs, seed, progress)
    run_x = np.asarray(space.to_physical(out.best_x))
    run_of = np.asarray(out.best_f)
    polish_info = None
    if polish:
        run_x, run_of, polish_info = _polish(run_x, problems, space, jw)
    settings = _settings(recordings, model, strategy, space, b, locals())
    return make_result(recordings, model, space, out, (run_x, run_of, polish_info), settings, timing)


def make_result(recordings, model, space, out, polished, settings: dict, timing: dict) -> IdentificationResult:
    """The result of the runs `out` (one recording's or a joint fit's), after the optional polish:
    `polished` = (parameters (R, P), OFs (R,), what the polish did or None)."""
    run_x, run_of, polish_info = polished
    best = int(np.argmin(run_of))
    memory = settings["memory"]
    return IdentificationResult(
        best_values=dict(zip(model.names, map(float, run_x[best]))),
        of=float(run_of[best]),
        run_of=run_of,
        run_params=run_x,
        fes=np.asarray(out.fes),
        iterations=np.asarray(out.iterations),
        history=np.asarray(out.history),
        settings=settings,
        timing=timing,
        polish=polish_info,
        dups=None if memory is None else np.asarray(out.dups),
        memory_chunks=None if memory is None else np.asarray(out.chunks),
        recordings=list(recordings),
        model=model,
        fixed=space.fixed,
    )


def _identify_auto_nd(recordings, nd_tol, nd_max, **kw) -> IdentificationResult:
    """Fit at ND = 1; at its best parameters compare the simulation at ND = 1, 2, 4, ... with an
    adaptive diffrax reference (`dcjax.simulation.reference_solve`) and take the first ND whose error (max
    over channels of max |y - y_ref| / max |y_measured|) is at most `nd_tol`; refit there, and
    repeat from that fit until the ND stays (at most 3 rounds)."""
    from ..simulation.reference_solve import reference_simulate_jit, simulation_error

    res = identify(recordings, nd=1, **kw)

    def errors_at(result, nds):
        x = np.array([result.best_values[n] for n in result.names])
        refs = [reference_simulate_jit(x, p) for p in result.problems()]
        out = {}
        for nd in nds:
            probs = [
                make_problem(r, model=result.model, integrator=kw["integrator"], nd=nd, weights=kw["weights"], i_limit=kw["i_limit"])
                for r in recordings
            ]
            out[nd] = max(simulation_error(x, p, ref) for p, ref in zip(probs, refs))
        return out

    candidates = [2**k for k in range(int(np.log2(nd_max)) + 1)]
    nd, rounds = 1, []
    for _ in range(3):  # a refit can move the parameters to where another ND is needed
        errors = errors_at(res, candidates)
        rounds.append({"fit_nd": nd, "errors": {str(k): v for k, v in errors.items()}})
        chosen = next((k for k in candidates if errors[k] <= nd_tol), None)
        if chosen is None:  # no ND meets tol: stop where doubling no longer halves the error
            stalled = [b for a, b in zip(candidates, candidates[1:]) if errors[b] > 0.5 * errors[a]]
            chosen = stalled[0] // 2 if stalled else candidates[-1]
        if chosen == nd:
            break
        nd = chosen
        res = identify(recordings, nd=nd, **kw)
    final = errors_at(res, [nd])[nd]
    res.settings["nd_auto"] = {
        "tol": nd_tol,
        "max": nd_max,
        "chosen": nd,
        "converged": bool(final <= nd_tol),
        "reference_error": final,
        "errors_at_nd1_fit": rounds[0]["errors"],
        "rounds": rounds,
        "reference": "diffrax Dopri8, PID rtol 1e-10 atol 1e-12, jump_ts at the samples",
    }
    return res
