"""`dcjax.Diffrax`: an adaptive diffrax solver as an integrator, against the independent NumPy
RK4 (`tests/reference.py`, 64 sub-steps), in a vmapped population, a fit and the CLI's
`--integrator diffrax`."""

import numpy as np
import pytest
import reference as ref

import dcjax
from dcjax import cli, datasets


def test_a_short_simulation_equals_the_numpy_reference():
    """The fast set's check: 40 samples of SD1, one member, against the NumPy RK4 to 1e-8."""
    rec, truth = datasets.load("SD1"), datasets.true_params("SD1")
    t, u = rec.t[:40], np.asarray(rec["u_a"])[:40, None]
    want = ref.simulate(ref.dc_field, truth, t, u, [0.0, 0.0], substeps=64)
    short = dcjax.Recording(t=t, u_a=u[:, 0], i_a=want[:, 0], omega=want[:, 1])
    sim = np.asarray(
        dcjax.simulate(truth, dcjax.make_problem(short, dcjax.Diffrax(rtol=1e-10, atol=1e-12), initial={"i_a": 0.0, "omega": 0.0}))
    )
    assert np.max(np.abs(sim - want) / np.max(np.abs(want), axis=0)) < 1e-8
    with pytest.raises(ValueError, match="rtol and atol must be positive"):
        dcjax.Diffrax(rtol=0.0)


@pytest.mark.slow
def test_simulation_equals_the_numpy_reference_and_fails_to_inf():
    rec = datasets.load("SD1")
    truth = datasets.true_params("SD1")
    t, u = rec.t[:100], np.asarray(rec["u_a"])[:100, None]
    want = ref.simulate(ref.dc_field, truth, t, u, [0.0, 0.0], substeps=64)
    short = dcjax.Recording(t=t, u_a=u[:, 0], i_a=want[:, 0], omega=want[:, 1])
    prob = dcjax.make_problem(short, dcjax.Diffrax(rtol=1e-10, atol=1e-12), initial={"i_a": 0.0, "omega": 0.0})
    sim = np.asarray(dcjax.simulate(truth, prob))
    assert np.max(np.abs(sim - want) / np.max(np.abs(want), axis=0)) < 1e-8
    # a population: a member whose solve fails gets +inf and changes no other member's OF
    lo, hi = dcjax.DC().bound_arrays("table4")
    X = lo + (hi - lo) * np.random.default_rng(0).uniform(size=(6, 7))
    X[5, 1] = 1e-30  # La ~ 0: the current's time constant vanishes, the step count runs out
    of = np.asarray(dcjax.objective(X, prob))
    without = np.asarray(dcjax.objective(np.vstack([X[:5], X[:1]]), prob))  # the same shape: no new compilation
    assert np.array_equal(of[:5], without[:5]) and np.all(np.isfinite(without)) and of[5] == np.inf


@pytest.mark.slow
def test_a_fit_through_the_cli(tmp_path):
    assert cli.main(["fit", "SD1", "--integrator", "diffrax", "--bounds", "table4", "--runs", "1", "--budget", "14000",
                     "--plots", "none", "--out", str(tmp_path)]) == 0  # fmt: skip
    res = dcjax.load_result(tmp_path / "result.json")
    truth = datasets.true_params("SD1")
    assert res.settings["integrator"] == "diffrax"
    assert all(abs(res.best_values[n] / truth[n] - 1) < 0.01 for n in ("Ra", "La", "cm", "J")), res.best_values
