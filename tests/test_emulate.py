"""The laboratory-drive emulator, the MD analogues and the fit checks of Sections 4.2.6–4.2.7."""

import dataclasses
import math
import runpy
import sys
from pathlib import Path

import numpy as np
import pytest

from dcjax import RK4, Recording, load_csv, make_problem, objective, simulate
from dcjax.analysis.validation import cross_validation, stationary_check, stationary_instants
from dcjax.io.emulate import MOTOR, DriveSettings, Effects, emulate, emulate_trace, md_settings

ROOT = Path(__file__).resolve().parent.parent
MDS = ("MD1", "MD2", "MD3", "MD4")


def test_effects_off_matches_core_rk4():
    """With every effect off, the emulator's plant is the core ODE: its fine trace (voltage at the
    control instants, linear in between) simulated by the core RK4 with ND = 10 (= the emulator's
    1e-4 s sub-steps) agrees to rounding."""
    s = dataclasses.replace(md_settings("MD3"), effects=Effects(), n_samples=20)
    t, u, i, w = emulate_trace(s)
    rec = Recording(t=t, u_a=u, i_a=np.where(i == 0, 1e-300, i), omega=np.where(w == 0, 1e-300, w))
    out = np.asarray(simulate(dict(s.params), make_problem(rec, RK4(substeps=s.substeps), initial={"i_a": 0.0, "omega": 0.0})))
    np.testing.assert_allclose(out[:, 0], i, rtol=1e-9, atol=1e-9 * np.max(np.abs(i)))
    np.testing.assert_allclose(out[:, 1], w, rtol=1e-9, atol=1e-9 * np.max(np.abs(w)))
    # Coarser core steps (ND = 1 on the 1 ms grid) are still close: the same ODE.
    coarse = np.asarray(simulate(dict(s.params), make_problem(rec, RK4(), initial={"i_a": 0.0, "omega": 0.0})))
    assert np.max(np.abs(coarse[:, 1] - w)) < 1e-3 * np.max(w)


@pytest.mark.parametrize("name", MDS)
def test_current_limit_overshoot(name):
    """The controller keeps the true current within 2.5 % above the limit (the start-up
    transient while the voltage is saturated), and it reaches the limit at start-up."""
    s = md_settings(name)
    _, _, i, _ = emulate_trace(s)
    assert np.max(np.abs(i)) <= 1.025 * s.i_limit
    if s.t_speed_up == 0:
        assert np.max(i) > 0.97 * s.i_limit


def test_md_sets_follow_table_7():
    expect = {"MD1": (126, 11.44, 87), "MD2": (182, 11.44, 81), "MD3": (182, 14.56, 65), "MD4": (182, 14.56, 106)}
    for name, (wf, lim, n) in expect.items():
        rec = load_csv(ROOT / "data" / f"{name}.csv")
        assert len(rec) == n and rec.limit == lim and rec.metadata["n_points"] == n
        assert abs(rec.omega[-1] - wf) < 0.03 * wf
        assert "NOT the paper" in rec.metadata["source"]
        assert np.allclose(np.diff(rec.t), 0.132)
    assert load_csv(ROOT / "data" / "MD4.csv").metadata["true_params"]["Tlb"] > 0.07


def test_md_files_are_regenerated_byte_identically(monkeypatch, capsys):
    """`python data/generate_md.py --check`, its `__main__` run in this process (no second JAX start)."""
    monkeypatch.setattr(sys, "argv", ["generate_md.py", "--check"])
    with pytest.raises(SystemExit) as end:
        runpy.run_path(str(ROOT / "data" / "generate_md.py"), run_name="__main__")
    out = capsys.readouterr().out  # "identical", or the files that differ
    assert end.value.code == 0 and "identical" in out, out


def test_effects_act():
    base = dataclasses.replace(md_settings("MD1"), effects=Effects(), n_samples=10)
    _, _, _, w0 = emulate_trace(base)
    # Static friction: with the voltage limited so that cm*i stays below Tla, the shaft never turns.
    stuck = dataclasses.replace(base, u_max=0.5 * MOTOR["Ra"] * MOTOR["Tla"] / MOTOR["cm"], effects=Effects(static_friction=True))
    assert np.all(emulate_trace(stuck)[3] == 0.0)
    free = dataclasses.replace(stuck, effects=Effects())
    assert np.min(emulate_trace(free)[3]) < 0.0  # the plain model turns backwards
    # Armature reaction changes the response.
    ar = dataclasses.replace(base, effects=Effects(armature_reaction=0.05))
    assert np.max(np.abs(emulate_trace(ar)[3] - w0)) > 0.1
    # Quantization: speeds are multiples of 2 pi / (ppr * window).
    q = dataclasses.replace(base, effects=Effects(encoder_ppr=1024, speed_window=0.01))
    w = emulate(q).omega
    step = 2 * math.pi / (1024 * 0.01)
    np.testing.assert_allclose(w / step, np.round(w / step), atol=1e-9)
    # Noise: reproducible with the seed, different with another.
    noisy = dataclasses.replace(base, effects=Effects(noise_i=1.0))
    a, b = emulate(noisy).i_a, emulate(noisy).i_a
    c = emulate(dataclasses.replace(noisy, seed=9)).i_a
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_bad_settings():
    with pytest.raises(ValueError, match="missing"):
        DriveSettings(params={"Ra": 1.0})
    with pytest.raises(ValueError, match="positive"):
        DriveSettings(params=dict(MOTOR, J=0.0))
    with pytest.raises(ValueError, match="control periods"):
        DriveSettings(params=MOTOR, dt_sample=0.1325)
    with pytest.raises(ValueError, match="unknown MD"):
        md_settings("MD7")


def test_md_best_of_is_not_zero():
    """Noise and unmodelled effects: even the true parameters leave OF of order 1e-4..1e-3."""
    for name in MDS:
        rec = load_csv(ROOT / "data" / f"{name}.csv")
        of = float(objective(dict(rec.metadata["true_params"]), make_problem(rec, RK4(substeps=10))))
        assert 1e-5 < of < 1e-1, (name, of)


def test_stationary_check_and_cross_validation():
    recs = {n: load_csv(ROOT / "data" / f"{n}.csv") for n in ("MD1", "MD2", "MD3")}
    truth = recs["MD1"].metadata["true_params"]
    idx = stationary_instants(recs["MD1"], 5)
    assert np.all(np.abs(recs["MD1"].omega[idx] - 126.0) < 0.02 * 126.0)  # at final speed
    assert idx.size == 5 and np.all(np.diff(idx) > 0)
    rows = stationary_check(truth, recs["MD1"], times=[2, 4, 6, 8, 10])
    assert [round(r["t"]) for r in rows] == [2, 4, 6, 8, 10]
    assert all(r["u_dev_pct"] < 5 for r in rows)  # true parameters: only noise and effects differ
    np.testing.assert_allclose(rows[0]["u_calc"], rows[0]["i_meas"] * truth["Ra"] + truth["cm"] * rows[0]["w_meas"])
    wrong = dict(truth, Ra=3 * truth["Ra"], cm=0.8 * truth["cm"])
    assert np.mean([r["u_dev_pct"] for r in stationary_check(wrong, recs["MD1"], times=[2, 4, 6])]) > 10
    fits = {"MD1": truth, "MD2": dict(truth, Ra=1.3 * truth["Ra"])}
    rn, fn, m = cross_validation(fits, recs)
    assert m.shape == (3, 2) and rn == ["MD1", "MD2", "MD3"] and np.all(np.isfinite(m))
    assert m[0, 0] < m[0, 1]  # on MD1, the true parameters beat a wrong Ra
