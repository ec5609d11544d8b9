"""Recording validation, CSV round trip, switch-on trimming, bounds and the SD data files."""

import runpy
import sys
from pathlib import Path

import numpy as np
import pytest

import dcjax
from dcjax import (
    Bounds,
    Recording,
    datasets,
    load_csv,
    make_problem,
    save_csv,
    trim_switch_on,
)

ROOT = Path(__file__).resolve().parent.parent


def _rec(**kw):
    n = 5
    base = dict(t=np.arange(n) * 0.1, u_a=np.full(n, 10.0), i_a=np.linspace(0, 1, n), omega=np.linspace(0, 2, n))
    base.update(kw)
    return Recording(**base)


@pytest.mark.parametrize(
    "kw,match",
    [
        (dict(t=np.arange(4) * 0.1), "different lengths"),
        (dict(i_a=np.array([0, 1, np.nan, 1, 1.0])), "NaN/inf"),
        (dict(omega=np.array([0, 1, np.inf, 1, 1.0])), "NaN/inf"),
        (dict(t=np.array([0, 0.1, 0.1, 0.2, 0.3])), "strictly increasing"),
        (dict(t=np.array([0, 0.2, 0.1, 0.3, 0.4])), "strictly increasing"),
        (dict(limit=-1.0), "limit must be a positive number"),
        (dict(limit=0.0), "limit must be a positive number"),
        (dict(u_a=np.ones((5, 2))), "one-dimensional"),
        (dict(i_a=np.linspace(0, 1, 5) + 0j), "column 'i_a' is complex; a channel is real"),  # was read as its real part
        (dict(t=[0, 0.1, 0.2, 0.3, 0.4j]), "column 't' is complex"),
    ],
)
def test_bad_recordings(kw, match):
    with pytest.raises(ValueError, match=match):
        _rec(**kw)


@pytest.mark.parametrize("channel", ["i_a", "omega"])
def test_all_zero_measured_channel_is_rejected_by_the_problem(channel):
    """The objective divides by a measured channel's peak: make_problem names the channel."""
    with pytest.raises(ValueError, match=f"column '{channel}' is all zero"):
        make_problem(_rec(**{channel: np.zeros(5)}))


def test_too_few_samples():
    with pytest.raises(ValueError, match="at least 3"):
        Recording(t=[0, 1.0], u_a=[1, 1.0], i_a=[0, 1.0], omega=[0, 1.0])


def test_csv_roundtrip(tmp_path):
    rec = _rec(limit=3.5, name="x")
    save_csv(rec, tmp_path / "x.csv", metadata={"note": "hi"})
    back = load_csv(tmp_path / "x.csv")
    for c in ("t", "u_a", "i_a", "omega"):
        np.testing.assert_array_equal(getattr(back, c), getattr(rec, c))
    assert back.limit == 3.5 and back.name == "x" and back.metadata["note"] == "hi"


def test_limit_is_the_generic_name_of_the_current_limit():
    rec = _rec(limit=3.5)
    assert rec.limit == 3.5 and rec == _rec(limit=3.5)
    assert rec.replace(limit=2.0).limit == 2.0 and rec.replace(limit=None).limit is None


@pytest.mark.parametrize(
    "text,match",
    [
        ("a,b,c,d\n1,2,3,4\n", "header"),
        ("t,u_a,i_a,omega\n0,1,1,1\n0.1,1,1\n0.2,1,1,1\n", "ragged"),
        ("t,u_a,i_a,omega\n0,1,1,1\n0.1,1,x,1\n0.2,1,1,1\n", "non-numeric"),
        ("t,u_a,i_a,omega\n0,1,1,1\n0.1,1,nan,1\n0.2,1,1,1\n", "NaN"),
        ("t,u_a,i_a,omega\n", "no data"),
        ("", "empty"),
    ],
)
def test_bad_csv(tmp_path, text, match):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    with pytest.raises(ValueError, match=match):
        load_csv(f)


def test_missing_file(tmp_path):
    with pytest.raises(ValueError, match="no such file"):
        load_csv(tmp_path / "nope.csv")


def test_trim_switch_on():
    t = np.arange(10) * 0.1
    u = np.r_[np.zeros(4), np.full(6, 100.0)]
    i = np.r_[np.zeros(4), np.ones(6)]
    w = np.r_[np.zeros(4), np.arange(1, 7.0)]
    trimmed = trim_switch_on(Recording(t=t, u_a=u, i_a=i, omega=w))
    assert len(trimmed) == 6 and trimmed.u_a[0] == 100.0 and trimmed.i_a[0] == 1.0
    np.testing.assert_allclose(trimmed.t, t[4:])
    np.testing.assert_allclose(trim_switch_on(Recording(t=t, u_a=u, i_a=i, omega=w), rezero_time=True).t, np.arange(6) * 0.1)
    with pytest.raises(ValueError, match="input u_a is zero"):
        trim_switch_on(Recording(t=t, u_a=np.zeros(10), i_a=i, omega=w))


def test_bounds():
    with pytest.raises(ValueError, match="lower bound above upper"):
        Bounds(np.ones(7), np.zeros(7))
    with pytest.raises(ValueError, match="7 values"):
        Bounds(np.zeros(6), np.ones(6), dcjax.DC.names)
    with pytest.raises(ValueError, match="finite"):
        Bounds(np.zeros(7), np.full(7, np.inf))


def test_make_problem_validation(sd1):
    with pytest.raises(ValueError, match="integrator"):
        make_problem(sd1, integrator=object())  # pyright: ignore[reportArgumentType]
    with pytest.raises(ValueError, match="substeps"):
        make_problem(sd1, dcjax.RK4(substeps=0))
    with pytest.raises(ValueError, match="weights"):
        make_problem(sd1, weights=(0.0, 0.0))
    with pytest.raises(ValueError, match="weights"):
        make_problem(sd1, weights=(-1.0, 1.0))
    with pytest.raises(ValueError, match="limit must be a positive number"):
        make_problem(sd1.replace(limit=-2.0))


def test_sd_files_are_regenerated_byte_identically(monkeypatch, capsys):
    """`python data/generate_sd.py --check`, its `__main__` run in this process (no second JAX start)."""
    monkeypatch.setattr(sys, "argv", ["generate_sd.py", "--check"])
    with pytest.raises(SystemExit) as end:
        runpy.run_path(str(ROOT / "data" / "generate_sd.py"), run_name="__main__")
    out = capsys.readouterr().out  # "identical", or the files that differ
    assert end.value.code == 0 and "identical" in out, out


def test_sd_sets_follow_tables_2_and_3():
    for name in ("SD1", "SD2", "SD3", "SD4"):
        rec = datasets.load(name)
        assert len(rec) == 501 and rec.t[0] == 0.0 and np.isclose(rec.t[-1], 0.05)
        assert np.all(rec.u_a == 220.0) and rec.i_a[0] == 0.0 and rec.omega[0] == 0.0
        assert rec.metadata["true_params"] == datasets.true_params(name)
        gen = datasets.generate_sd(name)
        np.testing.assert_array_equal(gen.i_a, rec.i_a)
    assert datasets.true_params("SD4")["J"] == 2e-6 and datasets.true_params("SD3")["La"] == 0.008
    with pytest.raises(ValueError, match="unknown data set"):
        datasets.load("SD9")
