"""Per-recording constants (issue 28, item 2): an input of a model given as a constant of each
recording (sidecar "constants", `--const`, `Recording(constants=)`) instead of a column."""

import json
import warnings

import numpy as np
import pytest

import dcjax
from dcjax import cli


class Gain(dcjax.Model):
    """dy/dt = (k u - y) / tau: a first-order plant behind a controller gain k, set per experiment."""

    names = ("tau",)
    states = ("y",)
    inputs = ("u", "k")
    bounds = {"box": {"tau": (0.01, 1.0)}}

    def vector_field(self, c, u, y):
        return ((u[1] * u[0] - y[0]) / c["tau"],)


def _write(folder, name, k: float, as_column: bool):
    t = np.arange(300) * 1e-3
    u = np.where(t > 0.02, 1.0, 0.0)
    rec = dcjax.Recording(t=t, u=u, y=np.ones_like(t), constants={"k": k})
    y = np.asarray(dcjax.simulate({"tau": 0.05}, dcjax.make_problem(rec, model=Gain(), initial={"y": 0.0})))[:, 0]
    cols = [t, u, y] + ([np.full_like(t, k)] if as_column else [])
    header = "t,u,y" + (",k" if as_column else "")
    np.savetxt(folder / f"{name}.csv", np.column_stack(cols), delimiter=",", header=header, comments="")
    if not as_column:
        (folder / f"{name}.json").write_text(json.dumps({"constants": {"k": k}}))
    return folder / f"{name}.csv"


def test_constants_from_a_sidecar_give_the_bits_of_the_same_constants_as_columns(tmp_path):
    model = Gain()
    col = dcjax.load_recording(_write(tmp_path, "col", 2.5, True), model=model)
    side = dcjax.load_recording(_write(tmp_path, "side", 2.5, False), model=model)
    assert "k" in col.channels and side.constants == {"k": 2.5} and "k" not in side.channels
    a = dcjax.fit(col, model, params="box", search=dcjax.Search(runs=2, budget=700))
    b = dcjax.fit(side, model, params="box", search=dcjax.Search(runs=2, budget=700))
    np.testing.assert_array_equal(a.run_params, b.run_params)
    np.testing.assert_array_equal(a.run_of, b.run_of)
    inline = dcjax.Recording(t=side.t, u=side["u"], y=side["y"], constants={"k": 2.5})
    np.testing.assert_array_equal(dcjax.fit(inline, model, params="box", search=dcjax.Search(runs=2, budget=700)).run_of, a.run_of)
    assert "constants k=2.5" in b.report()


@pytest.mark.slow
def test_the_cli_const_option_and_errors_that_name_the_inputs(tmp_path, capsys):
    path = _write(tmp_path, "bare", 2.5, False)
    (tmp_path / "bare.json").unlink()  # no sidecar: the constant comes from --const
    spec = f"{__file__}:Gain"
    out = tmp_path / "o"
    assert cli.main(["fit", str(path), "--model", spec, "--bounds", "box", "--const", "k=2.5", "--runs", "2", "--budget", "700",
                     "--out", str(out)]) == 0  # fmt: skip
    assert dcjax.load_result(out / "result.json", model=spec).best_values["tau"] == pytest.approx(0.05, rel=0.2)
    assert (
        cli.main(["validate", str(out / "result.json"), str(path), "--model", spec, "--out", str(tmp_path / "v")]) == 0
    )  # --const remembered
    capsys.readouterr()
    assert cli.main(["fit", str(path), "--model", spec, "--bounds", "box", "--runs", "1", "--budget", "70", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "'k'" in err and "--const k=V" in err
    assert cli.main(["fit", str(path), "--model", spec, "--const", "k=abc", "--out", str(out)]) == 2
    assert "--const: value of k must be a finite number" in capsys.readouterr().err
    with pytest.raises(ValueError, match="constant k must be a finite number"):
        dcjax.Recording(t=np.arange(5.0), u=np.ones(5), y=np.ones(5), constants={"k": float("nan")})
    with pytest.raises(ValueError, match="given both as a column and as a constant"):
        dcjax.Recording(t=np.arange(5.0), u=np.ones(5), y=np.ones(5), k=np.ones(5), constants={"k": 1.0})
    with pytest.raises(ValueError, match="may also be constants"):
        dcjax.make_problem(dcjax.Recording(t=np.arange(5.0), u=np.ones(5), y=np.ones(5)), model=Gain())


def test_a_constant_that_names_no_input_is_an_error_not_ignored(tmp_path, capsys):
    """A constant stands in for an input's column. One naming a parameter (`--const Ra=3`, meant
    as `--fix Ra=3`), a state or nothing of the model was dropped without a word and the fit ran
    as if it were not given; now it is a one-line error naming the model's inputs (and, for a
    parameter, how to hold it) wherever constants are given: a file, a table, an embedded data set."""
    path = _write(tmp_path, "bare", 2.5, False)
    with pytest.raises(dcjax.ConfigError, match=r"constants= names tau: not an input of model Gain \(its inputs: u, k\).*vary=False"):
        dcjax.load_recording(path, model=Gain(), constants={"k": 2.5, "tau": 0.05})
    with pytest.raises(dcjax.ConfigError, match=r"constants= names y, gain: not an input"):
        dcjax.Recording.from_dataframe(
            {"t": np.arange(5.0), "u": np.ones(5), "y": np.ones(5)}, model=Gain(), constants={"y": 0.0, "gain": 2.0}
        )
    assert dcjax.load_recording(path, model=Gain(), constants={"k": 2.5}).constants == {"k": 2.5}
    for data in (str(path), "SD1"):
        args = ["fit", data, "--runs", "1", "--budget", "70", "--out", str(tmp_path / "o")]
        assert (
            cli.main([*args, "--model", f"{__file__}:Gain", "--const", "k=2.5,tau=0.05"] if data != "SD1" else [*args, "--const", "Ra=3"])
            == 2
        )
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1
        assert (
            ("--const names tau" in err and "--fix tau=V" in err)
            if data != "SD1"
            else ("--const names Ra: not an input of model dc (its inputs: u_a)" in err and "--fix Ra=V" in err)
        )
    assert not (tmp_path / "o").exists()


def test_a_sidecar_constant_that_names_no_input_is_named_not_dropped_silently(tmp_path):
    """A sidecar's "constants" describe the rig, perhaps for another model too: one naming no
    input of the loaded model is a one-line warning (not an error); those that do are read."""
    path = _write(tmp_path, "rig", 2.5, False)
    (tmp_path / "rig.json").write_text(json.dumps({"constants": {"k": 2.5, "pp": 4}}))
    with pytest.warns(UserWarning, match=r"^rig\.json: constants pp name no input of model Gain \(its inputs: u, k\): not used$"):
        rec = dcjax.load_recording(path, model=Gain())
    assert rec.constants == {"k": 2.5, "pp": 4.0}  # kept as the sidecar says, the fit reads k alone
    (tmp_path / "rig.json").write_text(json.dumps({"constants": {"k": 2.5}}))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert dcjax.load_recording(path, model=Gain()).constants == {"k": 2.5}
