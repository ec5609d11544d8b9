"""The models of the composition matrix, written to the `dcjax.Model` protocol (their NumPy
twins, written independently, are in `tests/reference.py`):

- the paper's DC motor (`dcjax.DC`, an ODE) and `EncoderDC` (its shaft angle measured instead of
  the speed, the speed a derivative state);
- `EulerDC`: the same motor as a `dcjax.DiscreteModel` (its forward-Euler map per sample), and
  `EncoderEulerDC`;
- `SensorDC`, `SensorEulerDC`: the motor read through an output equation (torque cm i_a, |omega|);
- `PMSM`: a two-input (ud, uq), three-state (id, iq, w) synchronous motor in the dq frame, its
  pole pairs a per-recording constant input; `EncoderPMSM`.

A CLI test names a class here as `tests/matrix_models.py:PMSM`."""

from typing import ClassVar

import jax.numpy as jnp

import dcjax
from dcjax.models.dc import vector_field as dc_vector_field


class EncoderDC(dcjax.DC):
    """The paper's motor with the shaft angle: the current and the angle are measured."""

    states: ClassVar[tuple[str, ...]] = ("i_a", "omega", "theta")
    measured: ClassVar[tuple[str, ...] | None] = ("i_a", "theta")
    derivative_of: ClassVar[dict[str, str]] = {"omega": "theta"}
    quantities: ClassVar[dict[str, str]] = {**dcjax.DC.quantities, "theta": "angle"}
    follows: ClassVar[dict[str, str]] = {"i_a": "u_a"}

    @property
    def name(self) -> str:
        return "encoder-dc"

    def vector_field(self, c, u, y):
        return (*dc_vector_field(c, u[0], y[0], y[1]), y[1])

    def regression(self, y, dy, u):
        return None


class EulerDC(dcjax.DiscreteModel):
    """The paper's motor as its forward-Euler map from one sample to the next (eq. 11-12)."""

    names: ClassVar[tuple[str, ...]] = dcjax.DC.names
    units: ClassVar[dict[str, str]] = dcjax.DC.units
    states: ClassVar[tuple[str, ...]] = ("i_a", "omega")
    inputs: ClassVar[tuple[str, ...]] = ("u_a",)
    limited_state: ClassVar[str | None] = "i_a"
    quantities: ClassVar[dict[str, str]] = dcjax.DC.quantities

    def presets(self):
        return dcjax.DC().presets()

    def coefficients(self, p):
        return dcjax.DC().coefficients(p)

    def update(self, c, u, y, dt):
        di, dw = dc_vector_field(c, u[0], y[0], y[1])
        return (y[0] + dt * di, y[1] + dt * dw)


class EncoderEulerDC(EulerDC):
    states: ClassVar[tuple[str, ...]] = ("i_a", "omega", "theta")
    measured: ClassVar[tuple[str, ...] | None] = ("i_a", "theta")
    derivative_of: ClassVar[dict[str, str]] = {"omega": "theta"}
    quantities: ClassVar[dict[str, str]] = {**dcjax.DC.quantities, "theta": "angle"}

    def update(self, c, u, y, dt):
        di, dw = dc_vector_field(c, u[0], y[0], y[1])
        return (y[0] + dt * di, y[1] + dt * dw, y[2] + dt * y[1])


class PMSM(dcjax.Model):
    """Ld did/dt = ud - Rs id + pp w Lq iq; Lq diq/dt = uq - Rs iq - pp w (Ld id + psi);
    J dw/dt = 1.5 pp (psi iq + (Ld - Lq) id iq) - B w - Tl. The pole pairs `pp` are an input
    constant per recording."""

    names: ClassVar[tuple[str, ...]] = ("Rs", "Ld", "Lq", "psi", "J", "B", "Tl")
    units: ClassVar[dict[str, str]] = {"Rs": "Ohm", "Ld": "H", "Lq": "H", "psi": "Vs", "J": "kg m^2", "B": "Nm s", "Tl": "Nm"}
    states: ClassVar[tuple[str, ...]] = ("id", "iq", "w")
    inputs: ClassVar[tuple[str, ...]] = ("ud", "uq", "pp")
    quantities: ClassVar[dict[str, str]] = {"ud": "voltage", "uq": "voltage", "id": "current", "iq": "current", "w": "angular speed"}
    required: ClassVar[tuple[str, ...]] = ("Rs", "Ld", "Lq", "psi", "J")

    def coefficients(self, p):
        return p

    def vector_field(self, c, u, y):
        i_d, i_q, w = y[0], y[1], y[2]
        ud, uq, pp = u
        did = (ud - c["Rs"] * i_d + pp * w * c["Lq"] * i_q) / c["Ld"]
        diq = (uq - c["Rs"] * i_q - pp * w * (c["Ld"] * i_d + c["psi"])) / c["Lq"]
        dw = (1.5 * pp * (c["psi"] * i_q + (c["Ld"] - c["Lq"]) * i_d * i_q) - c["B"] * w - c["Tl"]) / c["J"]
        return did, diq, dw


class EncoderPMSM(PMSM):
    states: ClassVar[tuple[str, ...]] = ("id", "iq", "w", "theta")
    measured: ClassVar[tuple[str, ...] | None] = ("id", "iq", "theta")
    derivative_of: ClassVar[dict[str, str]] = {"w": "theta"}
    quantities: ClassVar[dict[str, str]] = {**PMSM.quantities, "theta": "angle"}

    def vector_field(self, c, u, y):
        return (*super().vector_field(c, u, y[:3]), y[2])


class SensorDC(dcjax.DC):
    """The paper's motor read through an output equation: a torque sensor (cm i_a, a parameter
    in the output) and a speed sensor that cannot see the sign (|omega|)."""

    outputs: ClassVar[tuple[str, ...]] = ("torque", "speed")

    @property
    def name(self) -> str:
        return "sensor-dc"

    def output(self, c, u, y):
        return (c.b / c.gu * y[0], jnp.abs(y[1]))


class SensorEulerDC(EulerDC):
    """`EulerDC` through `SensorDC`'s sensors."""

    outputs: ClassVar[tuple[str, ...]] = ("torque", "speed")

    def output(self, c, u, y):
        return (c.b / c.gu * y[0], jnp.abs(y[1]))
