"""Prediction error (issue 56): the extended Kalman filter against the plain-NumPy filter of
`tests/reference.py` (complex-step Jacobians, its own RK4), on data with process noise from the
independent Euler–Maruyama simulator; the prediction-error fit where the disturbance is inside
the loop."""

import numpy as np
import pytest
import reference as ref

import dcjax
from dcjax.errors import ConfigError
from dcjax.io import datasets
from dcjax.simulation.kalman import kalman_filter, predict, prediction_error
from dcjax.simulation.objectives import objective
from dcjax.simulation.predictors import EKF
from dcjax.simulation.problem import make_problem

TRUTH = datasets.true_params("SD1")
Q = np.array([0.0, 4e4])  # a white load torque: omega's random walk, (rad/s)^2/s


def process_noise_record(seed: int, n: int = 600, sensor: float = 0.005, name: str = "pn") -> tuple[dcjax.Recording, np.ndarray]:
    """SD1's motor under a voltage stepped every 5 ms (held between samples), a white load-torque
    disturbance and `sensor` x peak noise on both channels: (recording, the sensors' sd)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 1e-4
    u = np.repeat(rng.uniform(40.0, 220.0, n // 50 + 1), 50)[:n]
    y = ref.simulate_sde(ref.dc_field, TRUTH, t, u[:, None], [0.0, 0.0], Q, rng, substeps=16, held=(0,))
    r = sensor * np.abs(y).max(axis=0)
    z = y + r * rng.standard_normal(y.shape)
    return dcjax.Recording(t=t, u_a=u, i_a=z[:, 0], omega=z[:, 1], name=f"{name}{seed}"), r


@pytest.mark.parametrize("substeps, held", [(1, ("u_a",)), (2, ())])
def test_the_filter_is_the_numpy_filter(substeps, held):
    """Innovations, their covariances, the filtered states and the log-likelihood equal the NumPy
    EKF's to 1e-8 at the true parameters (a held input and linear interpolation, 1 and 2 sub-steps);
    the one-step prediction is the measurement less the innovation."""
    rec, r = process_noise_record(0)
    prob = make_problem(rec, dcjax.RK4(substeps=substeps), hold={c: "zoh" for c in held}, initial={"i_a": 0.0, "omega": 0.0})
    ekf = EKF.of(prob.model, process={"omega": Q[1]}, measurement={"i_a": r[0], "omega": r[1]}, initial={"i_a": 0.01, "omega": 1.0})
    x = np.array([TRUTH[n] for n in prob.model.names])
    f = kalman_filter(x, prob, ekf)
    z = np.column_stack([rec["i_a"], rec["omega"]])
    nu, s, xs, ll = ref.extended_kalman_filter(
        ref.dc_field, lambda p, u, y: y, TRUTH, rec.t, rec["u_a"][:, None], z, [0.0, 0.0], Q, r, [0.01, 1.0],
        substeps=substeps, held=(0,) if held else (),
    )  # fmt: skip
    np.testing.assert_allclose(np.asarray(f.innovations), nu, rtol=0, atol=1e-8 * np.abs(nu).max())
    np.testing.assert_allclose(np.asarray(f.innovation_covariances), s, rtol=1e-8)
    np.testing.assert_allclose(np.asarray(f.states), xs, rtol=0, atol=1e-8 * np.abs(xs).max())
    assert float(f.log_likelihood) == pytest.approx(ll, rel=1e-8)
    np.testing.assert_allclose(np.asarray(f.predicted), z - nu, rtol=0, atol=1e-8 * np.abs(z).max())
    assert float(prediction_error(x, prob, ekf)) == pytest.approx(-ll / len(rec), rel=1e-8)
    np.testing.assert_allclose(np.asarray(predict(x, prob, ekf, 1)), np.asarray(f.predicted), rtol=0, atol=1e-12 * np.abs(z).max())
    w = np.asarray(f.normalised())  # the right model (the input held, as simulated) with the right noise: unit variance
    assert not held or np.all(np.abs(w.mean(axis=0)) < 0.15) and np.all(np.abs(w.var(axis=0) - 1) < 0.2)


def test_a_problem_with_a_filter_scores_its_likelihood_and_bad_settings_are_one_line():
    rec, r = process_noise_record(1, n=200)
    ekf = EKF.of(dcjax.DC(), process={"omega": Q[1]}, measurement={"i_a": r[0], "omega": r[1]})
    prob = make_problem(rec, hold={"u_a": "zoh"}, predictor=ekf)
    x = np.array([TRUTH[n] for n in prob.model.names])
    pop = np.stack([x, x * 1.02, np.where(np.arange(7) == 3, 0.0, x)])  # J = 0: the filter blows up
    of = np.asarray(objective(pop, prob))
    assert of[0] == pytest.approx(float(prediction_error(x, prob, ekf)), rel=1e-12) and of[1] > of[0] and of[2] == np.inf
    with pytest.raises(ConfigError, match="loss must be the default sse"):
        make_problem(rec, loss="l1", predictor=ekf)
    with pytest.raises(ConfigError, match="measurement: give every output's noise"):
        EKF.of(dcjax.DC(), measurement={"i_a": 0.1})
    with pytest.raises(ConfigError, match="process: speed is not a state"):
        EKF.of(dcjax.DC(), process={"speed": 1.0}, measurement={"i_a": 0.1, "omega": 1.0})
    with pytest.raises(ConfigError, match="needs focus='prediction'"):
        dcjax.Observation(process={"omega": "fit"})
    with pytest.raises(ConfigError, match="must be a number >= 0 or fit"):
        dcjax.Observation(focus="prediction", process={"omega": -1.0})


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_prediction_error_puts_the_truth_within_three_standard_errors(seed, tmp_path):
    """Issue 56 (a): under a load-torque disturbance the prediction-error fit (noise fitted) puts
    Ra, La, cm, J within 3 of its standard errors of the truth; its fitted noise is the simulated
    one within 20 %; at the optimum a second record's normalised innovations are white with unit
    variance (b)."""
    rec, r = process_noise_record(seed, n=1500)
    obs = dcjax.Observation(hold={"u_a": "zoh"}, focus="prediction", initial={"i_a": 0.0, "omega": 0.0})
    res = dcjax.fit(rec, params="table4", search=dcjax.Search(runs=1, budget=12_000, polish=True), observation=obs).uncertainty()
    u = res.uncertainties
    assert u is not None
    for n in ("Ra", "La", "cm", "J"):
        assert abs(res.best_values[n] - TRUTH[n]) <= 3 * u.se[n], (n, res.best_values[n], u.se[n])
    assert res.best_values["q_omega"] == pytest.approx(Q[1], rel=0.2)
    assert res.best_values["r_i_a"] == pytest.approx(r[0], rel=0.2) and res.best_values["r_omega"] == pytest.approx(r[1], rel=0.2)
    if seed == 0:
        other, _ = process_noise_record(10 + seed, n=1500, name="held-out")
        target = res.target([other])
        prob = target.problems[0]
        x = np.array([res.best_values[n] for n in res.names])
        f = kalman_filter(target.model_x(x, 0), prob, prob.predictor, target.adjustments(x, 0))  # pyright: ignore[reportArgumentType]
        w = np.asarray(f.normalised())
        assert np.all(np.abs(w.mean(axis=0)) < 0.1) and np.all(np.abs(w.var(axis=0) - 1) < 0.2), (w.mean(axis=0), w.var(axis=0))
