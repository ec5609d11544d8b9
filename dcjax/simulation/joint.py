"""The objective over a fit's whole search vector: the model's parameters (shared by every
recording, or one copy per recording where local), each recording's fitted initial states, and
sensor offsets and input delays (shared or local).

`Layout` says which column of the search vector each recording's model parameters and
adjustments come from; `JointProblem` evaluates the (joint-weighted) objective and the stacked
residuals of a vector. Recordings of equal length and structure are stacked and evaluated by one
`vmap`ped scan: one compilation whatever their number."""

import dataclasses
import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..compiling import compiled_when_eager, on_device
from ..errors import ConfigError
from ..models.base import DiscreteModel
from .adjustments import Adjustments
from .objectives import objective, residuals, simulate, simulate_outputs
from .problem import Problem

Columns = tuple[tuple[int, ...], ...]  # (R, k): per recording, a column of the search vector per item


class Layout(eqx.Module):
    """The search vector's `names`; per recording r, `model_cols[r]` the column of each model
    parameter; `y0_cols[r]` of each state in `y0_states` (indices into the model's states);
    `offset_cols[r]` of each channel in `offset_channels` (indices into the measured channels);
    `delay_cols[r]` of each input in `delay_inputs`. A state that starts at its measured first
    sample and whose sensor has an offset (`measured_start`, indices into `offset_channels`)
    starts at that sample less the offset. A state estimator's fitted noise: `process_cols[r]` of
    each state in `process_states`, `noise_cols[r]` of each output in `noise_channels`."""

    names: tuple[str, ...] = eqx.field(static=True)
    model_cols: Columns = eqx.field(static=True)
    y0_states: tuple[int, ...] = eqx.field(static=True, default=())
    y0_cols: Columns = eqx.field(static=True, default=())
    offset_channels: tuple[int, ...] = eqx.field(static=True, default=())
    offset_cols: Columns = eqx.field(static=True, default=())
    delay_inputs: tuple[int, ...] = eqx.field(static=True, default=())
    delay_cols: Columns = eqx.field(static=True, default=())
    measured_start: tuple[int, ...] = eqx.field(static=True, default=())  # offset channels whose state starts at the measured sample
    process_states: tuple[int, ...] = eqx.field(static=True, default=())  # a state estimator's fitted process intensities q_<state>
    process_cols: Columns = eqx.field(static=True, default=())
    noise_channels: tuple[int, ...] = eqx.field(static=True, default=())  # and its fitted sensor sd r_<output>
    noise_cols: Columns = eqx.field(static=True, default=())

    @classmethod
    def plain(cls, names: tuple[str, ...], recordings: int = 1) -> "Layout":
        """The model's parameters, shared by every recording, nothing adjusted."""
        return cls(tuple(names), (tuple(range(len(names))),) * recordings)

    @property
    def recordings(self) -> int:
        return len(self.model_cols)

    @property
    def shared(self) -> bool:
        """Every recording takes the model parameters from the same columns, in order."""
        return all(c == tuple(range(len(c))) for c in self.model_cols)

    @property
    def adjusted(self) -> bool:
        return bool(self.y0_states or self.offset_channels or self.delay_inputs or self.process_states or self.noise_channels)

    def model_x(self, x, r: int):
        """Recording r's model parameter vector(s) of the search vector(s) `x` (…, D)."""
        cols = self.model_cols[r]
        if cols == tuple(range(x.shape[-1])):
            return x
        return x[..., np.asarray(cols)]

    def adjustments(self, x, r: int, problem: Problem) -> Adjustments | None:
        """Recording r's `Adjustments` of the search vector(s) `x` (None: nothing adjusted)."""
        if not self.adjusted:
            return None
        offset = delay = None
        y0 = jnp.broadcast_to(problem.y0, (*x.shape[:-1], problem.y0.shape[0]))
        if self.measured_start:
            model = problem.model
            for j in self.measured_start:
                s = model.states.index(model.outputs[self.offset_channels[j]])
                y0 = y0.at[..., s].add(-x[..., self.offset_cols[r][j]])
        if self.y0_states:
            y0 = y0.at[..., np.asarray(self.y0_states)].set(x[..., np.asarray(self.y0_cols[r])])
        if self.offset_channels:
            offset = jnp.zeros((*x.shape[:-1], problem.y_meas.shape[1]), x.dtype)
            offset = offset.at[..., np.asarray(self.offset_channels)].set(x[..., np.asarray(self.offset_cols[r])])
        if self.delay_inputs:
            delay = jnp.zeros((*x.shape[:-1], problem.u_start.shape[1]), x.dtype)
            delay = delay.at[..., np.asarray(self.delay_inputs)].set(x[..., np.asarray(self.delay_cols[r])])
        process = noise = None
        predictor = problem.predictor
        if self.process_states:
            process = jnp.broadcast_to(predictor.process, (*x.shape[:-1], len(problem.model.states))).astype(x.dtype)  # pyright: ignore[reportAttributeAccessIssue]
            process = process.at[..., np.asarray(self.process_states)].set(x[..., np.asarray(self.process_cols[r])])
        if self.noise_channels:
            noise = jnp.broadcast_to(predictor.measurement, (*x.shape[:-1], problem.y_meas.shape[1])).astype(x.dtype)  # pyright: ignore[reportAttributeAccessIssue]
            noise = noise.at[..., np.asarray(self.noise_channels)].set(x[..., np.asarray(self.noise_cols[r])])
        y0 = y0 if self.y0_states or self.measured_start else None
        return Adjustments(y0, offset, delay, self.delay_inputs, process, noise)


PAD_SHARE = 1.25  # pad a group's shorter recordings where that adds at most 25 % samples


def stack_structure(problem: Problem):
    """What must be equal to stack problems, their length aside."""
    return jax.tree.structure(problem), tuple(np.shape(a)[1:] for a in jax.tree.leaves(problem))


def paddable(problem: Problem) -> bool:
    """Whether `padded` can lengthen the problem (an ODE model's state holds over steps of zero
    length; a discrete-time model's map would run on past the end)."""

    return not isinstance(problem.model, DiscreteModel)


def grid_length(n: int) -> int:
    """The power of two at or above `n` (at least 64): evaluations of recordings of many lengths
    padded to it share a few compiled programs (a padded problem's extra steps change nothing
    before the recording's end)."""
    return max(64, 1 << (int(n) - 1).bit_length())


LENGTH_GRID = 8  # grid lengths per octave (`on_length_grid`): a recording is padded by at most 2^(1/8) - 1 = 9 %


def on_length_grid(n: int, per_octave: int = LENGTH_GRID) -> int:
    """The least length of the grid ceil(2^(k / per_octave)), k = 0, 1, ..., at or above `n`: a
    bounded set of lengths, the same for every folder, so that programs compiled for one folder's
    buckets serve the next (the persistent compilation cache)."""
    k = max(0, math.floor(per_octave * math.log2(max(int(n), 1))) - 1)
    while math.ceil(2 ** (k / per_octave)) < n:
        k += 1
    return math.ceil(2 ** (k / per_octave))


def length_buckets(lengths, fes: float, compile_fes: float, per_octave: int | None = None) -> dict[int, int]:
    """Each length -> the length it is padded to, the buckets that minimise the estimated cost
    sum over buckets of (compile_fes + fes * top * members): one compilation costs as much as
    `compile_fes` FEs of one sample, each of a bucket's members is searched for `fes` FEs over
    the bucket's top length. An exact partition of the sorted lengths (dynamic programming);
    equal lengths always share a bucket. With `per_octave`, every top is a grid length
    (`on_length_grid`): the lengths of one grid cell share a bucket, and the buckets are of cells."""
    count: dict[int, int] = {}
    top_of = (lambda n: on_length_grid(n, per_octave)) if per_octave else (lambda n: int(n))
    for n in lengths:
        count[top_of(n)] = count.get(top_of(n), 0) + 1
    u = sorted(count, reverse=True)
    best, cut = [0.0], [0]  # best[j]: the cost of the j longest tops; cut[j]: where its last bucket starts
    for j in range(1, len(u) + 1):
        members, options = 0, []
        for i in range(j, 0, -1):  # the last bucket holds u[i-1] .. u[j-1], its top u[i-1]
            members += count[u[i - 1]]
            options.append((best[i - 1] + compile_fes + fes * u[i - 1] * members, i))
        cost, i = min(options)
        best.append(cost)
        cut.append(i)
    bucket, j = {}, len(u)
    while j > 0:
        i = cut[j]
        bucket |= {n: u[i - 1] for n in u[i - 1 : j]}
        j = i - 1
    return {int(n): bucket[top_of(n)] for n in lengths}


def joint_buckets(problems: list[Problem], fes: float, compile_fes: float) -> list[Problem]:
    """A joint fit's problems with those of one structure whose lengths are too far apart for
    `JointProblem.groups` to pad into one scan (`PAD_SHARE`) `padded` into the length buckets
    that cost least (`length_buckets` with exact tops: every evaluation runs every recording, so
    each sample costs `fes` FEs; a scan more to compile `compile_fes`): few scans where the
    search is short, one per length where it is long. The others as they are (discrete-time
    models are not paddable)."""
    by_structure: dict = {}
    for r, p in enumerate(problems):
        if paddable(p):
            by_structure.setdefault(stack_structure(p), []).append(r)
    out = list(problems)
    for members in by_structure.values():
        lengths = [problems[r].n for r in members]
        if len(set(lengths)) < 2 or max(lengths) * len(members) <= PAD_SHARE * sum(lengths):  # one scan already
            continue
        to = length_buckets(lengths, fes, compile_fes)
        if len(set(to.values())) < len(set(lengths)):
            for r, n in zip(members, lengths):
                out[r] = padded(problems[r], to[n])
    return out


def padded(problem: Problem, n: int) -> Problem:
    """`problem` lengthened to `n` samples that do not count: steps of zero length (the state
    holds), the last inputs and measurements repeated, `mask` 0 there (eq. 24's 1/N and the
    peaks stay the recording's own)."""
    k = n - problem.n
    # NumPy on concrete arrays (a batch's recordings before its compiled call: jnp would compile
    # each eager op for each length), jnp on traced ones (a joint fit's groups, inside its objective)
    xp = jnp if isinstance(problem.h, jax.core.Tracer) else np
    mask = xp.ones(problem.n) if problem.mask is None else problem.mask
    if k == 0:
        return problem if problem.mask is not None else dataclasses.replace(problem, mask=on_device(mask))

    def hold(a):
        a = xp.asarray(a)
        return on_device(xp.concatenate([a, xp.repeat(a[-1:], k, axis=0)]))

    return dataclasses.replace(
        problem,
        h=on_device(xp.concatenate([problem.h, xp.zeros(k)])),
        u_start=hold(problem.u_start),
        u_end=hold(problem.u_end),
        y_meas=hold(problem.y_meas),
        mask=on_device(xp.concatenate([mask, xp.zeros(k)])),
    )


def to_common_length(problems: list[Problem]) -> list[Problem]:
    """A group's problems as one stack takes them: all `padded` to the longest where lengths differ."""
    n = max(p.n for p in problems)
    return problems if all(p.n == n for p in problems) else [padded(p, n) for p in problems]


UNROLLED_SUM = 32  # recordings up to which the weighted sum is written out term by term


def weighted_in_order(weights: tuple[float, ...], ofs) -> Array:
    """sum_r w_r OF_r term by term in recording order (the same bits however the OFs were
    evaluated; a scan's sum contracts differently under jit). Beyond `UNROLLED_SUM` recordings
    a loop over them (8 terms an iteration), so that the program does not grow with their
    number: 476 servo logs, DE, 2 runs, compiled in 2.6 s, was 3.5-3.6 s written out, the search
    2-4 % slower (`python -m experiments.bench_servo_eval --fit`)."""
    if len(weights) <= UNROLLED_SUM:
        acc = 0 + weights[0] * ofs[0]
        for r in range(1, len(weights)):
            acc = acc + weights[r] * ofs[r]
        return acc
    ofs = jnp.stack(list(ofs)) if isinstance(ofs, list | tuple) else ofs
    w = jnp.asarray(weights, ofs.dtype)
    return jax.lax.fori_loop(1, len(weights), lambda r, acc: acc + w[r] * ofs[r], w[0] * ofs[0], unroll=8)


class JointProblem(eqx.Module):
    """One or several recordings' problems, each recording's share of the objective (`weights`,
    static: eq. 24 per recording, summed) and the `Layout` of the search vector."""

    problems: tuple[Problem, ...]
    weights: tuple[float, ...] = eqx.field(static=True)
    layout: Layout = eqx.field(static=True)

    def __check_init__(self):
        if len(self.problems) != len(self.weights) or len(self.problems) != self.layout.recordings:
            raise ConfigError("a JointProblem needs one weight and one layout row per recording")

    @property
    def names(self) -> tuple[str, ...]:
        return self.layout.names

    def model_x(self, x, r: int):
        return self.layout.model_x(x, r)

    def adjustments(self, x, r: int) -> Adjustments | None:
        return self.layout.adjustments(x, r, self.problems[r])

    @compiled_when_eager
    def objective(self, x: Float[Array, "*batch D"]) -> Float[Array, "*batch"]:
        """sum_r w_r OF_r(x), OF_r the recording's objective with its parameters and adjustments;
        recordings of equal length and structure are evaluated stacked (`groups`), the sum is
        taken in recording order."""
        ofs: list = [None] * len(self.problems)
        for group in self.groups():
            if len(group) == 1:
                r = group[0]
                ofs[r] = objective(self.model_x(x, r), self.problems[r], self.adjustments(x, r))
            else:
                stacked = self._stacked(x, group)
                for k, r in enumerate(group):
                    ofs[r] = stacked[k]
        return weighted_in_order(self.weights, ofs)

    def groups(self) -> list[tuple[int, ...]]:
        """The recordings in groups that one scan evaluates: equal structure, and equal length or
        lengths close enough to pad the shorter ones (`padded`, at most `PAD_SHARE` more samples
        in all; not for a discrete-time model, whose map would run on past the end)."""
        out: dict = {}
        for r, p in enumerate(self.problems):
            out.setdefault(stack_structure(p), []).append(r)
        groups = []
        for members in out.values():
            lengths = [self.problems[r].n for r in members]
            if len(set(lengths)) == 1 or max(lengths) * len(members) <= PAD_SHARE * sum(lengths) and paddable(self.problems[members[0]]):
                groups.append(tuple(members))
                continue
            by_length: dict = {}
            for r in members:
                by_length.setdefault(self.problems[r].n, []).append(r)
            groups += [tuple(g) for g in by_length.values()]
        return groups

    def _stacked(self, x, group: tuple[int, ...], fn=None) -> Array:
        """(len(group), *batch, ...): `fn` (the objective, or the residuals) of the group's
        recordings from one vmapped call over their stacked (padded) problems."""
        lay = self.layout
        stacked = jax.tree.map(lambda *a: jnp.stack(a), *to_common_length([self.problems[r] for r in group]))
        xm = lay.model_x(x, group[0]) if lay.shared else jnp.stack([lay.model_x(x, r) for r in group])
        adj = None if not lay.adjusted else jax.tree.map(lambda *a: jnp.stack(a), *[self.adjustments(x, r) for r in group])
        fn = objective if fn is None else fn
        return jax.vmap(fn, in_axes=(None if lay.shared else 0, 0, 0 if adj is not None else None))(xm, stacked, adj)

    def each(self, x: Float[Array, " D"], fn) -> list:
        """`fn(params, problem, adjustments)` of every recording, in recording order; the
        recordings of one group from one vmapped call (a padded recording's value is over the
        group's length: the caller trims its padding)."""
        out: list = [None] * len(self.problems)
        for group in self.groups():
            if len(group) == 1:
                r = group[0]
                out[r] = fn(self.model_x(x, r), self.problems[r], self.adjustments(x, r))
                continue
            stacked = self._stacked(x, group, fn)
            for k, r in enumerate(group):
                out[r] = stacked[k]
        return out

    def residuals(self, x: Float[Array, " D"]) -> Float[Array, " m"]:
        """Every recording's residuals (`dcjax.residuals`, in recording order), each scaled by
        sqrt(its weight): sum r^2 is `objective(x)`. Recordings of one group are evaluated by one
        vmapped call, as in `objective` (a padded recording's extra samples are left out)."""
        out = [o.reshape(p.y_meas.shape[1], -1)[:, : p.n].reshape(-1) for o, p in zip(self.each(x, residuals), self.problems)]
        return jnp.concatenate([jnp.sqrt(w) * o for w, o in zip(self.weights, out)])

    def simulate(self, x: Float[Array, " D"], r: int = 0):
        """Recording r's states at its samples, with its parameters and adjustments."""

        return simulate(self.model_x(x, r), self.problems[r], self.adjustments(x, r))

    def simulate_outputs(self, x: Float[Array, " D"], r: int = 0):
        """Recording r's compared outputs at its samples (`dcjax.simulate_outputs`: through the
        output equation, with the fitted sensor offsets)."""

        return simulate_outputs(self.model_x(x, r), self.problems[r], self.adjustments(x, r))


def over_stack(fn, layout: Layout, stacked: Problem, x):
    """`fn(params, problem, None)` (the objective or the residuals) of every recording of a stack
    of problems with shared parameters, from one vmapped call: (recordings, ...)."""
    return jax.vmap(fn, in_axes=(None, 0, None))(layout.model_x(x, 0), stacked, None)


class StackedJoint(eqx.Module):
    """A `JointProblem` whose recordings form one stacked group, held stacked (`stacked_target`):
    the problems' leaves carry a leading recordings axis, so a compiled objective takes one set
    of arrays and makes one vmapped call whatever the number of recordings (a `JointProblem`
    stacks and splits them inside the program: its size, and XLA's compile time, grow with the
    count). The same OF to the bit: the same vmapped call, and the weighted sum in recording
    order."""

    stacked: Problem
    weights: tuple[float, ...] = eqx.field(static=True)
    layout: Layout = eqx.field(static=True)

    @compiled_when_eager
    def objective(self, x: Float[Array, "*batch D"]) -> Float[Array, "*batch"]:
        ofs = over_stack(objective, self.layout, self.stacked, x)
        return weighted_in_order(self.weights, ofs)

    def residuals(self, x: Float[Array, " D"]) -> Float[Array, " m"]:
        """`JointProblem.residuals` from one vmapped call: every recording's residuals scaled by
        sqrt(its weight), in recording order (a padded recording's extra samples, masked, are
        zeros: the same sum of squares). One program whatever the number of recordings."""
        out = over_stack(residuals, self.layout, self.stacked, x)
        return (jnp.sqrt(jnp.asarray(self.weights, out.dtype))[:, None] * out).reshape(-1)


class SplitJoint(eqx.Module):
    """A `StackedJoint` whose recordings are split over devices: inside a `shard_map` over `axis`
    each device holds its share of the stacked problems (and their weights) and the objective
    sums its share, then all shares (`psum`): every device gets the same OF, so the search runs
    the same on each. Padding recordings (to a multiple of the device count) carry weight 0. The
    OF equals `StackedJoint`'s to rounding (another order of the sum)."""

    stacked: Problem
    weights: Float[Array, " N"] | np.ndarray  # host arrays until placed on the devices
    layout: Layout = eqx.field(static=True)
    axis: str = eqx.field(static=True)

    def objective(self, x: Float[Array, "*batch D"]) -> Float[Array, "*batch"]:
        ofs = over_stack(objective, self.layout, self.stacked, x)
        w = self.weights.reshape(self.weights.shape + (1,) * (ofs.ndim - 1))
        return jax.lax.psum(jnp.sum(jnp.where(w > 0, w * ofs, 0.0), axis=0), self.axis)


def split_target(target: StackedJoint, parts: int, axis: str) -> SplitJoint:
    """`target`'s recordings ready to split into `parts` equal shares along `axis` (the last
    recording repeated with weight 0 up to a multiple of `parts`); host arrays, to be placed."""
    n = len(target.weights)
    pad = -(-n // parts) * parts - n
    more = lambda a: np.concatenate([np.asarray(a)] + [np.asarray(a)[-1:]] * pad) if pad else a  # no copy where the shares are equal
    stacked = jax.tree.map(lambda a: more(a) if eqx.is_array(a) else a, target.stacked)
    return SplitJoint(stacked, np.asarray(target.weights + (0.0,) * pad), target.layout, axis)


def stacked_target(target: JointProblem) -> "JointProblem | StackedJoint":
    """`target` held stacked (`StackedJoint`) where its recordings, two or more, form one group
    (`JointProblem.groups`), share the model's parameters and have no adjustments; else itself.
    On concrete arrays (NumPy): call it outside a traced function."""
    n = len(target.problems)
    if n < 2 or not target.layout.shared or target.layout.adjusted or target.groups() != [tuple(range(n))]:
        return target
    stacked = jax.tree.map(lambda *a: np.stack([np.asarray(v) for v in a]), *to_common_length(list(target.problems)))
    return StackedJoint(stacked, target.weights, target.layout)


def joint_problem(problems: list[Problem], weights=None, layout: Layout | None = None) -> JointProblem:
    """`JointProblem` of `problems` (default equal shares, the model's parameters shared)."""
    problems = list(problems)
    weights = tuple(float(w) for w in (weights if weights is not None else [1.0 / len(problems)] * len(problems)))
    layout = layout or Layout.plain(problems[0].model.names, len(problems))
    return JointProblem(tuple(problems), weights, layout)


def stacked_residuals(x, problems: list[Problem], weights: list[float]):
    """Residuals of several recordings (a joint fit), each scaled by sqrt(its weight): sum r^2
    is the weighted OF (eq. 24 per recording); `JointProblem.residuals` of the shared parameters."""
    return joint_problem(problems, weights).residuals(x)
