"""Many independent recordings in one compiled call: `identify_each`.

Recordings of equal length (same channels, a current limit on all or none, the same free
parameters) are stacked into one batched `Problem` and one batched `Space` (each recording keeps
its own bounds and start values), and the runs of every recording are `vmap`ped over the batch
inside the runner's per-device loop (`shard_map` over the runs, as for one recording; with one
run per recording over the recordings instead, padded to a multiple of the device count, which
also spans the processes of `jax.distributed`). Every
recording uses the same run keys as a fit of it alone (run r: `fold_in(PRNGKey(seed), r)`), so a
batch gives each recording the result `identify` gives it. Groups of other lengths get calls of
their own."""

import time
from collections.abc import Sequence

import jax
import numpy as np
from jax.sharding import PartitionSpec

from ..io.recording import Recording
from ..models import get_model
from ..models.precision import unit_precision
from ..simulation.kernel import kernel_mode
from ..simulation.problem import make_problem
from ..strategies import make_strategy
from ..strategies.base import hyperparameters, run_batch, structure_key, with_hyperparameters
from .identify import EXECUTABLES, _check_search, _fitness, _polish, _search_space, _settings, make_result
from .result import IdentificationResult
from .runner import fold_keys, leaf_signature, mesh_of, padded_size, replicate, shard, to_host


def _stack(trees):
    return jax.tree.map(lambda *xs: np.stack([np.asarray(x) for x in xs]), *trees)


def _batched_each(strategy, budget, memory, generations, mesh, dim, axis: str):
    """(keys, problems (B, ...), spaces (B, ...), precisions, start values, hyperparameters) ->
    runs (B, R, ...). On several devices the `axis` ("runs" or "recordings") is split over them."""

    def device_runs(keys, problem, space, prec, x0, hyper):
        strat = with_hyperparameters(strategy, hyper)
        return run_batch(strat, keys, _fitness(space, [problem], [1.0]), budget, dim, memory, prec, generations, x0)

    each = jax.vmap(device_runs, in_axes=(None, 0, 0, 0, 0, None))
    if mesh is not None:
        rep, split = PartitionSpec(), PartitionSpec(axis)
        specs = (split, rep, rep, rep, rep, rep) if axis == "runs" else (rep, split, split, split, split, rep)
        out = PartitionSpec(None, "runs") if axis == "runs" else split
        each = jax.shard_map(each, mesh=mesh, in_specs=specs, out_specs=out, check_vma=False)
    return jax.jit(each)


def identify_each(
    recordings: Sequence[Recording],
    bounds: Sequence | None = None,
    x0: Sequence | None = None,
    *,
    method="de-rand-1-exp",
    integrator: str = "rk4",
    nd: int = 1,
    weights=None,
    runs: int = 50,
    budget: int = 140_000,
    seed: int = 0,
    polish: bool = False,
    pop_size: int = 70,
    i_limit: float | None = None,
    memory: str | None = None,
    precision=None,
    generations: int | None = None,
    model=None,
    fixed: dict[str, float] | None = None,
) -> list[IdentificationResult]:
    """`identify` of each recording on its own, the recordings of one shape in one compiled call
    (module docstring). `bounds`, `x0`: one entry per recording (any form `identify` takes), or
    None. Raises what `identify` raises for a bad recording: validate them first (`fit_each`
    does, and fails a bad recording alone)."""
    recs = list(recordings)
    m = get_model(model)
    _check_search(runs, budget, pop_size, seed, memory, generations)
    bounds = list(bounds) if bounds is not None else [None] * len(recs)
    x0 = list(x0) if x0 is not None else [None] * len(recs)
    if len(bounds) != len(recs) or len(x0) != len(recs):
        raise ValueError("bounds and x0 need one entry per recording")
    strategy = make_strategy(method, pop_size=pop_size)
    setups = []
    for r, b, s in zip(recs, bounds, x0):
        box, space, start, z0 = _search_space([r], m, b, fixed, s)
        prob = make_problem(r, model=m, integrator=integrator, nd=nd, weights=weights, i_limit=i_limit)
        setups.append((r, box, space, start, z0, prob))
    groups: dict = {}
    for k, (r, _, space, _, _, prob) in enumerate(setups):
        key = (len(r), tuple(r.channels), prob.limit is None, space.free)
        groups.setdefault(key, []).append(k)
    out: list = [None] * len(recs)
    given = dict(method=method, integrator=integrator, nd=nd, weights=weights, runs=runs, budget=budget, seed=seed, pop_size=pop_size,
                 polish=polish, i_limit=i_limit, memory=memory, precision=precision, generations=generations, joint_weights=None)  # fmt: skip
    for members in groups.values():
        for k, res in zip(members, _run_group([setups[k] for k in members], strategy, given, m)):
            out[k] = res
    return out


def _run_group(setups, strategy, given, model) -> list[IdentificationResult]:
    runs, seed, budget, memory, generations = (given[k] for k in ("runs", "seed", "budget", "memory", "generations"))
    spaces = [s[2] for s in setups]
    dim = spaces[0].dim
    k_max = max((z.shape[0] for *_, z, _ in setups if z is not None), default=0)
    z0 = (
        None
        if k_max == 0
        else np.stack(
            [
                np.full((k_max, dim), np.nan) if z is None else np.pad(z, ((0, k_max - z.shape[0]), (0, 0)), constant_values=np.nan)
                for *_, z, _ in setups
            ]
        )
    )
    prec = None if memory is None else np.stack([unit_precision(given["precision"], sp, model) for sp in spaces])
    # Several runs: split them over the devices (as `identify`); one run of many recordings: split the recordings.
    axis = "recordings" if runs == 1 and len(setups) > 1 else "runs"
    devices = jax.devices() if runs > 1 or axis == "recordings" else jax.devices()[:1]
    mesh = mesh_of(devices, axis)
    pad = padded_size(len(setups), devices) - len(setups) if axis == "recordings" else 0
    batch = [_stack([s[5] for s in setups] + [setups[-1][5]] * pad), _stack(spaces + [spaces[-1]] * pad)]
    batch += [None if a is None else np.concatenate([a] + [a[-1:]] * pad) for a in (prec, z0)]
    if axis == "recordings":
        keys = replicate(fold_keys(seed, runs), mesh)
        batch = [jax.tree.map(lambda a: shard(a, mesh, axis), b) for b in batch]
    else:
        keys = shard(fold_keys(seed, padded_size(runs, devices)), mesh, axis)
        batch = [jax.tree.map(lambda a: replicate(a, mesh), b) for b in batch]
    args = (keys, *batch, hyperparameters(strategy))
    cache_key = ("each", axis, structure_key(strategy), budget, memory, generations, len(devices), kernel_mode(), leaf_signature(args))
    t0 = time.perf_counter()
    compiled, reused = EXECUTABLES.get(cache_key, lambda: _batched_each(strategy, budget, memory, generations, mesh, dim, axis), args)
    t1 = time.perf_counter()
    outs = jax.tree.map(to_host, jax.block_until_ready(compiled(*args)))
    t2 = time.perf_counter()
    results = []
    for b, (rec, box, space, start, _, prob) in enumerate(setups):
        o = jax.tree.map(lambda a, b=b: a[b, :runs], outs)
        run_x, run_of, info = np.asarray(space.to_physical(o.best_x)), np.asarray(o.best_f), None
        if given["polish"]:
            run_x, run_of, info = _polish(run_x, [prob], space, [1.0])
        timing = {"compile_s": t1 - t0, "run_s": (t2 - t1) / len(setups), "batch": len(setups), "batch_run_s": t2 - t1,
                  "devices": len(devices), "reused_executable": reused}  # fmt: skip
        settings = _settings([rec], model, strategy, space, box, {**given, "x0": start})
        results.append(make_result([rec], model, space, o, (run_x, run_of, info), settings, timing))
    return results
