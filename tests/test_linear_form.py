"""The automatic equation-error regression (`dcjax.analysis.linear_form`): a model that writes no
`regression()` gets the linear form the paper's motor writes by hand, and a first estimate in
well under a second of search-free work; data from the independent NumPy simulator."""

import time
from typing import ClassVar

import jax.numpy as jnp
import numpy as np
import pytest
import reference

import dcjax
from dcjax import datasets
from dcjax.analysis.estimate import filtered_states, initial_estimate
from dcjax.analysis.linear_form import linear_masses, linear_regression

TRUTH = {"J": 0.012, "Tc": 0.045, "B": 0.018}
WIDTH = 0.05


class PlainDC(dcjax.DC):
    """The paper's motor without its hand-written regression."""

    def regression(self, y, dy, u):
        return None


class Friction(dcjax.Model):
    """A bench: J dw/dt = T - Tc sgn(w) - B w, sgn smoothed over 0.05 rad/s (no regression())."""

    names: ClassVar[tuple[str, ...]] = ("J", "Tc", "B")
    states: ClassVar[tuple[str, ...]] = ("omega",)
    inputs: ClassVar[tuple[str, ...]] = ("T",)

    def vector_field(self, c, u, y):
        (w,) = y
        return ((u[0] - c["Tc"] * w / jnp.sqrt(w * w + WIDTH**2) - c["B"] * w) / c["J"],)


class FrictionWidth(Friction):
    """The same with the smoothing width a parameter: not linear after any one factor."""

    names: ClassVar[tuple[str, ...]] = ("J", "Tc", "B", "ws")

    def vector_field(self, c, u, y):
        (w,) = y
        return ((u[0] - c["Tc"] * w / jnp.sqrt(w * w + c["ws"] ** 2) - c["B"] * w) / c["J"],)


class FirstOrderMap(dcjax.DiscreteModel):
    """y_next = y + dt (b u - a y): its rate is linear in (a, b) without a factor."""

    names: ClassVar[tuple[str, ...]] = ("a", "b")
    states: ClassVar[tuple[str, ...]] = ("y",)
    inputs: ClassVar[tuple[str, ...]] = ("u",)

    def update(self, c, u, y, dt):
        return (y[0] + dt * (c["b"] * u[0] - c["a"] * y[0]),)


def friction_field(p, u, y):
    w = y[0]
    return np.array([(u[0] - p["Tc"] * w / np.sqrt(w * w + WIDTH**2) - p["B"] * w) / p["J"]])


@pytest.fixture(scope="module")
def bench():
    """Torque steps on the bench, 4 s at 1 kHz, from the NumPy reference (0.2 % noise)."""
    rng = np.random.default_rng(3)
    t = 1e-3 * np.arange(4001)
    T = rng.uniform(-0.4, 0.4, size=8)[np.minimum((t / 0.5).astype(int), 7)]
    w = reference.simulate(friction_field, TRUTH, t, T[:, None], [0.0], substeps=4)[:, 0]
    w = w + 0.002 * np.std(w) * rng.standard_normal(len(t))
    return dcjax.Recording(t=t, channels={"T": T, "omega": w}, name="bench")


def test_found_form_is_the_papers_hand_written_regression():
    """On SD1 the blocks found for the motor without its regression() are eq. 8 times La and
    eq. 9 times J, column for column, and the first estimate is the same to 1e-9."""
    rec = datasets.load("SD1")
    m, plain = dcjax.DC(), PlainDC()
    y, dy = filtered_states(rec, m)
    u = {"u_a": np.asarray(rec["u_a"])}
    assert linear_masses(plain, y, u, 1e-4, m.parameters()) == [1 + m.names.index("La"), 1 + m.names.index("J")]
    found = linear_regression(plain, y, dy, u, 1e-4, m.parameters())
    written = m.regression(y, dy, u)
    assert found is not None and len(found) == len(written) == 2
    for (fc, fr, fm), (wc, wr, wm) in zip(found, written):
        assert fm == wm
        scale = np.max(np.abs(wr)) if np.any(wr) else 1.0
        assert np.allclose(fr, wr, rtol=0, atol=1e-9 * scale)
        for name in set(fc) | set(wc):
            a, b = np.broadcast_to(fc.get(name, 0.0), fr.shape), np.broadcast_to(wc.get(name, 0.0), fr.shape)
            assert np.allclose(a, b, rtol=1e-9, atol=1e-12 * np.max(np.abs(b))), name
    a, b = initial_estimate(rec, m), initial_estimate(rec, plain)
    for n in m.names:
        assert a[n].value == pytest.approx(b[n].value, rel=1e-9), n


def test_a_user_model_without_regression_is_estimated_by_the_found_form(bench):
    """The bench's friction model: J is each equation's factor; the first estimate within 1 % of
    the truth and in well under the LM fallback's time."""
    m = Friction()
    y, dy = filtered_states(bench, m)
    assert linear_masses(m, y, {"T": np.asarray(bench["T"])}, 1e-3, m.parameters()) == [1]
    initial_estimate(bench, m)  # compiles the scoring
    t0 = time.perf_counter()
    est = initial_estimate(bench, m)
    seconds = time.perf_counter() - t0
    for n, v in TRUTH.items():
        assert est[n].value == pytest.approx(v, rel=0.01), n
    assert seconds < 2.0


def test_a_model_not_linear_after_any_factor_falls_back_to_lm(bench):
    m = FrictionWidth()
    y, _ = filtered_states(bench, m)
    assert linear_masses(m, y, {"T": np.asarray(bench["T"])}, 1e-3, m.parameters()) is None


def test_a_discrete_map_linear_without_a_factor():
    """y_next = y + dt (b u - a y) on data of its own NumPy twin: no factor (0), a and b to 1 %."""
    t = 1e-2 * np.arange(2001)
    u = np.sign(np.sin(2 * np.pi * 0.4 * t))
    y = reference.iterate(lambda p, u, y, h: y + h * (p["b"] * u - p["a"] * y), {"a": 3.0, "b": 6.0}, t, u[:, None], [0.0])[:, 0]
    rec = dcjax.Recording(t=t, channels={"u": u, "y": y})
    m = FirstOrderMap()
    ys, _ = filtered_states(rec, m)
    assert linear_masses(m, ys, {"u": u}, 1e-2, m.parameters()) == [0]
    est = initial_estimate(rec, m)
    assert est["a"].value == pytest.approx(3.0, rel=0.05) and est["b"].value == pytest.approx(6.0, rel=0.05)
