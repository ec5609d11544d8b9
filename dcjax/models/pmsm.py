"""A permanent-magnet synchronous motor in the rotor's dq frame, a built-in beyond the paper's DC
motor (`dcjax.models.PMSM`, `--model pmsm`):

    Ld did/dt = ud - Rs id + pp omega Lq iq
    Lq diq/dt = uq - Rs iq - pp omega (Ld id + psi_m)
    J domega/dt = 1.5 pp (psi_m iq + (Ld - Lq) id iq) - B omega - Tl

with the mechanical speed omega (rad/s), the pole pairs `pp` and the load torque `Tl` inputs that
are usually constant per recording (`Recording(constants={"pp": 4, "Tl": 0.02})`, a sidecar's
`"constants"` or `constants={"pp": 4, "Tl": 0.02}`; a logged load torque is read as a column). Every
parameter is positive; the equations are linear in them, so the first estimate is a regression.
A recording's `limit` (A) clamps the current vector's magnitude after every sub-step."""

from typing import ClassVar

import jax.numpy as jnp

from .base import Model

NAMES = ("Rs", "Ld", "Lq", "psi_m", "J", "B")


class PMSM(Model):
    """Parameters Rs, Ld, Lq, psi_m, J, B; inputs ud, uq, pp, Tl; states id, iq, omega (module docstring)."""

    names: ClassVar[tuple[str, ...]] = NAMES
    units: ClassVar[dict[str, str]] = {"Rs": "Ohm", "Ld": "H", "Lq": "H", "psi_m": "Vs", "J": "kg m^2", "B": "Nm s"}
    states: ClassVar[tuple[str, ...]] = ("id", "iq", "omega")
    inputs: ClassVar[tuple[str, ...]] = ("ud", "uq", "pp", "Tl")
    positive: ClassVar[tuple[str, ...]] = NAMES
    required: ClassVar[tuple[str, ...]] = ("Rs", "Ld", "Lq", "psi_m", "J")
    quantities: ClassVar[dict[str, str]] = {
        "ud": "voltage",
        "uq": "voltage",
        "id": "current",
        "iq": "current",
        "omega": "angular speed",
        "Tl": "torque",
    }

    @property
    def name(self) -> str:
        return "pmsm"

    def vector_field(self, c, u, y):
        i_d, i_q, w = y
        ud, uq, pp, tl = u
        we = pp * w  # the electrical speed
        did = (ud - c["Rs"] * i_d + we * c["Lq"] * i_q) / c["Ld"]
        diq = (uq - c["Rs"] * i_q - we * (c["Ld"] * i_d + c["psi_m"])) / c["Lq"]
        dw = (1.5 * pp * (c["psi_m"] * i_q + (c["Ld"] - c["Lq"]) * i_d * i_q) - c["B"] * w - tl) / c["J"]
        return did, diq, dw

    def regression(self, y, dy, u):
        """The three equations of the module docstring, each linear in the parameters."""
        i_d, i_q, w = y["id"], y["iq"], y["omega"]
        pp = u["pp"]
        we = pp * w
        return [
            ({"Ld": dy["id"], "Rs": i_d, "Lq": -we * i_q}, u["ud"], "Ld"),
            ({"Lq": dy["iq"], "Rs": i_q, "Ld": we * i_d, "psi_m": we}, u["uq"], "Lq"),
            ({"J": dy["omega"], "B": w, "psi_m": -1.5 * pp * i_q, "Ld": -1.5 * pp * i_d * i_q, "Lq": 1.5 * pp * i_d * i_q}, -u["Tl"], "J"),
        ]

    def clamp(self, y, limit):
        """The drive's current limit on the current vector: sqrt(id^2 + iq^2) <= limit, scaled
        along the vector (the angle kept); `Recording(limit=...)` / `--limit` in A."""
        if limit is None:
            return y
        i_d, i_q, w = y
        magnitude = jnp.sqrt(i_d * i_d + i_q * i_q)
        scale = jnp.where(magnitude > limit, limit / jnp.maximum(magnitude, 1e-300), 1.0)
        return i_d * scale, i_q * scale, w

    def time_constants(self, p):
        """The electrical time constants Ld/Rs and Lq/Rs."""
        rs = float(p["Rs"])
        return {"Ld/Rs": float(p["Ld"]) / rs, "Lq/Rs": float(p["Lq"]) / rs} if rs > 0 else {}

    def derived(self, p):
        """The electrical time constants Ld/Rs, Lq/Rs and the mechanical J/B."""
        rs, b = float(p["Rs"]), float(p["B"])
        out = {f"electrical time constant {k}": (v, "s") for k, v in self.time_constants(p).items()}
        if b > 0:
            out["mechanical time constant J/B"] = (float(p["J"]) / b, "s")
        return out if rs > 0 or b > 0 else {}
