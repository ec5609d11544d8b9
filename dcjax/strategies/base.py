"""What every search strategy shares: its state, budget-aware evaluation, bound rules and
operators (the compiled run loop is `dcjax.strategies.loop`'s). Strategies search the unit cube
[0, 1]^D; `Bounds.to_physical` maps it onto the paper's limits (Tables 4 and 8)."""

import dataclasses
from collections.abc import Callable, Sequence
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int, PRNGKeyArray, PyTree

from ..errors import ConfigError
from .compact import compacted
from .memory import HashRecords, Records

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


def evaluate(
    fn: FitnessFn, z: Float[Array, "P D"], state: State, budget: int | Int[Array, ""]
) -> tuple[Float[Array, " P"], Float[Array, "P D"], State]:
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
    state = pending_state(key, n, dim, init, aux, x0)
    allowed = jnp.arange(n) < budget
    return state.replace(fit=jnp.where(allowed, finite_or_inf(fn(state.pop)), jnp.inf), fes=jnp.sum(allowed))


def pending_state(key: PRNGKeyArray, n: int, dim: int, init: str, aux: PyTree = None, x0: Array | None = None) -> State:
    """`initial_state`'s population before its evaluation: no FE spent, every OF +inf. The
    strategy's `step` evaluates it as it finds it (`is_pending`), so that a run's program holds one
    copy of the objective, in its loop, not a second before it (`folds_initial_evaluation`)."""
    pop = seed_population(uniform_population(key, n, dim, init), x0)
    none = jnp.sum(jnp.zeros(n, bool))  # 0 FEs, typed as a count of evaluations is
    return State(pop, jnp.full(n, jnp.inf, pop.dtype), pop[0], jnp.asarray(jnp.inf), none, aux, jnp.asarray(0))


def is_pending(state: State) -> Bool[Array, ""]:
    """Whether `state` is a `pending_state` (an evaluated population has spent at least one FE)."""
    return state.fes == 0


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
    """Interface: `init(key, fn, budget, dim, x0) -> State`, `step(key, state, fn, budget) -> State`;
    where `evaluates_pending`, also `pending(key, dim, x0) -> State` (`init`'s population not yet
    evaluated), which `step` evaluates as its first pass (`folds_initial_evaluation`).
    `pop_size` members; a run stops at its FE budget or after `generations` iterations (default:
    as many as the budget buys without memory, paper Section 4.4). `dim` is the number of searched (free) parameters; `x0` optional start values (K, dim) in
    the unit cube that replace the first K members of the initial population.

    `cost` is the most evaluations one step can spend when it must run whole (GA); strategies
    that mask evaluations past the budget set it to 1 and stop exactly at the budget."""

    pop_size: int = eqx.field(static=True, default=70)
    generations: int | None = eqx.field(static=True, default=None)  # at most this many iterations a run (None: as the budget buys)
    traced: ClassVar[tuple[str, ...]] = ()  # float hyperparameters passed to the executable as values
    population_converges: ClassVar[bool] = True  # its population contracts on the optimum (`Converged`)
    evaluates_pending: ClassVar[bool] = False  # `step` evaluates a `pending` state's population (`loop.evaluates_pending`)

    @property
    def cost(self) -> int:
        return 1

    def max_iterations(self, budget: int) -> int:
        """The iterations `budget` FEs buy after the initial population: 0 only where no step
        fits the budget that the initial population leaves (the run loop is then not compiled)."""
        raise NotImplementedError

    def init(self, key, fn: FitnessFn, budget: int, dim: int, x0: Array | None = None) -> State:
        raise NotImplementedError

    def pending(self, key, dim: int, x0: Array | None = None) -> State:
        """`init`'s state before its evaluation (`pending_state`), for a strategy whose `step`
        evaluates it (`evaluates_pending`)."""
        raise NotImplementedError

    def step(self, key, state: State, fn: FitnessFn, budget: int) -> State:
        raise NotImplementedError
