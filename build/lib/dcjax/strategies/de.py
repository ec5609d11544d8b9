"""Differential evolution (Storn & Price; paper Section 2.2, refs. 17–26): DE/rand/1/exp and
DE/best/1/bin with F = 0.6, CR = 0.8 and one-to-one greedy selection."""

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .base import BOUND_RULES, State, Strategy, apply_bounds, distinct_indices, evaluate, greedy, initial_state


def exponential_crossover(key, target: Float[Array, "P D"], mutant: Float[Array, "P D"], cr: float):
    """Copy L consecutive genes (cyclically) from the mutant, starting at a random j0; L >= 1
    and each further gene is copied with probability CR while the run lasts."""
    p, d = target.shape
    k0, k1 = jax.random.split(key)
    j0 = jax.random.randint(k0, (p, 1), 0, d)
    runs = jnp.cumprod(jax.random.uniform(k1, (p, d - 1)) < cr, axis=1)
    length = 1 + jnp.sum(runs, axis=1, keepdims=True)
    offset = (jnp.arange(d)[None, :] - j0) % d
    return jnp.where(offset < length, mutant, target)


def binomial_crossover(key, target: Float[Array, "P D"], mutant: Float[Array, "P D"], cr: float):
    """Each gene from the mutant with probability CR; gene j_rand always from the mutant."""
    p, d = target.shape
    k0, k1 = jax.random.split(key)
    jrand = jax.random.randint(k0, (p, 1), 0, d)
    mask = (jax.random.uniform(k1, (p, d)) < cr) | (jnp.arange(d)[None, :] == jrand)
    return jnp.where(mask, mutant, target)


class _DE(Strategy):
    f: float = 0.6
    cr: float = 0.8
    bounds_rule: str = "redraw"
    init_rule: str = "uniform"

    def __check_init__(self):
        if self.bounds_rule not in BOUND_RULES:
            raise ValueError(f"bounds_rule must be one of {BOUND_RULES}, got {self.bounds_rule!r}")
        if self.pop_size < 5:
            raise ValueError("DE needs a population of at least 5")

    def max_iterations(self, budget: int) -> int:
        return max(0, -(-(budget - self.pop_size) // self.pop_size))

    def init(self, key, fn, budget, dim, x0=None) -> State:
        return initial_state(key, fn, budget, self.pop_size, dim, self.init_rule, x0=x0)

    def mutant(self, key, state: State) -> Array:
        raise NotImplementedError

    def crossover(self, key, target, mutant) -> Array:
        raise NotImplementedError

    def step(self, key, state: State, fn, budget) -> State:
        km, kc, kb = jax.random.split(key, 3)
        trial = self.crossover(kc, state.pop, self.mutant(km, state))
        trial = apply_bounds(kb, trial, self.bounds_rule, state.pop)
        trial_fit, trial, state = evaluate(fn, trial, state, budget)
        pop, fit, _ = greedy(state.pop, state.fit, trial, trial_fit)
        return state.replace(pop=pop, fit=fit)


class DERand1Exp(_DE):
    """DE/rand/1/exp: v_i = x_r1 + F (x_r2 - x_r3), r1, r2, r3, i distinct; exponential crossover."""

    def mutant(self, key, state):
        p = state.pop.shape[0]
        r = distinct_indices(key, p, jnp.arange(p), 3)
        x = state.pop
        return x[r[:, 0]] + self.f * (x[r[:, 1]] - x[r[:, 2]])

    def crossover(self, key, target, mutant):
        return exponential_crossover(key, target, mutant, self.cr)


class DEBest1Bin(_DE):
    """DE/best/1/bin: v_i = x_best + F (x_r1 - x_r2), r1, r2, i distinct; binomial crossover."""

    def mutant(self, key, state):
        p = state.pop.shape[0]
        r = distinct_indices(key, p, jnp.arange(p), 2)
        x = state.pop
        best = x[jnp.argmin(state.fit)]
        return best[None, :] + self.f * (x[r[:, 0]] - x[r[:, 1]])

    def crossover(self, key, target, mutant):
        return binomial_crossover(key, target, mutant, self.cr)
