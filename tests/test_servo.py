"""The built-in servo (`dcjax.Servo`, `--model servo`: BAM's m1 actuator on a pendulum, a
discrete-time map) against the independent NumPy map (`tests/reference.py`, written from the BAM
paper's description without dcjax): its trajectories, a fit that recovers the truth, `design` and
the CLI with its per-recording constants."""

import numpy as np
import pytest
import reference as ref

import dcjax
from dcjax import cli

TRUTH = dict(kt=1.6, R=2.2, armature=0.008, friction_base=0.05, friction_viscous=0.03)
SETUP = {"kp": 32.0, "vin": 15.0, "m": 0.5, "l": 0.15, "m_a": 0.05}
DT = 0.01


def recording(setup=SETUP, n: int = 600) -> tuple[dcjax.Recording, np.ndarray]:
    """Goal steps, then a sine: the duty saturates after each step, the joint sticks near rest."""
    t = DT * np.arange(n)
    goal = np.where(t < 1.5, 1.2, np.where(t < 3.0, -0.6, 0.0)) + 0.4 * np.sin(2 * np.pi * 0.7 * t) * (t > 4.0)
    u = np.column_stack([goal] + [np.full_like(t, setup[k]) for k in ("kp", "vin", "m", "l", "m_a")])
    y = ref.iterate(ref.servo_m1_map, TRUTH, t, u, [0.0, 0.0])
    return dcjax.Recording(t=t, channels={"q_goal": goal, "q": y[:, 0]}, constants=setup, name="servo"), y


@pytest.mark.parametrize("setup", [SETUP, {"kp": 16.0, "vin": 12.0, "m": 1.5, "l": 0.2, "m_a": 0.1}])
def test_trajectories_equal_the_numpy_reference(setup):
    rec, y = recording(setup)
    model = dcjax.get_model("servo")
    assert isinstance(model, dcjax.Servo) and dcjax.models.model_spec(model) == "servo"
    sim = np.asarray(dcjax.simulate(TRUTH, dcjax.make_problem(rec, None, model=model, initial={"q": 0.0, "dq": 0.0})))
    assert np.max(np.abs(sim - y) / np.max(np.abs(y), axis=0)) < 1e-10
    duty = setup["kp"] * 0.158 * (rec["q_goal"] - y[:, 0])
    assert np.any(np.abs(duty) > 0.9625) and np.any(np.abs(duty) < 0.9625)  # clipped and not
    assert np.sum(y[1:, 1] == 0.0) > 0  # the sticking branch stops the joint exactly


def test_the_firmware_constants_are_fields():
    rec, y = recording()
    slow = dcjax.Servo(error_gain=0.079)  # half the loop gain: a different trajectory, the same parameters
    sim = np.asarray(dcjax.simulate(TRUTH, dcjax.make_problem(rec, None, model=slow, initial={"q": 0.0, "dq": 0.0})))
    assert np.max(np.abs(sim[:, 0] - y[:, 0])) > 1e-3
    assert set(slow.derived(TRUTH)) == {"torque per volt kt/R", "back-EMF damping kt^2/R"}


@pytest.mark.slow
def test_a_fit_recovers_the_truth_and_design_and_the_cli_run(tmp_path):
    rec, _ = recording()  # the API's fit: the guide page's example (test_engine)
    # moving, the back-EMF kt^2/R dq and the viscous friction Fv dq act alike: a design needs R known
    d = dcjax.design_input(dcjax.Servo(), TRUTH, duration=6.0, dt=DT, u_range={"q_goal": (-1.5, 1.5)}, hold=0.5, given=SETUP,
                           fixed=("R",), starts=2, steps=20)  # fmt: skip
    assert d.inputs == ("q_goal",) and d.unidentifiable == [] and all(np.isfinite(v) for v in d.stderr.values())
    path = tmp_path / "swing.csv"
    np.savetxt(path, np.column_stack([rec.t, rec["q_goal"], rec["q"]]), delimiter=",", header="t,q_goal,q", comments="")
    out = tmp_path / "out"
    assert cli.main(["fit", str(path), "--model", "servo", "--const", "kp=32,vin=15,m=0.5,l=0.15,m_a=0.05", "--initial", "dq=0",
                     "--runs", "1", "--out", str(out)]) == 0  # fmt: skip
    back = dcjax.load_result(out / "result.json")
    assert max(abs(back.best_values[n] / v - 1) for n, v in TRUTH.items()) < 1e-6
    assert "back-EMF damping kt^2/R" in back.report()
