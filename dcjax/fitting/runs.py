"""The compiled runs: every run of every setup of a call, one compiled executable per group of
setups of equal structure (`run_setups`). One fit, a joint fit and a batch of recordings
(`fit_each`) take the same path:

- a group of one setup (a fit, a joint fit) runs its `runs` as one vmapped batch, split over
  the devices along the runs (`shard_map`);
- a group of several single-recording setups of one structure (length, channels, limit, free
  parameters, layout) is stacked into one batched target and space (each recording keeps its
  own bounds, start values and precisions) and `vmap`ped over the recordings; several runs are
  split over the devices along the runs, one run of many recordings along the recordings;
- a joint fit of many samples with fewer runs than devices (`recording_shards`) gives each run
  several devices: its stacked recordings split over them (`SplitJoint`, a mesh of runs x
  recordings), its search repeated on each.

Run r is keyed by `fold_in(PRNGKey(seed), r)` for every recording alike, so a recording gets
the same result in a batch as alone, and a run does not depend on how many others are made or
on the device count (but for a split joint fit's, whose OF is summed in another order). Data are
arguments, not constants: recordings of equal structure reuse one executable (`EXECUTABLES`). With `progress` each device reports its runs' fractions done
`PROGRESS_CHUNKS` times (`jax.debug.callback`, the same results)."""

import dataclasses
import itertools
import time
from collections.abc import Callable

import jax
import numpy as np
from jax.sharding import Mesh, PartitionSpec
from tqdm import tqdm

from ..compiling import LEAN, QUICK, on_device
from ..models.space import Space
from ..simulation.joint import (
    LENGTH_GRID,
    JointProblem,
    SplitJoint,
    StackedJoint,
    joint_buckets,
    length_buckets,
    paddable,
    padded,
    split_target,
    stack_structure,
    stacked_target,
)
from ..simulation.kernel import kernel_mode
from ..strategies.base import FitnessFn
from ..strategies.loop import BatchProgram, batch_program
from .runner import ExecutableCache, mesh_of, padded_size, replicate, shard, to_host
from .search import Search
from .setup import Setup

# The last few executables by (strategy, settings, argument shapes): consecutive cells of a sweep
# (other weights, bounds or recordings of equal length) reuse them.
EXECUTABLES = ExecutableCache(size=6)
PROGRESS_CHUNKS = 20


def fitness(space: Space, target: JointProblem | StackedJoint | SplitJoint) -> FitnessFn:
    """The population OF of unit-cube points: the (joint-weighted) eq. 24/27 of every recording
    (or the fit's loss), with each recording's parameters and adjustments (`JointProblem`)."""

    def of(z):
        return target.objective(space.to_physical(z))

    return of  # pyright: ignore[reportReturnType]


def _tqdm_progress(total: int):
    """A callback that moves a tqdm bar (on stderr) to `fraction * total`; `None` closes it."""
    bar = tqdm(total=total, unit="it", desc="iterations (all runs)", leave=False, dynamic_ncols=True)

    def report(fraction):
        if fraction is None:
            bar.close()
            return
        bar.update(int(round(fraction * total)) - bar.n)

    return report


class ProgressMeter:
    """One call's progress: the compiled runs report each device's runs' fractions done, per
    setup of the batch (a `jax.debug.callback`, once per device, setup and chunk, outside the
    vmap over runs, in any order), and the meter calls `target` with the fraction of all runs done."""

    def __init__(self, target: Callable[[float], object], total: int):
        self.target, self.total = target, total
        self.done: dict[tuple[int, int], np.ndarray] = {}

    def report(self, device, member, done) -> None:
        key = (int(device), int(member))
        old = self.done.get(key)  # unordered callbacks: keep the furthest state seen of every run
        self.done[key] = np.asarray(done) if old is None else np.maximum(old, done)
        self.target(float(sum(np.sum(d) for d in self.done.values()) / self.total))  # runs not heard from: not started


_TOKENS = itertools.count(1)
_METERS: dict[int, ProgressMeter] = {}  # the meters of the calls running now, by the token each passes its executable


def _report(token, device, member, done) -> None:
    meter = _METERS.get(int(token))
    if meter is not None:
        meter.report(device, member, done)


def leaf_signature(args) -> tuple:
    """Tree structure and (shape, dtype) of every array leaf: part of an executable's key."""
    return (jax.tree.structure(args), tuple((getattr(x, "shape", None), getattr(x, "dtype", type(x))) for x in jax.tree.leaves(args)))


def compile_key(search: Search, program: BatchProgram) -> tuple:
    """What of a search an executable is compiled for (the traced hyperparameters are arguments)."""
    return (program.key, search.budget, search.memory, search.generations, search.stop)


def group_key(setup: Setup) -> tuple:
    """Setups with the same key share one compiled call: the structure and shapes of their
    targets and spaces, their free parameters and integrator (a joint fit's setup is its own)."""
    if len(setup.recordings) != 1:
        return ("joint", id(setup))
    return (leaf_signature((setup.target, setup.space)), setup.space.free, repr(setup.integrator))


def _compiled_runs(program: BatchProgram, memory, mesh, dim: int, progress: bool, batched: bool, axis: str, split: bool = False):
    """All runs as one function of ((seed, run indices), target, space, precision, x0,
    hyperparameters, token, member), run r keyed by `fold_in(PRNGKey(seed), r)` inside the
    program (`runner.fold_keys`'s keys, not a separate compiled call): one setup's (`batched`
    False) or a stack of setups' (over the leading axis of the target, space, precision, x0 and
    member index, `_over_members`). On several devices each device runs
    its share along `axis` ("runs" or "recordings"); `split`: a joint fit on a mesh of runs x
    recordings, each run's recordings (a `SplitJoint`) split over its row of devices, the
    run's search repeated on each."""

    def device_runs(run_ids, target, space, prec, x0, hyper, token, member):
        seed, ids = run_ids
        keys = jax.vmap(lambda r: jax.random.fold_in(jax.random.PRNGKey(seed), r))(ids)
        report = None
        if progress:
            device = jax.lax.axis_index(("runs", axis) if split else axis) if mesh is not None else 0
            report = lambda done: jax.debug.callback(_report, token, device, member, done)
        return program.run(hyper, keys, fitness(space, target), dim, memory, prec, x0, report, PROGRESS_CHUNKS)

    fn = _over_members(device_runs, mesh) if batched else device_runs
    if mesh is not None:
        rep, part = PartitionSpec(), PartitionSpec(axis)
        if split:
            specs, out = ((rep, PartitionSpec("runs")), part, *[rep] * 6), PartitionSpec("runs")
        elif axis == "runs":
            specs, out = ((rep, part), *[rep] * 7), PartitionSpec(None, "runs") if batched else part
        else:
            specs, out = ((rep, rep), part, part, part, part, rep, rep, part), part
        fn = jax.shard_map(fn, mesh=mesh, in_specs=specs, out_specs=out, check_vma=False)
    return jax.jit(fn)


def side_by_side(mesh: Mesh | None) -> bool:
    """Whether a batch's setups run side by side on the mesh's devices (`_over_members`): not on a CPU."""
    return (mesh.devices.flat[0] if mesh is not None else jax.devices()[0]).platform != "cpu"


def _over_members(device_runs, mesh):
    """`device_runs` over the leading (setup) axis of a batch's target, space, precision, x0 and
    member index, the seeds, hyperparameters and token shared. On a CPU the setups run one after
    another (`lax.map`: each setup's loop ends with its own runs), elsewhere side by side
    (`vmap`, every setup's loop until the last has ended, its whole carry selected each
    iteration). Both give the same bits; on this 2-core CPU 20 recordings of 310-500 samples (2
    runs) compiled in 2.12 s instead of 2.31 and searched in 1.18 s instead of 1.47 at 20,000 FEs,
    1.75 s instead of 3.74 at 100,000, where the stopping rule ends the recordings' runs apart
    (medians, `python -m experiments.bench_members [--budget 100000]`)."""
    if side_by_side(mesh):
        return jax.vmap(device_runs, in_axes=(None, 0, 0, 0, 0, None, None, 0))

    def one_after_another(run_ids, target, space, prec, x0, hyper, token, member):
        each = lambda a: device_runs(run_ids, *a[:4], hyper, token, a[4])
        return jax.lax.map(each, (target, space, prec, x0, member))

    return one_after_another


def _stack(trees):
    return jax.tree.map(lambda *xs: np.stack([np.asarray(x) for x in xs]), *trees)


def _group_args(setups: list[Setup], targets: list, search: Search, pad: int):
    """(target, space, precision, x0, member) of a group (`targets`: the setups' objectives as the
    runs take them, `stacked_target`): one setup's as they are, several stacked (start rows padded
    with NaN to the most any setup has), `pad` copies of the last appended."""
    prec = None if search.memory is None else [s.precision() for s in setups]
    if len(setups) == 1 and pad == 0:
        s = setups[0]
        return (
            targets[0],
            s.space,
            None if prec is None else on_device(prec[0]),
            None if s.starts is None else on_device(s.starts),
            0,
        )
    dim = setups[0].space.dim
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
    more = lambda items: items + [items[-1]] * pad
    return (
        _stack(more(list(targets))),
        _stack(more([s.space for s in setups])),
        None if prec is None else np.stack(more(prec)),
        None if z0 is None else np.concatenate([z0] + [z0[-1:]] * pad),
        np.arange(len(setups) + pad),
    )


def run_group(
    setups: list[Setup], targets: list, search: Search, program: BatchProgram, report: Callable[[float], object] | None = None
) -> list[tuple]:
    """The runs of a group of setups of one `group_key` in one compiled call (`targets`: their
    objectives, `stacked_target`): per setup its runs' outputs (`RunOutput`, padding dropped) and
    the timing. `report`: called with the fraction done."""
    runs, n = search.runs, len(setups)
    batched = n > 1
    shards = 1 if batched else recording_shards(targets[0], runs)
    split = shards > 1
    axis = "recordings" if (runs == 1 and batched) or split else "runs"  # one run of many recordings: split the recordings
    devices = jax.devices()[: runs * shards] if split else jax.devices() if runs > 1 or axis == "recordings" else jax.devices()[:1]
    mesh = Mesh(np.array(devices).reshape(runs, shards), ("runs", axis)) if split else mesh_of(devices, axis)
    pad = padded_size(n, devices) - n if batched and axis == "recordings" else 0
    if split:
        targets = [split_target(targets[0], shards, axis)]
    target, space, prec, z0, member = _group_args(setups, targets, search, pad)
    if split:
        ids = shard(np.arange(runs), mesh, "runs")
        target = jax.tree.map(lambda a: shard(a, mesh, axis), target)
        space, prec, z0 = (jax.tree.map(lambda a: replicate(a, mesh), b) for b in (space, prec, z0))
    elif axis == "recordings":
        ids = replicate(np.arange(runs), mesh)
        target, space, prec, z0, member = (jax.tree.map(lambda a: shard(a, mesh, axis), b) for b in (target, space, prec, z0, member))
    else:
        ids = shard(np.arange(padded_size(runs, devices)), mesh, axis)
        if batched:
            target, space, prec, z0, member = (jax.tree.map(lambda a: replicate(a, mesh), b) for b in (target, space, prec, z0, member))
    token = next(_TOKENS)
    args = (
        (replicate(np.int64(search.seed), mesh), ids),
        target,
        space,
        prec,
        z0,
        program.hyper,
        on_device(token, np.int64),
        on_device(member),
    )
    show = report is not None
    weights = setups[0].target.weights, setups[0].target.layout
    options = compiler_options(search.budget * max(sample_steps(s) for s in setups), plain=search.memory is None and not batched)
    cache_key = (
        *compile_key(search, program),
        batched,
        batched and side_by_side(mesh),
        axis,
        *weights,
        len(devices),
        kernel_mode(),
        leaf_signature(args),
        show,
        tuple(sorted((options or {}).items())),
    )
    t0 = time.perf_counter()
    build = lambda: _compiled_runs(program, search.memory, mesh, setups[0].space.dim, show, batched, axis, split)
    compiled, reused = EXECUTABLES.get(cache_key, build, args, options)
    t1 = time.perf_counter()
    if report is not None:
        reports = shards  # split: every device of a run's row reports it
        _METERS[token] = ProgressMeter(report, (n + pad) * int(ids.shape[0]) * reports)
    try:
        outs = jax.block_until_ready(compiled(*args))
        jax.effects_barrier()
    finally:
        _METERS.pop(token, None)
    t2 = time.perf_counter()
    outs = jax.tree.map(to_host, outs)
    timing = {"compile_s": t1 - t0, "run_s": (t2 - t1) / n, "devices": len(devices), "reused_executable": reused}
    if batched:
        timing |= {"batch": n, "batch_run_s": t2 - t1}
        return [(jax.tree.map(lambda a, b=b: a[b, :runs], outs), timing) for b in range(n)]
    return [(jax.tree.map(lambda a: a[:runs], outs), timing)]


# `bucketed`, `compiler_options`: one compilation of a batch's runs costs about as much as this
# many FEs of one sample (a 2-core Xeon: ~2 s against ~2 ns; `python -m experiments.bench_each
# --lengths 400 1600`).
COMPILE_FES = 1e9

# XLA:CPU compiles at LLVM optimisation level 3 by default, with its fusion emitters. At level 2
# and without the fusion emitters (`dcjax.compiling.QUICK | LEAN`) a search program compiles in
# 0.31-0.55 of the time (SD1 DE 1.77 -> 0.71 s, ABC 4.47 -> 1.39 s) to the same bits for the paper's
# methods and memory (CMA-ES's linear algebra differs in the last bits) and searches in 0.90-1.08
# of the time; a memory-assisted search 1.27 and a batch of recordings (20 files of 20 lengths)
# 1.25 of it, which one rule for every run's program accepts: `python -m
# experiments.bench_compile_level`, `python -m experiments.bench_each --lengths 400 1600`. A long
# search keeps XLA's defaults.
QUICK_COMPILE = QUICK | LEAN


def sample_steps(setup: Setup) -> int:
    """Integration steps of one evaluation of `setup` (its samples times the sub-steps)."""
    return sum(p.n for p in setup.problems) * int(getattr(setup.integrator, "substeps", 1))


def compiler_options(run_work: float, plain: bool = True) -> dict | None:
    """`QUICK_COMPILE` where one run is short against a compilation (`run_work`: its one-sample
    FEs, budget x sample steps), else XLA's defaults (None). A plain search (no memory, one
    setup) compiles quick up to `COMPILE_FES`, ~2-3 s of search here: it compiles in 0.4-0.5 of
    the time (0.5-0.8 s saved) and searches in 0.97-1.05 of it (the paper's methods), 1.15 (476
    servo logs, CMA-ES; 1.05-1.07 on 2 devices), which the saving outweighs while a device's runs
    of the program search for less than ~5 s (`python -m experiments.bench_compile_level`). A
    memory-assisted search or a batch of recordings, 25-36 % slower, up to `COMPILE_FES` / 3.
    Per run, so that neither the number of runs nor a batch changes a run's program (CMA-ES's
    last bits differ between the options)."""
    return QUICK_COMPILE if run_work < (COMPILE_FES if plain else COMPILE_FES / 3) else None


# One run of a joint fit split over 2 host devices (servo logs of 700 samples, one run of 600 FEs,
# `python -m experiments.bench_split`): 2 logs (1,400 steps an evaluation) 0.99-1.07x, 8 logs
# (5,600) 1.15-1.64x, 32-476 logs 1.4-2.4x.
SPLIT_STEPS = 5_000


def recording_shards(target, runs: int) -> int:
    """Over how many devices each of `runs` runs of a joint fit splits its recordings
    (`SplitJoint`): the devices a run gets, `len(jax.devices()) // runs`, where that is at least 2,
    the target is stacked (`StackedJoint`) and an evaluation is at least `SPLIT_STEPS`
    integration steps (recordings x samples x sub-steps), where a share's simulation outweighs
    the sum over the devices every generation costs (`python -m experiments.bench_split`); else 1
    (the runs split over the devices as they are)."""
    shards = len(jax.devices()) // runs
    if not isinstance(target, StackedJoint) or shards < 2:
        return 1
    n, samples = target.stacked.y_meas.shape[:2]
    return shards if n * samples * int(getattr(target.stacked.integrator, "substeps", 1)) >= SPLIT_STEPS else 1


def bucketed(setups: list[Setup], search: Search) -> list[Setup]:
    """The setups with single recordings of one structure but several lengths padded into length
    buckets, masked as in a joint fit, where one compilation fewer saves more than the padding
    costs (`length_buckets`: a bucket's members are searched over its top length, `runs x
    budget` FEs each; a compilation weighs `COMPILE_FES`): a folder of many lengths compiles a
    few programs, not one per length. The tops are grid lengths (`on_length_grid`, at most 9 %
    above a member), the same for every folder: a second folder of similar files finds its
    programs in the persistent compilation cache. A padded recording is scored over its padded
    problem (the same OF to rounding, so its runs may differ in the last bits from a fit of it
    alone); recordings of one length only are not padded. A joint fit's recordings of far
    lengths likewise, into buckets of exact tops (`joint_buckets`)."""
    by_structure: dict = {}
    for k, s in enumerate(setups):
        if len(s.recordings) == 1 and paddable(s.problems[0]):
            key = (stack_structure(s.problems[0]), s.space.free, s.space.log, len(s.space.names), repr(s.integrator))
            by_structure.setdefault(key, []).append(k)
    fes = search.runs * search.budget
    out = [s if len(s.problems) < 2 else dataclasses.replace(s, problems=joint_buckets(s.problems, fes, COMPILE_FES)) for s in setups]
    for members in by_structure.values():
        lengths = [setups[k].problems[0].n for k in members]
        if len(set(lengths)) < 2:
            continue
        to = length_buckets(lengths, search.runs * search.budget, COMPILE_FES, LENGTH_GRID)
        for k, n in zip(members, lengths):
            out[k] = dataclasses.replace(setups[k], problems=[padded(setups[k].problems[0], to[n])])
    return out


def run_setups(setups: list[Setup], search: Search, progress=None) -> list[tuple]:
    """Every setup's runs (`run_group`), the setups of one `group_key` in one compiled call (single
    recordings of close lengths padded into one, `bucketed`): per setup, in order, its runs'
    outputs, the timing and the setup as it ran (itself, or padded)."""
    setups = bucketed(setups, search)
    targets = [stacked_target(s.target) for s in setups]  # a joint fit of one stacked group: held stacked
    groups: dict = {}
    for k, s in enumerate(setups):
        groups.setdefault(group_key(s), []).append(k)
    out: list = [None] * len(setups)
    show = progress is not None and progress is not False
    program = batch_program(search.strategy, search.budget, search.stop)
    total = search.runs * len(setups) * program.t_max
    overall = (progress if callable(progress) else _tqdm_progress(total)) if show else None
    done = 0
    try:
        for members in groups.values():
            share = len(members) / len(setups)
            base = done / len(setups)
            report = None if overall is None else lambda f, base=base, share=share: overall(base + share * f)
            for k, (outs, timing) in zip(
                members, run_group([setups[k] for k in members], [targets[k] for k in members], search, program, report)
            ):
                out[k] = (outs, timing, setups[k])
            done += len(members)
            if report is not None:
                report(1.0)
    finally:
        if show and not callable(progress):
            overall(None)  # pyright: ignore[reportOptionalCall]
    return out
