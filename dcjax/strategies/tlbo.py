"""Teaching–learning-based optimization (Rao et al.; paper refs. 27–35) without the duplicate
elimination phase, so FEs = 2 x NP x iterations (Section 2.2).

Teacher phase:  x' = x + r (x_teacher - T_F * mean),  T_F in {1, 2} at random, r ~ U(0, 1)^D.
Learner phase:  for a random partner j != i, x' = x_i + r (x_i - x_j) if f(x_i) < f(x_j), else
                x' = x_i + r (x_j - x_i).
Each phase keeps x' when it is no worse (greedy); out-of-bound genes are clipped.
"""

from typing import ClassVar

import jax.numpy as jnp

from .base import (
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


class TLBO(Strategy):
    bounds_rule: str = "clip"
    init_rule: str = "uniform"
    evaluates_pending: ClassVar[bool] = True

    def max_iterations(self, budget: int) -> int:
        return max(0, -(-(budget - self.pop_size) // (2 * self.pop_size)))

    def init(self, key, fn, budget, dim, x0=None) -> State:
        return initial_state(key, fn, budget, self.pop_size, dim, self.init_rule, x0=x0)

    def pending(self, key, dim, x0=None) -> State:
        return pending_state(key, self.pop_size, dim, self.init_rule, x0=x0)

    def step(self, key, state, fn, budget) -> State:
        """The teacher phase, then the learner phase; from a `pending` state, the teacher phase
        evaluates the population itself (every member beats its +inf) and the learner phase
        spends nothing (a budget of 0: its candidates are +inf, none accepted)."""
        n, d = state.pop.shape
        first = is_pending(state)
        r1, b1, pick, r2, b2, coin = uniforms(key, n, (d, d, 1, d, d, 1))
        pop, fit = state.pop, state.fit
        teacher = pop[jnp.argmin(fit)]
        tf = 1.0 + index_below(coin[0, 0], 2).astype(pop.dtype)  # T_F in {1, 2}
        new = pop + r1 * (teacher - tf * pop.mean(axis=0))
        new = apply_bounds(b1, new, self.bounds_rule, pop)
        new = jnp.where(first, pop, new)
        new_fit, new, state = evaluate(fn, new, state, budget)
        pop, fit, _ = greedy(pop, fit, new, new_fit)
        partner = distinct_indices(pick, n, jnp.arange(n))[:, 0]
        xj, fj = pop[partner], fit[partner]
        direction = jnp.where((fit < fj)[:, None], pop - xj, xj - pop)
        new = apply_bounds(b2, pop + r2 * direction, self.bounds_rule, pop)
        new_fit, new, state = evaluate(fn, new, state, jnp.where(first, 0, budget))
        pop, fit, _ = greedy(pop, fit, new, new_fit)
        return state.replace(pop=pop, fit=fit)
