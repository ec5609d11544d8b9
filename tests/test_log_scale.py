"""Positive and log-scale parameters (`Parameter(positive=True)`, `scale="log"`, `Model.positive`,
`dcjax fit --log`): automatic ranges keep the sign, and a search uniform in decades finds a
parameter that a linear search of the same budget does not, on data from the analytic solution."""

import numpy as np
import pytest

import dcjax
from dcjax.analysis.estimate import auto_bounds
from dcjax.models.bounds import Bounds
from dcjax.models.space import vector_space


class Leak(dcjax.Model):
    """dy/dt = u - k y: from rest under u = 1, y(t) = (1 - exp(-k t)) / k."""

    names = ("k",)
    states = ("y",)
    inputs = ("u",)

    def vector_field(self, c, u, y):
        return (u[0] - c["k"] * y[0],)


class Lag(dcjax.Model):
    """tau dy/dt = gain u - y, with its equation-error regression (tau dy + y = gain u)."""

    names = ("tau", "gain")
    states = ("y",)
    inputs = ("u",)

    def vector_field(self, c, u, y):
        return ((c["gain"] * u[0] - y[0]) / c["tau"],)

    def regression(self, y, dy, u):
        return [({"tau": dy["y"], "gain": -u["u"]}, -y["y"], "tau")]


class PositiveLag(Lag):
    positive = ("tau", "gain")


def test_a_log_scale_search_finds_a_parameter_six_decades_below_its_range_top():
    k = 2e-4
    t = np.linspace(0.0, 5000.0, 101)
    rec = dcjax.Recording(t=t, u=np.ones_like(t), y=(1 - np.exp(-k * t)) / k)  # the analytic solution
    errors = {}
    for scale in ("linear", "log"):
        params = dcjax.Parameters([dcjax.Parameter("k", min=1e-6, max=1.0, scale=scale)])
        res = dcjax.fit(rec, Leak(), params, dcjax.Search(runs=1, budget=600, seed=0))
        errors[scale] = abs(res.best_values["k"] - k) / k
        assert res.settings.get("log") == (["k"] if scale == "log" else None)
    assert errors["log"] < 1e-2 and errors["linear"] > 100 * errors["log"], errors  # measured: 2.4e-3 vs 7.2 (719 %)


def test_the_space_maps_log_parameters_in_decades_and_back():
    space = vector_space(("a", "b"), Bounds([1e-6, -1.0], [1.0, 1.0], ("a", "b")), log=("a",))
    z = np.array([[0.0, 0.0], [0.5, 0.5], [1.0, 1.0]])
    x = np.asarray(space.to_physical(z))
    np.testing.assert_allclose(x, [[1e-6, -1.0], [1e-3, 0.0], [1.0, 1.0]], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(np.asarray(space.to_unit(x)), z, atol=1e-12)
    with pytest.raises(ValueError, match=r"scale log: a \(min 0\) needs a lower bound > 0"):
        vector_space(("a",), Bounds([0.0], [1.0], ("a",)), log=("a",))


def test_positive_parameters_keep_their_sign_in_automatic_ranges():
    t = np.arange(400) * 1e-3
    u = np.where(t > 0.05, 2.0, 0.0)
    y = np.zeros_like(t)
    for j in range(1, t.size):  # a coarse Euler simulation with a little noise: the estimate is rough
        y[j] = y[j - 1] + 1e-3 * (3.0 * u[j - 1] - y[j - 1]) / 0.02
    y = y + 0.02 * np.random.default_rng(1).normal(size=t.size)
    rec = dcjax.Recording(t=t, u=u, y=y)
    signed, _, _ = auto_bounds(rec, Lag())
    positive, _, _ = auto_bounds(rec, PositiveLag())
    assert np.any(np.asarray(signed.lower) < 0)  # without the flag a range may cross zero
    assert np.all(np.asarray(positive.lower) >= 0) and np.all(np.asarray(positive.upper) > 0)
    assert PositiveLag().parameters()["tau"].positive and not Lag().parameters()["tau"].positive


def test_positive_and_scale_are_checked_in_one_line():
    assert dcjax.Parameter("a", positive=True).min == 0.0  # a positive range starts at 0 unless given
    assert dcjax.Parameter("a", min=1e-3, max=1, scale="log").positive
    with pytest.raises(ValueError, match=r"^a is positive: its min must be >= 0, got -1$"):
        dcjax.Parameter("a", min=-1.0, positive=True)
    with pytest.raises(ValueError, match=r"^a.scale must be 'linear' or 'log', got 'ln'$"):
        dcjax.Parameter("a", scale="ln")
    with pytest.raises(ValueError, match="is positive: its min must be >= 0"):
        dcjax.Parameter("a", min=0.0, positive=True).set(min=-2.0)
