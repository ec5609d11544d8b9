"""The search and its result: `fit` and `fit_each` (the boundaries) over one path: a `Plan` and
a `Setup` per fit (`dcjax.fitting.setup`), the compiled runs of every setup
(`dcjax.fitting.runs`, over the runner's keys, sharding and executable cache), the
Levenberg-Marquardt polish and each setup's `FitResult` (`dcjax.fitting.engine`), with its
save/load, and the summary of a batch. `dcjax.fit` is the function; `dcjax.fitting.fit` its
module (a subpackage re-exports no name that is also one of its modules)."""

from .each import fit_each
from .observation import Observation
from .problems import with_weights
from .restore import load_result
from .result import FailedFit, FitResult
from .search import Search
from .setup import Plan, Setup

__all__ = [
    "FailedFit",
    "FitResult",
    "Observation",
    "Plan",
    "Search",
    "Setup",
    "fit_each",
    "load_result",
    "with_weights",
]
