"""Which states a fit compares (`Observation(measure=...)`, `dcjax fit --measure`): the same fit as
a model class whose `measured` says so, recorded in result.json, and a file's column named after a
state that is not compared still gives that state's initial value."""

import numpy as np
import pytest

import dcjax
from dcjax import cli
from dcjax.fitting.planning import plan
from dcjax.io.loading import load_recording
from dcjax.models import model_spec


class DCSpeed(dcjax.DC):
    measured = ("omega",)


def test_measure_gives_the_bits_of_a_model_class_that_measures_the_same(sd1, tmp_path):
    kw = dict(search=dcjax.Search(runs=1, budget=1400, seed=3))
    by_flag = dcjax.fit(sd1, "dc", "table4", observation=dcjax.Observation(measure=("omega",)), **kw)
    by_class = dcjax.fit(sd1, DCSpeed(), "table4", **kw)
    assert by_flag.model.outputs == by_class.model.outputs == ("omega",)
    np.testing.assert_array_equal(by_flag.run_params, by_class.run_params)
    assert by_flag.of == by_class.of
    assert by_flag.of != dcjax.fit(sd1, "dc", "table4", **kw).of  # the current is compared there
    by_flag.to_json(tmp_path / "result.json")
    back = dcjax.load_result(tmp_path / "result.json")
    assert back.model.outputs == ("omega",) and back.observation.measure == ("omega",) and model_spec(back.model) == "dc"
    assert back.best_values == by_flag.best_values
    assert "[[Derived]] (dc.derived)" in back.report() and "static speed gain omega/u_a" in back.report()


def _csv(path, columns: dict) -> None:
    names = list(columns)
    rows = np.column_stack([columns[n] for n in names])
    np.savetxt(path, rows, delimiter=",", header=",".join(names), comments="")


def test_a_column_of_a_state_not_compared_gives_its_initial_value(tmp_path):
    n = 50
    t = np.arange(n) * 1e-3
    cols = {"t": t, "u_a": np.full(n, 100.0), "i_a": 0.7 + 0.01 * t, "omega": 50.0 + t}
    _csv(tmp_path / "with.csv", cols)
    _csv(tmp_path / "without.csv", {k: v for k, v in cols.items() if k != "i_a"})
    speed = dcjax.DC().measuring("omega")
    rec = load_recording(tmp_path / "with.csv", model=speed)
    assert set(rec.channels) == {"u_a", "i_a", "omega"}
    start = dcjax.Observation(measure=("omega",)).initial_values(speed, rec)
    assert start == {"i_a": pytest.approx(0.7), "omega": pytest.approx(50.0)}
    bare = load_recording(tmp_path / "without.csv", model=speed)  # the speed alone is enough
    assert "i_a" not in bare.channels
    assert dcjax.Observation(measure=("omega",)).initial_values(speed, bare)["i_a"] == 0.0
    with pytest.raises(
        ValueError, match=r"no column 'i_a' for i_a.*does not log i_a, compare the states it logs alone: measure=\('omega',\)"
    ):
        load_recording(tmp_path / "without.csv")  # the paper's motor compares the current
    with pytest.raises(ValueError, match="no column 'I' for i_a"):
        load_recording(tmp_path / "without.csv", model=speed, columns={"i_a": "I"})  # a mapped column must exist


def test_a_speed_only_log_is_told_of_measure_on_the_command_line(tmp_path, capsys):
    """The paper's motor logged without its current: the command line's error says `--measure omega`
    (it said only `--columns i_a=NAME`, a column the file does not have)."""
    n = 50
    t = np.arange(n) * 1e-3
    _csv(tmp_path / "speed.csv", {"t": t, "u_a": np.full(n, 100.0), "omega": 50.0 + t})
    assert cli.main(["fit", str(tmp_path / "speed.csv"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.endswith("compare the states it logs alone: --measure omega)"), err
    _csv(tmp_path / "untimed.csv", {"u_a": np.full(n, 100.0), "i_a": np.full(n, 0.5), "omega": 50.0 + t})
    assert cli.main(["fit", str(tmp_path / "untimed.csv"), "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.strip().endswith("(map them with --columns t=NAME or give the sample time with --dt or --rate)")


def test_measure_names_are_checked_in_one_line(capsys):
    with pytest.raises(ValueError, match=r"^measure: 'x' is not a state; model dc has states i_a, omega$"):
        dcjax.DC().measuring(["x"])
    with pytest.raises(ValueError, match="name each state once"):
        dcjax.DC().measuring(["omega", "omega"])
    with pytest.raises(ValueError, match="measure must be a list of state names"):
        dcjax.Observation(measure="omega")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="offset: i_a is not a measured channel"):
        plan("dc", observation=dcjax.Observation(measure=("omega",), offsets=("i_a",)))
    assert dcjax.DC().measuring(("i_a", "omega")) == dcjax.DC()  # every state: the model itself
    assert type(dcjax.DC().measuring("omega")) is type(dcjax.DC().measuring(("omega",)).measuring("omega"))
    assert cli.main(["fit", "SD1", "--measure", "x"]) == 2
    assert capsys.readouterr().err.strip().splitlines()[-1] == "dcjax: error: measure: 'x' is not a state; model dc has states i_a, omega"
