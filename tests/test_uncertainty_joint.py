"""Uncertainty/identifiability, joint fits over recordings and automatic ND (issue 6)."""

import numpy as np
import pytest

import dcjax
from dcjax import Recording, datasets, make_problem
from dcjax.analysis.uncertainty import NOT, WELL, profile, uncertainty
from dcjax.fitting.polish import polish_jit
from dcjax.io.numpy_simulator import simulate_numpy

NAMES = dcjax.DC.names
BOX4 = dcjax.Bounds(dcjax.DC().parameters("table4").lower, dcjax.DC().parameters("table4").upper, NAMES)
TRUE = datasets.true_params("SD1")
X_TRUE = np.array([TRUE[n] for n in NAMES])


def _noisy_sd1(seed, sigma_i=0.01, sigma_w=1.0, n=None):
    rec = datasets.load("SD1")
    rng = np.random.default_rng(seed)
    m = len(rec) if n is None else n
    i = rec.i_a[:m] + sigma_i * rng.standard_normal(m) * (np.arange(m) > 0)
    w = rec.omega[:m] + sigma_w * rng.standard_normal(m) * (np.arange(m) > 0)
    return Recording(t=rec.t[:m], u_a=rec.u_a[:m], i_a=i, omega=w, name=f"noisy{seed}")


@pytest.mark.slow
def test_intervals_cover_truth_at_about_the_stated_rate():
    """Noiseless SD1 + Gaussian noise, fitted by LM from the truth: the 95 % intervals of the
    well-determined parameters cover the true values in about 95 % of 40 seeds. The noise std on
    i and w is chosen so their normalized residuals have the same variance (the OF's assumption)."""
    rec0 = datasets.load("SD1")
    scale_i, scale_w = np.max(np.abs(rec0.i_a)), np.max(np.abs(rec0.omega))
    hits, total = 0, 0
    for seed in range(40):
        rec = _noisy_sd1(seed, sigma_i=0.004 * scale_i, sigma_w=0.004 * scale_w)
        prob = make_problem(rec)
        fit = polish_jit(X_TRUE, prob, BOX4)
        u = uncertainty(np.asarray(fit.x), prob, BOX4)
        for k, n in enumerate(NAMES):
            if u.verdict[n] == WELL:
                lo, hi = u.ci95[n]
                hits += lo <= X_TRUE[k] <= hi
                total += 1
    rate = hits / total
    assert total >= 40 * 4, total
    assert 0.85 <= rate <= 1.0, rate


def test_verdicts_on_constructed_non_identifiable_case():
    """The first 3 ms of SD1 (30 samples) with 0.4 % noise: the load torque has no visible effect
    yet, so Tla, Tlb, Tlc cannot be identified; the electrical Ra, La can."""
    rec0 = datasets.load("SD1")
    rec = _noisy_sd1(0, sigma_i=0.004 * np.max(rec0.i_a), sigma_w=0.004 * np.max(rec0.omega), n=30)
    u = uncertainty(X_TRUE, make_problem(rec), BOX4)
    for n in ("Tla", "Tlb", "Tlc"):
        assert u.verdict[n] == NOT, (n, u.reason[n])
    for n in ("Ra", "La"):
        assert u.verdict[n] == WELL, (n, u.reason[n])
    # A parameter on its bound is flagged.
    x = X_TRUE.copy()
    x[6] = 0.0
    assert uncertainty(x, make_problem(datasets.load("SD1")), BOX4).reason["Tlc"] == "at a bound"


@pytest.mark.slow
def test_profile_likelihood_minimum_at_fit():
    rec = _noisy_sd1(3, sigma_i=0.005, sigma_w=0.5)
    prob = make_problem(rec)
    fit = np.asarray(polish_jit(X_TRUE, prob, BOX4).x)
    grid = fit[0] * np.array([0.98, 0.99, 1.0, 1.01, 1.02])
    ofs = profile(fit, "Ra", grid, prob, BOX4)
    assert np.argmin(ofs) == 2 and ofs[0] > ofs[2] and ofs[-1] > ofs[2]
    with pytest.raises(ValueError, match="unknown parameter"):
        profile(fit, "Rb", grid, prob, BOX4)


@pytest.mark.slow
def test_result_uncertainty_method(sd1):
    r = dcjax.fit(sd1, params="table4", search=dcjax.Search(runs=2, budget=7000, seed=0, polish=True))
    r2 = r.uncertainty(profile="Ra", profile_points=3)
    u = r2.uncertainties
    assert r.uncertainties is None and r2.params["Ra"].stderr == u.se["Ra"] and r.params["Ra"].stderr is None
    assert set(u.verdict) == set(NAMES) and u.correlation.shape == (7, 7)
    assert len(u.profile[0]) == 3 and "verdict" in u.table()


def _voltage_recording(u_volts, name):
    t = np.arange(301) * 1e-4
    u = np.full_like(t, u_volts)
    traj = simulate_numpy(X_TRUE, t, u)
    return Recording(t=t, u_a=u, i_a=traj[:, 0], omega=traj[:, 1], name=name)


@pytest.mark.slow
def test_joint_fit_recovers_shared_parameters():
    recs = [_voltage_recording(v, f"U{v}") for v in (220.0, 150.0, 90.0)]
    r = dcjax.fit(recs, params="table4", search=dcjax.Search(runs=2, seed=0))
    assert r.of <= 1e-15
    for k, n in enumerate(NAMES):
        assert abs(r.params[n] - X_TRUE[k]) <= 1e-6 * X_TRUE[k], n
    assert r.settings["recording"] == ["U220.0", "U150.0", "U90.0"]
    # Weighted: all weight on one recording equals fitting it alone (same seed).
    weighted = [dcjax.with_weights(r, joint_weight=w) for r, w in zip(recs, (1.0, 0.0, 0.0))]
    only = dcjax.fit(weighted, params="table4", search=dcjax.Search(runs=1, budget=1400, seed=0))
    alone = dcjax.fit(recs[0], params="table4", search=dcjax.Search(runs=1, budget=1400, seed=0))
    np.testing.assert_allclose(only.run_of, alone.run_of, rtol=1e-12)
    with pytest.raises(ValueError, match="joint weights must be non-negative"):
        dcjax.fit([dcjax.with_weights(r, joint_weight=-1.0) for r in recs], params="table4", search=dcjax.Search(runs=1, budget=70))


@pytest.mark.slow
def test_nd_auto_picks_the_first_nd_within_tolerance_of_a_diffrax_reference():
    """RK4 on SD1: at the ND = 1 fit the simulation error against the adaptive reference falls by
    ~16 per doubling (4th order); with tol 1e-9 the first ND below it is chosen and refitted."""
    rec = datasets.load("SD1")
    r = dcjax.fit(
        rec,
        params="table4",
        integrator=dcjax.AutoSubsteps(dcjax.RK4(), tol=1e-9, max_substeps=16),
        search=dcjax.Search(runs=2, budget=70_000, seed=0),
    )
    auto = r.settings["nd_auto"]
    errs = [auto["errors_at_nd1_fit"][str(k)] for k in (1, 2, 4, 8, 16)]
    assert all(10 < a / b < 25 for a, b in zip(errs[:3], errs[1:4])), errs
    chosen = next(k for k, e in zip((1, 2, 4, 8, 16), errs) if e <= 1e-9)
    assert auto["chosen"] == chosen == r.settings["nd"] and auto["converged"] and auto["reference_error"] <= 1e-9
    loose = dcjax.fit(
        rec, params="table4", integrator=dcjax.AutoSubsteps(dcjax.RK4(), tol=1e-3), search=dcjax.Search(runs=1, budget=7_000, seed=0)
    )
    assert loose.settings["nd_auto"]["chosen"] == 1


def test_consistency_flags_disagreeing_fits():
    from dcjax.analysis.uncertainty import CONSISTENT, INCONSISTENT, Uncertainty, consistency

    def fake(la, se_la):
        params = dict(TRUE, La=la)
        se = {n: 1e-3 * abs(v) + 1e-12 for n, v in params.items()}
        se["La"] = se_la
        verdict = {n: WELL for n in NAMES}
        verdict["Tlc"] = NOT
        return Uncertainty(params, se, {}, np.eye(7), verdict, {}, np.ones(7), 10, 1.0)

    c = consistency({"a": fake(0.25, 0.01), "b": fake(0.15, 0.01), "c": fake(0.23, 0.01)})
    assert c["La"]["verdict"] == INCONSISTENT and c["La"]["max_z"] > 3
    assert c["Ra"]["verdict"] == CONSISTENT
    assert c["Tlc"]["verdict"].startswith("not identifiable")
    c2 = consistency({"a": fake(0.25, 0.1), "b": fake(0.15, 0.1)})
    assert c2["La"]["verdict"] == CONSISTENT
