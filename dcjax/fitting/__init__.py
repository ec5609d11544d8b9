"""The search and its result: `fit` (one entry point) over the engine (`Search`, `Setup`, the
compiled runs), the runner (keys, sharding, the executable cache), batches of recordings
(`fit_each`, `fit_setups`), the Levenberg-Marquardt polish, and the `FitResult` with its
save/load. `dcjax.fit` is the function; `dcjax.fitting.fit` its module (a subpackage re-exports
no name that is also one of its modules)."""

from .each import FailedFit, fit_each
from .engine import Search, Setup, with_weights
from .result import FitResult, load_result

__all__ = [
    "FailedFit",
    "FitResult",
    "Search",
    "Setup",
    "fit_each",
    "load_result",
    "with_weights",
]
