"""What every search strategy shares: its state, budget-aware evaluation, bound rules and the
compiled run loop. Strategies search the unit cube [0, 1]^D; `Bounds.to_physical` maps it onto
the paper's limits (Tables 4 and 8)."""

import dataclasses
from collections.abc import Callable, Sequence
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int, PRNGKeyArray, PyTree

from ..compiling import on_device
from ..errors import ConfigError
from .compact import compacted
from .memory import HashRecords, MemoryAssistance, Records, get_memory
from .stopping import Converged

FitnessFn = Callable[[Float[Array, "P D"]], Float[Array, " P"]]


class State(eqx.Module):
    """Population `pop` (P, D) in the unit cube, its objective values `fit`, the best point
    seen, the fitness evaluations really made (`fes`), the candidates answered from memory
    (`dups`), a strategy-specific `aux` pytree and the optional memory `Records`."""

    pop: Float[Array, "P D"]
    fit: Float[Array, " P"]
    best_x: Float[Array, " D"]
    best_f: Float[Array, ""]
    fes: Int[Array, ""]
    aux: PyTree = None
    dups: Int[Array, ""] | None = None
    memory: Records | HashRecords | None = None

    def replace(self, **changes) -> "State":
        return dataclasses.replace(self, **changes)


def finite_or_inf(f: Array) -> Array:
    """Non-finite objective values become +inf, so they never win a comparison or an argmin."""
    return jnp.where(jnp.isfinite(f), f, jnp.inf)


def evaluate(fn: FitnessFn, z: Float[Array, "P D"], state: State, budget: int) -> tuple[Float[Array, " P"], Float[Array, "P D"], State]:
    """Evaluate candidates `z`, spending at most the remaining budget: candidates past it get
    +inf (never accepted) and are not counted. With `state.memory`, a candidate within precision
    of a record takes the record's x and OF and is not simulated (`compacted`); only real
    evaluations count as FEs, and LTMA stores every evaluated non-duplicate.

    Returns (fitness, candidates (duplicates replaced by their records), state with `fes`,
    `dups` and `memory` advanced)."""
    mem = state.memory
    if mem is None:
        allowed = state.fes + jnp.arange(z.shape[0]) < budget
        f = jnp.where(allowed, finite_or_inf(fn(z)), jnp.inf)
        return f, z, state.replace(fes=state.fes + jnp.sum(allowed))
    found, x_rec, f_rec, mem = mem.lookup(z)
    need = ~found
    allowed = need & (state.fes + jnp.cumsum(need) <= budget)
    f_new = finite_or_inf(compacted(fn)(z, allowed))
    f = jnp.where(found, f_rec, jnp.where(allowed, f_new, jnp.inf))
    z = jnp.where(found[:, None], x_rec, z)
    mem = mem.add(z, f_new, allowed)
    dups = jnp.asarray(0) if state.dups is None else state.dups
    return f, z, state.replace(fes=state.fes + jnp.sum(allowed), dups=dups + jnp.sum(found), memory=mem)


def initial_state(
    key: PRNGKeyArray, fn: FitnessFn, budget: int, n: int, dim: int, init: str, aux: PyTree = None, x0: Array | None = None
) -> State:
    """A random population of `n` (see `uniform_population`), evaluated within the budget.
    `x0` (K, D), unit cube: start values put in place of the first K members' genes (NaN: keep
    the random gene)."""
    pop = seed_population(uniform_population(key, n, dim, init), x0)
    allowed = jnp.arange(n) < budget
    fit = jnp.where(allowed, finite_or_inf(fn(pop)), jnp.inf)
    return State(pop, fit, pop[0], jnp.asarray(jnp.inf), jnp.sum(allowed), aux, jnp.asarray(0))


def seed_population(pop: Float[Array, "n d"], x0: Array | None) -> Float[Array, "n d"]:
    """Put start values `x0` (K, D; NaN = not given) into the first K members."""
    if x0 is None:
        return pop
    x0 = jnp.asarray(x0, pop.dtype)[: pop.shape[0]]
    k = x0.shape[0]
    return pop.at[:k].set(jnp.where(jnp.isnan(x0), pop[:k], jnp.clip(x0, 0.0, 1.0)))


def with_best(state: State) -> State:
    k = jnp.argmin(state.fit)
    better = state.fit[k] < state.best_f
    return eqx.tree_at(
        lambda s: (s.best_x, s.best_f),
        state,
        (jnp.where(better, state.pop[k], state.best_x), jnp.where(better, state.fit[k], state.best_f)),
    )


def uniform_population(key: PRNGKeyArray, n: int, d: int, init: str = "uniform") -> Float[Array, "n d"]:
    """Initial population: `"uniform"` (i.i.d. in the cube) or `"lhs"` (Latin hypercube)."""
    if init == "uniform":
        return jax.random.uniform(key, (n, d))
    if init == "lhs":
        k1, k2 = jax.random.split(key)
        strata = jax.vmap(lambda k: jax.random.permutation(k, n))(jax.random.split(k1, d)).T
        return (strata + jax.random.uniform(k2, (n, d))) / n
    raise ConfigError(f"init must be 'uniform' or 'lhs', got {init!r}")


def apply_bounds(u: Float[Array, "P D"], z: Array, rule: str, parent: Array | None = None) -> Array:
    """Bring trial genes back into [0, 1]:

    - `"redraw"`: an out-of-bound gene is replaced by its U[0, 1) variate in `u` (same shape as
      `z`; scipy's and pygmo's DE);
    - `"clip"`: clipped to the nearest bound (`u` is not read);
    - `"midpoint"`: halfway between the parent's gene and the violated bound (`u` is not read)."""
    out = (z < 0.0) | (z > 1.0)
    if rule == "redraw":
        return jnp.where(out, u, z)
    if rule == "clip":
        return jnp.clip(z, 0.0, 1.0)
    if rule == "midpoint":
        assert parent is not None
        return jnp.where(z < 0.0, 0.5 * parent, jnp.where(z > 1.0, 0.5 * (parent + 1.0), z))
    raise ConfigError(f"bounds rule must be 'redraw', 'clip' or 'midpoint', got {rule!r}")


BOUND_RULES = ("redraw", "clip", "midpoint")


def uniforms(key: PRNGKeyArray, n: int, widths: Sequence[int]) -> list[Float[Array, "n _"]]:
    """All the U[0, 1) variates one step needs, drawn at once and split into blocks of `widths`
    columns. (On CPU every `jax.random` call is a loop of its own: a DE generation that made ten
    of them spent 42 µs on random numbers and bookkeeping, one draw 19 µs.)"""
    u = jax.random.uniform(key, (n, sum(widths)))
    return jnp.split(u, np.cumsum(widths)[:-1].tolist(), axis=1)


def index_below(u: Array, n) -> Int[Array, "..."]:
    """floor(u n) for u ~ U[0, 1): an index uniform on 0 .. n-1."""
    return jnp.minimum(jnp.floor(u * n), n - 1).astype(jnp.int32)


def _ascending(cols: list[Array]) -> list[Array]:
    """Columns sorted row-wise by a compare-exchange network of minimum/maximum (fuses into the
    surrounding elementwise code, where a `sort` is a kernel of its own)."""
    cols = list(cols)
    for i in range(len(cols)):
        for j in range(len(cols) - 1 - i):
            cols[j], cols[j + 1] = jnp.minimum(cols[j], cols[j + 1]), jnp.maximum(cols[j], cols[j + 1])
    return cols


def distinct_indices(u: Float[Array, "P count"], n: int, exclude: Int[Array, " P"]) -> Int[Array, "P count"]:
    """For each row p, `count` distinct indices in [0, n) all different from `exclude[p]`, drawn
    uniformly without replacement from the row's variates `u[p]` (no argsort of a random
    matrix): the m-th is uniform on the n - 1 - m indices not yet taken."""
    taken = [exclude.astype(jnp.int32)]
    for m in range(u.shape[1]):
        k = index_below(u[:, m], n - 1 - m)
        for e in _ascending(taken):  # shift past the taken ones, ascending
            k = k + (k >= e)
        taken.append(k)
    return jnp.stack(taken[1:], axis=1)


def greedy(pop, fit, trial, trial_fit) -> tuple[Array, Array, Bool[Array, " P"]]:
    """One-to-one selection: a trial replaces its parent when it is no worse and finite."""
    win = (trial_fit <= fit) & jnp.isfinite(trial_fit)
    return jnp.where(win[:, None], trial, pop), jnp.where(win, trial_fit, fit), win


class Strategy(eqx.Module):
    """Interface: `init(key, fn, budget, dim, x0) -> State`, `step(key, state, fn, budget) -> State`.
    `pop_size` members; a run stops at its FE budget or after `generations` iterations (default:
    as many as the budget buys without memory, paper Section 4.4). `dim` is the number of searched (free) parameters; `x0` optional start values (K, dim) in
    the unit cube that replace the first K members of the initial population.

    `cost` is the most evaluations one step can spend when it must run whole (GA); strategies
    that mask evaluations past the budget set it to 1 and stop exactly at the budget."""

    pop_size: int = eqx.field(static=True, default=70)
    generations: int | None = eqx.field(static=True, default=None)  # at most this many iterations a run (None: as the budget buys)
    traced: ClassVar[tuple[str, ...]] = ()  # float hyperparameters passed to the executable as values
    population_converges: ClassVar[bool] = True  # its population contracts on the optimum (`Converged`)

    @property
    def cost(self) -> int:
        return 1

    def max_iterations(self, budget: int) -> int:
        """The iterations `budget` FEs buy after the initial population: 0 only where no step
        fits the budget that the initial population leaves (the run loop is then not compiled)."""
        raise NotImplementedError

    def init(self, key, fn: FitnessFn, budget: int, dim: int, x0: Array | None = None) -> State:
        raise NotImplementedError

    def step(self, key, state: State, fn: FitnessFn, budget: int) -> State:
        raise NotImplementedError


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
    state = with_best(strategy.init(k_init, fn, budget, dim, x0))
    memory = get_memory(memory)
    if memory is not None:
        if precision is None:
            raise ConfigError("memory needs a precision vector (unit-cube units)")
        evaluated = jnp.arange(state.pop.shape[0]) < state.fes
        cap = capacity if capacity is not None else budget + strategy.pop_size
        state = state.replace(memory=memory.create(precision, state.pop, state.fit, evaluated, cap))
    return RunCarry(state, jnp.asarray(0), jnp.full((max(1, t_max),), jnp.nan), k_run)


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
    """One iteration of a run (the body of `run_steps`)."""
    state = with_best(strategy.step(jax.random.fold_in(carry.key, carry.it), carry.state, fn, budget))
    if state.memory is not None:
        state = state.replace(memory=state.memory.refresh(state.pop, state.fit))
    history = jax.lax.dynamic_update_slice(carry.history, state.best_f[None], (carry.it,))  # in place, not a scatter
    return RunCarry(state, carry.it + 1, history, carry.key)


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
    if strategy.max_iterations(budget) == 0:  # the initial population spends the budget: no loop to compile (its body would not run)
        return jax.vmap(lambda c: run_output(c, converged(strategy, c, stop)))(carry)
    n_runs = keys.shape[0]

    def active(c):
        return jax.vmap(lambda c: run_active(strategy, c, budget, t_max, stop))(c)

    def masked(go, new, old):
        def pick(a, b):
            if a.ndim == 0 or a.size // n_runs > MASK_LIMIT:
                return a
            return jnp.where(go.reshape((n_runs,) + (1,) * (a.ndim - 1)), a, b)

        # The history is written at the run's slot, not selected whole (a copy of every run's
        # history each iteration: 50 SD1 runs searched 2 % longer with it).
        slot = lambda h, i, f, g: jax.lax.dynamic_update_slice(h, jnp.where(g, f, h[i])[None], (i,))
        kept = jax.tree.map(pick, eqx.tree_at(lambda c: c.history, new, old.history), old)
        return eqx.tree_at(lambda c: c.history, kept, jax.vmap(slot)(old.history, old.it, new.state.best_f, go))

    def body(loop):
        i, c = loop
        new = jax.vmap(lambda c: run_iteration(strategy, c, fn, budget))(c)
        c = new if n_runs == 1 else masked(active(c), new, c)  # one run: the loop runs only while it is active
        if report is not None:
            send = report
            done = jnp.where(active(c), jnp.minimum(jnp.maximum(c.it / t_max, c.state.fes / budget), 1.0), 1.0)
            jax.lax.cond((i + 1) % report_every == 0, lambda: send(done), lambda: None)
        return i + 1, c

    _, carry = jax.lax.while_loop(lambda loop: jnp.any(active(loop[1])), body, (jnp.asarray(0), carry))
    return jax.vmap(lambda c: run_output(c, converged(strategy, c, stop)))(carry)


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
