"""pandas in and out (`dcjax[notebook]`): a DataFrame with its time as the index fits to the bits
of the CSV it came from, `Recording.to_dataframe` round-trips, and results, validations,
parameters and simulations come out as DataFrames."""

import numpy as np
import pandas as pd
import pytest

import dcjax
from dcjax import datasets
from dcjax.extras import optional_module

SEARCH = dcjax.Search(runs=2, budget=700, seed=0)


def test_a_dataframe_with_its_time_as_the_index_fits_to_the_bits_of_the_csv(sd1):
    df = pd.read_csv(datasets.DATA_DIR / "SD1.csv", index_col="t")  # the CSV as a notebook reads it: time as the index
    assert df.index.name == "t" and list(df.columns) == ["u_a", "i_a", "omega"]
    a = dcjax.fit(sd1, params="table4", search=SEARCH)
    b = dcjax.fit(df, params="table4", search=SEARCH)
    np.testing.assert_array_equal(np.asarray(a.run_of), np.asarray(b.run_of))
    np.testing.assert_array_equal(np.asarray(a.run_params), np.asarray(b.run_params))
    table = b.to_dataframe()
    assert list(table.index) == list(dcjax.DC.names) and table.loc["Ra", "value"] == b.best_values["Ra"]
    assert {"value", "stderr", "min", "max", "vary", "unit"} <= set(table.columns)
    (v,) = b.validate([datasets.load("SD2").to_dataframe()])  # a DataFrame to validate on, too
    frame = v.to_dataframe()
    assert list(frame.index) == ["i_a", "omega"] and frame.loc["i_a", "rmse"] == v.channels["i_a"]["rmse"]
    inputs = df[["u_a"]]  # the inputs alone: simulated, labelled
    sim = b.simulation(inputs).to_dataframe()
    assert list(sim.columns) == ["u_a", "i_a", "omega"] and np.allclose(sim["i_a"].to_numpy(), b.simulate(sd1)[:, 0], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(np.asarray(dcjax.simulate(b.best_values, inputs)), b.simulate(sd1))


def test_to_dataframe_round_trips_a_recording_with_its_constants_and_limit():
    rec = dcjax.Recording(t=np.arange(5) * 0.1, ud=np.ones(5), uq=np.arange(5.0), id=np.zeros(5), iq=np.ones(5), omega=np.arange(5.0),
                          limit=3.0, name="bench", constants={"pp": 4.0, "Tl": 0.02})  # fmt: skip
    df = rec.to_dataframe()
    back = dcjax.Recording.from_dataframe(df, model="pmsm")
    assert back.name == "bench" and back.limit == 3.0 and back.constants == {"pp": 4.0, "Tl": 0.02}
    np.testing.assert_array_equal(back.t, rec.t)
    assert all(np.array_equal(back[c], rec[c]) for c in rec.channels) and set(back.channels) == set(rec.channels)


def test_a_datetime_index_is_seconds_from_the_first_and_bad_input_is_one_line(sd1):
    df = sd1.to_dataframe()
    df.index = pd.Timestamp("2026-12-04 10:00") + pd.to_timedelta(df.index.to_numpy(), unit="s")
    rec = dcjax.Recording.from_dataframe(df)
    np.testing.assert_allclose(rec.t, sd1.t, rtol=0, atol=2e-9)  # datetimes hold whole nanoseconds
    with pytest.raises(ValueError, match=r"^data must be a dcjax.Recording, a pandas DataFrame \(its time a column t or the index\)"):
        dcjax.fit([1, 2, 3])
    with pytest.raises(ValueError, match=r"^X needs no_such_module_dcjax: pip install 'dcjax\[no_such_module_dcjax\]'$"):
        optional_module("no_such_module_dcjax", "X")
    with pytest.warns(DeprecationWarning, match="i_limit"):
        assert dcjax.Recording.from_dataframe(sd1.to_dataframe(), i_limit=2.0).limit == 2.0


NOTEBOOK_MODEL = """
from typing import ClassVar

import dcjax


class FirstOrder(dcjax.Model):
    names: ClassVar = ("a", "b")
    states: ClassVar = ("x",)
    inputs: ClassVar = ("u",)

    def vector_field(self, c, u, y):
        return (-c["a"] * y[0] + c["b"] * u[0],)
"""


@pytest.mark.slow  # a CLI run
def test_a_model_defined_in_a_notebook_reloads_from_the_class_or_its_file(tmp_path, capsys):
    """A class of `__main__` (a notebook's): the result names it, `load_result` says in one line
    how to give it, and takes the class itself; `dcjax report --model FILE:Name` the file."""
    import json

    from dcjax import cli

    space: dict = {"__name__": "__main__"}
    exec(compile(NOTEBOOK_MODEL, "<notebook cell>", "exec"), space)  # as a notebook defines it
    model = space["FirstOrder"]()
    t = np.arange(200) * 0.01
    u = np.where(t < 1.0, 1.0, -0.5)
    x = dcjax.simulate({"a": 2.0, "b": 3.0}, dcjax.Recording(t=t, u=u), model=model)[:, 0]
    rec = dcjax.Recording(t=t, u=u, x=np.asarray(x), name="nb")
    params = dcjax.Parameters([dcjax.Parameter("a", min=0.5, max=5), dcjax.Parameter("b", min=0.5, max=5)])
    res = dcjax.fit(rec, model, params, search=dcjax.Search(runs=1, budget=280, polish=True))
    path = tmp_path / "result.json"
    res.to_json(path)
    assert json.loads(path.read_text())["model"] == "__main__:FirstOrder"
    with pytest.raises(ValueError, match=r"defined in a notebook or a script \(__main__\).*model='path/to/file.py:FirstOrder'"):
        dcjax.load_result(path)
    again = dcjax.load_result(path, model=model)
    assert again.best_values == res.best_values and abs(again.best_values["a"] / 2.0 - 1) < 1e-6
    (tmp_path / "first_order.py").write_text(NOTEBOOK_MODEL)
    capsys.readouterr()
    assert cli.main(["report", str(path), "--model", f"{tmp_path / 'first_order.py'}:FirstOrder"]) == 0
    assert "[[Variables]]" in capsys.readouterr().out
