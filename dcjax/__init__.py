"""dcjax: DC motor and drive parameter identification in JAX.

Implements Jesenik, Hamler, Trbušić, Trlep, "The Use of Evolutionary Methods for the
Determination of a DC Motor and Drive Parameters Based on the Current and Angular Speed
Response", Mathematics 2020, 8, 1269, for the paper's model and for any model written to the
`dcjax.Model` protocol.

Importing dcjax enables ``jax_enable_x64``: the paper's best objective values are ~1e-19,
which float32 cannot resolve. It changes nothing else: for one CPU device per core (independent
runs sharded over the cores) and time loops compiled as one function, call
``dcjax.use_host_devices()`` and ``dcjax.use_compiled_loops()`` before any JAX computation.

The 0.1 names (`identify`, `Params`, `PARAM_NAMES`, `TABLE4`, ...) still work from `dcjax.compat`
and warn (`DeprecationWarning`); they are not in `__all__`.
"""

import jax

jax.config.update("jax_enable_x64", True)

from .analysis.design import design_input  # noqa: E402
from .analysis.estimate import initial_estimate  # noqa: E402
from .analysis.held_out import Validation, compare  # noqa: E402
from .analysis.tracking import Tracked, track  # noqa: E402
from .devices import use_compilation_cache, use_compiled_loops, use_host_devices  # noqa: E402
from .errors import ConfigError, DataError, DcjaxError, ModelError  # noqa: E402
from .fitting.each import fit_each  # noqa: E402
from .fitting.fit import fit  # noqa: E402
from .fitting.observation import Observation  # noqa: E402
from .fitting.parameter_spec import ParameterSpec  # noqa: E402
from .fitting.problems import with_weights  # noqa: E402
from .fitting.restore import load_result  # noqa: E402
from .fitting.result import FailedFit, FitResult  # noqa: E402
from .fitting.search import RunStatus, Search  # noqa: E402
from .io import datasets  # noqa: E402
from .io.loading import load_recording  # noqa: E402
from .io.recording import Recording, load_csv, save_csv, trim_switch_on  # noqa: E402
from .models import DC, MODELS, PMSM, DCCoulomb, DiscreteModel, Model, Servo, get_model  # noqa: E402
from .models.bounds import Bounds  # noqa: E402
from .models.parameters import Parameter, Parameters  # noqa: E402
from .models.priors import HalfNormalPrior, LogNormalPrior, NormalPrior, Prior  # noqa: E402
from .models.space import Space, make_space  # noqa: E402
from .simulation.integrators import INTEGRATORS, RK4, AutoSubsteps, Diffrax, Euler, Integrator  # noqa: E402
from .simulation.kalman import Filtered, kalman_filter, predict  # noqa: E402
from .simulation.losses import L1, LOSSES, SSE, Huber, Loss  # noqa: E402
from .simulation.objectives import Problem, make_problem, objective, residuals, simulate, simulate_outputs  # noqa: E402
from .simulation.predictors import EKF, Predictor, Simulation  # noqa: E402
from .strategies.memory import LTMA, MEMORIES, STMA, IndexedLTMA, MemoryAssistance  # noqa: E402
from .strategies.stopping import Converged  # noqa: E402
from .version import __version__  # noqa: E402

__all__ = [
    "datasets",
    "__version__",
    "Model",
    "DiscreteModel",
    "DC",
    "DCCoulomb",
    "PMSM",
    "Servo",
    "MODELS",
    "get_model",
    "Bounds",
    "Space",
    "make_space",
    "Recording",
    "load_csv",
    "load_recording",
    "save_csv",
    "trim_switch_on",
    "Problem",
    "make_problem",
    "simulate",
    "simulate_outputs",
    "objective",
    "residuals",
    "fit",
    "fit_each",
    "Search",
    "Validation",
    "compare",
    "Converged",
    "RunStatus",
    "FailedFit",
    "with_weights",
    "Observation",
    "Integrator",
    "Euler",
    "RK4",
    "Diffrax",
    "AutoSubsteps",
    "INTEGRATORS",
    "Loss",
    "SSE",
    "L1",
    "Huber",
    "LOSSES",
    "Predictor",
    "Simulation",
    "EKF",
    "kalman_filter",
    "predict",
    "Filtered",
    "track",
    "Tracked",
    "MemoryAssistance",
    "STMA",
    "LTMA",
    "IndexedLTMA",
    "MEMORIES",
    "Parameter",
    "Parameters",
    "ParameterSpec",
    "Prior",
    "NormalPrior",
    "LogNormalPrior",
    "HalfNormalPrior",
    "initial_estimate",
    "design_input",
    "FitResult",
    "load_result",
    "use_host_devices",
    "use_compiled_loops",
    "use_compilation_cache",
    "DcjaxError",
    "ConfigError",
    "ModelError",
    "DataError",
]


_DEPRECATED = (
    "identify",
    "identify_each",
    "identify_fleet",
    "FleetResult",
    "IdentificationResult",
    "Params",
    "PARAM_NAMES",
    "TABLE4",
    "TABLE8",
    "bounds_preset",
)


def __getattr__(name: str):
    """The 0.1 names (`dcjax.compat.DEPRECATED`), each with a `DeprecationWarning`."""
    if name not in _DEPRECATED:
        raise AttributeError(f"module 'dcjax' has no attribute {name!r}")
    import importlib  # a 0.1 name only: dcjax.compat is not imported otherwise

    from .deprecation import warn_deprecated  # a 0.1 name only

    obj, new = importlib.import_module("dcjax.compat").DEPRECATED[name]
    warn_deprecated(f"dcjax.{name}", new)
    return obj
