"""Many independent fits in one compiled call: `fit_setups`.

Setups of equal length (same channels, a current limit on all or none, the same free
parameters and integrator) are stacked into one batched `Problem` and one batched `Space` (each
recording keeps its own bounds and start values), and the runs of every recording are `vmap`ped
over the batch inside the runner's per-device loop (`shard_map` over the runs, as for one
recording; with one run per recording over the recordings instead, padded to a multiple of the
device count, which also spans the processes of `jax.distributed`). Every recording uses the
same run keys as a fit of it alone (run r: `fold_in(PRNGKey(seed), r)`), so a batch gives each
recording the result `fit` gives it. Groups of other shapes get calls of their own."""

import time

import jax
import numpy as np
from jax.sharding import PartitionSpec

from ..simulation.kernel import kernel_mode
from ..strategies.base import hyperparameters, run_batch, with_hyperparameters
from .engine import EXECUTABLES, Search, Setup, compile_key, fitness, make_result
from .result import FitResult
from .runner import fold_keys, leaf_signature, mesh_of, padded_size, replicate, shard, to_host


def _stack(trees):
    return jax.tree.map(lambda *xs: np.stack([np.asarray(x) for x in xs]), *trees)


def _batched_each(search: Search, mesh, dim, axis: str):
    """(keys, targets (B, ...), spaces (B, ...), precisions, start values, hyperparameters) ->
    runs (B, R, ...). On several devices the `axis` ("runs" or "recordings") is split over them."""

    def device_runs(keys, target, space, prec, x0, hyper):
        strat = with_hyperparameters(search.strategy, hyper)
        return run_batch(strat, keys, fitness(space, target), search.budget, dim, search.memory, prec, search.generations, x0)

    each = jax.vmap(device_runs, in_axes=(None, 0, 0, 0, 0, None))
    if mesh is not None:
        rep, split = PartitionSpec(), PartitionSpec(axis)
        specs = (split, rep, rep, rep, rep, rep) if axis == "runs" else (rep, split, split, split, split, rep)
        out = PartitionSpec(None, "runs") if axis == "runs" else split
        each = jax.shard_map(each, mesh=mesh, in_specs=specs, out_specs=out, check_vma=False)
    return jax.jit(each)


def group_key(setup: Setup) -> tuple:
    """Setups with the same key share one compiled call."""
    prob = setup.problems[0]
    return (len(setup.recordings[0]), tuple(setup.recordings[0].channels), prob.limit is None, setup.space.free,
            repr(setup.integrator), setup.weights is None, setup.observation.loss, setup.layout)  # fmt: skip


def fit_setups(setups: list[Setup], search: Search) -> list[FitResult]:
    """The result of each single-recording setup, the setups of one `group_key` in one compiled
    call (module docstring): the same results as `fit_setup` of each."""
    if any(len(s.recordings) != 1 for s in setups):
        raise ValueError("fit_setups fits single recordings; a joint fit is one `fit`")
    groups: dict = {}
    for k, s in enumerate(setups):
        groups.setdefault(group_key(s), []).append(k)
    out: list = [None] * len(setups)
    for members in groups.values():
        for k, res in zip(members, _run_group([setups[k] for k in members], search)):
            out[k] = res
    return out


def _run_group(setups: list[Setup], search: Search) -> list[FitResult]:
    runs, seed = search.runs, search.seed
    spaces = [s.space for s in setups]
    dim = spaces[0].dim
    k_max = max((s.starts.shape[0] for s in setups if s.starts is not None), default=0)
    z0 = (
        None
        if k_max == 0
        else np.stack(
            [
                np.full((k_max, dim), np.nan)
                if s.starts is None
                else np.pad(s.starts, ((0, k_max - s.starts.shape[0]), (0, 0)), constant_values=np.nan)
                for s in setups
            ]
        )
    )
    prec = None if search.memory is None else np.stack([s.precision() for s in setups])
    # Several runs: split them over the devices (as one fit); one run of many recordings: split the recordings.
    axis = "recordings" if runs == 1 and len(setups) > 1 else "runs"
    devices = jax.devices() if runs > 1 or axis == "recordings" else jax.devices()[:1]
    mesh = mesh_of(devices, axis)
    pad = padded_size(len(setups), devices) - len(setups) if axis == "recordings" else 0
    targets = [s.target for s in setups]
    batch = [_stack(targets + [targets[-1]] * pad), _stack(spaces + [spaces[-1]] * pad)]
    batch += [None if a is None else np.concatenate([a] + [a[-1:]] * pad) for a in (prec, z0)]
    if axis == "recordings":
        keys = replicate(fold_keys(seed, runs), mesh)
        batch = [jax.tree.map(lambda a: shard(a, mesh, axis), b) for b in batch]
    else:
        keys = shard(fold_keys(seed, padded_size(runs, devices)), mesh, axis)
        batch = [jax.tree.map(lambda a: replicate(a, mesh), b) for b in batch]
    args = (keys, *batch, hyperparameters(search.strategy))
    cache_key = ("each", axis, *compile_key(search), len(devices), kernel_mode(), leaf_signature(args))
    t0 = time.perf_counter()
    compiled, reused = EXECUTABLES.get(cache_key, lambda: _batched_each(search, mesh, dim, axis), args)
    t1 = time.perf_counter()
    outs = jax.tree.map(to_host, jax.block_until_ready(compiled(*args)))
    t2 = time.perf_counter()
    results = []
    for b, setup in enumerate(setups):
        o = jax.tree.map(lambda a, b=b: a[b, :runs], outs)
        timing = {"compile_s": t1 - t0, "run_s": (t2 - t1) / len(setups), "batch": len(setups), "batch_run_s": t2 - t1,
                  "devices": len(devices), "reused_executable": reused}  # fmt: skip
        results.append(make_result(setup, search, o, timing))
    return results
