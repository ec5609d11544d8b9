"""The motor ODE (paper eq. 8–9) in a form with the divisions hoisted out of the time loop."""

import equinox as eqx
from jaxtyping import Array, Float

from .params import Params


class Coefficients(eqx.Module):
    """Eq. 8–9 divided through once per simulation:

        di/dt = gu*u - a*i - b*w            (gu = 1/La, a = Ra/La, b = cm/La)
        dw/dt = c*i - d - e*w - f*w^2       (c = cm/J, d = Tla/J, e = Tlb/J, f = Tlc/J)
    """

    gu: Float[Array, "*batch"]
    a: Float[Array, "*batch"]
    b: Float[Array, "*batch"]
    c: Float[Array, "*batch"]
    d: Float[Array, "*batch"]
    e: Float[Array, "*batch"]
    f: Float[Array, "*batch"]

    @classmethod
    def from_params(cls, p: Params) -> "Coefficients":
        inv_la = 1.0 / p.La
        inv_j = 1.0 / p.J
        return cls(inv_la, p.Ra * inv_la, p.cm * inv_la, p.cm * inv_j, p.Tla * inv_j, p.Tlb * inv_j, p.Tlc * inv_j)


def vector_field(k: Coefficients, u, i, w):
    """(di/dt, dw/dt) of eq. 8–9 with hoisted coefficients."""
    di = k.gu * u - k.a * i - k.b * w
    dw = k.c * i - k.d - (k.e + k.f * w) * w
    return di, dw


def derivatives(p: Params, u, i, w):
    """Eq. 8 and 9 written exactly as in the paper (reference form, not the hot path)."""
    di = (u - i * p.Ra - p.cm * w) / p.La
    dw = (p.cm * i - (p.Tla + p.Tlb * w + p.Tlc * w**2)) / p.J
    return di, dw
