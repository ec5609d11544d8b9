"""`Parameters`: a Parameter in arithmetic, the models' presets, `result.params`, and the CLI's
flags reaching the engine through `dcjax.fit`."""

import json
from typing import ClassVar

import numpy as np
import pytest

import dcjax
from dcjax.cli import main
from dcjax.models.dc import table4


def test_a_parameter_stands_for_its_value():
    p = dcjax.Parameter("Ra", value=2.5, min=0.0, max=10.0, unit="Ohm")
    assert p - 0.5 == 2.0 and 0.5 - p == -2.0 and 2 * p == 5.0 and p / 5 == 0.5 and 5 / p == 2.0 and p**2 == 6.25
    assert -p == -2.5 and abs(-p) == 2.5 and float(p) == 2.5 and round(p, 0) == 2.0
    assert p == 2.5 and p != 3.0 and p < 3 and p <= 2.5 and p > 2 and p >= 2.5
    assert f"{p:.3f}" == "2.500" and "Ra" in f"{p}" and "bounds=[0:10]" in repr(p)
    np.testing.assert_array_equal(np.arange(3) * p, [0.0, 2.5, 5.0])
    assert np.array([p, p]).dtype == np.float64 and p == pytest.approx(2.5)
    q = dcjax.Parameter("Ra", value=2.5, min=0.0, max=10.0, unit="Ohm")
    assert p == q and p != q.set(max=11.0)  # another Parameter: every field
    with pytest.raises(ValueError, match="parameter J has no value"):
        float(dcjax.Parameter("J"))
    params = dcjax.Parameters([p, dcjax.Parameter("La", value=0.1)])
    np.testing.assert_array_equal(np.asarray(params), [2.5, 0.1])
    assert params == {"Ra": 2.5, "La": 0.1}


def test_dc_presets_are_tables_4_8_and_29_and_new_each_call():
    m = dcjax.DC()
    assert m.preset_names == ("table4", "table8")
    t4, t8 = m.parameters(), m.parameters("table8")
    assert [t4[n].max for n in m.names] == [100.0, 1.0, 5.0, 1.0, 1.0, 1e-3, 1e-6]
    assert [t8[n].max for n in m.names] == [100.0, 100.0, 5.0, 1.0, 20.0, 9.55e-2, 4.56e-4]
    assert all(p.min == 0.0 for p in (*t4.values(), *t8.values()))
    assert m.memory_precision == {"Ra": 1e-3, "La": 1e-3, "cm": 1e-3, "J": 1e-4, "Tla": 1e-3, "Tlb": 5e-6, "Tlc": 2e-8}
    assert t8["J"].unit == "kg m^2" and t8["Tlc"].precision == 2e-8
    t4["Ra"].set(max=1.0, vary=False)  # changing one preset object changes no other
    assert m.parameters()["Ra"].max == 100.0 and m.parameters()["Ra"].vary and dcjax.DCCoulomb().parameters()["Ra"].max == 100.0
    with pytest.raises(ValueError, match="unknown bounds preset 'table9'.*table4"):
        m.parameters("table9")


class _Legacy(dcjax.Model):
    names: ClassVar = ("a", "b")
    units: ClassVar = {"a": "m", "b": "s"}
    states: ClassVar = ("x",)
    inputs: ClassVar = ("u",)
    bounds: ClassVar = {"wide": {"a": (0.0, 10.0), "b": (-1.0, 1.0)}, "narrow": {"a": (1.0, 2.0), "b": (0.0, 0.5)}}
    precision: ClassVar = {"a": 1e-3, "b": 1e-4}

    def vector_field(self, c, u, y):
        return (c["a"] * u[0] - c["b"] * y[0],)


class _Presets(_Legacy):
    bounds: ClassVar = {}
    precision: ClassVar = None

    def presets(self):
        return {
            "wide": dcjax.Parameters(
                [dcjax.Parameter("a", min=0.0, max=10.0, precision=1e-3), dcjax.Parameter("b", min=-1.0, max=1.0, precision=1e-4)]
            ),
            "narrow": dcjax.Parameters(
                [dcjax.Parameter("a", min=1.0, max=2.0, precision=1e-3), dcjax.Parameter("b", min=0.0, max=0.5, precision=1e-4)]
            ),
        }


def test_a_model_with_the_01_class_dicts_gets_the_same_presets():
    old, new = _Legacy(), _Presets()
    assert old.preset_names == new.preset_names == ("wide", "narrow")
    for preset in old.preset_names:
        assert old.parameters(preset) == new.parameters(preset)  # units from the model's `units`, precisions, ranges
    assert new.parameters()["b"].unit == "s" and new.memory_precision == {"a": 1e-3, "b": 1e-4}
    np.testing.assert_array_equal(new.bound_arrays("narrow")[1], [2.0, 0.5])


def test_recording_channels_by_any_name():
    t = np.arange(5) * 0.1
    r = dcjax.Recording(t=t, u=np.ones(5), x=np.zeros(5), name="r")
    assert list(r.channels) == ["u", "x"] and r.x.shape == (5,)
    assert list(dcjax.Recording(t=t, u_a=t, i_a=t, omega=None).channels) == ["u_a", "i_a"]  # None: not recorded
    with pytest.raises(ValueError, match="channel 'u' is given twice"):
        dcjax.Recording(t=t, u=t, channels={"u": t})
    with pytest.raises(ValueError, match="i_limit=5.0: a keyword of Recording is a channel.*limit="):
        dcjax.Recording(t=t, u=t, i_limit=5.0)


def test_result_params_are_parameters_and_result_json_keeps_values(tmp_path):
    res = dcjax.fit(dcjax.datasets.load("MD1").replace(limit=9.0), params="table8", search=dcjax.Search(runs=2, budget=1400, seed=3))
    assert isinstance(res.params, dcjax.Parameters) and res.params == res.best_values
    assert res.params["Ra"].min == 0.0 and res.params["Tla"].max == 20.0 and res.params["J"].unit == "kg m^2"
    assert res.params["Ra"] - res.best_values["Ra"] == 0.0
    path = tmp_path / "result.json"
    res.to_json(path)
    d = json.loads(path.read_text())
    assert d["params"] == res.best_values and all(isinstance(v, float) for v in d["params"].values())
    assert dcjax.Parameters.from_dict(d["parameters"]) == res.params  # the whole Parameters, saved with the result
    back = dcjax.load_result(path)
    assert back.best_values == res.best_values and back.recording is not None and back.recording.limit == 9.0  # the fitted limit


def _same_runs(a, b):
    np.testing.assert_array_equal(a.run_of, b.run_of)
    np.testing.assert_array_equal(a.run_params, b.run_params)


def test_fit_each_takes_one_parameters_per_recording():
    sd1 = dcjax.datasets.load("SD1")
    a, b = sd1.replace(name="a"), sd1.replace(name="b", i_a=sd1.i_a * 1.01)
    pa, pb = table4(), table4()
    pb["Ra"].set(min=30.0, max=50.0)
    each = dcjax.fit_each([a, b], params=[pa, pb], search=dcjax.Search(runs=1, budget=700, seed=2))
    alone = [dcjax.fit(r, params=p, search=dcjax.Search(runs=1, budget=700, seed=2)) for r, p in ((a, pa), (b, pb))]
    for e, s in zip(each, alone):
        _same_runs(e, s)
    assert isinstance(each[1], dcjax.FitResult) and each[1].params["Ra"].min == 30.0 and 30.0 <= each[1].params["Ra"] <= 50.0
    with pytest.raises(ValueError, match="one entry per recording"):
        dcjax.fit_each([a, b], params=[pa])


def test_a_parameter_spec_is_the_parameters_in_short():
    """`dcjax.ParameterSpec`: a preset with ranges, known and start values gives the `Parameters`
    the command line's --bounds/--bound/--fix/--x0 give; a known value outside its range is an error."""
    sd1 = dcjax.datasets.load("SD1")
    spec = dcjax.ParameterSpec("table4", ranges={"Ra": (0.0, 50.0), "offset_i_a": (-0.1, 0.1)}, fixed={"Tlc": 0.0}, start={"J": 2e-5},
                               log=("Tlb",))  # fmt: skip
    p = spec.resolve(dcjax.DC(), sd1)
    assert (p["Ra"].min, p["Ra"].max) == (0.0, 50.0) and p["Tlc"].vary is False and p["J"].value == 2e-5
    assert p["Tlb"].scale == "log" and (p["offset_i_a"].min, p["offset_i_a"].max) == (-0.1, 0.1)
    assert (p["La"].min, p["La"].max) == (dcjax.DC().parameters("table4")["La"].min, dcjax.DC().parameters("table4")["La"].max)
    with pytest.raises(ValueError, match="fixed Ra=60 lies outside its range 0:50"):
        dcjax.ParameterSpec(ranges={"Ra": (0.0, 50.0)}, fixed={"Ra": 60.0})
    with pytest.raises(ValueError, match="local: needs a joint fit"):
        dcjax.ParameterSpec(local=("Tla",)).resolve(dcjax.DC(), [sd1])


@pytest.mark.parametrize("other,flag", [("start", "--x0 Ra=40"), ("log", "--log Ra"), ("local", "--local Ra")])
def test_a_fixed_parameter_named_again_is_an_error_not_ignored(tmp_path, capsys, other, flag):
    """A fixed parameter is not searched: a start value, a log scale or a value per recording for
    it (`--fix Ra=42.5 --x0 Ra=40`) was dropped without a word. Now `ParameterSpec` refuses the
    pair in one line, which the command line spells in its flags."""
    given = {"start": {"Ra": 40.0}, "log": ("Ra",), "local": ("Ra",)}[other]
    with pytest.raises(
        dcjax.ConfigError, match=rf"^ParameterSpec: fixed= and {other}= both name Ra: a fixed parameter is not searched; drop one$"
    ):
        dcjax.ParameterSpec("table4", fixed={"Ra": 42.5}, **{other: given})
    out = tmp_path / "o"
    assert main(["fit", "SD1", "SD2", "--fix", "Ra=42.5", *flag.split(), "--runs", "1", "--budget", "70", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"dcjax: error: ParameterSpec: --fix and {flag.split()[0]} both name Ra: a fixed parameter is not searched; drop one"
    assert not out.exists()
