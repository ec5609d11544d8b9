"""Models whose outputs are not their states (an output equation), written to the `dcjax.Model`
protocol; their NumPy twins, written independently, are `tests/reference.py`'s `spring_drive_field`
with `abs_speed_sensor` and `saturating_sensor`.

A DC drive on a torsion spring (third order: current, speed, angle), four unknown parameters
(R, k, J, K), its inductance and friction known; the sensor is a pulse counter on a pulley that
cannot see the sign (y = |b w|, `PulleyDrive`) or a speed sensor that saturates (y = min(w, w_max),
`SaturatingDrive`). A CLI test names a class here as `tests/output_models.py:PulleyDrive`."""

from typing import ClassVar

import jax.numpy as jnp

import dcjax

L, C, B, W_MAX = 0.05, 0.02, 0.5, 6.0  # the known inductance, viscous friction, pulley ratio, sensor limit


class PulleyDrive(dcjax.Model):
    names: ClassVar[tuple[str, ...]] = ("R", "k", "J", "K")
    units: ClassVar[dict[str, str]] = {"R": "ohm", "k": "V*s/rad", "J": "kg*m^2", "K": "N*m/rad"}
    states: ClassVar[tuple[str, ...]] = ("i", "w", "th")
    inputs: ClassVar[tuple[str, ...]] = ("u",)
    outputs: ClassVar[tuple[str, ...]] = ("y",)

    def vector_field(self, c, u, y):
        i, w, th = y
        return ((u[0] - c["R"] * i - c["k"] * w) / L, (c["k"] * i - C * w - c["K"] * th) / c["J"], w)

    def output(self, c, u, y):
        return (jnp.abs(B * y[1]),)


class SaturatingDrive(PulleyDrive):
    outputs: ClassVar[tuple[str, ...]] = ("y",)

    def output(self, c, u, y):
        return (jnp.minimum(y[1], W_MAX),)


class TwoSensorDrive(PulleyDrive):
    """Both sensors: `--measure` chooses among them."""

    outputs: ClassVar[tuple[str, ...]] = ("pulses", "w_sat")

    def output(self, c, u, y):
        return (jnp.abs(B * y[1]), jnp.minimum(y[1], W_MAX))


class RigidPulleyDrive(dcjax.Model):
    """`PulleyDrive` without its spring (second order): the wrong model for the spring drive's data."""

    names: ClassVar[tuple[str, ...]] = ("R", "k", "J")
    units: ClassVar[dict[str, str]] = {"R": "ohm", "k": "V*s/rad", "J": "kg*m^2"}
    states: ClassVar[tuple[str, ...]] = ("i", "w")
    inputs: ClassVar[tuple[str, ...]] = ("u",)
    outputs: ClassVar[tuple[str, ...]] = ("y",)

    def vector_field(self, c, u, y):
        i, w = y
        return ((u[0] - c["R"] * i - c["k"] * w) / L, (c["k"] * i - C * w) / c["J"])

    def output(self, c, u, y):
        return (jnp.abs(B * y[1]),)
