"""What a person reads: printed values to the digits their error justifies (issue 55 item 5), the
report's relative errors bounded and each flag once, plain numbers, notebook tables."""

import json
import math
from pathlib import Path

import numpy as np
import pytest
import reference as ref

import dcjax
from dcjax import cli
from dcjax.analysis.report import relative_error
from dcjax.io import datasets
from dcjax.numbers import csv_text, plain, significant_digits, to_uncertainty


def test_numbers_keep_two_digits_of_their_error_and_files_read_back_exactly():
    assert to_uncertainty(42.4967273282272, 0.013) == "42.497"
    assert to_uncertainty(0.0100000000000002, 1e-14) == "0.010000000000000"  # significant zeros kept
    assert to_uncertainty(3.27000000000095e-05, 2.1e-07) == "3.270e-05"
    assert to_uncertainty(1.5321136e-15, 0.0242) == "0.000"  # an error far above the value: zero at the error's digit
    assert to_uncertainty(30.2, 140.0) == "30" and to_uncertainty(0.3, 4.3) == "0.3" and to_uncertainty(1e-7, 6.7e-4) == "0.0e-04"
    assert to_uncertainty(8.7e-05, 6.2e-05) == "8.7e-05" and to_uncertainty(-0.0008, 0.11) == "0.00"
    assert to_uncertainty(-0.2, 0.16) == "-0.20" and to_uncertainty(5.0, math.inf) == "5"
    assert significant_digits(123456.0, 0.5) == 8 and significant_digits(0.0, 1.0) == 1
    assert plain(0.032399999999999998) == "0.0324" and float(plain(1 / 3)) == 1 / 3
    text = csv_text(["t", "y"], np.array([[0.0001, 0.1 + 0.2], [1e-300, -0.0]]))
    assert text == "t,y\n0.0001,0.30000000000000004\n1e-300,-0.0\n"
    assert relative_error(1.5321136e-15, 0.0242) == " (> 1000 %)" and relative_error(42.5, 0.131) == " (0.31 %)"
    assert relative_error(0.0, 1.0) == ""


@pytest.fixture(scope="module")
def noisy_sd1_csv(tmp_path_factory) -> Path:
    """SD1 from the independent NumPy RK4 with 1 % noise on both channels."""
    sd1, truth = datasets.load("SD1"), datasets.true_params("SD1")
    y = ref.simulate(ref.dc_field, truth, sd1.t, np.asarray(sd1["u_a"])[:, None], [0.0, 0.0], substeps=64)
    y = y + 0.01 * np.abs(y).max(axis=0) * np.random.default_rng(1).standard_normal(y.shape)
    path = tmp_path_factory.mktemp("noisy") / "sd1n.csv"
    dcjax.save_csv(dcjax.Recording(t=sd1.t, u_a=sd1["u_a"], i_a=y[:, 0], omega=y[:, 1], name="sd1n"), path)
    return path


def _last_digit(text: str) -> int:
    """The decimal exponent of the last digit written: '42.51' -> -2, '3.1e-05' -> -6."""
    mantissa, _, exponent = text.lower().partition("e")
    if "." not in mantissa and mantissa.strip("-0"):  # an integer: its trailing zeros may or may not be digits
        return int(exponent or 0) + len(mantissa) - len(mantissa.rstrip("0"))
    return int(exponent or 0) - len(mantissa.partition(".")[2])


def _significant(text: str) -> int:
    return len(text.lower().partition("e")[0].replace("-", "").replace(".", "").lstrip("0"))


def test_the_fit_table_prints_no_digit_its_standard_error_does_not_justify(noisy_sd1_csv, tmp_path, capsys):
    """SD1 with 1 % noise, `--uncertainty`: every value ends at the second significant digit of its
    standard error (the +/- column is the uncertainty table's standard error), no further; the
    notebook's tables show the same; result.json keeps the full float64."""
    out = tmp_path / "fit"
    argv = ["fit", str(noisy_sd1_csv), "--bounds", "table4", "--runs", "2", "--budget", "3000", "--uncertainty"]
    assert cli.main([*argv, "--plots", "none", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    lines = text.splitlines()
    head = next(k for k, line in enumerate(lines) if line.split()[:4] == ["param", "unit", "identified", "+/-"])
    rows = [line.partition("[")[0].split() for line in lines[head + 1 : head + 10]]  # without a flag [at bound]
    table = {r[0]: r for r in (line.split() for line in lines) if len(r) > 3 and r[0] in {x[0] for x in rows} and r[1][0] in "-0123456789"}
    saved = json.loads((out / "result.json").read_text())["params"]
    assert [r[0] for r in rows] == ["Ra", "La", "cm", "J", "Tla", "Tlb", "Tlc", "y0_i_a", "y0_omega"]
    for r in rows:
        name, value, error = r[0], r[-4], float(r[-3])
        se = float(table[name][2])  # the uncertainty table's standard error
        assert error == pytest.approx(se, rel=0.051), (name, error, se)
        justified = math.floor(math.log10(error)) - 1  # the second significant digit of the error
        assert _last_digit(value) >= justified, r  # no digit beyond it
        assert _last_digit(value) == justified or "." not in value, (
            r
        )  # and none short of it (a value the error cannot tell from 0 is 0 at that digit)
        assert abs(float(value) - saved[name]) <= 0.05 * error, (name, value, saved[name])
    assert "values to two significant digits of their standard error; all 17 in result.json" in text
    result = dcjax.load_result(out / "result.json")
    html = result._repr_html_() + result.params._repr_html_() + result.recordings[0]._repr_html_()
    assert html.count("<table>") == 3 and "Recording &#x27;sd1n&#x27;: 501 samples" in html


def test_the_digits_note_says_how_many_runs_the_six_digits_come_from():
    """Six significant digits where nothing tells the error (their source "best run", as a notebook's
    table shows it): one run says so and asks for two; of several runs, none but the best within 2x
    of its OF says that (a second run would not help)."""
    from types import SimpleNamespace

    from dcjax.analysis.report import digits_note, value_uncertainties

    def result(run_of):
        x = np.outer(np.arange(1, len(run_of) + 1), [42.5, 0.08])
        return SimpleNamespace(names=("Ra", "La"), fixed=(), best_values={"Ra": 42.5, "La": 0.08}, run_of=np.asarray(run_of),
                               run_params=x, uncertainties=None)  # fmt: skip

    assert digits_note(result([1e-20])).startswith(
        "values to six significant digits (one run, no standard error: --uncertainty or --runs 2"
    )
    note = digits_note(result([1e-20, 5e-20, 1e-13]))
    assert "no other of the 3 runs came within 2x of the best's OF" in note and "--runs 2" not in note, note
    assert {s for _, s in value_uncertainties(result([1e-20, 5e-20, 1e-13])).values()} == {"best run"}  # the notebook's "from" column
    assert digits_note(result([1e-20, 1.5e-20, 1e-13])).startswith("values to two significant digits of the spread of the 2 runs")
