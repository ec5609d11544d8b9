"""What every search strategy shares: its state, budget-aware evaluation, bound rules and the
compiled run loop. Strategies search the unit cube [0, 1]^D; `Bounds.to_physical` maps it onto
the paper's limits (Tables 4 and 8)."""

from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float, Int, PRNGKeyArray, PyTree

FitnessFn = Callable[[Float[Array, "P D"]], Float[Array, " P"]]


class State(eqx.Module):
    """Population `pop` (P, D) in the unit cube, its objective values `fit`, the best point
    seen, the fitness evaluations spent and a strategy-specific `aux` pytree."""

    pop: Float[Array, "P D"]
    fit: Float[Array, " P"]
    best_x: Float[Array, " D"]
    best_f: Float[Array, ""]
    fes: Int[Array, ""]
    aux: PyTree = None


def finite_or_inf(f: Array) -> Array:
    """Non-finite objective values become +inf, so they never win a comparison or an argmin."""
    return jnp.where(jnp.isfinite(f), f, jnp.inf)


def evaluate(fn: FitnessFn, z: Float[Array, "P D"], fes: Int[Array, ""], budget: int):
    """Evaluate `z`, spending at most the remaining budget: candidates past it get +inf (never
    accepted) and are not counted. Returns (fitness, fes after)."""
    allowed = fes + jnp.arange(z.shape[0]) < budget
    f = jnp.where(allowed, finite_or_inf(fn(z)), jnp.inf)
    return f, fes + jnp.sum(allowed)


def initial_state(key: PRNGKeyArray, fn: FitnessFn, budget: int, n: int, dim: int, init: str, aux: PyTree = None) -> State:
    """A random population of `n` (see `uniform_population`), evaluated within the budget."""
    pop = uniform_population(key, n, dim, init)
    fit, fes = evaluate(fn, pop, jnp.asarray(0), budget)
    return State(pop, fit, pop[0], jnp.asarray(jnp.inf), fes, aux)


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
    raise ValueError(f"init must be 'uniform' or 'lhs', got {init!r}")


def apply_bounds(key: PRNGKeyArray, z: Array, rule: str, parent: Array | None = None) -> Array:
    """Bring trial genes back into [0, 1]:

    - `"redraw"`: an out-of-bound gene is redrawn uniformly in [0, 1] (scipy's and pygmo's DE);
    - `"clip"`: clipped to the nearest bound;
    - `"midpoint"`: halfway between the parent's gene and the violated bound."""
    out = (z < 0.0) | (z > 1.0)
    if rule == "redraw":
        return jnp.where(out, jax.random.uniform(key, z.shape), z)
    if rule == "clip":
        return jnp.clip(z, 0.0, 1.0)
    if rule == "midpoint":
        assert parent is not None
        return jnp.where(z < 0.0, 0.5 * parent, jnp.where(z > 1.0, 0.5 * (parent + 1.0), z))
    raise ValueError(f"bounds rule must be 'redraw', 'clip' or 'midpoint', got {rule!r}")


BOUND_RULES = ("redraw", "clip", "midpoint")


def distinct_indices(key: PRNGKeyArray, n: int, exclude: Int[Array, " P"], count: int) -> Int[Array, "P count"]:
    """For each row p, `count` distinct indices in [0, n) all different from `exclude[p]`,
    drawn directly (uniform without replacement, no argsort of a random matrix)."""
    taken = exclude[:, None]
    keys = jax.random.split(key, count)
    picks = []
    for m in range(count):
        k = jax.random.randint(keys[m], exclude.shape, 0, n - 1 - m)
        for e in jnp.moveaxis(jnp.sort(taken, axis=1), 1, 0):  # shift past taken ones, ascending
            k = k + (k >= e)
        picks.append(k)
        taken = jnp.concatenate([taken, k[:, None]], axis=1)
    return jnp.stack(picks, axis=1)


def greedy(pop, fit, trial, trial_fit) -> tuple[Array, Array, Bool[Array, " P"]]:
    """One-to-one selection: a trial replaces its parent when it is no worse and finite."""
    win = (trial_fit <= fit) & jnp.isfinite(trial_fit)
    return jnp.where(win[:, None], trial, pop), jnp.where(win, trial_fit, fit), win


class Strategy(eqx.Module):
    """Interface: `init(key, fn, budget) -> State`, `step(key, state, fn, budget) -> State`.

    `cost` is the most evaluations one step can spend when it must run whole (GA); strategies
    that mask evaluations past the budget set it to 1 and stop exactly at the budget."""

    pop_size: int = eqx.field(static=True, default=70)

    @property
    def cost(self) -> int:
        return 1

    def max_iterations(self, budget: int) -> int:
        raise NotImplementedError

    def init(self, key, fn: FitnessFn, budget: int, dim: int = 7) -> State:
        raise NotImplementedError

    def step(self, key, state: State, fn: FitnessFn, budget: int) -> State:
        raise NotImplementedError


class RunOutput(eqx.Module):
    """One run: best point (unit cube), its OF, FEs spent, iterations done and the best OF
    after each iteration (`history[k]`; NaN past the last iteration)."""

    best_x: Float[Array, " D"]
    best_f: Float[Array, ""]
    fes: Int[Array, ""]
    iterations: Int[Array, ""]
    history: Float[Array, " T"]


def run(strategy: Strategy, key: PRNGKeyArray, fn: FitnessFn, budget: int, dim: int = 7) -> RunOutput:
    """The whole run as one `lax.while_loop`: init, then steps while budget is left."""
    t_max = max(1, strategy.max_iterations(budget))
    k_init, k_run = jax.random.split(key)
    state = with_best(strategy.init(k_init, fn, budget, dim))
    history = jnp.full((t_max,), jnp.nan)

    def cond(carry):
        state, it, _ = carry
        return (state.fes + strategy.cost <= budget) & (it < t_max)

    def body(carry):
        state, it, history = carry
        state = with_best(strategy.step(jax.random.fold_in(k_run, it), state, fn, budget))
        return state, it + 1, history.at[it].set(state.best_f)

    state, it, history = jax.lax.while_loop(cond, body, (state, jnp.asarray(0), history))
    return RunOutput(state.best_x, state.best_f, state.fes, it, history)
