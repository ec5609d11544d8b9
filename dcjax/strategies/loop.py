"""A search's run as one compiled loop: the run's carry between iterations, its start (the
evaluated initial population, or a `pending` one that the loop's first pass evaluates), its
iterations under the budget and the stopping rule, a batch of runs in one loop, and what a run
returns. The strategies' operators and state are `dcjax.strategies.base`'s."""

import dataclasses
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int, PRNGKeyArray

from ..compiling import on_device
from ..errors import ConfigError
from .base import FitnessFn, State, Strategy, is_pending, with_best
from .memory import MemoryAssistance, get_memory
from .stopping import Converged


def hyperparameters(strategy: Strategy) -> dict[str, Array]:
    """The strategy's traced hyperparameters (`Strategy.traced`, e.g. DE's F and CR) as float64
    scalars: an argument of the compiled runs, so a sweep over them reuses one executable."""
    return {n: on_device(getattr(strategy, n), np.float64) for n in strategy.traced}


def with_hyperparameters(strategy: Strategy, values: dict[str, Array]) -> Strategy:
    """`strategy` with its traced hyperparameters set to `values` (tracers inside the executable)."""
    if not values:
        return strategy
    names = tuple(values)
    return eqx.tree_at(lambda s: tuple(getattr(s, n) for n in names), strategy, tuple(values[n] for n in names))


def structure_key(strategy: Strategy) -> str:
    """What of the strategy the executable is compiled for: everything but the traced values."""
    return repr(dataclasses.replace(strategy, **{n: None for n in strategy.traced}))


Scalar = Float[Array, ""]
Count = Int[Array, ""]


class RunOutput(eqx.Module):
    """One run's outcome."""

    best_x: Float[Array, " D"]
    """The best point (unit cube)."""
    best_f: Scalar
    """Its OF."""
    fes: Count
    """The FEs really spent (simulations)."""
    iterations: Count
    """The iterations done."""
    history: Float[Array, " T"]
    """The best OF after each iteration (`history[k]`; NaN past the last iteration)."""
    dups: Count
    """Candidates answered from memory."""
    chunks: Count
    """Memory chunks searched (0 without memory)."""
    converged: Bool[Array, ""]
    """Whether the run ended by its stopping rule (`Converged`) before its budget."""


class RunCarry(eqx.Module):
    """A run between iterations: the strategy's state, the iteration count, the best OF after
    each iteration so far and the key of the iterations."""

    state: State
    it: Int[Array, ""]
    history: Float[Array, " T"]
    key: PRNGKeyArray


def iteration_limit(strategy: Strategy, budget: int, generations: int | None = None) -> int:
    """The most iterations a run makes (see `run`): `generations` (default the strategy's), else the memory-free run's
    count for the budget, with or without memory (paper Section 4.4: 2000 iterations either way;
    a duplicate saves its simulation, it does not buy more iterations)."""
    generations = strategy.generations if generations is None else generations
    if generations is not None:
        return int(generations)
    return max(1, strategy.max_iterations(budget))


def run_start(
    strategy: Strategy,
    key: PRNGKeyArray,
    fn: FitnessFn,
    budget: int,
    dim: int,
    memory: "MemoryAssistance | str | None" = None,
    precision: Float[Array, " D"] | None = None,
    generations: int | None = None,
    capacity: int | None = None,
    x0: Float[Array, "K D"] | None = None,
) -> RunCarry:
    """The evaluated initial population (and memory) of a run; see `run`."""
    t_max = iteration_limit(strategy, budget, generations)
    k_init, k_run = jax.random.split(key)
    memory = get_memory(memory)
    if memory is None and folds_initial_evaluation(strategy, budget, t_max):
        return RunCarry(strategy.pending(k_init, dim, x0), jnp.asarray(0), jnp.full((t_max,), jnp.nan), k_run)
    state = with_best(strategy.init(k_init, fn, budget, dim, x0))
    if memory is not None:
        if precision is None:
            raise ConfigError("memory needs a precision vector (unit-cube units)")
        evaluated = jnp.arange(state.pop.shape[0]) < state.fes
        cap = capacity if capacity is not None else budget + strategy.pop_size
        state = state.replace(memory=memory.create(precision, state.pop, state.fit, evaluated, cap))
    return RunCarry(state, jnp.asarray(0), jnp.full((max(1, t_max),), jnp.nan), k_run)


def folds_initial_evaluation(strategy: Strategy, budget: int, t_max: int) -> bool:
    """Whether a run's initial population is evaluated by the first pass of its loop (`pending`,
    an extra pass that counts as no iteration) rather than before the loop: a strategy that can
    (`evaluates_pending`), without memory, where the loop runs. Its program then holds one copy
    of the objective's simulation fewer, to the same bits on the paper's data: XLA compiled a
    short DE search of SD1 in 0.73-0.83 of the time, TLBO's in 0.92, ABC's in 0.86, a folder of 20
    recordings in 0.83 (GA's: no gain measured; `python -m experiments.bench_fold_initial`)."""
    return evaluates_pending(strategy) and t_max >= 1 and strategy.max_iterations(budget) > 0


def evaluates_pending(strategy: Strategy) -> bool:
    """`strategy.evaluates_pending` where one class defines its `init`, `pending` and `step`: a
    subclass that overrides one of them (its own `init`, say) runs as that says, its initial
    population evaluated by `init` before the loop."""
    owner = lambda name: next(c for c in type(strategy).__mro__ if name in vars(c))
    return strategy.evaluates_pending and owner("init") is owner("pending") is owner("step")


def run_active(strategy: Strategy, carry: RunCarry, budget: int, t_max: int, stop: Converged | None = None) -> Bool[Array, ""]:
    """Whether the run goes on: budget for another step is left, fewer than `t_max` iterations
    are done and, with `stop`, the run has not converged."""
    go = (carry.state.fes + strategy.cost <= budget) & (carry.it < t_max)
    return go if stop is None else go & ~converged(strategy, carry, stop)


def converged(strategy: Strategy, carry: RunCarry, stop: Converged | None) -> Bool[Array, ""]:
    """Whether the run has converged by `stop` (False without one)."""
    if stop is None:
        return jnp.asarray(False)
    return has_converged(stop, carry.it, carry.history, carry.state.fit, strategy.population_converges)


def has_converged(
    stop: Converged, it: Int[Array, ""], history: Float[Array, " T"], fit: Float[Array, " P"], spread: bool
) -> Bool[Array, ""]:
    """`Converged` for a run `it` iterations in (its best OF after each in `history`, its
    population's OFs `fit`): the best improved by at most rtol |best| + atol over the last
    `patience` iterations and, with `spread`, more than half the population within that of the
    best (a member stuck far off, as a TLBO learner that no longer improves, does not keep the
    run going). NaN or inf OFs: never."""
    history, fit = jnp.asarray(history), jnp.asarray(fit)  # NumPy arrays too, without NumPy's warning for inf - inf
    best = history[jnp.maximum(it - 1, 0)]
    past = history[jnp.maximum(it - 1 - stop.patience, 0)]
    tol = stop.rtol * jnp.abs(best) + stop.atol
    done = (it > stop.patience) & (past - best <= tol)
    if spread:  # more than half the population within tol of the best (the median, counted: no sort)
        done = done & (2 * jnp.sum(fit - best <= tol) > fit.shape[0])
    return done


def run_steps(
    strategy: Strategy, carry: RunCarry, fn: FitnessFn, budget: int, t_max: int, until=None, stop: Converged | None = None
) -> RunCarry:
    """Iterate while the run is active (`run_active`, with the stopping rule `stop`) and, with
    `until`, while fewer than `until` iterations are done (so a run can be advanced in chunks
    with one executable; the result does not depend on the chunking: iteration `it` always uses
    `fold_in(key, it)`)."""

    def cond(c: RunCarry):
        go = run_active(strategy, c, budget, t_max, stop)
        return go if until is None else go & (c.it < until)

    return jax.lax.while_loop(cond, lambda c: run_iteration(strategy, c, fn, budget), carry)


def run_iteration(strategy: Strategy, carry: RunCarry, fn: FitnessFn, budget: int) -> RunCarry:
    """One iteration of a run (the body of `run_steps`), or, from a `pending` state, the pass
    that evaluates the initial population: no iteration counted, nothing in the history (its
    variates, drawn with the first iteration's key, are not used)."""
    state, it, entry = iterate(strategy, carry, fn, budget)
    history = jax.lax.dynamic_update_slice(carry.history, entry[None], (carry.it,))  # in place, not a scatter
    return RunCarry(state, it, history, carry.key)


def iterate(strategy: Strategy, carry: RunCarry, fn: FitnessFn, budget: int) -> tuple[State, Int[Array, ""], Float[Array, ""]]:
    """`run_iteration`'s new state, iteration count and history entry (for slot `carry.it`: the
    best OF, or the slot's old value after a `pending` state's pass), the history not written."""
    state = with_best(strategy.step(jax.random.fold_in(carry.key, carry.it), carry.state, fn, budget))
    if state.memory is not None:
        state = state.replace(memory=state.memory.refresh(state.pop, state.fit))
    if not evaluates_pending(strategy):
        return state, carry.it + 1, state.best_f
    counted = ~is_pending(carry.state)
    return state, carry.it + counted, jnp.where(counted, state.best_f, carry.history[carry.it])


# Per-run leaves larger than this (a memory's history or hash table) are not masked when a run
# has finished: they are never read for its results, and selecting them costs a full copy.
MASK_LIMIT = 4096


def run_batch(
    strategy: Strategy,
    keys: PRNGKeyArray,
    fn: FitnessFn,
    budget: int,
    dim: int,
    *,
    report: Callable | None = None,
    report_every: int = 0,
    stop: Converged | None = None,
    **options,
) -> RunOutput:
    """Independent runs (one per key) in one loop: the same results as `jax.vmap(run)`, but the
    loop stops when no run is active and a finished run's carry is kept by selecting only its
    small leaves. (Under `vmap`, a `while_loop` whose predicate differs between runs selects the
    whole carry every iteration — for LTMA a table of ~10^5 records per run, which made LTMA
    5-160x slower than no memory.) With `report`, `report(done)` is traced every `report_every`
    iterations with each run's fraction done (a callback's calls may arrive out of order).
    `stop`: the stopping rule (`Converged`; a run that meets it ends, as one at its budget).
    `options`: `run_start`'s `memory`, `precision`, `generations`, `x0` (no `capacity`: the default)."""
    t_max = iteration_limit(strategy, budget, options.get("generations"))
    carry = jax.vmap(lambda k: run_start(strategy, k, fn, budget, dim, **options))(keys)
    # the initial population spends the budget: no loop to compile (its body would not run)
    if strategy.max_iterations(budget) == 0 or t_max < 1:
        return jax.vmap(lambda c: run_output(c, converged(strategy, c, stop)))(carry)
    n_runs = keys.shape[0]

    def flags(c):
        """(active, converged) of every run: the stopping rule's test once per iteration, its
        result carried to the loop's condition, the next iteration's mask and the output."""
        done = jax.vmap(lambda c: converged(strategy, c, stop))(c)
        return jax.vmap(lambda c: run_active(strategy, c, budget, t_max))(c) & ~done, done

    def advanced(go, c):
        """The carry after one iteration of the runs still active (`go`): a finished run's small
        leaves selected back, its history slot keeping its old value."""
        state, it, entry = jax.vmap(lambda c: iterate(strategy, c, fn, budget))(c)
        new = RunCarry(state, it, c.history, c.key)
        if n_runs > 1:  # one run: the loop runs only while it is active, nothing to select back

            def pick(a, b):
                if a.ndim == 0 or a.size // n_runs > MASK_LIMIT:
                    return a
                return jnp.where(go.reshape((n_runs,) + (1,) * (a.ndim - 1)), a, b)

            new = jax.tree.map(pick, new, c)
        # The history is written once, at the run's slot (not selected whole: a copy of every
        # run's history each iteration made 50 SD1 runs search 2 % longer).
        slot = lambda h, i, e, g: jax.lax.dynamic_update_slice(h, jnp.where(g, e, h[i])[None], (i,))
        return eqx.tree_at(lambda c: c.history, new, jax.vmap(slot)(c.history, c.it, entry, go))

    def body(loop):
        i, c, (go, _) = loop
        c = advanced(go, c)
        go, done = flags(c)
        if report is not None:
            send = report
            fraction = jnp.where(go, jnp.minimum(jnp.maximum(c.it / t_max, c.state.fes / budget), 1.0), 1.0)
            jax.lax.cond((i + 1) % report_every == 0, lambda: send(fraction), lambda: None)
        return i + 1, c, (go, done)

    _, carry, (_, done) = jax.lax.while_loop(lambda loop: jnp.any(loop[2][0]), body, (jnp.asarray(0), carry, flags(carry)))
    return jax.vmap(run_output)(carry, done)


class BatchProgram(eqx.Module):
    """What the compiled runs of a strategy are built from, derived once: the strategy, its
    budget, iteration limit (`iteration_limit`), traced hyperparameters (`hyperparameters`: an
    argument of the executable, so a sweep over them reuses it) and the key of what is compiled
    in (`structure_key`). `run` is `run_batch` with the hyperparameters given."""

    strategy: Strategy = eqx.field(static=True)
    budget: int = eqx.field(static=True)
    t_max: int = eqx.field(static=True)
    key: str = eqx.field(static=True)
    hyper: dict
    stop: Converged | None = eqx.field(static=True, default=None)

    def run(
        self,
        hyper: dict[str, Array],
        keys: PRNGKeyArray,
        fn: FitnessFn,
        dim: int,
        memory=None,
        precision=None,
        x0=None,
        report: Callable | None = None,
        chunks: int = 20,
    ) -> RunOutput:
        """`run_batch` of the strategy with `hyper` (traced), reporting about `chunks` times."""
        strategy = with_hyperparameters(self.strategy, hyper)
        every = max(1, -(-self.t_max // chunks))
        return run_batch(
            strategy,
            keys,
            fn,
            self.budget,
            dim,
            report=report,
            report_every=every,
            stop=self.stop,
            memory=memory,
            precision=precision,
            x0=x0,
        )


def batch_program(strategy: Strategy, budget: int, stop: Converged | None = None) -> BatchProgram:
    """The `BatchProgram` of `strategy` at `budget` FEs a run (ending a converged run by `stop`)."""
    return BatchProgram(strategy, budget, iteration_limit(strategy, budget), structure_key(strategy), hyperparameters(strategy), stop)


def run_output(carry: RunCarry, stopped: Bool[Array, ""] | bool = False) -> RunOutput:
    """A finished run's `RunOutput`; `stopped`: it ended by its stopping rule."""
    state = carry.state
    chunks = jnp.asarray(0) if state.memory is None else state.memory.chunks
    dups = jnp.asarray(0) if state.dups is None else state.dups
    return RunOutput(state.best_x, state.best_f, state.fes, carry.it, carry.history, dups, chunks, jnp.asarray(stopped))


def run(strategy: Strategy, key: PRNGKeyArray, fn: FitnessFn, budget: int, dim: int, **options) -> RunOutput:
    """The whole run as one `lax.while_loop`: init, then steps while budget is left and, with
    `generations`, at most that many iterations. `options`: `run_start`'s `memory`,
    `precision`, `generations`, `capacity`, `x0`, and `stop` (`Converged`: a converged run ends).

    `memory` (`STMA()`, `LTMA(order=...)`, `IndexedLTMA()` or their names; see
    `dcjax.strategies.memory`) with `precision` in unit-cube units. Duplicates cost no FEs and are not simulated; without `generations` a run with memory
    makes the memory-free run's iterations (the paper's Time % and Dupl. % compare equal counts).
    The LTMA history holds `capacity` records (default: budget + one population). `x0` seeds the
    initial population (see `Strategy.init`). The same run in pieces: `run_start`, `run_steps`
    (with `until`), `run_output`."""
    stop = options.pop("stop", None)
    t_max = iteration_limit(strategy, budget, options.get("generations"))
    carry = run_start(strategy, key, fn, budget, dim, **options)
    if strategy.max_iterations(budget) > 0:  # else the initial population spends the budget (see `run_batch`)
        carry = run_steps(strategy, carry, fn, budget, t_max, stop=stop)
    return run_output(carry, converged(strategy, carry, stop))
