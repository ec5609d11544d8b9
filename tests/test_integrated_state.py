"""A state the recording lacks whose rate no parameter enters (an angle, dth/dt = w) is the
integral of the recorded states for the first estimate (`linear_form.integrated_states`), so
`--bounds auto` works for a drive on a spring logged without its angle; checked on data from the
NumPy reference (`tests/reference.py`'s `spring_drive_field`, its angle left out)."""

from typing import ClassVar

import numpy as np
import pytest
import reference as ref

import dcjax
from dcjax.analysis.estimate import initial_estimate
from dcjax.analysis.linear_form import integrated_states
from dcjax.errors import ConfigError

TRUTH = {"R": 2.0, "k": 0.5, "J": 0.01, "K": 2.0}
L, C = 0.05, 0.02  # the reference's known inductance and friction


class SpringDrive(dcjax.Model):
    """`spring_drive_field` written to the protocol, its states compared (no output equation)."""

    names: ClassVar[tuple[str, ...]] = ("R", "k", "J", "K")
    states: ClassVar[tuple[str, ...]] = ("i", "w", "th")
    inputs: ClassVar[tuple[str, ...]] = ("u",)
    positive: ClassVar[tuple[str, ...]] = ("R", "k", "J", "K")

    def vector_field(self, c, u, y):
        i, w, th = y
        return ((u[0] - c["R"] * i - c["k"] * w) / L, (c["k"] * i - C * w - c["K"] * th) / c["J"], w)


class GearedSpringDrive(SpringDrive):
    """The angle's rate has a parameter in it (a gear ratio): not integrable without it."""

    names: ClassVar[tuple[str, ...]] = ("R", "k", "J", "K", "g")

    def vector_field(self, c, u, y):
        di, dw, _ = super().vector_field(c, u, y)
        return di, dw, y[1] / c["g"]


def _logged(n: int = 1000) -> tuple[dcjax.Recording, np.ndarray]:
    """The reference's PRBS response (2 ms samples) with its current and speed logged, not its angle."""
    t = np.arange(n) * 2e-3
    u = np.repeat(np.random.default_rng(1).choice([-10.0, 10.0], size=n // 25 + 1), 25)[:n]
    x = ref.simulate(ref.spring_drive_field, TRUTH, t, u[:, None], [0.0, 0.0, 0.0], substeps=8)
    return dcjax.Recording(t=t, u=u, i=x[:, 0], w=x[:, 1]), x


def test_an_angle_not_logged_is_the_integral_of_its_speed():
    rec, x = _logged()
    got = integrated_states(SpringDrive(), {"i": rec["i"], "w": rec["w"]}, {"u": rec["u"]}, 2e-3)
    assert set(got) == {"th"}
    assert np.max(np.abs(got["th"] - x[:, 2])) < 1e-3 * np.max(np.abs(x[:, 2]))  # the trapezoid rule's error at 2 ms
    assert integrated_states(GearedSpringDrive(), {"i": rec["i"], "w": rec["w"]}, {"u": rec["u"]}, 2e-3) == {}


def test_the_first_estimate_of_a_drive_on_a_spring_logged_without_its_angle():
    rec, _ = _logged()
    est = initial_estimate(rec, SpringDrive().measuring(("i", "w")))  # as `fit(..., observation=Observation(measure=("i", "w")))` has it
    for name, value in TRUTH.items():
        assert est[name].value == pytest.approx(value, rel=0.02), (name, est[name].value)
        assert est[name].min < value < est[name].max
    with pytest.raises(ConfigError, match="missing th"):  # g enters the angle's rate: still the one line naming it
        initial_estimate(rec, GearedSpringDrive().measuring(("i", "w")))
