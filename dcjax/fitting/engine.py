"""The engine under `fit` and `fit_each`, in the typed vocabulary: a `Search` (strategy, memory,
runs, budget, generations, seed, polish), a `Setup` per fit (recordings, model, `Parameters`,
integrator: the problems and the search space), all runs of one setup in one compiled call
(`run_setup`), and the settings a result records, derived from those objects in one place
(`settings_of`).

Run r is keyed by `fold_in(PRNGKey(seed), r)`, so a run does not depend on how many others are
made or on the device count; on several devices each device runs its share (`shard_map`)."""

import dataclasses
import itertools
import time
from collections.abc import Callable, Mapping

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import PartitionSpec

from ..io.recording import Recording
from ..models import Model
from ..models.bounds import Bounds
from ..models.parameters import Parameters
from ..models.precision import physical_precision
from ..models.space import Space, vector_space
from ..simulation.integrators import Integrator, integrator_spec
from ..simulation.joint import JointProblem, Layout
from ..simulation.kernel import kernel_mode
from ..simulation.problem import Problem, check_positive_int, make_problem
from ..strategies import METHODS, Strategy
from ..strategies.base import FitnessFn, hyperparameters, iteration_limit, run_batch, structure_key, with_hyperparameters
from ..strategies.memory import MemoryAssistance
from .observation import Observation
from .result import FitResult, model_spec
from .runner import ExecutableCache, fold_keys, leaf_signature, mesh_of, padded_size, shard
from .vector import base_name, search_vector, split_parameters, start_rows

# The last few executables by (strategy, settings, argument shapes): consecutive cells of a sweep
# (other weights, bounds or recordings of equal length) reuse them.
EXECUTABLES = ExecutableCache(size=6)
PROGRESS_CHUNKS = 20


@dataclasses.dataclass(frozen=True)
class Search:
    """How a fit searches: `runs` independent runs of `strategy` of at most `budget` FEs each
    (`generations` iterations at most; default as many as the budget buys without memory, paper
    Section 4.4), keyed from `seed`, with an optional `memory` and Levenberg–Marquardt `polish`."""

    strategy: Strategy
    memory: MemoryAssistance | None = None
    runs: int = 50
    budget: int = 140_000
    generations: int | None = None
    seed: int = 0
    polish: bool = False

    def __post_init__(self):
        if not isinstance(self.strategy, Strategy):
            raise ValueError(f"method must be a strategy name or a dcjax Strategy, got {self.strategy!r}")
        for name in ("runs", "budget"):
            check_positive_int(name, getattr(self, name))
        check_positive_int("pop_size", self.strategy.pop_size)
        if self.budget < self.strategy.pop_size:
            raise ValueError(f"budget ({self.budget}) must be at least one population ({self.strategy.pop_size})")
        if not isinstance(self.seed, (int, np.integer)) or isinstance(self.seed, bool):
            raise ValueError(f"seed must be an integer, got {self.seed!r}")
        if self.memory is not None and not isinstance(self.memory, MemoryAssistance):
            raise ValueError(f"memory must be None, dcjax.STMA(), dcjax.LTMA(order=...) or dcjax.IndexedLTMA(), got {self.memory!r}")
        if self.generations is not None:
            check_positive_int("generations", self.generations)
        if not isinstance(self.polish, (bool, np.bool_)):
            raise ValueError(f"polish must be True or False, got {self.polish!r}")

    @property
    def method(self) -> str:
        """The strategy's name: a built-in's registry name, an evosax algorithm's, else the class name."""
        s = self.strategy
        for name, cls in METHODS.items():
            if type(s) is cls:
                return name
        return str(getattr(s, "name", "")) or type(s).__name__


# -- what belongs to the recordings ----------------------------------------------------------------
def with_weights(recording: Recording, weights: Mapping[str, float] | None = None, joint_weight: float | None = None) -> Recording:
    """The recording with its objective weights: `weights` per measured channel (eq. 27's w1, w2;
    default all 1, eq. 24) and, in a joint fit, its `joint_weight` (default equal shares)."""
    meta = dict(recording.metadata)
    if weights is not None:
        meta["weights"] = {str(k): float(v) for k, v in weights.items()}
    if joint_weight is not None:
        meta["joint_weight"] = float(joint_weight)
    return recording.replace(metadata=meta)


def channel_weights(recordings: list[Recording], model: Model) -> tuple[float, ...] | None:
    """The channel weights the recordings carry (`with_weights`), in the model's output order."""
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


def joint_weights(recordings: list[Recording], pooled: bool = False) -> list[float]:
    """Each recording's share of a joint fit's OF: its `joint_weight`, default equal shares, or
    (`pooled`, a loss without normalisation) its share of all samples, so the recordings' means
    pool into one mean over every sample."""
    jw = [r.metadata.get("joint_weight") for r in recordings]
    if all(w is None for w in jw):
        if pooled and len(recordings) > 1:
            total = sum(len(r) for r in recordings)
            return [len(r) / total for r in recordings]
        return [1.0 / len(recordings)] * len(recordings)
    out = [1.0 if w is None else float(w) for w in jw]
    if any(not w >= 0 for w in out) or sum(out) <= 0:
        raise ValueError("joint weights must be non-negative and not all zero")
    return out


# -- one fit's setup -----------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Setup:
    """One fit, prepared: the recordings (one, or a joint set), the model, the resolved
    `Parameters` and integrator, and what the compiled runs take (problems, space, start rows,
    joint weights)."""

    recordings: list[Recording]
    model: Model
    params: Parameters  # of the search vector (`dcjax.fitting.vector`)
    integrator: Integrator
    problems: list[Problem]
    space: Space
    starts: np.ndarray | None  # (K, D) unit cube, NaN where not given
    joint_weights: list[float]
    weights: tuple[float, ...] | None  # channel weights (None: all 1)
    observation: Observation = dataclasses.field(default_factory=Observation)
    layout: Layout | None = None  # None: the model's parameters, shared

    @property
    def target(self) -> JointProblem:
        """The objective over the search vector (every recording, its weight, the layout)."""
        layout = self.layout or Layout.plain(self.model.names, len(self.problems))
        return JointProblem(tuple(self.problems), tuple(float(w) for w in self.joint_weights), layout)

    def physical_precision(self) -> list[float]:
        """The memory precision of every entry of the search vector: a model parameter's (given,
        else the model's; Table 29 for the paper's), 1e-6 of the range for the observation's."""
        given = {base_name(n): p.precision for n, p in self.params.items() if p.precision is not None and base_name(n) in self.model.names}
        model_prec = dict(zip(self.model.names, physical_precision(given or None, self.model)))
        lo, hi = self.params.lower, self.params.upper
        out = []
        for k, (n, p) in enumerate(self.params.items()):
            b = base_name(n)
            out.append(float(model_prec[b]) if b in model_prec else p.precision if p.precision is not None else 1e-6 * float(hi[k] - lo[k]))
        return out

    def precision(self) -> np.ndarray:
        """The memory precisions of the free parameters in the unit cube."""
        p = np.asarray(self.physical_precision())
        if not np.all(p >= 0) or np.any(np.isnan(p)):
            raise ValueError(f"precision needs non-negative numbers, got {p!r}")
        return self.space.free_of(p) / np.asarray(self.space.upper - self.space.lower)


def prepare(
    recordings: list[Recording],
    model: Model,
    params: Parameters,
    integrator: Integrator,
    starts=None,
    observation: Observation | None = None,
) -> Setup:
    """The `Setup` of a fit of `recordings` with resolved `params` (`resolve_parameters`; may hold
    the observation's parameters too) and the `observation` (loss, initial states, offsets,
    delays; default the paper's terms): the search vector (`dcjax.fitting.vector`), its space and
    the problems. A fixed parameter's value may lie outside its range (a known value overrides
    it). `starts`: start rows in any form `start_rows` takes, instead of the parameters' values."""
    observation = (observation or Observation()).check(model)
    own, extras = split_parameters(params, model)
    local = [n for n, p in own.items() if p.local and not p.vary]
    if local and len(recordings) > 1:
        raise ValueError(f"local: {', '.join(local)} is fixed (one known value); a local parameter must be searched")
    layout, vec = search_vector(model, list(recordings), own, extras, observation)
    fixed = vec.fixed
    lo, hi = vec.lower.copy(), vec.upper.copy()
    for k, n in enumerate(vec.names):
        if n in fixed and not lo[k] <= fixed[n] <= hi[k]:
            lo[k] = hi[k] = fixed[n]
    space = vector_space(vec.names, Bounds(lo, hi, vec.names), fixed, f"model {model.name}")
    weights = channel_weights(recordings, model)
    problems = [make_problem(r, integrator, weights, model=model, loss=observation.loss, initial=observation.initial_values(model, r))
                for r in recordings]  # fmt: skip
    x0 = starts if starts is not None else (vec.start or None)
    jw = joint_weights(recordings, pooled=observation.loss.normalize == "none")
    trivial = layout == Layout.plain(model.names, len(recordings))
    return Setup(list(recordings), model, vec, integrator, problems, space, start_rows(x0, model, space), jw, weights, observation,
                 None if trivial else layout)  # fmt: skip


def settings_of(setup: Setup, search: Search) -> dict:
    """What a result records of its configuration (result.json's "settings"), from the typed objects."""
    recs, model, space = setup.recordings, setup.model, setup.space
    # the weights used where they are not equal shares (given, or pooled by sample count)
    weighted = any(r.metadata.get("joint_weight") is not None for r in recs) or len(set(setup.joint_weights)) > 1
    start = setup.params.start
    observed = {} if setup.observation.plain and setup.layout is None else {
        **setup.observation.to_dict(), "names": list(space.names), "local": sorted({base_name(n) for n, p in setup.params.items() if p.local}),
    }  # fmt: skip
    return observed | {
        "recording": recs[0].name if len(recs) == 1 else [r.name for r in recs],
        "data": [_source(r) for r in recs],
        "model": model_spec(model),
        "joint_weights": setup.joint_weights if weighted else None,
        "method": search.method,
        "integrator": integrator_spec(setup.integrator),
        "nd": setup.integrator.substeps,
        "weights": [float(w) for w in (setup.weights if setup.weights is not None else [1.0] * len(model.outputs))],
        "bounds": {"lower": np.asarray(space.bounds.lower).tolist(), "upper": np.asarray(space.bounds.upper).tolist()},
        "fixed": space.fixed,
        "x0": start or None,
        "runs": search.runs,
        "budget": search.budget,
        "seed": int(search.seed),
        "pop_size": search.strategy.pop_size,
        "polish": bool(search.polish),
        "memory": None if search.memory is None else search.memory.kind,
        "precision": None if search.memory is None else setup.physical_precision(),
        "generations": search.generations,
        "strategy": repr(search.strategy),
        "ndata": int(sum(len(r) * len(model.outputs) for r in recs)),
    }


def _source(r: Recording):
    """Where a recording came from (its loader's record, else its name), with the limit fitted and
    each channel's peak (so a validation can tell a unit or scale slip)."""
    src = r.metadata.get("source", {"name": r.name})
    peaks = {c: float(np.max(np.abs(v))) for c, v in r.channels.items()}
    return {**src, "limit": r.limit, "peaks": peaks} if isinstance(src, dict) else src


# -- the compiled runs ---------------------------------------------------------------------------
def fitness(space: Space, target: JointProblem) -> FitnessFn:
    """The population OF of unit-cube points: the (joint-weighted) eq. 24/27 of every recording
    (or the fit's loss), with each recording's parameters and adjustments (`JointProblem`)."""

    def of(z):
        return target.objective(space.to_physical(z))

    return of  # pyright: ignore[reportReturnType]


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


def _per_device(fn, mesh, n_args: int):
    """On several devices, each device runs its own vmapped batch of runs (shard_map): compaction
    stays local to the device (memory), and a device's loop does not wait for the others'. The
    first argument is split along the runs."""
    if mesh is None:
        return fn
    spec, rep = PartitionSpec("runs"), PartitionSpec()
    return jax.shard_map(fn, mesh=mesh, in_specs=(spec, *[rep] * (n_args - 1)), out_specs=spec, check_vma=False)


def _batched_runs(search: Search, mesh, dim, progress: bool = False):
    """All runs as one function of (keys, target, space, precision, x0, hyperparameters,
    token): data are arguments, not constants, so recordings of equal length (and other
    bounds) reuse one executable. With `progress` each device reports the fraction done
    `PROGRESS_CHUNKS` times (`jax.debug.callback`, same results)."""
    strategy = search.strategy
    t_max = iteration_limit(strategy, search.budget, search.generations)

    def device_runs(keys, target, space, prec, x0, hyper, token):
        report = None
        if progress:
            device = jax.lax.axis_index("runs") if mesh is not None else 0
            report = lambda done: jax.debug.callback(_report, token, device, done)
        return run_batch(
            with_hyperparameters(strategy, hyper), keys, fitness(space, target), search.budget, dim, search.memory, prec,
            search.generations, x0, report=report, report_every=max(1, -(-t_max // PROGRESS_CHUNKS)),
        )  # fmt: skip

    return jax.jit(_per_device(device_runs, mesh, 7))


def compile_key(search: Search) -> tuple:
    """What of a search an executable is compiled for (the traced hyperparameters are arguments)."""
    return (structure_key(search.strategy), search.budget, search.memory, search.generations)


def run_setup(setup: Setup, search: Search, progress=None):
    """Every run of one setup in one compiled call (each device its share), with progress
    reports; returns the runs' outputs (padding dropped) and the timing."""
    prec = None if search.memory is None else jnp.asarray(setup.precision())
    runs = search.runs
    devices = jax.devices() if runs > 1 else jax.devices()[:1]
    mesh = mesh_of(devices, "runs")
    keys = shard(fold_keys(search.seed, padded_size(runs, devices)), mesh, "runs")
    token = next(_TOKENS)
    z0 = None if setup.starts is None else jnp.asarray(setup.starts)
    target = setup.target
    args = (keys, target, setup.space, prec, z0, hyperparameters(search.strategy), jnp.asarray(token, jnp.int64))
    show = progress is not None and progress is not False
    cache_key = (*compile_key(search), target.weights, target.layout, len(devices), kernel_mode(), leaf_signature(args), show)
    t0 = time.perf_counter()
    compiled, reused = EXECUTABLES.get(cache_key, lambda: _batched_runs(search, mesh, setup.space.dim, show), args)
    t1 = time.perf_counter()
    total = runs * iteration_limit(search.strategy, search.budget, search.generations)
    report = (progress if callable(progress) else _tqdm_progress(total)) if show else None
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
    out = jax.tree.map(lambda a: a[:runs], out)
    return out, {"compile_s": t1 - t0, "run_s": t2 - t1, "devices": len(devices), "reused_executable": reused}


def polish_runs(run_x, setup: Setup):
    """Levenberg–Marquardt from every run's best: (parameters, OFs, what the polish did)."""
    from .polish import polish_batch

    t0 = time.perf_counter()
    pol = jax.block_until_ready(polish_batch(jnp.asarray(run_x), setup.target, setup.space))
    info = {
        "of_before": np.asarray(pol.of_before).tolist(),
        "of_after": np.asarray(pol.of_after).tolist(),
        "steps": np.asarray(pol.steps).tolist(),
        "converged": np.asarray(pol.converged).tolist(),
        "time_s": time.perf_counter() - t0,
    }
    return np.asarray(pol.x), np.asarray(pol.of_after), info


def make_result(setup: Setup, search: Search, out, timing: dict) -> FitResult:
    """The result of the runs `out` of one setup, after the optional polish."""
    run_x = np.asarray(setup.space.to_physical(out.best_x))
    run_of = np.asarray(out.best_f)
    polish_info = None
    if search.polish:
        run_x, run_of, polish_info = polish_runs(run_x, setup)
    best = int(np.argmin(run_of))
    memory = search.memory is not None
    return FitResult(
        best_values=dict(zip(setup.space.names, map(float, run_x[best]))),
        of=float(run_of[best]),
        run_of=run_of,
        run_params=run_x,
        fes=np.asarray(out.fes),
        iterations=np.asarray(out.iterations),
        history=np.asarray(out.history),
        settings=settings_of(setup, search),
        timing=timing,
        polish=polish_info,
        dups=np.asarray(out.dups) if memory else None,
        memory_chunks=np.asarray(out.chunks) if memory else None,
        recordings=list(setup.recordings),
        model=setup.model,
        fixed=setup.space.fixed,
        integrator=setup.integrator,
        observation=setup.observation,
        layout=setup.layout,
    )


def fit_setup(setup: Setup, search: Search, progress=None) -> FitResult:
    """All runs of one setup and their result."""
    out, timing = run_setup(setup, search, progress)
    return make_result(setup, search, out, timing)
