"""Continuous (real-coded) genetic algorithm after Haupt & Haupt, *Practical Genetic
Algorithms* (the paper's ref. 13), with mutation rate 0.2 and fraction kept 0.5 (Section 2.2).

One generation:
1. natural selection: sort by OF, keep the best `N_keep = round(keep * NP)`;
2. mate selection: rank-weighted roulette over the kept, P_n = (N_keep - n + 1) / sum(1..N_keep);
3. crossover (Haupt's single-point blend): a random gene a and beta ~ U(0, 1);
   child1[a] = m[a] - beta (m[a] - d[a]), child2[a] = d[a] + beta (m[a] - d[a]); genes left of a
   come from one parent and right of a from the other;
4. mutation: `round(rate * (NP - 1) * D)` genes chosen uniformly among all members but the best
   (elitism) are replaced by uniform random values;
5. every member is evaluated: NP FEs per generation (the paper: 2000 iterations = 140,000 FEs).
"""

from typing import ClassVar

import jax
import jax.numpy as jnp

from .base import State, Strategy, evaluate, initial_state, is_pending, pending_state


class GA(Strategy):
    population_converges: ClassVar[bool] = False  # its mutation (scouts) keeps it diverse: `Converged` asks the best's stagnation only
    evaluates_pending: ClassVar[bool] = True
    mutation_rate: float = 0.2
    keep: float = 0.5
    init_rule: str = "uniform"

    @property
    def cost(self) -> int:
        return self.pop_size

    def max_iterations(self, budget: int) -> int:
        return max(0, (budget - self.pop_size) // self.pop_size)

    def init(self, key, fn, budget, dim, x0=None) -> State:
        return initial_state(key, fn, budget, self.pop_size, dim, self.init_rule, x0=x0)

    def pending(self, key, dim, x0=None) -> State:
        return pending_state(key, self.pop_size, dim, self.init_rule, x0=x0)

    def step(self, key, state, fn, budget) -> State:
        """One generation (above); from a `pending` state, the evaluation of its population."""
        n, d = state.pop.shape
        n_keep = max(2, int(round(self.keep * n)))
        n_child = n - n_keep
        n_pairs = -(-n_child // 2)
        ks, ka, kb, km, kg, kv = jax.random.split(key, 6)
        order = jnp.argsort(state.fit)
        kept = state.pop[order[:n_keep]]
        rank_w = jnp.arange(n_keep, 0, -1, dtype=jnp.float64)
        parents = jax.random.choice(ks, n_keep, (n_pairs, 2), p=rank_w / rank_w.sum())
        mom, dad = kept[parents[:, 0]], kept[parents[:, 1]]
        a = jax.random.randint(ka, (n_pairs, 1), 0, d)
        beta = jax.random.uniform(kb, (n_pairs, 1))
        j = jnp.arange(d)[None, :]
        blend1 = mom - beta * (mom - dad)
        blend2 = dad + beta * (mom - dad)
        child1 = jnp.where(j < a, mom, jnp.where(j == a, blend1, dad))
        child2 = jnp.where(j < a, dad, jnp.where(j == a, blend2, mom))
        children = jnp.concatenate([child1, child2])[:n_child]
        pop = jnp.concatenate([kept, children])
        n_mut = int(round(self.mutation_rate * (n - 1) * d))
        flat = jax.random.choice(km, (n - 1) * d, (n_mut,), replace=False) + d  # skip row 0 (elite)
        mask = jnp.zeros(n * d, bool).at[flat].set(True).reshape(n, d)
        pop = jnp.where(mask, jax.random.uniform(kv, (n, d)), pop)
        pop = jnp.where(is_pending(state), state.pop, pop)
        fit, pop, state = evaluate(fn, pop, state, budget)
        return state.replace(pop=pop, fit=fit)
