"""`dcjax fit` says where runs that fit as well as the best spread in their values
(`dcjax.analysis.report.loose_parameters`): a model written with a direction the data cannot see
(a heated block's C, k, Rth, of which only k/C and Rth*C act) printed its parameters to two digits
of the runs' spread and said nothing; the null direction showed only under `report --uncertainty`."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import reference as ref

import dcjax
from dcjax import cli
from dcjax.analysis.report import loose_parameters
from dcjax.cli.each import file_line
from dcjax.fitting.summary import summary_rows, write_summary
from dcjax.models.bounds import Bounds

MODEL = str(Path(__file__).with_name("heated_block.py"))
TRUTH = {"C": 800.0, "k": 0.9, "Rth": 0.5, "Ta": 294.45}


def _block(path: Path) -> None:
    rng = np.random.default_rng(1)
    t = np.arange(400) * 9.0
    power = np.repeat(rng.choice([0.0, 20.0, 40.0], 14), 30)[: len(t)]
    temperature = ref.simulate(ref.heated_block_field, TRUTH, t, power, [295.0], substeps=8)[:, 0]
    temperature = temperature + 0.05 * rng.standard_normal(len(t))
    np.savetxt(path, np.column_stack([t, power, temperature]), delimiter=",", header="t,P,T", comments="")


@pytest.mark.slow  # four CLI commands
def test_runs_that_fit_as_well_with_other_values_are_named(tmp_path, capsys):
    _block(tmp_path / "block.csv")
    fit = ["fit", str(tmp_path / "block.csv"), "--model", MODEL, "--runs", "3", "--budget", "20000", "--polish", "--plots", "none"]
    assert cli.main([*fit, "--out", str(tmp_path / "free")]) == 0
    note = [line for line in capsys.readouterr().out.splitlines() if "converged runs fit as well as the best" in line]
    assert len(note) == 1 and "C by" in note[0] and "k by" in note[0] and "Ta" not in note[0], note
    assert f"--uncertainty --model {MODEL}:HeatedBlock` names what they do determine" in note[0]  # a file model: said how to load it
    assert cli.main(["report", str(tmp_path / "free" / "result.json"), "--model", f"{MODEL}:HeatedBlock"]) == 0
    assert "spread: C by" in capsys.readouterr().out  # the report says it too, and what to run
    assert cli.main(["report", str(tmp_path / "free" / "result.json"), "--uncertainty", "--model", f"{MODEL}:HeatedBlock"]) == 0
    assert "null direction: C, k, Rth are not determined" in capsys.readouterr().out
    free = dcjax.load_result(tmp_path / "free" / "result.json", model=f"{MODEL}:HeatedBlock")
    (row,) = summary_rows([free])  # a folder's summary.csv names them in its `loose` column
    assert {"C", "k"} <= set(row["loose"].split()) and "Ta" not in row["loose"], row["loose"]
    csv_path, _ = write_summary([row], tmp_path / "summary", free.model, plot=False)
    assert csv_path.read_text().splitlines()[0].endswith(",outlier,loose"), csv_path.read_text()
    # k known: C and Rth are determined, the runs agree, nothing to say; the automatic ranges come
    # from an estimate that holds k at 0.9 too (it took them from the free estimate: C at 136 +- 58,
    # its range's top 202, and the fit pinned C there)
    assert cli.main([*fit, "--fix", "k=0.9", "--out", str(tmp_path / "fixed")]) == 0
    assert "converged runs fit" not in capsys.readouterr().out
    fixed = dcjax.load_result(tmp_path / "fixed" / "result.json", model=f"{MODEL}:HeatedBlock").best_values
    assert all(abs(fixed[n] / TRUTH[n] - 1) < 0.01 for n in ("C", "Rth", "Ta")), fixed
    # runs stopped short by a small budget say nothing of the data (SD1: far apart, unconverged)
    assert cli.main(["fit", "SD1", "--runs", "3", "--budget", "700", "--plots", "none", "--out", str(tmp_path / "short")]) == 0
    assert "converged runs fit" not in capsys.readouterr().out


def test_the_rule_takes_runs_that_ended_and_values_that_spread_past_their_range_share():
    """`loose_parameters` on runs given by hand: only runs that ended (converged or polished)
    within 2x of the best OF count; a value spreads by > 5 % of its mean and > 1 % of its range
    (a start near 0 that moves by a hair of its range is not named); a fixed value never."""
    names = ("a", "b", "c", "d")
    params = np.array([[1.0, 10.0, 1e-4, 5.0], [2.0, 10.1, -1e-4, 5.0], [1.5, 9.9, 0.0, 5.0], [9.0, 1.0, 1.0, 5.0]])

    def runs(of, converged=None, polish=None):
        bounds = Bounds([0.0, 0.0, -1.0, 5.0], [10.0, 100.0, 1.0, 5.0], names)
        return SimpleNamespace(run_of=np.array(of), run_params=params, names=names, fixed={"d": 5.0}, bounds=bounds,
                               converged=converged, polish=polish)  # fmt: skip

    ended = np.array([True, True, True, True])
    assert loose_parameters(runs([1.0, 1.5, 1.9, 50.0], ended)) == (3, {"a": pytest.approx(1 / 3)})  # the 4th is 50x worse
    assert loose_parameters(runs([1.0, 1.5, 1.9, 50.0])) == (0, {})  # budget spent, no polish: they say nothing
    assert loose_parameters(runs([1.0, 1.5, 1.9, 50.0], polish={"steps": 1}))[1].keys() == {"a"}  # polished runs ended
    assert loose_parameters(runs([1.0, 3.0, 3.0, 3.0], ended)) == (1, {})  # one run alone
    assert loose_parameters(runs([np.nan, np.inf, np.nan, np.inf], ended)) == (0, {})
    # `dcjax fit --each`: a file's line names them too, with the command that tells more
    spread = SimpleNamespace(**vars(runs([1.0, 1.5, 1.9, 50.0], ended)), of=1.0, checks=[], model=dcjax.DC())
    line = file_line("f1", spread, ["b"], Path("out/f1"))
    assert (
        line == "f1: OF 1.0000e+00; at bound: b; runs as good spread in: a (`dcjax report out/f1/result.json --uncertainty`); wrote out/f1"
    )
    assert "spread" not in file_line("f1", spread, [], Path("out/f1"), spread=False)  # with --uncertainty: its errors say it
