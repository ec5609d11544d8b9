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
    res = dcjax.fit(rec, params="table4", integrator=dcjax.RK4(substeps=8), observation=dcjax.Observation(measure=("omega",)),
                    runs=2, budget=40_000, polish=True)  # fmt: skip
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
