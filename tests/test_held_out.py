"""Held-out validation (`dcjax validate`, `FitResult.validate`, `dcjax.compare`): the figures of
merit against a plain NumPy simulation of the fitted parameters, the residual tests on the right
and a wrong model, and the input test's band against a NumPy computation. The data: the spring
drive of `tests/reference.py` seen through |0.5 w|, two records from the same (unknown) start."""

import json

import numpy as np
import pytest
import reference as ref
from test_outputs import MODELS, TRUTH

import dcjax
from dcjax import cli
from dcjax.analysis import metrics

START = [0.0, 0.0, 0.3]  # both records start with the spring wound by 0.3 rad: not measured


def record(path, seed: int, n: int = 800) -> tuple[str, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 2e-3
    u = np.repeat(rng.choice([-10.0, 10.0], size=n // 25 + 1), 25)[:n]
    y = ref.abs_speed_sensor(ref.simulate(ref.spring_drive_field, TRUTH, t, u[:, None], START, substeps=8, held=(0,)))
    y = y + 0.01 * np.abs(y).max() * np.random.default_rng(seed + 100).standard_normal(n)
    np.savetxt(path, np.column_stack([t, u, y]), delimiter=",", header="t,u,y", comments="")
    return str(path), t, u


FIT = ["--hold", "u=zoh", "--nd", "8", "--runs", "1", "--budget", "3000", "--polish", "--initial", "th=fit"]


@pytest.mark.slow  # a CLI fit and five validations: 8 s
def test_validate_with_the_fitted_start_scores_as_numpy_does(tmp_path, capsys):
    a, _, _ = record(tmp_path / "a.csv", 1)
    b, t, u = record(tmp_path / "b.csv", 2)
    model = f"{MODELS}:PulleyDrive"
    bounds = "R=0.5:8,k=0.1:2,J=0.001:0.1,K=0.2:10,y0_th=-1:1"
    held = ["--validate", b, "--validate-initial", "fitted", "--validate-skip", "10"]  # fit and validate in one command
    assert cli.main(["fit", a, "--model", model, "--bound", bounds, *FIT, *held, "--out", str(tmp_path / "f")]) == 0
    assert "held-out validation:" in capsys.readouterr().out
    res = dcjax.load_result(tmp_path / "f" / "result.json", model=model)
    assert abs(res.best_values["y0_th"] - 0.3) < 0.01
    args = ["validate", str(tmp_path / "f" / "result.json"), b, "--model", model, "--skip", "10"]
    capsys.readouterr()
    assert cli.main([*args[:-1], "100000", "--out", str(tmp_path / "x")]) == 2  # a skip longer than the record: one line
    assert capsys.readouterr().err.strip().endswith(f"skip: 100000 samples of {len(t)} leave 0 (need at least 3 after the skipped ones)")
    assert cli.main([*args, "--initial", "fitted", "--out", str(tmp_path / "v")]) == 0
    row = json.loads((tmp_path / "v" / "validation.json").read_text())[0]
    p = {n: res.best_values[n] for n in TRUTH}
    sim = ref.abs_speed_sensor(
        ref.simulate(ref.spring_drive_field, p, t, u[:, None], [0.0, 0.0, res.best_values["y0_th"]], substeps=8, held=(0,))
    )
    y = np.loadtxt(b, delimiter=",", skiprows=1)[:, 2]
    rmse = float(np.sqrt(np.mean((y[10:] - sim[10:]) ** 2)))
    got = row["channels"]["y"]
    assert row["initial"] == "fitted" and row["skip"] == 10 and row["samples"] == len(t) - 10
    assert got["rmse"] == pytest.approx(rmse, rel=1e-6)
    assert got["mae"] == pytest.approx(float(np.mean(np.abs(y[10:] - sim[10:]))), rel=1e-6)
    assert got["whiteness"] <= 0.1 and got["input_correlation"]["u"] <= 0.1, got  # sensor noise alone: white, not input-correlated
    assert json.loads((tmp_path / "f" / "validation.json").read_text())[0]["channels"]["y"] == got  # fit --validate: the same figures
    # the measured start (the angle's spec: 0, not recorded) is worse: the fitted start is what the records share
    assert cli.main([*args, "--initial", "measured", "--out", str(tmp_path / "m")]) == 0
    measured = json.loads((tmp_path / "m" / "validation.json").read_text())[0]["channels"]["y"]
    assert measured["rmse"] > 1.5 * got["rmse"], (measured["rmse"], got["rmse"])
    assert "fit %" in capsys.readouterr().out
    # estimated on the record with the parameters fixed (findstates): the start the data hold, on all or the first samples
    assert cli.main([*args, "--initial", "estimate", "--out", str(tmp_path / "e")]) == 0
    est = json.loads((tmp_path / "e" / "validation.json").read_text())[0]
    assert est["initial"] == "estimate" and abs(est["start"]["th"] - START[2]) < 0.01, est["start"]
    assert est["channels"]["y"]["rmse"] <= got["rmse"] * 1.001 and (tmp_path / "e" / est["residual_plot"]).is_file()
    # the default (auto): the state whose start the fit fitted (th) estimated on the record, the others as their specs say
    assert cli.main([*args, "--out", str(tmp_path / "a")]) == 0
    auto = json.loads((tmp_path / "a" / "validation.json").read_text())[0]
    assert auto["initial"] == "auto: th=estimate" and abs(auto["start"]["th"] - START[2]) < 0.01 and auto["start"]["i"] == 0.0
    assert auto["channels"]["y"]["rmse"] <= got["rmse"] * 1.001
    assert cli.main([*args, "--initial", "th=estimate:200,i=measured", "--out", str(tmp_path / "k")]) == 0
    first = json.loads((tmp_path / "k" / "validation.json").read_text())[0]
    assert abs(first["start"]["th"] - START[2]) < 0.02 and first["start"]["i"] == 0.0, first["start"]
    capsys.readouterr()
    assert cli.main([*args, "--initial", "th=guess", "--out", str(tmp_path / "g")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "initial: th 'guess': give measured, fitted, estimate, estimate:K" in err, err


@pytest.mark.slow
def test_the_residual_tests_tell_the_right_model_from_a_wrong_order(tmp_path):
    from output_models import PulleyDrive, RigidPulleyDrive

    recs = [dcjax.load_recording(record(tmp_path / f"{k}.csv", k)[0], model=PulleyDrive()) for k in (3, 4)]
    obs = dcjax.Observation(hold={"u": "zoh"})
    search = dcjax.Search(runs=1, budget=3000, polish=True)
    box = {"R": (0.5, 8), "k": (0.1, 2), "J": (0.001, 0.1), "K": (0.2, 10)}
    params = lambda names: dcjax.Parameters([dcjax.Parameter(n, min=box[n][0], max=box[n][1]) for n in names])
    fit = lambda model: dcjax.fit(recs[0], model, params(model.names), search=search, observation=obs, integrator=dcjax.RK4(substeps=8))
    right, wrong = fit(PulleyDrive()), fit(RigidPulleyDrive())
    # the records start at the wound spring: leave its first half second out
    (good,) = right.validate([recs[1]], skip=250)
    (bad,) = wrong.validate([recs[1]], skip=250)
    assert good.channels["y"]["whiteness"] <= 0.1 and bad.channels["y"]["whiteness"] > 0.3, (good.channels, bad.channels)
    rows = dcjax.compare([recs[1]], right, wrong, skip=250)
    assert [r["model"] for r in rows] == ["PulleyDrive", "RigidPulleyDrive"] and [r["free"] for r in rows] == [4, 3]
    assert rows[0]["aic"] < rows[1]["aic"] and rows[0]["bic"] < rows[1]["bic"] and rows[0]["fpe"] < rows[1]["fpe"]
    text = dcjax.analysis.held_out.format_comparison(rows)
    assert "PulleyDrive" in text and "RigidPulleyDrive" in text and "AICc" in text


def test_the_input_tests_band_and_fraction_against_numpy():
    """Ljung's band for a residual and an input that are both coloured: z sqrt(sum_tau r_e r_u / N)."""
    rng = np.random.default_rng(0)
    n, lags = 2000, metrics.LAGS
    u = np.convolve(rng.standard_normal(n + 10), np.ones(10) / 10, mode="valid")[:n]  # coloured
    e = np.convolve(rng.standard_normal(n + 5), [1.0, 0.8, 0.5, 0.2, 0.1, 0.05], mode="valid")[:n] + 0.3 * np.roll(u, 3)
    ec, uc = e - e.mean(), u - u.mean()
    full = lambda a, b: np.correlate(a, b, mode="full")[n - 1 - lags : n + lags] / n  # lags -25..25 of sum a(t + tau) b(t)
    re, ru = full(ec, ec) / (ec @ ec / n), full(uc, uc) / (uc @ uc / n)
    band = 2.58 * np.sqrt(np.sum(re * ru) / n)
    assert metrics.input_band(e, u) == pytest.approx(band, rel=1e-12)
    r = full(ec, uc) / np.sqrt((ec @ ec / n) * (uc @ uc / n))
    assert metrics.input_correlation(e, u) == pytest.approx(np.mean(np.abs(r) > band))
    assert 0 < metrics.input_correlation(e, u) < 1  # the lag-3 term stands out, the far lags do not
    white = rng.standard_normal(n)
    assert metrics.whiteness(white) <= 0.1 and metrics.whiteness(e) > 0.1
