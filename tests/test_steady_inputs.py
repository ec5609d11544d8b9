"""Inputs given as a recording's constants are read once, not at every step (`Problem.steady`),
and a discrete-time map's scan reads no interval ends: the time loop carries only what changes.
The numbers are the reference's (`tests/reference.py`, plain NumPy) and, to the bit, those of
the same constants written out as columns, on every path of the scan: the squared error, another
loss, fitted initial states, delayed inputs, a stacked joint fit and a designed input."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import reference as ref
import test_pmsm
import test_servo

import dcjax
from dcjax.analysis.design import with_input
from dcjax.simulation.adjustments import Adjustments
from dcjax.simulation.integrate import scan_inputs
from dcjax.simulation.joint import joint_problem, stacked_target
from dcjax.simulation.objectives import objective


def _as_columns(rec: dcjax.Recording) -> dcjax.Recording:
    """The recording with its constants as channels of repeated samples."""
    cols = {**rec.channels, **{k: np.full(rec.t.shape, v) for k, v in rec.constants.items()}}
    return dcjax.Recording(t=rec.t, channels=cols, name=rec.name)


def _pmsm_problems(**kw):
    rec = test_pmsm.recording()
    init = {"id": 0.0, "iq": 0.0, "omega": 0.0}
    return [dcjax.make_problem(r, dcjax.RK4(substeps=4), model="pmsm", initial=init, **kw) for r in (rec, _as_columns(rec))]


def test_an_ode_models_constants_are_read_once_and_simulate_as_the_reference():
    steady, columns = _pmsm_problems()
    assert steady.steady == (2, 3) and columns.steady == () and steady.varying == (0, 1)
    assert scan_inputs(steady).shape[1] == 1 + 2 * 2 and scan_inputs(columns).shape[1] == 1 + 2 * 4  # h, ud, uq at both ends
    x = np.array([test_pmsm.TRUTH[n] for n in dcjax.PMSM.names])
    sim = np.asarray(dcjax.simulate(x, steady))
    rec = test_pmsm.recording()
    u = np.column_stack([rec["ud"], rec["uq"], np.full(len(rec), 4.0), np.full(len(rec), 0.02)])
    want = ref.simulate(test_pmsm.field, test_pmsm.TRUTH, rec.t, u, np.zeros(3), substeps=64)
    assert np.max(np.abs(sim - want) / np.max(np.abs(want), axis=0)) < 1e-8
    np.testing.assert_array_equal(sim, np.asarray(dcjax.simulate(x, columns)))


@pytest.mark.parametrize("loss", ["sse", pytest.param("l1", marks=pytest.mark.slow)])
def test_every_scan_path_gives_the_bits_of_the_constants_as_columns(loss):
    steady, columns = _pmsm_problems(loss=loss)
    rng = np.random.default_rng(0)
    x = np.array([test_pmsm.TRUTH[n] for n in dcjax.PMSM.names]) * rng.uniform(0.8, 1.2, (9, 6))
    for adj in (None, Adjustments(y0=jnp.full((9, 3), 0.01)), Adjustments(delay=jnp.asarray([1.7e-4, 0.0, 0.0, 0.0]), delayed=(0,))):
        a, b = np.asarray(objective(x, steady, adj)), np.asarray(objective(x, columns, adj))
        assert np.all(np.isfinite(a)) and np.all(a > 0)
        np.testing.assert_array_equal(a, b)
    delayed = Adjustments(delay=jnp.asarray([1.7e-4, 0.0, 0.0, 0.0]), delayed=(0,))
    assert not np.array_equal(np.asarray(objective(x, steady, delayed)), np.asarray(objective(x, steady)))  # the delay acts


def test_a_discrete_maps_scan_reads_the_goal_alone_and_a_stack_sums_as_the_recordings():
    setups = [test_servo.SETUP, {"kp": 16.0, "vin": 12.0, "m": 1.5, "l": 0.2, "m_a": 0.1}, {**test_servo.SETUP, "m": 1.0}]
    recs = [test_servo.recording(s, n=300)[0] for s in setups]
    init = {"q": "measured", "dq": 0.0}
    obs = dcjax.Observation(loss=dcjax.L1(normalize="none"), initial=init)
    probs = [dcjax.make_problem(r, None, model="servo", loss=obs.loss, initial={"q": float(r["q"][0]), "dq": 0.0}) for r in recs]
    cols = [dcjax.make_problem(_as_columns(r), None, model="servo", loss=obs.loss, initial={"q": float(r["q"][0]), "dq": 0.0})
            for r in recs]  # fmt: skip
    assert probs[0].steady == (1, 2, 3, 4, 5) and not probs[0].reads_ends and scan_inputs(probs[0]).shape[1] == 2  # h, q_goal
    assert scan_inputs(cols[0]).shape[1] == 1 + 6
    x = np.array([test_servo.TRUTH[n] for n in dcjax.Servo.names]) * np.random.default_rng(1).uniform(0.7, 1.3, (5, 5))
    singles = [np.asarray(objective(x, p)) for p in probs]
    for c, s in zip(cols, singles):
        np.testing.assert_array_equal(s, np.asarray(objective(x, c)))
    y = ref.iterate(ref.servo_m1_map, dict(zip(dcjax.Servo.names, x[0])), recs[0].t,
                    np.column_stack([recs[0]["q_goal"]] + [np.full(300, setups[0][k]) for k in ("kp", "vin", "m", "l", "m_a")]),
                    [recs[0]["q"][0], 0.0])  # fmt: skip
    assert singles[0][0] == pytest.approx(np.mean(np.abs(y[:, 0] - recs[0]["q"])), rel=1e-10)  # the reference's mean |error|
    w = (0.5, 0.3, 0.2)
    stacked = stacked_target(joint_problem(probs, w))
    assert type(stacked).__name__ == "StackedJoint"
    np.testing.assert_allclose(np.asarray(stacked.objective(jnp.asarray(x))), sum(wi * s for wi, s in zip(w, singles)), rtol=1e-14)


def test_a_designed_input_that_was_a_constant_is_read_at_every_step():
    steady, columns = _pmsm_problems()
    load = jnp.asarray(0.02 + 0.01 * np.sin(np.arange(steady.n) * 0.05))
    on_device = lambda p: jax.tree.map(jnp.asarray, p)  # as the design's problems are
    a, b = with_input(on_device(steady), load, (3,)), with_input(on_device(columns), load, (3,))
    assert a.steady == (2,)
    x = np.array([test_pmsm.TRUTH[n] for n in dcjax.PMSM.names])
    np.testing.assert_array_equal(np.asarray(dcjax.simulate(x, a)), np.asarray(dcjax.simulate(x, b)))
    assert not np.array_equal(np.asarray(dcjax.simulate(x, a)), np.asarray(dcjax.simulate(x, steady)))
    assert dataclasses.replace(a, steady=()).steady == ()
