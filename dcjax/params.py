"""The seven motor and drive parameters (paper Table 1, eq. 6–7)."""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

PARAM_NAMES: tuple[str, ...] = ("Ra", "La", "cm", "J", "Tla", "Tlb", "Tlc")
PARAM_UNITS: dict[str, str] = {
    "Ra": "Ohm",
    "La": "H",
    "cm": "Vs",
    "J": "kg m^2",
    "Tla": "Nm",
    "Tlb": "Nm s",
    "Tlc": "Nm s^2",
}


class Params(eqx.Module):
    """Armature resistance `Ra`, inductance `La`, motor constant `cm`, inertia `J` and the
    load torque `T_load = Tla + Tlb*w + Tlc*w^2` (eq. 5). Leaves may carry leading batch
    axes (a population is a `Params` whose leaves have shape `(P,)`)."""

    Ra: Float[Array, "*batch"]
    La: Float[Array, "*batch"]
    cm: Float[Array, "*batch"]
    J: Float[Array, "*batch"]
    Tla: Float[Array, "*batch"]
    Tlb: Float[Array, "*batch"]
    Tlc: Float[Array, "*batch"]

    names: ClassVar[tuple[str, ...]] = PARAM_NAMES

    @classmethod
    def from_array(cls, x: Float[ArrayLike, "*batch 7"]) -> "Params":
        """`x[..., k]` is the parameter `PARAM_NAMES[k]`."""
        x = jnp.asarray(x, dtype=jnp.float64)
        if x.shape[-1] != 7:
            raise ValueError(f"parameter vector must have 7 entries {PARAM_NAMES}, got shape {x.shape}")
        return cls(*(x[..., k] for k in range(7)))

    @classmethod
    def from_dict(cls, d: dict) -> "Params":
        missing = [n for n in PARAM_NAMES if n not in d]
        if missing:
            raise ValueError(f"missing parameters {missing}; need all of {PARAM_NAMES}")
        return cls(*(jnp.asarray(d[n], dtype=jnp.float64) for n in PARAM_NAMES))

    def to_array(self) -> Float[Array, "*batch 7"]:
        return jnp.stack([getattr(self, n) for n in PARAM_NAMES], axis=-1)

    def to_dict(self) -> dict[str, float]:
        """Python floats by name (unbatched parameters only)."""
        return {n: float(np.asarray(getattr(self, n))) for n in PARAM_NAMES}
