"""The search and its result: `fit` (one entry point) over the engine `identify`, the runner
(keys, sharding, the executable cache), batches of recordings (`identify_each`, `fit_each`, the
fleet), the Levenberg-Marquardt polish, and the `FitResult` with its save/load. `dcjax.fit` and
`dcjax.identify` are the functions; `dcjax.fitting.fit` and `dcjax.fitting.identify` their modules
(a subpackage re-exports no name that is also one of its modules)."""

from .batch import identify_each
from .each import FailedFit, fit_each
from .fit import LTMA, RK4, STMA, AutoSubsteps, Euler, IndexedLTMA, with_weights
from .result import FitResult, IdentificationResult, load_result

__all__ = [
    "LTMA",
    "RK4",
    "STMA",
    "AutoSubsteps",
    "Euler",
    "FailedFit",
    "FitResult",
    "IdentificationResult",
    "IndexedLTMA",
    "fit_each",
    "identify_each",
    "load_result",
    "with_weights",
]
