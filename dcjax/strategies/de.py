"""Differential evolution (Storn & Price; paper Section 2.2, refs. 17–26): DE/rand/1/exp and
DE/best/1/bin with F = 0.6, CR = 0.8 and one-to-one greedy selection."""

from typing import ClassVar

import jax.numpy as jnp
from jaxtyping import Array, Float, Int

from ..errors import ConfigError
from .base import (
    BOUND_RULES,
    State,
    Strategy,
    apply_bounds,
    distinct_indices,
    evaluate,
    greedy,
    index_below,
    initial_state,
    is_pending,
    pending_state,
    uniforms,
)


def exponential_crossover(u: Float[Array, "P D"], target: Float[Array, "P D"], mutant: Float[Array, "P D"], cr: float):
    """Copy L consecutive genes (cyclically) from the mutant, starting at j0 (from `u[:, 0]`);
    L >= 1 and each further gene is copied with probability CR (`u[:, 1:] < CR`) while the run
    lasts."""
    d = target.shape[1]
    j0 = index_below(u[:, :1], d)
    length, going = jnp.ones_like(j0), True
    for j in range(1, d):  # the run of copied genes goes on (a loop, not a cumprod: one kernel)
        going = going & (u[:, j : j + 1] < cr)
        length = length + going
    offset = (jnp.arange(d)[None, :] - j0) % d
    return jnp.where(offset < length, mutant, target)


def binomial_crossover(u: Float[Array, "P D+1"], target: Float[Array, "P D"], mutant: Float[Array, "P D"], cr: float):
    """Each gene from the mutant with probability CR (`u[:, 1:] < CR`); gene j_rand (from
    `u[:, 0]`) always from the mutant."""
    d = target.shape[1]
    jrand = index_below(u[:, :1], d)
    mask = (u[:, 1:] < cr) | (jnp.arange(d)[None, :] == jrand)
    return jnp.where(mask, mutant, target)


class _DE(Strategy):
    f: float = 0.6
    cr: float = 0.8
    traced: ClassVar[tuple[str, ...]] = ("f", "cr")
    bounds_rule: str = "redraw"
    init_rule: str = "uniform"
    n_picks: ClassVar[int] = 0  # distinct population indices the mutation needs
    evaluates_pending: ClassVar[bool] = True

    def __check_init__(self):
        if self.bounds_rule not in BOUND_RULES:
            raise ConfigError(f"bounds_rule must be one of {BOUND_RULES}, got {self.bounds_rule!r}")
        if self.pop_size < 5:
            raise ConfigError("DE needs a population of at least 5")

    def max_iterations(self, budget: int) -> int:
        return max(0, -(-(budget - self.pop_size) // self.pop_size))

    def init(self, key, fn, budget, dim, x0=None) -> State:
        return initial_state(key, fn, budget, self.pop_size, dim, self.init_rule, x0=x0)

    def pending(self, key, dim, x0=None) -> State:
        return pending_state(key, self.pop_size, dim, self.init_rule, x0=x0)

    def mutant(self, r: Int[Array, "P n"], state: State) -> Array:
        raise NotImplementedError

    def crossover(self, u, target, mutant) -> Array:
        raise NotImplementedError

    def crossover_width(self, d: int) -> int:
        raise NotImplementedError

    def step(self, key, state: State, fn, budget) -> State:
        """Mutation, crossover and bounds from one draw of variates, then greedy selection; from a
        `pending` state the population itself is the trial (every member beats its +inf)."""
        p, d = state.pop.shape
        u_pick, u_cross, u_bounds = uniforms(key, p, (self.n_picks, self.crossover_width(d), d))
        r = distinct_indices(u_pick, p, jnp.arange(p))
        trial = self.crossover(u_cross, state.pop, self.mutant(r, state))
        trial = apply_bounds(u_bounds, trial, self.bounds_rule, state.pop)
        trial = jnp.where(is_pending(state), state.pop, trial)
        trial_fit, trial, state = evaluate(fn, trial, state, budget)
        pop, fit, _ = greedy(state.pop, state.fit, trial, trial_fit)
        return state.replace(pop=pop, fit=fit)


class DERand1Exp(_DE):
    """DE/rand/1/exp: v_i = x_r1 + F (x_r2 - x_r3), r1, r2, r3, i distinct; exponential crossover."""

    n_picks: ClassVar[int] = 3

    def mutant(self, r, state):
        x = state.pop
        return x[r[:, 0]] + self.f * (x[r[:, 1]] - x[r[:, 2]])

    def crossover(self, u, target, mutant):
        return exponential_crossover(u, target, mutant, self.cr)

    def crossover_width(self, d: int) -> int:
        return d


class DEBest1Bin(_DE):
    """DE/best/1/bin: v_i = x_best + F (x_r1 - x_r2), r1, r2, i distinct; binomial crossover."""

    n_picks: ClassVar[int] = 2

    def mutant(self, r, state):
        x = state.pop
        best = x[jnp.argmin(state.fit)]
        return best[None, :] + self.f * (x[r[:, 0]] - x[r[:, 1]])

    def crossover(self, u, target, mutant):
        return binomial_crossover(u, target, mutant, self.cr)

    def crossover_width(self, d: int) -> int:
        return d + 1
