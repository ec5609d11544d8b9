"""Search limits of the parameters (paper Tables 4 and 8)."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .params import PARAM_NAMES


class Bounds(eqx.Module):
    """Box `lower <= x <= upper` in physical units, ordered as `PARAM_NAMES`.

    Strategies search the unit cube; `to_physical` maps it affinely onto the box, which is
    exact for the per-coordinate operators of GA, DE, TLBO and ABC."""

    lower: Float[Array, "7"]
    upper: Float[Array, "7"]

    def __init__(self, lower: Float[ArrayLike, "7"], upper: Float[ArrayLike, "7"]):
        lo = np.asarray(lower, dtype=np.float64)
        hi = np.asarray(upper, dtype=np.float64)
        if lo.shape != (7,) or hi.shape != (7,):
            raise ValueError(f"bounds need 7 values each {PARAM_NAMES}, got {lo.shape} and {hi.shape}")
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ValueError("bounds must be finite numbers")
        bad = [PARAM_NAMES[k] for k in range(7) if lo[k] > hi[k]]
        if bad:
            raise ValueError(f"lower bound above upper bound for {bad}")
        self.lower = jnp.asarray(lo)
        self.upper = jnp.asarray(hi)

    def to_physical(self, z: Float[Array, "*batch 7"]) -> Float[Array, "*batch 7"]:
        """x = lower + z * (upper - lower)."""
        return self.lower + z * (self.upper - self.lower)

    def to_unit(self, x: Float[Array, "*batch 7"]) -> Float[Array, "*batch 7"]:
        width = jnp.where(self.upper > self.lower, self.upper - self.lower, 1.0)
        return (x - self.lower) / width

    def contains(self, x: Float[ArrayLike, "*batch 7"]) -> bool:
        x = np.asarray(x)
        return bool(np.all((x >= np.asarray(self.lower)) & (x <= np.asarray(self.upper))))


# Table 4: limits for the simulated data SD1–SD4.
TABLE4 = Bounds(
    lower=[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    upper=[100.0, 1.0, 5.0, 1.0, 1.0, 1e-3, 1e-6],
)

# Table 8: limits for the measured data MD1–MD4 (Tlb, Tlc: 20 Nm at 209 1/s).
# The extracted text prints Tlc <= 4.56e-6, but the table's own rule gives 20/209^2 = 4.58e-4
# and Table 9 reports a mean fitted Tlc of 4.99e-5, above 4.56e-6: the exponent is -4.
TABLE8 = Bounds(
    lower=[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    upper=[100.0, 100.0, 5.0, 1.0, 20.0, 9.55e-2, 4.56e-4],
)

_PRESETS = {"table4": TABLE4, "table8": TABLE8}


def bounds_preset(name: str) -> Bounds:
    """`"table4"` or `"table8"`."""
    try:
        return _PRESETS[name.lower()]
    except KeyError:
        raise ValueError(f"unknown bounds preset {name!r}; choose one of {sorted(_PRESETS)}") from None
