"""Real-recording features: scale factors, files without time, models in files, the
equation-error first estimate, automatic bounds, many files at once (issue: real recordings of an
unknown motor)."""

import csv
import json

import numpy as np
import pytest

import dcjax
from dcjax import FailedFit, cli, datasets, fit_each
from dcjax.analysis.estimate import auto_bounds, initial_estimate
from dcjax.fitting.summary import robust_outliers, summary_rows
from dcjax.models import get_model, model_spec

SPEED_SCALE = 9.68 / 0.03  # 322.67: wheel speed in m/s behind a 9.68:1 gear on a 30 mm wheel


def _write(path, cols: dict):
    names = list(cols)
    np.savetxt(path, np.column_stack([cols[n] for n in names]), delimiter=",", header=",".join(names), comments="", fmt="%.17g")


def test_scale_and_sample_time_load_the_same_recording(tmp_path, sd1):
    _write(tmp_path / "scaled.csv", {"t": sd1.t, "u_a": sd1.u_a, "i_a": sd1.i_a, "omega": sd1.omega / SPEED_SCALE})
    rec = dcjax.load_recording(tmp_path / "scaled.csv", scale={"omega": SPEED_SCALE})
    np.testing.assert_allclose(rec.omega, sd1.omega, rtol=1e-14)
    assert rec.metadata["source"]["load"]["scale"] == {"omega": SPEED_SCALE}
    np.savez(tmp_path / "no_t.npz", u_a=sd1.u_a, i_a=sd1.i_a, omega=sd1.omega)
    for kw in ({"dt": 1e-4}, {"rate": 1e4}):
        rec = dcjax.load_recording(tmp_path / "no_t.npz", **kw)
        np.testing.assert_allclose(rec.t, sd1.t, rtol=1e-12, atol=1e-18)
    frame = dcjax.Recording.from_dataframe({"U": sd1.u_a, "I": sd1.i_a, "n": sd1.omega * 60 / (2 * np.pi)}, columns={"u_a": "U", "i_a": "I", "omega": "n"},
                                           units={"omega": "rpm"}, scale={"i_a": 2.0}, dt=1e-4)  # fmt: skip
    np.testing.assert_allclose(frame.i_a, 2 * sd1.i_a)
    np.testing.assert_allclose(frame.omega, sd1.omega, rtol=1e-12)


@pytest.mark.parametrize(
    "kw, match",
    [
        ({}, "give the sample time with dt"),
        ({"dt": 1e-4, "rate": 1e4}, "either dt"),
        ({"dt": -1.0}, "dt must be a positive number"),
        ({"dt": 1e-4, "scale": {"omega": 0}}, "scale of omega must be a finite non-zero"),
        ({"dt": 1e-4, "scale": {"speed": 2}}, "unknown channel 'speed'"),
    ],
)
def test_scale_and_time_errors_are_clear(tmp_path, sd1, kw, match):
    np.savez(tmp_path / "no_t.npz", u_a=sd1.u_a, i_a=sd1.i_a, omega=sd1.omega)
    with pytest.raises(ValueError, match=match):
        dcjax.load_recording(tmp_path / "no_t.npz", **kw)


@pytest.mark.slow
def test_cli_scale_and_dt_fit_like_sd1(tmp_path, sd1, capsys):
    _write(tmp_path / "scaled.csv", {"t": sd1.t, "u_a": sd1.u_a, "i_a": sd1.i_a, "omega": sd1.omega / SPEED_SCALE})
    np.savez(tmp_path / "no_t.npz", u_a=sd1.u_a, i_a=sd1.i_a, omega=sd1.omega)
    truth = datasets.true_params("SD1")
    for args in ([str(tmp_path / "scaled.csv"), "--scale", f"omega={SPEED_SCALE!r}"], [str(tmp_path / "no_t.npz"), "--dt", "1e-4"]):
        out = tmp_path / ("out_" + args[0].rsplit("/", 1)[-1])
        assert cli.main(["fit", *args, "--runs", "2", "--bounds", "table4", "--out", str(out)]) == 0
        d = json.loads((out / "result.json").read_text())
        assert max(r["of"] for r in d["runs"]) <= 1e-15
        for n, v in truth.items():
            assert d["params"][n] == pytest.approx(v, rel=1e-6)
    assert cli.main(["fit", str(tmp_path / "no_t.npz"), "--out", str(tmp_path / "x")]) == 2
    assert "--dt" in capsys.readouterr().err


def test_model_from_a_file(tmp_path, sd1):
    (tmp_path / "mymodel.py").write_text("import dcjax\n\nclass Mine(dcjax.DC):\n    pass\n")
    spec = f"{tmp_path / 'mymodel.py'}:Mine"
    m = get_model(spec)
    assert type(m).__name__ == "Mine" and isinstance(m, dcjax.DC)
    assert get_model(model_spec(m)).__class__ is m.__class__  # a saved result names the file again
    out = tmp_path / "fit"
    assert cli.main(["fit", str(datasets.DATA_DIR / "SD1.csv"), "--model", spec, "--runs", "1", "--budget", "140", "--out", str(out)]) == 0
    assert cli.main(["report", str(out / "result.json")]) == 2  # the result names the file, but dcjax imports no code on its word
    assert cli.main(["report", str(out / "result.json"), "--model", spec]) == 0  # the user names it: its model and, with it, the data
    with pytest.raises(ValueError, match="cannot import model"):
        get_model(f"{tmp_path / 'absent.py'}:Mine")
    with pytest.raises(ValueError, match="cannot import model"):
        get_model(f"{tmp_path / 'mymodel.py'}:Other")


def test_initial_estimate_on_sd1_is_within_20_percent(sd1):
    est = initial_estimate(sd1)
    truth = datasets.true_params("SD1")
    for n in ("Ra", "La", "cm", "J", "Tla"):
        assert est[n].value == pytest.approx(truth[n], rel=0.2), n
        assert est[n].stderr is not None and est[n].stderr < abs(est[n].value)
        assert est[n].min <= truth[n] <= est[n].max  # the automatic range holds the truth


def test_initial_estimate_is_linear_least_squares_of_the_regression(sd1):
    """With a fixed filter, the DC estimate equals a plain NumPy solve of eq. 8 x La and eq. 9 x J
    (each equation weighted by its inertial term, iterated to the fixed point)."""
    from scipy.signal import butter, filtfilt

    est = initial_estimate(sd1, cutoff=2000.0, border=5)
    b, a = butter(4, 2000.0 / 5000.0)  # pyright: ignore  (scipy stubs: butter may return None)
    i, w = filtfilt(b, a, sd1.i_a), filtfilt(b, a, sd1.omega)
    di, dw = np.gradient(i, 1e-4), np.gradient(w, 1e-4)
    s = slice(5, -5)
    i, w, di, dw, u = i[s], w[s], di[s], dw[s], sd1.u_a[s]
    z = np.zeros_like(i)
    e8 = np.column_stack([i, di, w, z, z, z, z])
    e9 = np.column_stack([z, z, -i, dw, np.ones_like(i), w, w * w])
    x = np.array([est[n].value for n in dcjax.DC.names])
    w8, w9 = 1 / np.sqrt(np.mean((x[1] * di) ** 2)), 1 / np.sqrt(np.mean((x[3] * dw) ** 2))
    A = np.vstack([w8 * e8, w9 * e9])
    rhs = np.concatenate([w8 * u, z])
    norm = np.linalg.norm(A, axis=0)
    ref = np.linalg.lstsq(A / norm, rhs, rcond=None)[0] / norm
    np.testing.assert_allclose(x, ref, rtol=1e-6)
    # a known cm (a fit's --fix) held in the estimate: its terms on the right-hand side
    cm = 0.9 * float(ref[2])
    held = initial_estimate(sd1, cutoff=2000.0, border=5, known={"cm": cm})
    x = np.array([held[n].value for n in dcjax.DC.names])
    w8, w9 = 1 / np.sqrt(np.mean((x[1] * di) ** 2)), 1 / np.sqrt(np.mean((x[3] * dw) ** 2))
    free = [0, 1, 3, 4, 5, 6]
    A = np.vstack([w8 * e8, w9 * e9])
    rhs = np.concatenate([w8 * u, z]) - cm * A[:, 2]
    norm = np.linalg.norm(A[:, free], axis=0)
    ref = np.linalg.lstsq(A[:, free] / norm, rhs, rcond=None)[0] / norm
    assert x[2] == cm and held["cm"].stderr == 0.0
    np.testing.assert_allclose(x[free], ref, rtol=1e-6)


def test_initial_estimate_refuses_an_unmeasured_state(sd1):
    rec = sd1.replace(channels={"u_a": sd1.u_a, "i_a": sd1.i_a})

    class OnlyCurrent(dcjax.DC):
        measured = ("i_a",)

    with pytest.raises(ValueError, match="missing omega"):
        initial_estimate(rec, OnlyCurrent())


def test_initial_estimate_of_a_model_without_regression_uses_lm(sd1):
    class NoRegression(dcjax.DC):
        def regression(self, y, dy, u):
            return None

    est = initial_estimate(sd1, NoRegression(), cutoff=2000.0)
    truth = datasets.true_params("SD1")
    for n in ("Ra", "La", "cm", "J"):
        assert est[n].value == pytest.approx(truth[n], rel=0.05), n
    held = initial_estimate(sd1, NoRegression(), cutoff=2000.0, known={"cm": truth["cm"]})  # LM with cm held at its value
    assert held["cm"].value == truth["cm"] and held["cm"].stderr == 0.0
    for n in ("Ra", "La", "J"):
        assert held[n].value == pytest.approx(truth[n], rel=0.05), n
    with pytest.raises(ValueError, match="known"):
        initial_estimate(sd1, known={"cmm": 0.5})
    with pytest.raises(ValueError, match=r"^known: cm=nan: a known value must be a finite number$"):
        initial_estimate(sd1, known={"cm": float("nan")})


def test_bounds_auto_holds_the_preset_and_the_estimate(sd1):
    b, start, (est,) = auto_bounds(sd1)
    lo4, hi4 = dcjax.DC().bound_arrays("table4")
    assert np.all(b.lower <= lo4) and np.all(b.upper >= hi4)
    assert np.all(b.upper >= est.upper)
    assert set(start) >= {"Ra", "La", "cm", "J"}


def test_bounds_auto_of_a_long_joint_fit_estimates_a_spread_few(sd1, monkeypatch):
    """A joint fit of more recordings than `AUTO_RECORDINGS` is estimated on that many, spread
    over it (the first and the last among them), its ranges the union of theirs; a short one on
    every recording."""
    from dcjax.analysis import estimate

    recs = [sd1.replace(name=f"r{k}", u_a=sd1.u_a * (1.0 + 0.01 * k)) for k in range(19)]
    seen = []
    real = estimate.initial_estimate
    monkeypatch.setattr(estimate, "initial_estimate", lambda r, m, known=None: seen.append(r.name) or real(r, m, known=known))
    bounds, start, ests = auto_bounds(recs)
    picked = [f"r{k}" for k in np.unique(np.round(np.linspace(0, 18, estimate.AUTO_RECORDINGS)).astype(int))]
    assert seen == picked and len(seen) == estimate.AUTO_RECORDINGS and seen[0] == "r0" and seen[-1] == "r18"
    np.testing.assert_array_equal(bounds.lower, np.min([e.lower for e in ests], axis=0))
    np.testing.assert_array_equal(bounds.upper, np.max([e.upper for e in ests], axis=0))
    seen.clear()
    auto_bounds(recs[:3])
    assert seen == ["r0", "r1", "r2"]


def test_bounds_auto_fits_sd1_exactly(sd1):
    res = dcjax.fit(sd1, params="auto", search=dcjax.Search(runs=4, seed=3))
    assert np.all(res.run_of <= 1e-15)
    truth = datasets.true_params("SD1")
    for n, v in truth.items():
        assert res.params[n] == pytest.approx(v, rel=1e-6)


def test_a_bound_hit_gets_a_hint(tmp_path, capsys):
    assert cli.main(["fit", "SD1", "--runs", "2", "--polish", "--bound", "Ra=0:20", "--out", str(tmp_path / "hint")]) == 0
    assert "hint: Ra ended at its upper bound 20" in capsys.readouterr().out


def test_robust_outliers():
    v = np.array([1.0, 1.1, 0.9, 1.05, 0.95, 30.0])
    assert robust_outliers(v).tolist() == [False] * 5 + [True]
    assert not robust_outliers(v[:3]).any()  # too few to judge
    assert robust_outliers(np.array([2.0, 2.0, 2.0, 2.0, 5.0])).tolist() == [False] * 4 + [True]


def test_fit_each_in_one_call_equals_one_fit_each():
    recs = [datasets.load(n) for n in ("SD1", "SD4")]
    batch = fit_each(recs, search=dcjax.Search(runs=2, budget=2800, polish=True))
    for rec, b in zip(recs, batch):
        alone = dcjax.fit(rec, search=dcjax.Search(runs=2, budget=2800, polish=True))
        assert b.timing["batch"] == 2
        np.testing.assert_array_equal(b.run_of, alone.run_of)
        assert b.params == alone.params and b.settings["bounds"] == alone.settings["bounds"]


def test_fit_each_fails_a_dead_sensor_alone():
    recs = [datasets.load(n) for n in ("SD1", "SD2", "SD3")]
    dead = recs[1].replace(i_a=np.zeros(len(recs[1])), name="dead")
    out = fit_each([recs[0], dead, recs[2], "no/such/file.csv"], search=dcjax.Search(runs=2, budget=1400))
    assert [isinstance(r, FailedFit) for r in out] == [False, True, False, True]
    assert "all zero" in out[1].error and "no such file" in out[3].error
    rows = summary_rows(out)
    assert [r["status"] for r in rows] == ["ok", "failed", "ok", "failed"]
    assert [r.get("loose") for r in rows] == ["", None, "", None]  # unpolished runs that spent their budget say nothing of a spread


@pytest.mark.slow
def test_cli_each_writes_one_row_per_file(tmp_path, capsys):
    (tmp_path / "corrupt.csv").write_text("t,u_a,i_a,omega\n0,1,2\nnot a number\n")
    files = [f"data/{n}.csv" for n in ("SD1", "SD2", "SD3", "SD4")] + [str(tmp_path / "corrupt.csv")]
    rc = cli.main(["fit", "--each", *files, "--runs", "2", "--out", str(tmp_path / "each")])
    assert rc == 1  # some failed, the others fitted
    rows = list(csv.DictReader((tmp_path / "each" / "summary.csv").open()))
    assert [r["name"] for r in rows] == ["SD1", "SD2", "SD3", "SD4", "corrupt"]
    assert [r["status"] for r in rows] == ["ok"] * 4 + ["failed"]
    assert rows[-1]["error"]
    for r in rows[:4]:
        assert float(r["of"]) <= 1e-15
        assert (tmp_path / "each" / r["name"] / "result.json").is_file()
    assert (tmp_path / "each" / "summary.png").is_file()
    assert "4/5 fitted" in capsys.readouterr().out


# -- the 0.2 fit API ------------------------------------------------------------------------


def test_fit_with_parameters_and_lmfits_statistics(sd1):
    params = dcjax.DC().parameters("table4")
    params["Tlc"].set(value=8.55e-8, vary=False)
    params["Ra"].set(min=10.0, max=60.0, value=40.0)
    a = dcjax.fit(sd1, params=params, integrator=dcjax.RK4(substeps=2), search=dcjax.Search(runs=2, budget=2800, seed=5))
    assert a.fixed == {"Tlc": 8.55e-8}
    assert a.nvarys == 6 and a.ndata == 2 * len(sd1) and a.nfev == int(a.fes.sum()) == 2 * 2800
    n = a.ndata
    assert a.chisqr == a.of and a.redchi == pytest.approx(a.of / (n - 6))
    assert a.aic == pytest.approx(n * np.log(a.of / n) + 12) and a.bic == pytest.approx(n * np.log(a.of / n) + np.log(n) * 6)
    assert a.success and "chi-square" in a.report()
    p = a.params
    assert p["Tlc"].vary is False and p["Ra"].min == 10.0 and p["Ra"].value == a.params["Ra"]
    d = json.loads(a.to_json())
    assert d["params"] == a.params and d["statistics"]["nvarys"] == 6


@pytest.mark.slow
def test_fit_typed_options(sd1):
    e = dcjax.fit(sd1, params="table4", integrator=dcjax.Euler(substeps=3), search=dcjax.Search(runs=1, budget=1400))
    assert (e.settings["integrator"], e.settings["nd"]) == ("euler", 3)
    m = dcjax.fit(
        sd1,
        params="table4",
        search=dcjax.Search(dcjax.strategies.DERand1Exp(pop_size=40), runs=1, budget=1400, memory=dcjax.LTMA(order="oldest")),
    )
    assert m.settings["memory"] == "ltma-s1" and m.settings["pop_size"] == 40
    w = dcjax.fit(dcjax.with_weights(sd1, {"omega": 0.5}), params="table4", search=dcjax.Search(runs=1, budget=1400))
    assert w.settings["weights"] == [1.0, 0.5]
    for kw, match in (
        ({"integrator": "rk4"}, "integrator must be"),
        ({"params": 3}, "params must be"),
    ):
        with pytest.raises(ValueError, match=match):
            dcjax.fit(sd1, **kw, search=dcjax.Search(runs=1, budget=1400))
    with pytest.raises(ValueError, match="Search.memory must be"):
        dcjax.Search(runs=1, budget=1400, memory="stma")  # pyright: ignore[reportArgumentType]
    bad = dcjax.DC().parameters()
    bad["Ra"].set(min=5.0, max=1.0)
    with pytest.raises(ValueError, match="min 5 is above max 1"):
        dcjax.fit(sd1, params=bad, search=dcjax.Search(runs=1, budget=1400))


def test_parameters_roundtrip_and_errors():
    p = dcjax.DC().parameters("table8")
    p["J"].set(value=0.01, stderr=1e-3)
    q = dcjax.Parameters.from_dict(json.loads(json.dumps(p.to_dict())))
    assert q.to_dict() == p.to_dict() and q["J"].relative_stderr == pytest.approx(0.1)
    with pytest.raises(KeyError, match="no parameter 'X'"):
        p["X"]
    with pytest.raises(ValueError, match="Ra.value must be a finite number"):
        p["Ra"].set(value=float("nan"))
    with pytest.raises(ValueError, match="vary must be True or False"):
        p["Ra"].set(vary="no")


def test_a_hundred_recordings_with_one_broken_give_99_fits_and_one_failure():
    sd1 = datasets.load("SD1")
    rng = np.random.default_rng(0)
    recs = [sd1.replace(i_a=sd1.i_a * (1 + 0.01 * rng.standard_normal()), name=f"motor{k:03d}") for k in range(100)]
    recs[37] = recs[37].replace(omega=np.zeros(len(sd1)))  # a dead speed sensor
    out = fit_each(recs, params="table4", search=dcjax.Search(runs=1, budget=140))
    failed = [k for k, r in enumerate(out) if isinstance(r, FailedFit)]
    assert failed == [37] and "'omega' is all zero" in out[37].error
    assert all(r.success for r in out if not isinstance(r, FailedFit))
    assert {r.timing["batch"] for r in out if not isinstance(r, FailedFit)} == {99}  # the 99 in one compiled call
