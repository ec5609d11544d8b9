"""Models whose outputs are not their states (`outputs` + `output(c, u, y)`), checked on data
from the independent NumPy reference (`tests/reference.py`: the spring drive's states through its
own sensor functions), through the command line and the Python API."""

import functools
from typing import ClassVar

import numpy as np
import pytest
import reference as ref

import dcjax
from dcjax import cli

MODELS = f"{ref.__file__.replace('reference.py', 'output_models.py')}"
TRUTH = {"R": 2.0, "k": 0.5, "J": 0.01, "K": 2.0}
BOUNDS = "R=0.5:8,k=0.1:2,J=0.001:0.1,K=0.2:10"
SENSORS = {"PulleyDrive": ref.abs_speed_sensor, "SaturatingDrive": ref.saturating_sensor}


@functools.cache
def states(n: int = 1000, seed: int = 1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, u, states) of the reference: a PRBS of +-10 V held between samples (50 ms levels), 2 ms samples."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 2e-3
    u = np.repeat(rng.choice([-10.0, 10.0], size=n // 25 + 1), 25)[:n]
    return t, u, ref.simulate(ref.spring_drive_field, TRUTH, t, u[:, None], [0.0, 0.0, 0.0], substeps=8, held=(0,))


def noisy_csv(path, sensor, seed: int = 1, noise: float = 0.01) -> str:
    t, u, x = states(seed=seed)
    y = sensor(x)
    y = y + noise * np.abs(y).max() * np.random.default_rng(seed + 100).standard_normal(len(t))
    np.savetxt(path, np.column_stack([t, u, y]), delimiter=",", header="t,u,y", comments="")
    return str(path)


def test_the_reference_converges():
    t, u, _ = states()
    assert ref.converged(ref.spring_drive_field, TRUTH, t[:300], u[:300, None], [0.0, 0.0, 0.0], 8, held=(0,)) < 1e-9


def test_simulated_outputs_are_the_references_sensor_readings():
    """At the truth, `dcjax.simulate_outputs` is the reference's sensor of its own states."""
    from output_models import PulleyDrive, TwoSensorDrive

    t, u, x = states()
    rec = dcjax.Recording(t=t, u=u, y=np.ones_like(t), name="r")
    prob = dcjax.make_problem(rec, dcjax.RK4(substeps=8), model=PulleyDrive(), hold={"u": "zoh"})
    out = np.asarray(dcjax.simulate_outputs(TRUTH, prob))
    want = ref.abs_speed_sensor(x)
    assert out.shape == (len(t), 1) and np.max(np.abs(out[:, 0] - want)) <= 1e-9 * np.max(want)
    two = TwoSensorDrive()
    rec2 = dcjax.Recording(t=t, u=u, pulses=np.ones_like(t), w_sat=np.ones_like(t), name="r2")
    prob2 = dcjax.make_problem(rec2, dcjax.RK4(substeps=8), model=two.measuring("w_sat"), hold={"u": "zoh"})
    out2 = np.asarray(dcjax.simulate_outputs(TRUTH, prob2))
    assert out2.shape == (len(t), 1) and np.max(np.abs(out2[:, 0] - ref.saturating_sensor(x))) <= 1e-9 * 6.0


@pytest.mark.parametrize("name", list(SENSORS))
def test_a_fit_through_the_cli_recovers_the_four_parameters(name, tmp_path, capsys):
    data = noisy_csv(tmp_path / f"{name}.csv", SENSORS[name])
    args = ["fit", data, "--model", f"{MODELS}:{name}", "--bound", BOUNDS, "--hold", "u=zoh", "--runs", "1", "--budget", "3000"]
    assert cli.main([*args, "--polish", "--out", str(tmp_path / "out")]) == 0
    res = dcjax.load_result(tmp_path / "out" / "result.json", model=f"{MODELS}:{name}")
    err = {n: abs(res.best_values[n] / v - 1) for n, v in TRUTH.items()}
    assert max(err.values()) < 0.02, err
    assert (tmp_path / "out" / "fit.png").is_file() and "neither measured nor given" in capsys.readouterr().out  # the states start at 0
    if name != "PulleyDrive":
        return
    # the fit simulates a file of the inputs alone (time in ms), labelled and written back in the file's units
    t, u, _ = states(seed=7)
    np.savetxt(tmp_path / "inputs.csv", np.column_stack([t * 1e3, u]), delimiter=",", header="time_ms,u", comments="")
    sim_args = ["simulate", str(tmp_path / "out" / "result.json"), str(tmp_path / "inputs.csv"), "--model", f"{MODELS}:{name}"]
    assert cli.main([*sim_args, "--columns", "t=time_ms", "--units", "t=ms", "--out", str(tmp_path / "s")]) == 0
    assert "holds no output (y)" in capsys.readouterr().out
    got = np.genfromtxt(tmp_path / "s" / "simulated_inputs.csv", delimiter=",", names=True)
    assert got.dtype.names == ("t", "u", "i_sim", "w_sim", "th_sim", "y_sim")
    p = {n: res.best_values[n] for n in TRUTH}
    want = ref.simulate(ref.spring_drive_field, p, t, u[:, None], [0.0, 0.0, 0.0], substeps=8, held=(0,))
    np.testing.assert_allclose(got["t"], t * 1e3, rtol=1e-12)
    assert np.max(np.abs(got["y_sim"] - ref.abs_speed_sensor(want))) <= 1e-6 * np.max(np.abs(want[:, 1]))
    labelled = res.simulation(dcjax.Recording(t=t, u=u, name="new"))
    assert labelled.name == "new simulated" and list(labelled.channels) == ["u", "i", "w", "th", "y"]
    np.testing.assert_allclose(labelled["y"], got["y_sim"], rtol=1e-12, atol=1e-12)


def test_simulate_takes_a_recording_of_the_inputs_alone():
    """`dcjax.simulate(params, recording, model=...)`: the model's default problem (RK4, one step
    per sample, eq. 29) on a recording without its outputs, as the NumPy reference integrates it."""
    t, u, _ = states(n=400)
    p = {"Ra": 2.5, "La": 0.08, "cm": 0.2, "J": 3e-4, "Tla": 0.01, "Tlb": 1e-4, "Tlc": 1e-7}
    got = np.asarray(dcjax.simulate(p, dcjax.Recording(t=t, u_a=12.0 + u)))
    want = ref.simulate(ref.dc_field, p, t, (12.0 + u)[:, None], [0.0, 0.0], substeps=1)
    assert got.shape == (len(t), 2) and np.max(np.abs(got - want) / np.max(np.abs(want), axis=0)) <= 1e-12
    with pytest.raises(ValueError, match=r"^model dc needs channel\(s\) u_a; the recording has y "):
        dcjax.simulate(p, dcjax.Recording(t=t, y=u))


def test_measure_chooses_among_the_outputs(tmp_path):
    from output_models import TwoSensorDrive

    t, u, x = states()
    rec = dcjax.Recording(t=t, u=u, pulses=ref.abs_speed_sensor(x), w_sat=ref.saturating_sensor(x), name="two")
    obs = dcjax.Observation(measure=("pulses",), hold={"u": "zoh"})
    params = dcjax.Parameters([dcjax.Parameter(n, value=v * 1.03, min=0.7 * v, max=1.4 * v) for n, v in TRUTH.items()])
    res = dcjax.fit(rec, TwoSensorDrive(), params, search=dcjax.Search(runs=1, budget=70, polish=True), observation=obs,
                    integrator=dcjax.RK4(substeps=8))  # fmt: skip
    assert res.model.outputs == ("pulses",) and res.simulate_outputs(rec).shape == (len(t), 1)
    assert max(abs(res.best_values[n] / v - 1) for n, v in TRUTH.items()) < 1e-6
    with pytest.raises(ValueError, match=r"^measure: 'w' is not an output; model TwoSensorDrive has outputs pulses, w_sat$"):
        TwoSensorDrive().measuring("w")

    class NoEquation(dcjax.Model):  # outputs declared, their equation forgotten: one line, at the first use
        names: ClassVar[tuple[str, ...]] = ("a",)
        states: ClassVar[tuple[str, ...]] = ("x",)
        inputs: ClassVar[tuple[str, ...]] = ("u",)
        outputs: ClassVar[tuple[str, ...]] = ("y",)

        def vector_field(self, c, u, y):
            return (-c["a"] * y[0] + u[0],)

    with pytest.raises(ValueError, match=r"^model NoEquation: output\(s\) y are not states; define output\(c, u, y\) for them$"):
        dcjax.make_problem(dcjax.Recording(t=t[:5], u=u[:5], y=np.ones(5)), model=NoEquation()).model.compared({}, (), (0.0,))
