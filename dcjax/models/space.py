"""The search space: which parameters are searched (free) and which are known (fixed), and the
affine map between the unit cube of the free ones and a full physical parameter vector.

Strategies see only the free parameters: a model with P parameters and F fixed ones is searched
in [0, 1]^(P - F). A parameter whose bounds coincide is fixed at that value."""

from collections.abc import Mapping

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..compiling import on_device
from ..errors import ConfigError, finite_number
from . import Model
from .bounds import Bounds


class Space(eqx.Module):
    """x[free] = lower + z (upper - lower), or lower (upper / lower)^z for a log-scale one;
    x[fixed] = the fixed values."""

    bounds: Bounds  # full bounds (P,), fixed parameters at their value
    values: Float[Array, " P"]  # the fixed values (free entries: 0)
    free: tuple[int, ...] = eqx.field(static=True)
    names: tuple[str, ...] = eqx.field(static=True)
    log: tuple[int, ...] = eqx.field(static=True, default=())  # free parameters searched on log(x) (`Parameter(scale="log")`)

    def _log_mask(self) -> np.ndarray:
        return np.array([k in self.log for k in self.free])

    def _free_physical(self, z: Float[Array, "*batch D"]) -> Float[Array, "*batch D"]:
        lo, hi = self.lower, self.upper
        x = lo + z * (hi - lo)
        if not self.log:
            return x
        mask = self._log_mask()
        llo, lhi = jnp.log(jnp.where(mask, lo, 1.0)), jnp.log(jnp.where(mask, hi, 1.0))
        return jnp.where(mask, jnp.exp(llo + z * (lhi - llo)), x)

    @property
    def dim(self) -> int:
        """Dimension of the search (free parameters)."""
        return len(self.free)

    @property
    def fixed(self) -> dict[str, float]:
        v = np.asarray(self.values)
        return {n: float(v[k]) for k, n in enumerate(self.names) if k not in self.free}

    @property
    def free_names(self) -> tuple[str, ...]:
        return tuple(self.names[k] for k in self.free)

    @property
    def lower(self) -> Float[Array, " D"]:
        return self.bounds.lower[jnp.asarray(self.free, dtype=int)]

    @property
    def upper(self) -> Float[Array, " D"]:
        return self.bounds.upper[jnp.asarray(self.free, dtype=int)]

    def to_physical(self, z: Float[Array, "*batch D"]) -> Float[Array, "*batch P"]:
        """The full parameter vector of unit-cube point(s) `z` of the free parameters."""
        if len(self.free) == len(self.names) and not self.log:
            return self.bounds.to_physical(z)
        xf = self._free_physical(z)
        if len(self.free) == len(self.names):
            return xf
        cols, j = [], 0
        for k in range(len(self.names)):
            if k in self.free:
                cols.append(xf[..., j])
                j += 1
            else:
                cols.append(jnp.broadcast_to(self.values[k], z.shape[:-1]))
        return jnp.stack(cols, axis=-1)

    def to_unit(self, x: Float[Array, "*batch P"]) -> Float[Array, "*batch D"]:
        """The free parameters of `x` in the unit cube."""
        x = jnp.asarray(x)
        lo, hi = self.lower, self.upper
        width = jnp.where(hi > lo, hi - lo, 1.0)
        xf = x[..., jnp.asarray(self.free, dtype=int)]
        z = (xf - lo) / width
        if not self.log:
            return z
        mask = self._log_mask()
        llo, lhi = jnp.log(jnp.where(mask, lo, 1.0)), jnp.log(jnp.where(mask, hi, 2.0))
        return jnp.where(mask, (jnp.log(jnp.where(mask, xf, 1.0)) - llo) / (lhi - llo), z)

    def free_of(self, v) -> np.ndarray:
        """The free entries of a full (P,) vector."""
        return np.asarray(v)[..., list(self.free)]


def make_space(model: Model, bounds: Bounds, fixed: Mapping[str, float] | None = None) -> Space:
    """Free/fixed split of `model`'s parameters: `fixed` name -> value (need not lie inside the
    bounds: a known value overrides them), plus every parameter whose bounds coincide."""
    fixed = dict(fixed or {})
    model.check_names(fixed, "fixed parameter")
    return vector_space(tuple(model.names), bounds, fixed, f"model {model.name}")


def vector_space(
    names: tuple[str, ...], bounds: Bounds, fixed: Mapping[str, float] | None = None, what: str = "the fit", log: tuple[str, ...] = ()
) -> Space:
    """`make_space` over any named vector (a fit's search vector: the model's parameters and more);
    `log`: the names searched on log(x) (each free one needs a lower bound > 0)."""
    fixed = dict(fixed or {})
    lo, hi = np.array(bounds.lower), np.array(bounds.upper)
    values = np.zeros(len(names))
    for n, v in fixed.items():
        v = finite_number(v, f"fixed value of {n}")
        k = names.index(n)
        lo[k] = hi[k] = values[k] = v
    for k in np.flatnonzero(lo == hi):
        values[k] = lo[k]
    free = tuple(int(k) for k in np.flatnonzero(lo < hi))
    if not free:
        raise ConfigError(f"every parameter of {what} is fixed; nothing to identify")
    logs = tuple(k for k in free if names[k] in log)
    bad = [f"{names[k]} (min {lo[k]:g})" for k in logs if not lo[k] > 0]
    if bad:
        raise ConfigError(
            f"scale log: {', '.join(bad)} needs a lower bound > 0 (a log-scale search spans min..max in decades); "
            f"give one: params[{names[logs[0]]!r}].set(min=LO, max=HI)"
        )
    return Space(Bounds(lo, hi, names), on_device(values), free, tuple(names), logs)
