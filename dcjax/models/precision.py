"""Memory-assistance precisions (paper Table 29) of a model's parameters, physical and in the
unit cube the strategies search (`dcjax.strategies.memory` knows only the latter)."""

import numpy as np
from jaxtyping import ArrayLike

from ..errors import ConfigError
from . import DC, Model
from .bounds import Bounds
from .space import Space, make_space


def physical_precision(precision: ArrayLike | dict | None, model: Model) -> np.ndarray:
    """The precision vector (model order): None -> the model's own (Table 29 for `DC`), a
    name -> value mapping, or a full vector."""
    if precision is None:
        return model.precision_array()
    if isinstance(precision, dict):
        model.check_names(precision)
        known = model.memory_precision is not None
        base = model.precision_array() if known else np.zeros(model.n_params)
        missing = [n for n in model.names if n not in precision and not known]
        if missing:
            raise ConfigError(f"precision needs a value for {missing} (model {model.name} has no default)")
        return np.array([float(precision.get(n, base[k])) for k, n in enumerate(model.names)])
    p = np.asarray(precision, dtype=np.float64)
    if p.shape != (model.n_params,):
        raise ConfigError(f"precision needs {model.n_params} non-negative numbers {model.names}, got {p!r}")
    return p


def unit_precision(precision: ArrayLike | dict | None, space: "Space | Bounds", model: Model | None = None) -> np.ndarray:
    """Physical precisions (default: the model's, Table 29 for the paper's model) of the free
    parameters in the unit cube the strategies search (`space`: a `Space`, or `Bounds`)."""
    model = model if model is not None else DC()
    if isinstance(space, Bounds):
        space = make_space(model, space)
    p = physical_precision(precision, model)
    if not np.all(p >= 0) or np.any(np.isnan(p)):
        raise ConfigError(f"precision needs {model.n_params} non-negative numbers {model.names}, got {p!r}")
    p = space.free_of(p)
    width = np.asarray(space.upper - space.lower)
    return p / width
