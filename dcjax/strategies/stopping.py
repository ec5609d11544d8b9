"""When a run stops before its budget: `Converged`, the rule of scipy's `differential_evolution`
(`tol`, `atol`), pygmo (`ftol`) and CMA-ES (`tolfun`, stagnation), which the run loop asks after
every iteration inside the compiled loop (`dcjax.strategies.loop.converged`). The budget (and a
strategy's `generations`) stays the upper bound."""

import equinox as eqx

from ..errors import ConfigError


class Converged(eqx.Module):
    """A run has converged when its best OF improved by at most `rtol` |best| + `atol` over the
    last `patience` iterations and, for a strategy whose population contracts on the optimum
    (`Strategy.population_converges`: the DEs, TLBO, CMA-ES), more than half its population's OFs
    lie within the same tolerance of the best (a member stuck far off, as a TLBO learner that no
    longer improves, does not keep the run going); GA's mutation and ABC's scouts keep
    their populations diverse, so for them the stagnation of the best alone decides. The defaults
    (rtol 1e-8 over 50 iterations) are every default search's rule but the paper's
    (`dcjax.fitting.search.DEFAULT_STOP`), measured by `python -m experiments.bench_defaults`."""

    rtol: float = eqx.field(static=True, default=1e-8)
    atol: float = eqx.field(static=True, default=0.0)
    patience: int = eqx.field(static=True, default=50)

    def __check_init__(self):
        for name in ("rtol", "atol"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not v >= 0 or v == float("inf"):
                raise ConfigError(f"Converged.{name} must be a finite number >= 0, got {v!r}")
        if not isinstance(self.patience, int) or isinstance(self.patience, bool) or self.patience < 1:
            raise ConfigError(f"Converged.patience must be a positive integer (iterations), got {self.patience!r}")

    def spec(self) -> dict:
        """The rule as result.json records it."""
        return {"rtol": float(self.rtol), "atol": float(self.atol), "patience": int(self.patience)}
