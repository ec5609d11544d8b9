"""An exact null direction named as combinations (issue: honest uncertainty). SD1 with only the
speed measured: Ra/s, La/s, J s, Tla s, Tlb s, Tlc s give the same speed for every s (the current,
unmeasured, becomes s i). Noise-free data from the independent NumPy RK4 (`tests/reference.py`)."""

import numpy as np
import pytest
import reference as ref

import dcjax
from dcjax import datasets

SCALED = ("Ra", "La", "J", "Tla", "Tlb", "Tlc")


@pytest.fixture(scope="module")
def speed_only():
    sd1, truth = datasets.load("SD1"), datasets.true_params("SD1")
    y = ref.simulate(ref.dc_field, truth, sd1.t, np.asarray(sd1["u_a"])[:, None], [0.0, 0.0], substeps=64)
    rec = dcjax.Recording(t=sd1.t, u_a=sd1["u_a"], i_a=y[:, 0], omega=y[:, 1], name="SD1-speed")
    return rec, truth


@pytest.mark.slow
def test_no_interval_inside_the_symmetry_and_the_combinations_match_the_truth(speed_only):
    rec, truth = speed_only
    res = dcjax.fit(rec, params="table4", integrator=dcjax.RK4(substeps=8), observation=dcjax.Observation(measure=("omega",)), search=dcjax.Search(runs=2, budget=40_000, polish=True))  # fmt: skip
    u = res.uncertainty().uncertainties
    assert set(u.null_names) == set(SCALED)
    for n in SCALED:
        assert np.isnan(u.se[n]) and u.verdict[n].startswith("not identifiable"), (n, u.reason[n])
        assert not np.all(np.isfinite(u.ci95[n]))
    assert np.isfinite(u.se["cm"]) and u.verdict["cm"] == "well determined"
    want = {"La/Ra": truth["La"] / truth["Ra"], **{f"{n}*Ra": truth[n] * truth["Ra"] for n in ("J", "Tla", "Tlb", "Tlc")}}
    assert set(u.combinations) == set(want)
    for k, v in want.items():
        assert u.combinations[k][0] == pytest.approx(v, rel=1e-6), (k, u.combinations[k], v)
        assert np.isfinite(u.combinations[k][1])
    text = u.table()
    assert "not determined, each alone" in text and "La/Ra = " in text
    assert "J*Ra = " in res.uncertainty().report()


def test_a_parameter_at_zero_with_a_small_absolute_error_is_determined():
    """Tla = 0 in truth, inside a range of +-1 Nm (not at a bound), 0.05 % noise: its relative error
    is infinite, its absolute one under a thousandth of its range -> well determined (near 0)."""
    sd1 = datasets.load("SD1")
    truth = {**datasets.true_params("SD1"), "Tla": 0.0}
    y = ref.simulate(ref.dc_field, truth, sd1.t, np.asarray(sd1["u_a"])[:, None], [0.0, 0.0], substeps=16)
    y = y + 0.0005 * np.abs(y).max(axis=0) * np.random.default_rng(0).standard_normal(y.shape)
    rec = dcjax.Recording(t=sd1.t, u_a=sd1["u_a"], i_a=y[:, 0], omega=y[:, 1], name="SD1-Tlc0")
    lo, hi = dcjax.DC().bound_arrays("table4")
    lo, hi = lo.copy(), hi.copy()
    lo[4], hi[4] = -1.0, 1.0
    names = dcjax.DC().names
    x = np.array([truth[n] for n in names])
    from dcjax.analysis.uncertainty import uncertainty

    u = uncertainty(x, dcjax.make_problem(rec, dcjax.RK4(substeps=4)), dcjax.Bounds(lo, hi, names))
    assert u.se["Tla"] <= 1e-3 * 2.0 and abs(x[4]) < u.se["Tla"]
    assert u.verdict["Tla"] == "well determined" and u.reason["Tla"].startswith("near 0"), u.reason["Tla"]
    assert u.verdict["Tlc"] == "weakly determined"  # 8.55e-8 +- 1.3e-8: not near 0, judged relatively as before
