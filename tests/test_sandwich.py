"""The standard errors of an l1 or huber fit are its estimator's sandwich (`dcjax.analysis.sandwich`),
checked against the asymptotic variances of a location estimate under noise drawn here by NumPy:
the median's b^2 / n under Laplace noise of scale b and (pi / 2) sigma^2 / n under Gaussian noise,
Huber's E[psi^2] / P(|a| <= delta)^2 / n (Huber 1964), not the squared error's sigma^2 / n."""

from typing import ClassVar

import numpy as np
import pytest
from scipy import integrate, stats

import dcjax

N = 4001


class Level(dcjax.DiscreteModel):
    """y_next = c: every sample after the first measures the constant c."""

    names: ClassVar[tuple[str, ...]] = ("c",)
    states: ClassVar[tuple[str, ...]] = ("y",)
    inputs: ClassVar[tuple[str, ...]] = ("u",)

    def update(self, c, u, y, dt):
        return (c["c"] + 0.0 * u[0],)


def _se(noise: np.ndarray, loss) -> float:
    t = 1e-3 * np.arange(N)
    rec = dcjax.Recording(t=t, channels={"u": np.zeros(N), "y": 1.0 + noise}, name="level")
    params = dcjax.Parameters([dcjax.Parameter("c", min=0.5, max=1.5)])
    obs = dcjax.Observation(loss=loss, initial={"y": "measured"})
    res = dcjax.fit(rec, Level(), params, search=dcjax.Search("de-rand-1-exp", runs=1, budget=1400, seed=0), observation=obs)
    return res.uncertainty().uncertainties.se["c"]


@pytest.mark.parametrize("noise", ["laplace", "gauss"])
def test_l1_standard_error_is_the_medians_asymptotic_one(noise):
    rng = np.random.default_rng(5)
    scale = 0.01
    e = rng.laplace(0.0, scale, N) if noise == "laplace" else rng.normal(0.0, scale, N)
    want = (scale if noise == "laplace" else np.sqrt(np.pi / 2) * scale) / np.sqrt(N - 1)
    got = _se(e, dcjax.L1(normalize="none"))
    assert got == pytest.approx(want, rel=0.12), (got, want)
    least_squares = np.std(e) / np.sqrt(N - 1)  # what the squared error's linearisation gave: 41 % / 25 % off
    assert abs(least_squares / want - 1) > 0.2


def test_huber_standard_error_is_hubers_asymptotic_one():
    sigma, delta = 0.01, 0.01
    e = np.random.default_rng(6).normal(0.0, sigma, N)
    psi2 = integrate.quad(lambda a: min(a * a, delta * delta) * stats.norm.pdf(a, scale=sigma), -np.inf, np.inf)[0]
    inside = 2 * stats.norm.cdf(delta / sigma) - 1
    want = np.sqrt(psi2 / inside**2 / (N - 1))
    assert _se(e, dcjax.Huber(delta=delta, normalize="none")) == pytest.approx(want, rel=0.06)
