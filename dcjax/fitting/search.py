"""How a fit searches, as one typed object (`Search`), and the search a fit gets where none is
given (`Search.for_steps`). The paper's data (recordings whose sidecar names one of the paper's
presets, `PAPER_PRESETS`) and the reproduction keep the paper's comparison setting
(DE/rand/1/exp, 50 runs of 140,000 FEs, every run spending its budget: `Search.paper()`); every
other fit stops a run once it has converged (`DEFAULT_STOP`, the budget the upper bound):
`Search.own()` for a fit whose evaluation is short, and `Search.many()` for a joint fit of many
recordings, where the paper's would take hours (476 servo logs: 50 x 140,000 evaluations of
1.1 ms). Chosen by measurement on 476 servo logs, 128 DC recordings and the real EMPS axis:
`python -m experiments.bench_defaults` (`experiments/BENCHMARKS.md`)."""

import dataclasses
import enum
from collections.abc import Mapping

import numpy as np

from ..deprecation import warn_deprecated
from ..errors import ConfigError, check_seed
from ..strategies import METHODS, Strategy, make_strategy
from ..strategies.memory import MemoryAssistance
from ..strategies.stopping import Converged

MANY_STEPS = 50_000  # integration steps of one evaluation from which a fit is "of many recordings" (100 of 500 samples)
PAPER_PRESETS = ("table4", "table8")  # a sidecar naming one marks the paper's data (SD*, MD*): the paper's fixed budget
DEFAULT_STOP = Converged()  # the stopping rule of every default search but the paper's (`experiments/bench_defaults.py`)
MANY = {"method": "de-best-1-bin", "pop_size": 30, "runs": 1, "budget": 20_000}  # `Search.many()` beside the rule
LEGACY = ("method", "runs", "budget", "seed", "memory", "polish")  # fit's keywords of 0.2/0.3, now Search's fields


def _positive_int(name: str, v) -> None:
    if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < 1:
        raise ConfigError(f"Search.{name} must be a positive integer, got {v!r}")


@dataclasses.dataclass(frozen=True)
class Search:
    """`runs` independent runs of `method` (a strategy name, `dcjax.strategies.METHODS`, an
    evosax algorithm's name, or a `Strategy` carrying its own settings) of at most `budget` FEs
    each (and at most the strategy's `generations` iterations), run r keyed by
    `fold_in(PRNGKey(seed), r)`, with an optional `memory` (`dcjax.STMA()`, `LTMA(...)`,
    `IndexedLTMA()`, paper Section 4.4), a Levenberg–Marquardt `polish` of every run, and a
    stopping rule `stop` (`dcjax.Converged(rtol=, atol=, patience=)`: a run that has converged
    ends before its budget; None: every run spends its budget, as the paper's)."""

    method: "str | Strategy" = "de-rand-1-exp"
    runs: int = 50
    budget: int = 140_000
    seed: int = 0
    memory: MemoryAssistance | None = None
    polish: bool = False
    stop: Converged | None = None
    strategy: Strategy = dataclasses.field(init=False, repr=False, compare=False)  # `method` resolved

    def __post_init__(self):
        if not isinstance(self.method, (str, Strategy)):
            raise ConfigError(f"Search.method must be a strategy name or a dcjax Strategy, got {self.method!r}")
        object.__setattr__(self, "strategy", self.method if isinstance(self.method, Strategy) else make_strategy(self.method))
        for name in ("runs", "budget"):
            _positive_int(name, getattr(self, name))
        _positive_int("method's pop_size", self.strategy.pop_size)
        if self.strategy.generations is not None:
            _positive_int("method's generations", self.strategy.generations)
        if self.budget < self.strategy.pop_size:
            raise ConfigError(f"Search.budget ({self.budget}) must be at least one population ({self.strategy.pop_size})")
        check_seed(self.seed, "Search.seed")
        if self.memory is not None and not isinstance(self.memory, MemoryAssistance):
            raise ConfigError(
                f"Search.memory must be None, dcjax.STMA(), dcjax.LTMA(order=...) or dcjax.IndexedLTMA(), got {self.memory!r}"
            )
        if not isinstance(self.polish, (bool, np.bool_)):
            raise ConfigError(f"Search.polish must be True or False, got {self.polish!r}")
        if self.stop is not None and not isinstance(self.stop, Converged):
            raise ConfigError(f"Search.stop must be None or dcjax.Converged(rtol=, atol=, patience=), got {self.stop!r}")

    @classmethod
    def paper(cls, **changes) -> "Search":
        """The paper's comparison setting: DE/rand/1/exp, 50 runs of 140,000 FEs (Section 3.1),
        every run spending its budget."""
        return cls(**changes)

    @classmethod
    def own(cls, **changes) -> "Search":
        """The default of a fit of one's own data: the paper's search, each run ending once it has
        converged (`DEFAULT_STOP`; at most the paper's budget)."""
        return cls(**{"stop": DEFAULT_STOP, **changes})

    @classmethod
    def many(cls, **changes) -> "Search":
        """The default of a joint fit of many recordings: DE/best/1/bin with 30 members, 1 run of
        at most 20,000 FEs, ending once it has converged (`DEFAULT_STOP`)."""
        method = make_strategy(MANY["method"], pop_size=MANY["pop_size"])
        return cls(**{"method": method, "runs": MANY["runs"], "budget": MANY["budget"], "stop": DEFAULT_STOP, **changes})

    @classmethod
    def for_steps(cls, steps: int) -> "Search":
        """The default of a fit whose one evaluation integrates `steps` steps (a joint fit's
        samples times the sub-steps; 0 for one recording): `many()` from `MANY_STEPS` on, else
        `own()`; a fit of the paper's data runs it without the stopping rule (`for_data`)."""
        return cls.many() if steps >= MANY_STEPS else cls.own()

    @property
    def generations(self) -> int | None:
        return self.strategy.generations

    @property
    def name(self) -> str:
        """The strategy's name: a built-in's registry name, an evosax algorithm's, else the class name."""
        s = self.strategy
        for name, cls in METHODS.items():
            if type(s) is cls:
                return name
        return str(getattr(s, "name", "")) or type(s).__name__

    def with_generations(self, generations: int | None) -> "Search":
        """The same search with the strategy's iterations limited to `generations`."""
        return dataclasses.replace(self, method=dataclasses.replace(self.strategy, generations=generations))


class RunStatus(enum.Enum):
    """How a run ended (a result's `run_status`, result.json's `runs[].status`)."""

    CONVERGED = "converged"  # its stopping rule (`Search.stop`) ended it before its budget
    BUDGET = "budget"  # its FEs were spent
    GENERATIONS = "generations"  # it reached the strategy's iteration limit first
    NON_FINITE = "non-finite"  # no candidate's objective was finite
    POLISH_STEP_LIMIT = "polish step limit"  # its Levenberg-Marquardt polish stopped at its step limit or failed


@dataclasses.dataclass(frozen=True)
class SearchRecord:
    """The search a result ran, as its file records it (a result loaded from a file need not
    rebuild the strategy: a user's own may not be importable): the method's name, runs, budget,
    seed, the population size, the iteration limit, the memory's kind, whether every run was
    polished, the strategy object's repr and the stopping rule."""

    method: str
    runs: int
    budget: int
    seed: int
    pop_size: int
    generations: int | None = None
    memory: str | None = None
    polish: bool = False
    strategy: str = ""
    stop: dict | None = None  # the stopping rule (`Converged.spec`)

    @classmethod
    def of(cls, search: Search) -> "SearchRecord":
        return cls(
            search.name,
            search.runs,
            search.budget,
            int(search.seed),
            search.strategy.pop_size,
            search.generations,
            None if search.memory is None else search.memory.kind,
            bool(search.polish),
            repr(search.strategy),
            None if search.stop is None else search.stop.spec(),
        )


def search_of(search: "Search | Mapping | None", legacy: dict, default: "Search") -> Search:
    """`search`: a `Search`; None: `default`; a mapping of changes to `default` (its fields, and
    `generations`: the strategy's iteration limit), so `{"runs": 5}` is the problem's default
    search with 5 runs. The 0.2/0.3 keywords of `fit`/`fit_each` (`method`, `runs`, `budget`,
    `seed`, `memory`, `polish`) go over it, each with a `DeprecationWarning`; any other keyword is
    a one-line error."""
    unknown = [k for k in legacy if k not in LEGACY]
    if unknown:
        raise ConfigError(
            f"unknown argument(s) {', '.join(unknown)}; fit takes data, model, params, search, observation, integrator, progress"
        )
    if isinstance(search, Mapping):
        search = _changed(default, dict(search))
    if search is not None and not isinstance(search, Search):
        raise ConfigError(
            f"search must be a dcjax.Search(method=, runs=, budget=, seed=, memory=, polish=) or a dict of changes to the default, got {search!r}"
        )
    if not legacy:
        return search if search is not None else default
    warn_deprecated(
        f"fit's {', '.join(f'{k}=' for k in legacy)}",
        f"search=dcjax.Search({', '.join(f'{k}=...' for k in legacy)})",
        stacklevel=5,  # warn_deprecated, search_of, plan, fit: the caller of fit
        since="0.4",
    )
    return dataclasses.replace(search if search is not None else default, **legacy)


def _changed(default: Search, changes: dict) -> Search:
    """`default` with `changes` (fields of `Search`, and `generations`)."""
    bad = sorted(str(k) for k in changes if k not in (*LEGACY, "stop", "generations"))
    if bad:
        raise ConfigError(f"search: unknown field(s) {', '.join(bad)}; changes to the default take {', '.join(LEGACY)}, stop, generations")
    generations = changes.pop("generations", None)
    search = dataclasses.replace(default, **changes)
    return search if generations is None else search.with_generations(generations)


def papers_data(recordings) -> bool:
    """Whether every one of `recordings` is the paper's: its sidecar names one of `PAPER_PRESETS`."""
    return bool(recordings) and all(str(r.metadata.get("bounds", "")).lower() in PAPER_PRESETS for r in recordings)


__all__ = [
    "DEFAULT_STOP",
    "LEGACY",
    "MANY",
    "MANY_STEPS",
    "PAPER_PRESETS",
    "papers_data",
    "RunStatus",
    "Search",
    "SearchRecord",
    "search_of",
]
