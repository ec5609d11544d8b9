"""Search strategies (paper Section 2.2) behind one interface: `init`/`step` over a `State`,
run whole by `run` as a `lax.while_loop`, `vmap`-able over independent runs."""

from ..errors import ConfigError
from .abc import ABC
from .base import State, Strategy
from .de import DEBest1Bin, DERand1Exp
from .ga import GA
from .loop import RunOutput, run
from .stopping import Converged
from .tlbo import TLBO

METHODS = {
    "ga": GA,
    "de-rand-1-exp": DERand1Exp,
    "de-best-1-bin": DEBest1Bin,
    "tlbo": TLBO,
    "abc": ABC,
}


# Named methods that are evosax algorithms (`Evosax`): `"cma-es"` is evosax's CMA_ES with a population of
# CMA_POP (about CMA-ES's own 4 + 3 ln n for the 7-12 unknowns here; at equal budgets it beat 70 on every
# case of experiments/bench_methods_real.py), std_init 0.3 of the unit cube and penalised repair at the bounds.
EVOSAX_NAMES = {"cma-es": "CMA_ES"}
CMA_POP = 12
PAPER_POP = 70


def evosax_names() -> list[str]:
    """The evosax algorithms (empty where the `evosax` extra is not installed)."""
    try:
        from .evosax_adapter import evosax_names as names  # optional: the evosax extra
    except ImportError:
        return []
    return names()


def make_strategy(method: str | Strategy, pop_size: int | None = None, **options) -> Strategy:
    """A strategy by name: one of `METHODS` (the paper's five; population 70 unless given),
    `"cma-es"` (evosax's CMA_ES, population `CMA_POP` = 12 unless given) or an evosax algorithm
    name (`"CMA_ES"`, `"PSO"`, `"DifferentialEvolution"`, ...; population 70 unless given; prefix
    `evosax:` optional; needs the `evosax` extra, imported only here)."""
    if isinstance(method, Strategy):
        return method
    if not isinstance(method, str):
        raise ConfigError(f"method must be a name or a Strategy, got {method!r}")
    key = method.lower()
    if key in METHODS:
        return METHODS[key](pop_size=PAPER_POP if pop_size is None else pop_size, **options)
    if pop_size is None:
        pop_size = CMA_POP if key in EVOSAX_NAMES else PAPER_POP
    name = EVOSAX_NAMES.get(key, method.removeprefix("evosax:"))
    try:
        from .evosax_adapter import Evosax  # optional: the evosax extra
    except ImportError:
        raise ConfigError(
            f"unknown method {method!r}; choose one of {list(METHODS)}, or install the evosax extra "
            "(pip install 'dcjax[evosax]') for evosax algorithms"
        ) from None
    if name in evosax_names():
        return Evosax(pop_size=pop_size, name=name, params=options)
    raise ConfigError(f"unknown method {method!r}; choose one of {list(METHODS)} or an evosax algorithm {evosax_names()}")


def __getattr__(name):
    if name == "Evosax":  # imported on use: evosax starts JAX's backend at import
        from .evosax_adapter import Evosax  # optional: the evosax extra

        return Evosax
    raise AttributeError(name)


__all__ = [
    "ABC",
    "Converged",
    "GA",
    "TLBO",
    "DERand1Exp",
    "DEBest1Bin",
    "METHODS",
    "RunOutput",
    "State",
    "Strategy",
    "evosax_names",
    "make_strategy",
    "run",
]
