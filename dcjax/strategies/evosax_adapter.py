"""Run any evosax algorithm (`CMA_ES`, `PSO`, `DifferentialEvolution`, ...) on the same problem
through the same `run`/`identify` machinery.

The algorithm searches the unit cube; candidates are clipped into it before evaluation and the
clipped point is what is told back, so every returned parameter respects the bounds. One
generation costs `pop_size` FEs (the initial population of a population-based algorithm too)."""

import inspect

import equinox as eqx
import evosax.algorithms as ea
import jax
import jax.numpy as jnp
from evosax.core.fitness_shaping import weights_fitness_shaping_fn
from jaxtyping import Array, Float

from ..errors import ConfigError
from .base import State, Strategy, evaluate, initial_state

PENALTY = 1e3  # per unit of squared distance outside the cube


def evosax_names() -> list[str]:
    return sorted(ea.algorithms)


class Evosax(Strategy):
    """`Evosax("CMA_ES")`, `Evosax("PSO")`, `Evosax("DifferentialEvolution", params={...})`.
    `params` overrides fields of the algorithm's default params; `std_init` (distribution-based
    only, unit-cube scale) defaults to 0.3."""

    name: str = eqx.field(static=True, default="CMA_ES")
    params: dict = eqx.field(static=True, default_factory=dict)

    def __check_init__(self):
        if self.name not in ea.algorithms:
            raise ConfigError(f"unknown evosax algorithm {self.name!r}; choose from {evosax_names()}")

    def _algo(self, dim: int):
        cls = ea.algorithms[self.name]
        shaping = inspect.signature(cls.__init__).parameters.get("fitness_shaping_fn")
        if shaping is not None and shaping.default is weights_fitness_shaping_fn:
            return cls(population_size=self.pop_size, solution=jnp.zeros(dim), fitness_shaping_fn=rank_weights)
        return cls(population_size=self.pop_size, solution=jnp.zeros(dim))

    def _params(self, algo):
        p = algo.default_params
        fields = dict(self.params)
        if self_is_pop(algo):
            fields.pop("std_init", None)
        elif hasattr(p, "std_init"):
            fields.setdefault("std_init", 0.3)
        return p.replace(**fields) if fields else p

    @property
    def cost(self) -> int:
        return self.pop_size

    def max_iterations(self, budget: int) -> int:
        return max(0, budget // self.pop_size)

    def init(self, key, fn, budget, dim, x0=None) -> State:
        algo = self._algo(dim)
        params = self._params(algo)
        k1, k2 = jax.random.split(key)
        if self_is_pop(algo):
            state = initial_state(k1, fn, budget, self.pop_size, dim, "uniform", x0=x0)
            es = algo.init(k2, state.pop, state.fit, params)
            return state.replace(aux=es)
        mean = jnp.full(dim, 0.5) if x0 is None else jnp.nanmean(jnp.where(jnp.isnan(x0), 0.5, x0), axis=0)
        es = algo.init(k2, mean, params)
        pop = jnp.full((self.pop_size, dim), 0.5)
        return State(pop, jnp.full(self.pop_size, jnp.inf), pop[0], jnp.asarray(jnp.inf), jnp.asarray(0), es, jnp.asarray(0))

    def step(self, key, state, fn, budget) -> State:
        algo = self._algo(state.pop.shape[1])
        params = self._params(algo)
        ka, kt = jax.random.split(key)
        raw, es = algo.ask(ka, state.aux, params)
        x = jnp.clip(raw, 0.0, 1.0)
        fit, x, state = evaluate(fn, x, state, budget)
        if self_is_pop(algo):
            es, _ = algo.tell(kt, x, fit, es, params)
        else:  # a distribution: told its own samples, ranked by the repaired point's OF times (1 + squared excess)
            excess = jnp.sum((raw - x) ** 2, axis=-1)
            es, _ = algo.tell(kt, raw, fit * (1.0 + PENALTY * excess), es, params)
        return state.replace(pop=x, fit=fit, aux=es)


def rank_weights(population, fitness: Float[Array, " P"], state, params) -> Float[Array, " P"]:
    """evosax's `weights_fitness_shaping_fn` (the recombination weights by rank, `params.weights`)
    with the ranks counted pairwise instead of by `jax.scipy.stats.rankdata`'s sorts: rank_i =
    #{j: f_j < f_i} + (#{j: f_j = f_i} - 1) / 2 (NaN as +inf), the same average rank of ties,
    truncated to an index as evosax does, so the same weights to the bit. A CMA-ES search program
    compiles ~0.08 s faster (476 servo logs: 0.81 -> 0.73 s; `python -m
    experiments.bench_servo_fleet`'s compile column 0.8 -> 0.7 s); P^2 comparisons cost nothing at
    a population of 12."""
    f = jnp.where(jnp.isnan(fitness), jnp.inf, fitness)
    below = jnp.sum(f[None, :] < f[:, None], axis=-1)
    ties = jnp.sum(f[None, :] == f[:, None], axis=-1)
    weights = params.weights[..., (below + 0.5 * (ties - 1.0)).astype(jnp.int32)]
    return jnp.where(jnp.all(jnp.isnan(fitness), axis=-1, keepdims=True), jnp.zeros_like(weights), weights)


def self_is_pop(algo) -> bool:
    from evosax.algorithms.population_based.base import PopulationBasedAlgorithm  # optional: the evosax extra

    return isinstance(algo, PopulationBasedAlgorithm)
