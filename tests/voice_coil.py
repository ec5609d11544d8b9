"""A linear actuator written to the `dcjax.Model` protocol: a moving coil on a spring, its
position logged in mm and its current in mA (the quantities `position`, `speed`, `current`).
Its NumPy twin, written independently, is `tests/reference.py`'s `voice_coil_field`. The CLI
tests name this file alone (`--model tests/voice_coil.py`: the one model it defines).

    L di/dt = u - R i - Kf v,    m dv/dt = Kf i - c v - k x,    dx/dt = v"""

from typing import ClassVar

import dcjax


class VoiceCoil(dcjax.Model):
    names: ClassVar[tuple[str, ...]] = ("R", "L", "Kf", "m", "k", "c")
    units: ClassVar[dict[str, str]] = {"R": "Ohm", "L": "H", "Kf": "N/A", "m": "kg", "k": "N/m", "c": "N s/m"}
    states: ClassVar[tuple[str, ...]] = ("i", "v", "x")
    inputs: ClassVar[tuple[str, ...]] = ("u",)
    measured: ClassVar[tuple[str, ...] | None] = ("i", "x")
    derivative_of: ClassVar[dict[str, str]] = {"v": "x"}
    positive: ClassVar[tuple[str, ...]] = names
    quantities: ClassVar[dict[str, str]] = {"u": "voltage", "i": "current", "v": "speed", "x": "position"}

    def coefficients(self, p):
        return 1 / p["L"], p["R"] / p["L"], p["Kf"] / p["L"], p["Kf"] / p["m"], p["c"] / p["m"], p["k"] / p["m"]

    def vector_field(self, c, u, y):
        gu, a, b, kf, cm, km = c
        i, v, x = y
        return gu * u[0] - a * i - b * v, kf * i - cm * v - km * x, v
