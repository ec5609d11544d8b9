"""Search limits: a box per parameter, and per-name overrides over a model's preset."""

from collections.abc import Mapping

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import numpy.typing as npt
from jaxtyping import Array, ArrayLike, Float

from ..errors import ConfigError
from . import Model


class Bounds(eqx.Module):
    """Box `lower <= x <= upper` in physical units, ordered as the model's `names`.

    Strategies search the unit cube; `to_physical` maps it affinely onto the box, which is
    exact for the per-coordinate operators of GA, DE, TLBO and ABC."""

    lower: Float[Array, " P"]
    upper: Float[Array, " P"]

    def __init__(self, lower: npt.ArrayLike, upper: npt.ArrayLike, names: tuple[str, ...] | None = None):
        lo = np.atleast_1d(np.asarray(lower, dtype=np.float64))
        hi = np.atleast_1d(np.asarray(upper, dtype=np.float64))
        if lo.ndim != 1 or lo.shape != hi.shape or (names is not None and lo.shape != (len(names),)):
            want = f"{len(names)} values each {tuple(names)}" if names is not None else "equal-length vectors"
            raise ConfigError(f"bounds need {want}, got shapes {lo.shape} and {hi.shape}")
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ConfigError("bounds must be finite numbers")
        bad = [k if names is None else names[k] for k in np.flatnonzero(lo > hi)]
        if bad:
            raise ConfigError(f"lower bound above upper bound for {bad}")
        # NumPy leaves: building bounds (the presets at import) starts no JAX backend.
        self.lower = lo
        self.upper = hi

    @property
    def size(self) -> int:
        return int(self.lower.shape[0])

    def to_physical(self, z: Float[Array, "*batch P"]) -> Float[Array, "*batch P"]:
        """x = lower + z * (upper - lower)."""
        return self.lower + z * (self.upper - self.lower)

    def to_unit(self, x: Float[Array, "*batch P"]) -> Float[Array, "*batch P"]:
        width = jnp.where(self.upper > self.lower, self.upper - self.lower, 1.0)
        return (x - self.lower) / width

    def contains(self, x: Float[ArrayLike, "*batch P"]) -> bool:
        x = np.asarray(x)
        return bool(np.all((x >= np.asarray(self.lower)) & (x <= np.asarray(self.upper))))

    def to_dict(self, names) -> dict[str, list[float]]:
        lo, hi = np.asarray(self.lower), np.asarray(self.upper)
        return {n: [float(lo[k]), float(hi[k])] for k, n in enumerate(names)}


def resolve_bounds(model: Model, bounds=None, overrides: Mapping[str, tuple[float, float]] | None = None) -> Bounds:
    """`bounds`: None (the model's first preset), a preset name, a `Bounds`, a `(lower, upper)`
    pair or a name -> (lower, upper) mapping over the default preset; then `overrides`
    (name -> (lower, upper)) replace single parameters."""
    if isinstance(bounds, Mapping):
        overrides = {**bounds, **(overrides or {})}
        bounds = None
    if bounds is None or isinstance(bounds, str):
        if bounds is None and not model.preset_names:
            raise ConfigError(f"model {model.name} has no bounds presets; give bounds for {', '.join(model.names)}")
        b = Bounds(*model.bound_arrays(bounds), model.names)
    elif isinstance(bounds, Bounds):
        b = bounds
    else:
        try:
            lo, hi = bounds
        except (TypeError, ValueError):
            raise ConfigError("bounds must be a preset name, a Bounds, a (lower, upper) pair or a name -> (lower, upper) mapping") from None
        b = Bounds(lo, hi, model.names)
    if b.size != model.n_params:
        raise ConfigError(f"bounds have {b.size} entries but model {model.name} has {model.n_params} parameters {model.names}")
    if overrides:
        model.check_names(overrides)
        lo, hi = np.array(b.lower), np.array(b.upper)
        for n, pair in overrides.items():
            try:
                a, c = (float(v) for v in pair)
            except (TypeError, ValueError):
                raise ConfigError(f"bound of {n} must be a (lower, upper) pair of numbers, got {pair!r}") from None
            k = model.names.index(n)
            lo[k], hi[k] = a, c
        b = Bounds(lo, hi, model.names)
    return b
