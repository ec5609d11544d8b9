"""`identify`: independent evolutionary runs on one recording, batched into one compiled call,
with an optional Levenberg–Marquardt polish, and the result object (paper Section 3.1, Tables
5–6: best B, worst W, mean M and standard deviation SD over runs)."""

import dataclasses
import json
import time
from collections import OrderedDict
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from .bounds import TABLE4, Bounds, bounds_preset
from .objectives import objective
from .params import PARAM_NAMES, Params
from .problem import make_problem
from .recording import Recording
from .strategies import Strategy, make_strategy, run
from .strategies.memory import MEMORY_KINDS, TABLE29, unit_precision


@dataclasses.dataclass
class IdentificationResult:
    """Best parameters over all runs, per-run results and their statistics."""

    params: dict[str, float]
    of: float
    run_of: np.ndarray  # (R,)
    run_params: np.ndarray  # (R, 7), physical units
    fes: np.ndarray  # (R,) real evaluations
    iterations: np.ndarray  # (R,)
    history: np.ndarray  # (R, T) best OF after each iteration (NaN past a run's end)
    settings: dict
    timing: dict
    polish: dict | None = None
    dups: np.ndarray | None = None  # (R,) candidates answered from memory
    memory_chunks: np.ndarray | None = None  # (R,) memory chunks searched
    recordings: list[Recording] = dataclasses.field(default_factory=list, repr=False)

    @property
    def recording(self) -> Recording | None:
        """The (first) fitted recording."""
        return self.recordings[0] if self.recordings else None

    def _problems(self, recordings=None):
        s = self.settings
        return [
            make_problem(r, integrator=s["integrator"], nd=s["nd"], weights=tuple(s["weights"]), i_limit=s["i_limit"])
            for r in (recordings or self.recordings)
        ]

    def uncertainty(self, profile: str | None = None, profile_points: int = 11):
        """Standard errors, 95 % intervals, correlations and identifiability verdicts at the best
        parameters (`dcjax.uncertainty`); with `profile="Tla"` also a profile likelihood over the
        95 % interval of that parameter (`.profile = (values, OFs)`)."""
        from .uncertainty import profile as profile_fn
        from .uncertainty import uncertainty

        b = Bounds(self.settings["bounds"]["lower"], self.settings["bounds"]["upper"])
        x = np.array([self.params[n] for n in PARAM_NAMES])
        jw = self.settings.get("joint_weights")
        u = uncertainty(x, self._problems(), b, weights=jw)
        if profile is not None:
            lo, hi = u.ci95[profile]
            k = PARAM_NAMES.index(profile)
            grid = np.linspace(max(lo, float(b.lower[k])), min(hi, float(b.upper[k])), profile_points)
            u.profile = (grid, profile_fn(x, profile, grid, self._problems(), b, weights=jw))
        return u

    @property
    def stats(self) -> dict[str, float]:
        """B, W, M, SD of the per-run best OF (Table 5; SD is the population std, ddof = 0)."""
        f = self.run_of
        return {"best": float(f.min()), "worst": float(f.max()), "mean": float(f.mean()), "std": float(f.std())}

    @property
    def duplicates(self) -> dict[str, float] | None:
        """Memory use (Tables 30–33): mean candidates answered from memory per run and that as a
        percentage of all candidates proposed, `pop_size` x (iterations + 1) (the paper's
        convention, 70 x 2000 = 140,000)."""
        if self.dups is None:
            return None
        proposed = self.settings["pop_size"] * (self.iterations + 1)
        return {"mean": float(self.dups.mean()), "percent": float(100 * np.mean(self.dups / proposed))}

    @property
    def mean_params(self) -> dict[str, float]:
        """Mean of each parameter over runs (Table 6)."""
        return dict(zip(PARAM_NAMES, map(float, self.run_params.mean(axis=0))))

    def to_dict(self) -> dict:
        return {
            "params": self.params,
            "of": self.of,
            "runs": [
                {"of": float(o), "params": dict(zip(PARAM_NAMES, map(float, p))), "fes": int(n), "iterations": int(it)}
                | ({} if self.dups is None else {"dups": int(self.dups[r])})
                for r, (o, p, n, it) in enumerate(zip(self.run_of, self.run_params, self.fes, self.iterations))
            ],
            "stats": self.stats,
            "duplicates": self.duplicates,
            "mean_params": self.mean_params,
            "polish": self.polish,
            "settings": self.settings,
            "timing": self.timing,
        }

    def to_json(self, path: str | Path | None = None) -> str:
        text = json.dumps(self.to_dict(), indent=2)
        if path is not None:
            Path(path).write_text(text + "\n")
        return text

    def simulate(self, recording: Recording | None = None) -> np.ndarray:
        """(N, 2) current and speed of the best parameters on `recording` (default: the fitted one)."""
        from .integrate import simulate

        prob = self._problems([recording or self.recording])[0]
        return np.asarray(simulate(Params.from_dict(self.params), prob))

    def plot(self, path: str | Path | None = None, true_params: dict | None = None):
        """Measured vs simulated current and speed (paper Figs. 8–11) and convergence."""
        import matplotlib

        if path is not None:
            matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        n = len(self.recordings)
        fig, axes = plt.subplots(n, 3, figsize=(14, 4 * n), squeeze=False)
        for row, rec in enumerate(self.recordings):
            ax = axes[row]
            sim = self.simulate(rec)
            ax[0].plot(rec.t, rec.i_a, "k.", ms=3, label="measured")
            ax[0].plot(rec.t, sim[:, 0], "r-", lw=1, label="simulated")
            ax[0].set(xlabel="t (s)", ylabel="i_a (A)", title=f"{rec.name}: current")
            ax[1].plot(rec.t, rec.omega, "k.", ms=3, label="measured")
            ax[1].plot(rec.t, sim[:, 1], "r-", lw=1, label="simulated")
            ax[1].set(xlabel="t (s)", ylabel="ω (1/s)", title="speed")
            for a in ax[:2]:
                a.legend()
            if row == 0:
                for h in self.history:
                    ax[2].semilogy(np.arange(1, h.size + 1), h, lw=0.7)
                ax[2].set(xlabel="iteration", ylabel="best OF", title=f"convergence ({len(self.history)} runs)")
            else:
                ax[2].axis("off")
        fig.tight_layout()
        if path is not None:
            fig.savefig(path, dpi=120)
            plt.close(fig)
        return fig


def _run_keys(seed: int, runs: int):
    """Key of run r = fold_in(PRNGKey(seed), r). With several devices the runs are padded to a
    multiple of the device count and sharded along the run axis (`NamedSharding`); the padding
    runs are dropped afterwards, so results do not depend on the device count."""
    devices = jax.devices()
    n_dev = len(devices) if runs > 1 else 1
    padded = -(-runs // n_dev) * n_dev
    keys = jax.vmap(lambda r: jax.random.fold_in(jax.random.PRNGKey(seed), r))(jnp.arange(padded))
    mesh = None
    if n_dev > 1:
        mesh = Mesh(np.array(devices), ("runs",))
        keys = jax.device_put(keys, NamedSharding(mesh, PartitionSpec("runs")))
    return keys, n_dev, mesh


# The last few executables by (strategy, settings, argument shapes): consecutive cells of a sweep
# (other weights, bounds or recordings of equal length) reuse them. Bounded, and JAX's caches are
# cleared after each compilation: every XLA CPU executable holds memory mappings (~450-750 per
# `identify` here), and a process that kept them all hit the kernel's mapping limit
# (vm.max_map_count, LLVM "Cannot allocate memory") after ~170 cells of the full reproduction.
_COMPILED: OrderedDict = OrderedDict()
_COMPILED_MAX = 4


def _batched_runs(strategy, budget, memory, generations, jw, mesh):
    """All runs as one function of (keys, problems, bounds, precision): data are arguments, not
    constants, so recordings of equal length (and other weights or bounds) reuse one executable."""

    def one_run(key, problems, b, prec):
        def of(x):
            p = Params.from_array(x)
            return sum(w * objective(p, prob) for w, prob in zip(jw, problems))

        return run(strategy, key, lambda z: of(b.to_physical(z)), budget, memory=memory, precision=prec, generations=generations)

    batched = jax.vmap(one_run, in_axes=(0, None, None, None))
    if memory is not None and mesh is not None:
        # Each device runs its own vmapped batch, so compaction stays local to the device.
        spec, rep = PartitionSpec("runs"), PartitionSpec()
        batched = jax.shard_map(batched, mesh=mesh, in_specs=(spec, rep, rep, rep), out_specs=spec, check_vma=False)
    return eqx.filter_jit(batched)


def _resolve_bounds(bounds) -> Bounds:
    if bounds is None:
        return TABLE4
    if isinstance(bounds, Bounds):
        return bounds
    if isinstance(bounds, str):
        return bounds_preset(bounds)
    lo, hi = bounds
    return Bounds(lo, hi)


def identify(
    recording: Recording | list[Recording],
    method: str | Strategy = "de-rand-1-exp",
    integrator: str = "rk4",
    nd: int | str = 1,
    weights: tuple[float, float] = (1.0, 1.0),
    bounds: Bounds | str | tuple | None = None,
    runs: int = 50,
    budget: int = 140_000,
    seed: int = 0,
    polish: bool = False,
    pop_size: int = 70,
    i_limit: float | None = None,
    strategy_options: dict | None = None,
    joint_weights: list[float] | None = None,
    nd_tol: float = 1e-3,
    nd_max: int = 64,
    memory: str | None = None,
    precision=None,
    generations: int | None = None,
) -> IdentificationResult:
    """Identify `Ra, La, cm, J, Tla, Tlb, Tlc` from `recording`.

    `runs` independent runs of `method` (paper defaults: NP = 70, 140,000 FEs) are `vmap`ped into
    one compiled call; run r uses `jax.random.fold_in(PRNGKey(seed), r)`, so a run does not depend
    on how many others are made. `bounds`: a `Bounds`, `"table4"` (default) / `"table8"`, or a
    `(lower, upper)` pair. `polish=True` runs Levenberg–Marquardt from every run's best.

    Joint fit: a list of recordings of one drive (each with its own voltage, limit and initial
    state) shares the seven parameters; the OF is the mean of their OFs, or the weighted sum with
    `joint_weights` (Section 4.2.5's argument that MD1–MD3 must give one parameter set).

    `nd="auto"` (paper Section 5): fit with ND = 1, 2, 4, ... until the best parameters change by
    less than `nd_tol` (relative, floored at 1e-6 of the bound width) from one ND to its double;
    returns the finer fit with the sequence in `settings["nd_sequence"]`.

    `memory` (Section 4.4): `None`, `"stma"`, `"ltma-s1"` or `"ltma-s2"`; a candidate within
    `precision` (physical units, default Table 29, see `dcjax.strategies.memory`) of a record is
    not simulated and costs no FE, so the budget lasts longer; `generations` caps the iterations
    (the paper's Tables 30–33 compare equal iteration counts: 1999 DE steps after the initial
    population = 70 x 2000 candidates). The runs of each device are compacted together so that
    skipped candidates are really not computed (`dcjax.strategies.compact`)."""
    recordings = recording if isinstance(recording, (list, tuple)) else [recording]
    if not recordings or not all(isinstance(r, Recording) for r in recordings):
        raise ValueError("recording must be a dcjax.Recording or a non-empty list of them")
    if joint_weights is not None:
        joint_weights = [float(w) for w in joint_weights]
        if len(joint_weights) != len(recordings) or any(not w >= 0 for w in joint_weights) or sum(joint_weights) <= 0:
            raise ValueError("joint_weights needs one non-negative weight per recording, not all zero")
    if nd == "auto":
        return _identify_auto_nd(
            recordings, nd_tol=nd_tol, nd_max=nd_max, method=method, integrator=integrator, weights=weights,
            bounds=bounds, runs=runs, budget=budget, seed=seed, polish=polish, pop_size=pop_size, i_limit=i_limit,
            strategy_options=strategy_options, joint_weights=joint_weights, memory=memory, precision=precision,
            generations=generations,
        )
    for name, v in (("runs", runs), ("budget", budget), ("pop_size", pop_size)):
        if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < 1:
            raise ValueError(f"{name} must be a positive integer, got {v!r}")
    if budget < pop_size:
        raise ValueError(f"budget ({budget}) must be at least one population ({pop_size})")
    if not isinstance(seed, (int, np.integer)):
        raise ValueError(f"seed must be an integer, got {seed!r}")
    if memory is not None and memory not in MEMORY_KINDS:
        raise ValueError(f"memory must be None or one of {MEMORY_KINDS}, got {memory!r}")
    if generations is not None and (not isinstance(generations, (int, np.integer)) or generations < 1):
        raise ValueError(f"generations must be a positive integer, got {generations!r}")
    b = _resolve_bounds(bounds)
    prec = None if memory is None else jnp.asarray(unit_precision(precision, b))
    strategy = make_strategy(method, pop_size=pop_size, **(strategy_options or {}))
    problems = [make_problem(r, integrator=integrator, nd=nd, weights=weights, i_limit=i_limit) for r in recordings]
    jw = joint_weights or [1.0 / len(problems)] * len(problems)

    keys, n_dev, mesh = _run_keys(seed, runs)
    args = (keys, problems, b, prec)
    cache_key = (repr(strategy), budget, memory, generations, tuple(jw), n_dev, jax.tree.structure(args),
                 tuple((x.shape, x.dtype) for x in jax.tree.leaves(args)))
    t0 = time.perf_counter()
    compiled = _COMPILED.get(cache_key)
    reused = compiled is not None
    if compiled is None:
        compiled = _batched_runs(strategy, budget, memory, generations, tuple(jw), mesh).lower(*args).compile()
        _COMPILED[cache_key] = compiled
        while len(_COMPILED) > _COMPILED_MAX:
            _COMPILED.popitem(last=False)
        # JAX's own caches keep what tracing and lowering this one-off function made; with a
        # fresh function per call they are never hit again and only hold memory mappings.
        jax.clear_caches()
    _COMPILED.move_to_end(cache_key)
    t1 = time.perf_counter()
    out = jax.block_until_ready(compiled(*args))
    t2 = time.perf_counter()
    out = jax.tree.map(lambda a: a[:runs], out)
    run_x = np.asarray(b.to_physical(out.best_x))
    run_of = np.asarray(out.best_f)
    polish_info = None
    if polish:
        from .polish import polish_batch

        t3 = time.perf_counter()
        pol = jax.block_until_ready(polish_batch(jnp.asarray(run_x), problems, b, jw))
        polish_info = {
            "of_before": np.asarray(pol.of_before).tolist(),
            "of_after": np.asarray(pol.of_after).tolist(),
            "steps": np.asarray(pol.steps).tolist(),
            "time_s": time.perf_counter() - t3,
        }
        run_x = np.asarray(pol.x)
        run_of = np.asarray(pol.of_after)
    best = int(np.argmin(run_of))
    name = method if isinstance(method, str) else type(method).__name__
    settings = {
        "recording": recordings[0].name if len(recordings) == 1 else [r.name for r in recordings],
        "joint_weights": joint_weights,
        "method": name,
        "integrator": integrator,
        "nd": nd,
        "weights": list(map(float, weights)),
        "bounds": {"lower": np.asarray(b.lower).tolist(), "upper": np.asarray(b.upper).tolist()},
        "runs": runs,
        "budget": budget,
        "seed": seed,
        "pop_size": pop_size,
        "polish": polish,
        "i_limit": i_limit,
        "memory": memory,
        "precision": None if memory is None else np.asarray(TABLE29 if precision is None else precision, float).tolist(),
        "generations": generations,
        "strategy": repr(strategy),
    }
    return IdentificationResult(
        params=dict(zip(PARAM_NAMES, map(float, run_x[best]))),
        of=float(run_of[best]),
        run_of=run_of,
        run_params=run_x,
        fes=np.asarray(out.fes),
        iterations=np.asarray(out.iterations),
        history=np.asarray(out.history),
        settings=settings,
        timing={"compile_s": t1 - t0, "run_s": t2 - t1, "devices": n_dev, "reused_executable": reused},
        polish=polish_info,
        dups=None if memory is None else np.asarray(out.dups),
        memory_chunks=None if memory is None else np.asarray(out.chunks),
        recordings=list(recordings),
    )


def _identify_auto_nd(recordings, nd_tol, nd_max, **kw) -> IdentificationResult:
    b = _resolve_bounds(kw["bounds"])
    floor = 1e-6 * np.asarray(b.upper - b.lower)
    sequence, prev, nd = [], None, 1
    while True:
        res = identify(recordings, nd=nd, **kw)
        x = np.array([res.params[n] for n in PARAM_NAMES])
        change = None if prev is None else float(np.max(np.abs(x - prev) / np.maximum(np.abs(prev), floor)))
        sequence.append({"nd": nd, "of": res.of, "params": res.params, "max_rel_change": change})
        if (change is not None and change < nd_tol) or 2 * nd > nd_max:
            break
        prev, nd = x, 2 * nd
    res.settings["nd_sequence"] = sequence
    res.settings["nd_auto"] = {"tol": nd_tol, "max": nd_max, "converged": sequence[-1]["max_rel_change"] is not None and sequence[-1]["max_rel_change"] < nd_tol}
    return res
