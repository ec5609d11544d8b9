"""An input held between samples (`Observation(hold={"u_a": "zoh"})`, `dcjax fit --hold u_a=zoh`):
the simulation equals the independent NumPy reference's zero-order hold, delayed or not, for an ODE
and a discrete-time model; the option is checked, recorded and taken by `--nd auto`."""

import numpy as np
import pytest
import reference as ref
from matrix_models import EulerDC

import dcjax
from dcjax.fitting.planning import plan
from dcjax.simulation.adjustments import Adjustments
from dcjax.simulation.integrate import simulate_scan

TRUTH = dict(Ra=42.5, La=0.08, cm=0.4781, J=2e-5, Tla=0.01, Tlb=3.27e-5, Tlc=8.55e-8)
DT = 1e-4


def _stepped(n=120):
    t = np.arange(n) * DT
    u = np.empty(n)
    for k, (a, b) in enumerate(zip([0, 12, 40, 80], [12, 40, 80, n])):
        u[a:b] = (60.0, 220.0, 120.0, 180.0)[k]
    return t, u, dcjax.Recording(t=t, u_a=u, i_a=np.ones(n), omega=np.ones(n))


@pytest.mark.parametrize("delay", [0.0, 2.5 * DT], ids=["undelayed", "delayed"])
def test_a_held_input_equals_the_references_zero_order_hold(delay):
    t, u, rec = _stepped()
    x = dcjax.DC().as_array(TRUTH)
    adj = Adjustments(delay=np.array([delay]), delayed=(0,))
    start = {"i_a": 0.0, "omega": 0.0}
    for hold, held in (({"u_a": "zoh"}, (0,)), ({}, ())):
        y = ref.simulate(ref.dc_field, TRUTH, t, u[:, None], np.zeros(2), substeps=8, delays=np.array([delay]), held=held)
        prob = dcjax.make_problem(rec, dcjax.RK4(substeps=8), model=dcjax.DC(), initial=start, hold=hold)
        sim = np.asarray(simulate_scan(x, prob, adj))
        # delayed, dcjax splits the interval at the step (two pieces of 8 sub-steps), the reference
        # takes 8 equal sub-steps with the step on one's boundary: equal to RK4's error (~4e-12)
        assert np.max(np.abs(sim - y) / np.max(np.abs(y), axis=0)) < 1e-10, hold
        yd = ref.iterate(ref.dc_euler_map, TRUTH, t, u[:, None], np.zeros(2), delays=np.array([delay]), held=held)
        simd = np.asarray(simulate_scan(x, dcjax.make_problem(rec, model=EulerDC(), initial=start, hold=hold), adj))
        assert np.max(np.abs(simd - yd) / np.max(np.abs(yd), axis=0)) < 1e-12, hold
    linear = ref.simulate(ref.dc_field, TRUTH, t, u[:, None], np.zeros(2), substeps=8, delays=np.array([delay]))
    held_sim = np.asarray(simulate_scan(x, dcjax.make_problem(rec, dcjax.RK4(substeps=8), model=dcjax.DC(), initial=start,
                                                               hold={"u_a": "zoh"}), adj))  # fmt: skip
    assert np.max(np.abs(held_sim - linear)) > 1.0  # the hold matters: the two readings differ by rad/s


def test_hold_is_checked_recorded_and_taken_by_nd_auto():
    obs = dcjax.Observation(hold={"u_a": "ZOH"})
    assert obs.hold == {"u_a": "zoh"} and not obs.plain
    assert dcjax.Observation.from_settings(obs.to_dict()).hold == {"u_a": "zoh"}
    assert dcjax.Observation(hold={"u_a": "linear"}).plain  # the default said aloud
    with pytest.raises(ValueError, match=r"^hold must be an input -> linear\|zoh mapping, got \{'u_a': 'step'\}$"):
        dcjax.Observation(hold={"u_a": "step"})
    with pytest.raises(ValueError, match=r"^hold: uq is not an input of model dc \(u_a\)$"):
        plan("dc", observation=dcjax.Observation(hold={"uq": "zoh"}))
    _, _, rec = _stepped(40)
    p = plan("dc", observation=obs, integrator=dcjax.AutoSubsteps())
    assert p.setup([rec], "table4").problems[0].held == (0,)  # nd auto's reference holds it too (tests/test_matrix.py)
