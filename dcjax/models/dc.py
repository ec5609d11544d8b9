"""The paper's separately excited DC motor (eq. 6–9) and a variant with Coulomb friction.

    di/dt = (u_a - Ra i - cm w) / La                              (eq. 8)
    dw/dt = (cm i - T_load(w)) / J                                (eq. 9)

`DC`: T_load = Tla + Tlb w + Tlc w^2 (eq. 5), the paper's load, the package default.
`DCCoulomb`: T_load = Tla sgn(w) + Tlb w + Tlc w |w|, odd in w, for drives that reverse."""

from collections.abc import Mapping
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..errors import ModelError
from .base import Model
from .parameters import Parameter, Parameters

NAMES = ("Ra", "La", "cm", "J", "Tla", "Tlb", "Tlc")


def table4() -> Parameters:
    """Table 4: the search ranges for the simulated data SD1–SD4, with the units and Table 29's
    memory precisions (Ra < 1 mOhm, La < 1 mH, cm < 1 mVs, J < 1e-4 kgm^2, Tla < 1 mNm, Tlb <
    5e-6 Nms, Tlc < 2e-8 Nms^2: 1 mNm at 209 1/s). A new `Parameters` each call."""
    return Parameters(
        [
            Parameter("Ra", min=0.0, max=100.0, unit="Ohm", precision=1e-3),
            Parameter("La", min=0.0, max=1.0, unit="H", precision=1e-3),
            Parameter("cm", min=0.0, max=5.0, unit="Vs", precision=1e-3),
            Parameter("J", min=0.0, max=1.0, unit="kg m^2", precision=1e-4),
            Parameter("Tla", min=0.0, max=1.0, unit="Nm", precision=1e-3),
            Parameter("Tlb", min=0.0, max=1e-3, unit="Nm s", precision=5e-6),
            Parameter("Tlc", min=0.0, max=1e-6, unit="Nm s^2", precision=2e-8),
        ]
    )


def table8() -> Parameters:
    """Table 8: the ranges for the measured data MD1–MD4 (Tlb, Tlc: 20 Nm at 209 1/s); the rest
    as Table 4. The extracted text prints Tlc <= 4.56e-6, but the table's own rule gives 20/209^2
    = 4.58e-4 and Table 9 reports a mean fitted Tlc of 4.99e-5, above 4.56e-6: the exponent is -4."""
    params = table4()
    for name, upper in (("La", 100.0), ("Tla", 20.0), ("Tlb", 9.55e-2), ("Tlc", 4.56e-4)):
        params[name].set(max=upper)
    return params


# Views of the presets for the protocol's readers (one source: the functions above).
UNITS = {n: p.unit for n, p in table4().items()}
TABLE29_PRECISION: dict[str, float] = {n: float(p.precision) for n, p in table4().items()}  # pyright: ignore[reportArgumentType]
TABLE29 = np.array([TABLE29_PRECISION[n] for n in NAMES])  # Table 29 as a vector in `NAMES` order


def load_torque_precision(torque: float, speed: float, ra: float, la: float, cm: float, j: float) -> np.ndarray:
    """Table 29's rule for other drives of the paper's model: the load coefficients are resolved
    to a torque of `torque` at `speed` (Tla: torque, Tlb: torque / speed, Tlc: torque / speed^2);
    Ra, La, cm and J get the resolution the user gives (Table 29: 1e-3, 1e-3, 1e-3, 1e-4 with
    1 mNm at 209 1/s)."""
    if not (torque > 0 and speed > 0 and min(ra, la, cm, j) > 0):
        raise ModelError("precisions, torque and speed must be positive")
    return np.array([ra, la, cm, j, torque, torque / speed, torque / speed**2])


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
    def from_params(cls, p) -> "Coefficients":
        """From a name -> value mapping or a `Params`."""
        g = p.__getitem__ if isinstance(p, Mapping) else p.__getattribute__
        inv_la = 1.0 / g("La")
        inv_j = 1.0 / g("J")
        return cls(inv_la, g("Ra") * inv_la, g("cm") * inv_la, g("cm") * inv_j, g("Tla") * inv_j, g("Tlb") * inv_j, g("Tlc") * inv_j)


def vector_field(k: Coefficients, u, i, w):
    """(di/dt, dw/dt) of eq. 8–9 with hoisted coefficients."""
    di = k.gu * u - k.a * i - k.b * w
    dw = k.c * i - k.d - (k.e + k.f * w) * w
    return di, dw


def derivatives(p: Mapping, u, i, w):
    """Eq. 8 and 9 written exactly as in the paper (reference form, not the hot path); `p` a
    name -> value mapping."""
    di = (u - i * p["Ra"] - p["cm"] * w) / p["La"]
    dw = (p["cm"] * i - (p["Tla"] + p["Tlb"] * w + p["Tlc"] * w**2)) / p["J"]
    return di, dw


class DC(Model):
    """The paper's DC drive: states (i_a, omega), input u_a, the supply's current limit on i_a."""

    names: ClassVar[tuple[str, ...]] = NAMES
    units: ClassVar[dict[str, str]] = UNITS
    states: ClassVar[tuple[str, ...]] = ("i_a", "omega")
    inputs: ClassVar[tuple[str, ...]] = ("u_a",)
    precision: ClassVar[dict[str, float] | None] = TABLE29_PRECISION
    limited_state: ClassVar[str | None] = "i_a"
    quantities: ClassVar[dict[str, str]] = {"u_a": "voltage", "i_a": "current", "omega": "angular speed"}
    follows: ClassVar[dict[str, str]] = {"i_a": "u_a", "omega": "u_a"}  # a positive voltage drives positive current and speed
    required: ClassVar[tuple[str, ...]] = ("Ra", "La", "cm", "J")  # the back-EMF, inertia and winding are never zero

    @property
    def name(self) -> str:
        return "dc"

    def presets(self) -> dict[str, Parameters]:
        return {"table4": table4(), "table8": table8()}

    def coefficients(self, p):
        return Coefficients.from_params(p)

    def vector_field(self, c, u, y):
        return vector_field(c, u[0], y[0], y[1])

    def load_torque(self, p, w):
        return p["Tla"] + p["Tlb"] * w + p["Tlc"] * w * w

    def derived(self, p):
        """Eq. 6-9 at rest (d/dt = 0) and linearised with Tla = Tlc = 0: the static speed gain
        omega/u_a = cm / (Ra Tlb + cm^2); the electrical time constant La/Ra; the mechanical
        Ra J / (cm^2 + Ra Tlb)."""
        Ra, La, cm, J, Tlb = (float(p[n]) for n in ("Ra", "La", "cm", "J", "Tlb"))
        damping = Ra * Tlb + cm * cm
        out = {}
        if damping > 0:
            out["static speed gain omega/u_a"] = (cm / damping, "rad/(V s)")
            out["mechanical time constant Ra J/(cm^2 + Ra Tlb)"] = (Ra * J / damping, "s")
        if Ra > 0:
            out["electrical time constant La/Ra"] = (La / Ra, "s")
        return out

    def time_constants(self, p):
        """The electrical time constant La/Ra (eq. 8)."""
        return {"La/Ra": float(p["La"]) / float(p["Ra"])} if float(p["Ra"]) > 0 else {}

    def load_regressors(self, w):
        """The columns of Tla, Tlb, Tlc in the load torque (eq. 5): 1, w, w^2."""
        return np.ones_like(w), w, w * w

    def regression(self, y, dy, u):
        """Eq. 8 times La and eq. 9 times J, linear in the parameters:
        La di/dt + Ra i + cm w = u_a  and  J dw/dt - cm i + Tla + Tlb w + Tlc w^2 = 0."""
        i, w = y["i_a"], y["omega"]
        one, lin, quad = self.load_regressors(w)
        return [
            ({"La": dy["i_a"], "Ra": i, "cm": w}, u["u_a"], "La"),
            ({"J": dy["omega"], "cm": -i, "Tla": one, "Tlb": lin, "Tlc": quad}, np.zeros_like(w), "J"),
        ]

    def steady_state(self, p, channels):
        """Eq. 25–26 (di/dt = dw/dt = 0): u_a = Ra i_a + cm w and i_a = T_load(w) / cm."""
        i, w = channels["i_a"], channels["omega"]
        return {"u_a": i * p["Ra"] + p["cm"] * w, "i_a": self.load_torque(p, w) / p["cm"]}


def smooth_sign(w, width):
    """sgn(w) regularized over |w| <~ width: w / sqrt(w^2 + width^2)."""
    return w / jnp.sqrt(w * w + width * width)


class DCCoulomb(DC):
    """`DC` with a load torque odd in w: T_load = Tla sgn(w) + Tlb w + Tlc w |w|.

    sgn is regularized, sgn(w) ~ w / sqrt(w^2 + w_eps^2) (`w_eps` in rad/s, default 0.5): with the
    exact sign an explicit integrator chatters at standstill (the friction flips each step and the
    speed oscillates around 0 with amplitude ~h Tla / J), and a switch inside a step costs RK4 its
    order. Below |w| ~ w_eps the friction acts like a steep viscous term, so a drive held near
    standstill creeps instead of sticking; across a reversal the trajectory is unchanged to
    O(w_eps / |dw/dt|) in time. Explicit stability needs roughly h Tla / (J w_eps) < 2.8 (RK4, h
    the sub-step): raise `w_eps` or ND where a fit of a slowly sampled drive turns unstable."""

    w_eps: float = eqx.field(static=True, default=0.5)

    @property
    def name(self) -> str:
        return "dc-coulomb"

    def vector_field(self, c, u, y):
        i, w = y
        di = c.gu * u[0] - c.a * i - c.b * w
        dw = c.c * i - c.d * smooth_sign(w, self.w_eps) - (c.e + c.f * jnp.abs(w)) * w
        return di, dw

    def load_torque(self, p, w):
        return p["Tla"] * w / np.sqrt(w * w + self.w_eps**2) + p["Tlb"] * w + p["Tlc"] * w * np.abs(w)

    def load_regressors(self, w):
        return w / np.sqrt(w * w + self.w_eps**2), w, w * np.abs(w)
