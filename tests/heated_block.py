"""A heated block in a room, written to the `dcjax.Model` protocol as a user would first write it:
C dT/dt = k P - (T - Ta) / Rth. Its parameters hold a direction the temperature cannot see (C, k
and Rth as sC, sk, Rth/s give the same k/C and Rth*C): the tests' model of an over-parameterized
file model. Its NumPy twin is `tests/reference.py`'s `heated_block_field`."""

from typing import ClassVar

import dcjax


class HeatedBlock(dcjax.Model):
    names: ClassVar[tuple[str, ...]] = ("C", "k", "Rth", "Ta")
    units: ClassVar[dict[str, str]] = {"C": "J/K", "k": "1", "Rth": "K/W", "Ta": "K"}
    states: ClassVar[tuple[str, ...]] = ("T",)
    inputs: ClassVar[tuple[str, ...]] = ("P",)

    def coefficients(self, p):
        return p["k"] / p["C"], 1 / (p["Rth"] * p["C"]), p["Ta"]

    def vector_field(self, c, u, y):
        a, b, ta = c
        (temperature,) = y
        return (a * u[0] - b * (temperature - ta),)
