"""A linear actuator (`tests/voice_coil.py`: a moving coil on a spring, its position logged in
mm) through the loaders and the CLI, on data from the NumPy reference (`voice_coil_field`): the
length, speed and force units, a model file named without its class, and the start of a speed
that is the derivative of a recorded position."""

from pathlib import Path

import numpy as np
import pytest
import reference as ref
from voice_coil import VoiceCoil

import dcjax
from dcjax import cli
from dcjax.io.units import split_unit, unit_factor
from dcjax.models import get_model

MODEL = str(Path(__file__).with_name("voice_coil.py"))
TRUTH = {"R": 4.0, "L": 2e-3, "Kf": 8.0, "m": 0.05, "k": 2000.0, "c": 3.0}
MM = {"t": "ms", "i": "mA", "x": "mm"}


def recording(n: int = 800, noise: float = 0.002) -> np.ndarray:
    """(t [ms], u [V], i [mA], x [mm]) rows: a square wave of 6 V / -3 V from rest, the current and
    position with white noise of `noise` of their ranges."""
    t = np.arange(n) * 2e-4
    u = np.where(np.arange(n) // 100 % 2 == 0, 6.0, -3.0)
    y = ref.simulate(ref.voice_coil_field, TRUTH, t, u[:, None], [0.0, 0.0, 0.0], substeps=8)
    rng = np.random.default_rng(0)
    i, x = (y[:, k] + noise * np.ptp(y[:, k]) * rng.standard_normal(n) for k in (0, 2))
    return np.column_stack([t * 1e3, u, i * 1e3, x * 1e3])


def written(path: Path, header: str, rows: np.ndarray, units: str | None = None) -> Path:
    lines = [header] + ([units] if units else []) + [";".join(repr(float(v)) for v in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_lengths_speeds_and_forces_convert_to_si_and_a_subscript_is_no_unit(tmp_path):
    rows = recording(120)
    f = written(tmp_path / "mm.csv", "t [ms];u [V];i [mA];x [mm]", rows)
    rec = dcjax.load_recording(f, model=VoiceCoil(), units=MM)
    for k, (c, factor) in enumerate((("t", 1e-3), ("u", 1.0), ("i", 1e-3), ("x", 1e-3))):
        np.testing.assert_allclose(rec.t if c == "t" else rec[c], rows[:, k] * factor, rtol=1e-15)
    with pytest.raises(
        dcjax.DataError, match=r"column 'x \[mm\]' names x in mm, not m: map it with columns=\{'x': 'x \[mm\]'\} and units=\{'x': 'mm'\}"
    ):
        dcjax.load_recording(f, model=VoiceCoil(), units={"t": "ms", "i": "mA"})
    with pytest.warns(UserWarning, match=r"column 'x' \(x\) is in mm by its units line, but read as m: units=\{'x': 'mm'\} converts it"):
        dcjax.load_recording(written(tmp_path / "line.csv", "t;u;i;x", rows, "ms;V;mA;mm"), model=VoiceCoil(), units={"t": "ms", "i": "mA"})
    with pytest.raises(dcjax.ConfigError, match=r"unknown unit 'furlong' for x; accepted: m, mm, cm, um, µm$"):
        dcjax.load_recording(f, model=VoiceCoil(), units={**MM, "x": "furlong"})
    assert split_unit("x [m]") == ("x", "m") and split_unit("x_mm") == ("x", "mm") and split_unit("v (mm/s)") == ("v", "mm/s")
    assert split_unit("F_kN") == ("F", "kN") and split_unit("T [Ncm]") == ("T", "Ncm")
    # a name's last word m or N is a subscript (the motor's speed, a rated torque), not a unit
    assert split_unit("omega_m") == ("omega_m", None) and split_unit("T_N") == ("T_N", None)
    assert unit_factor("F", "kN", "force") == 1e3 and unit_factor("v", "m/min", "speed") == pytest.approx(1 / 60, rel=1e-15)

    class Misspelt(VoiceCoil):
        quantities = {**VoiceCoil.quantities, "x": "length"}  # pyright: ignore[reportIncompatibleVariableOverride]

    with pytest.raises(
        dcjax.ConfigError, match=r"Model.quantities: 'length' \(channel x\) is not one of time, voltage, .*, force; leave x out"
    ):
        dcjax.load_recording(f, model=Misspelt(), units=MM)


def test_a_model_file_without_its_class_names_the_one_it_defines(tmp_path):
    assert type(get_model(MODEL)).__name__ == "VoiceCoil"  # imported from the file
    two = tmp_path / "two.py"
    two.write_text(Path(MODEL).read_text() + "\n\nclass Stiffer(VoiceCoil):\n    pass\n")
    with pytest.raises(
        dcjax.ModelError, match=r"two.py defines 2 Model subclasses \(VoiceCoil, Stiffer\): give the model as '.*two.py:NAME'$"
    ):
        get_model(str(two))
    none = tmp_path / "none.py"
    none.write_text("from dcjax import DC\n")  # imported, not defined
    with pytest.raises(dcjax.ModelError, match=r"none.py defines no dcjax Model subclass: give the model as '.*none.py:NAME'$"):
        get_model(str(none))


@pytest.mark.slow
def test_a_speed_that_is_a_logged_positions_derivative_starts_fitted(tmp_path, capsys):
    """From rest under a force that builds (i = 0 at the start), x bends as t^3: the slope of a
    quadratic through its first samples is off by tens of its noise sd, and every parameter
    took that start (m -1.1 %, L +0.7 %, OF 3.6x). Fitted: within 0.11 % (L), the others
    within 0.02 %."""
    f = written(tmp_path / "coil.csv", "t [ms];u [V];i [mA];x [mm]", recording())
    fit = ["fit", str(f), "--model", MODEL, "--units", "t=ms,i=mA,x=mm", "--runs", "2", "--plots", "none"]
    assert cli.main([*fit, "--out", str(tmp_path / "fit")]) == 0
    assert "note: v is the derivative of x: its initial value is fitted (y0_v)" in capsys.readouterr().out
    res = dcjax.load_result(tmp_path / "fit" / "result.json", model=MODEL)
    assert res.observation.initial == {"i": "fit", "x": "fit", "v": "fit"}
    assert max(abs(res.best_values[n] / v - 1) for n, v in TRUTH.items()) < 2e-3
    assert cli.main([*fit, "--initial", "v=derivative", "--out", str(tmp_path / "slope")]) == 0
    slope = dcjax.load_result(tmp_path / "slope" / "result.json", model=MODEL)
    assert slope.of > 3 * res.of and abs(slope.best_values["m"] / TRUTH["m"] - 1) > 5e-3


def test_a_known_value_counts_as_a_range_where_nothing_can_be_estimated():
    """With the current not logged, `--bounds auto` has nothing to estimate from (one line says to
    give every range); a parameter fixed by its known value (`--fix R=4`) needed a range as well."""
    rows = recording(120)
    model = VoiceCoil().measuring(("x",))
    rec = dcjax.Recording(t=rows[:, 0] * 1e-3, u=rows[:, 1], x=rows[:, 3] * 1e-3)
    ranges = {n: (0.5 * v, 2 * v) for n, v in TRUTH.items() if n != "R"}
    params = dcjax.ParameterSpec(ranges=ranges, fixed={"R": 4.0}).resolve(model, rec)
    assert params["R"].value == 4.0 and not params["R"].vary and (params["L"].min, params["L"].max) == ranges["L"]
    with pytest.raises(dcjax.ConfigError, match=r"missing i .*give every parameter's range \(params\['R'\].set\(min=LO, max=HI\)\)$"):
        dcjax.ParameterSpec(ranges=ranges).resolve(model, rec)
