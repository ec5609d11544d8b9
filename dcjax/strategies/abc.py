"""Artificial bee colony (Karaboga; paper refs. 36–45) with limit = 100 (Section 2.2).

A colony of NP bees tends SN = NP / 2 food sources.
- Employed bees: for each source i, a random partner k != i and gene j:
  v_ij = x_ij + phi (x_ij - x_kj), phi ~ U(-1, 1); greedy; the trial counter of i grows on failure.
- Onlooker bees: SN bees choose sources by roulette on fit_i = 1 / (1 + f_i) and move as above.
  They fly together (vectorized): where several choose one source, the best of their candidates
  is compared with it.
- Scout: the source with the most failures, if above `limit`, is replaced by a random point
  (one FE). FEs are counted as spent; evaluations past the budget are not made, so a run stops
  exactly at the budget.
"""

from typing import ClassVar

import jax
import jax.numpy as jnp

from .base import State, Strategy, apply_bounds, distinct_indices, evaluate, index_below, initial_state, is_pending, pending_state, uniforms


class ABC(Strategy):
    population_converges: ClassVar[bool] = False  # its mutation (scouts) keeps it diverse: `Converged` asks the best's stagnation only
    evaluates_pending: ClassVar[bool] = True
    limit: int = 100
    bounds_rule: str = "clip"
    init_rule: str = "uniform"

    @property
    def n_sources(self) -> int:
        return self.pop_size // 2

    def max_iterations(self, budget: int) -> int:
        return max(0, -(-(budget - self.n_sources) // (2 * self.n_sources)))

    def init(self, key, fn, budget, dim, x0=None) -> State:
        return initial_state(key, fn, budget, self.n_sources, dim, self.init_rule, aux=jnp.zeros(self.n_sources, jnp.int32), x0=x0)

    def pending(self, key, dim, x0=None) -> State:
        return pending_state(key, self.n_sources, dim, self.init_rule, aux=jnp.zeros(self.n_sources, jnp.int32), x0=x0)

    def _move(self, key, pop, who):
        """Candidate v for the sources `who` (one per bee)."""
        sn, d = pop.shape
        pick, gene, phi, bounds = uniforms(key, who.shape[0], (1, 1, 1, d))
        partner = distinct_indices(pick, sn, who)[:, 0]
        j = index_below(gene, d)
        phi = 2.0 * phi - 1.0  # U(-1, 1)
        x = pop[who]
        v = jnp.where(jnp.arange(d)[None, :] == j, x + phi * (x - pop[partner]), x)
        return apply_bounds(bounds, v, self.bounds_rule, x)

    def step(self, key, state, fn, budget) -> State:
        """Employed, onlooker and scout bees (above); from a `pending` state, the employed bees
        evaluate the sources themselves (each beats its +inf), the onlookers spend nothing (a
        budget of 0) and no trial is counted (so no scout flies)."""
        sn = self.n_sources
        first = is_pending(state)
        ke, ko, kc, ks = jax.random.split(key, 4)
        pop, fit, trials = state.pop, state.fit, state.aux
        # Employed bees.
        idx = jnp.arange(sn)
        v = jnp.where(first, pop, self._move(ke, pop, idx))
        fv, v, state = evaluate(fn, v, state, budget)
        win = (fv <= fit) & jnp.isfinite(fv)
        pop = jnp.where(win[:, None], v, pop)
        fit = jnp.where(win, fv, fit)
        trials = jnp.where(win, 0, trials + 1)
        # Onlooker bees.
        quality = jnp.where(fit >= 0, 1.0 / (1.0 + fit), 1.0 + jnp.abs(fit))
        total = quality.sum()
        prob = jnp.where(total > 0, quality / jnp.where(total > 0, total, 1.0), 1.0 / sn)
        chosen = jax.random.choice(kc, sn, (sn,), p=prob)
        v = self._move(ko, pop, chosen)
        fv, v, state = evaluate(fn, v, state, jnp.where(first, 0, budget))
        per_source = jnp.where(chosen[None, :] == idx[:, None], fv[None, :], jnp.inf)  # (source, bee)
        best_bee = jnp.argmin(per_source, axis=1)
        cand_f = per_source[idx, best_bee]
        targeted = jnp.any(chosen[None, :] == idx[:, None], axis=1)
        win = targeted & (cand_f <= fit) & jnp.isfinite(cand_f)
        pop = jnp.where(win[:, None], v[best_bee], pop)
        fit = jnp.where(win, cand_f, fit)
        trials = jnp.where(win | first, 0, trials + targeted.astype(trials.dtype))
        # Scout bee.
        worst = jnp.argmax(trials)
        scout = trials[worst] > self.limit
        x_new = jax.random.uniform(ks, (1, pop.shape[1]))
        f_new, x_new, scouted = evaluate(fn, x_new, state, budget)
        do = scout & (state.fes < budget)
        pop = pop.at[worst].set(jnp.where(do, x_new[0], pop[worst]))
        fit = fit.at[worst].set(jnp.where(do, f_new[0], fit[worst]))
        trials = trials.at[worst].set(jnp.where(do, 0, trials[worst]))
        state = jax.tree.map(lambda a, b: jnp.where(do, a, b), scouted, state)
        return state.replace(pop=pop, fit=fit, aux=trials)
