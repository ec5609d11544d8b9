"""The seven parameters of the paper's DC drive (Table 1, eq. 6–7) as a structured module.

The rest of dcjax works with parameter vectors ordered as a model's `names`; `Params` is a
convenience for the default `dcjax.models.DC` model."""

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .dc import NAMES, UNITS

PARAM_NAMES: tuple[str, ...] = NAMES
PARAM_UNITS: dict[str, str] = UNITS


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
    def from_array(cls, x: Float[ArrayLike, "*batch P"]) -> "Params":
        """`x[..., k]` is the parameter `PARAM_NAMES[k]`."""
        x = jnp.asarray(x, dtype=jnp.float64)
        if x.ndim == 0 or x.shape[-1] != len(PARAM_NAMES):
            raise ValueError(f"parameter vector must have {len(PARAM_NAMES)} entries {PARAM_NAMES}, got shape {x.shape}")
        return cls(*(x[..., k] for k in range(len(PARAM_NAMES))))

    @classmethod
    def from_dict(cls, d: dict) -> "Params":
        missing = [n for n in PARAM_NAMES if n not in d]
        if missing:
            raise ValueError(f"missing parameters {missing}; need all of {PARAM_NAMES}")
        return cls(*(jnp.asarray(d[n], dtype=jnp.float64) for n in PARAM_NAMES))

    def to_array(self) -> Float[Array, "*batch P"]:
        return jnp.stack([getattr(self, n) for n in PARAM_NAMES], axis=-1)

    def to_dict(self) -> dict[str, float]:
        """Python floats by name (unbatched parameters only)."""
        return {n: float(np.asarray(getattr(self, n))) for n in PARAM_NAMES}
