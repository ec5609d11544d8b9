"""Prediction error (issue 56): the extended Kalman filter against the plain-NumPy filter of
`tests/reference.py` (complex-step Jacobians, its own RK4), on data with process noise from the
independent Euler–Maruyama simulator; the prediction-error fit where the disturbance is inside
the loop."""

import json

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import reference as ref

import dcjax
from dcjax import cli
from dcjax.errors import ConfigError
from dcjax.io import datasets
from dcjax.simulation import unrolled as um
from dcjax.simulation.kalman import kalman_filter, predict, prediction_error
from dcjax.simulation.objectives import objective
from dcjax.simulation.predictors import EKF
from dcjax.simulation.problem import make_problem

TRUTH = datasets.true_params("SD1")
Q = np.array([0.0, 4e4])  # a white load torque: omega's random walk, (rad/s)^2/s
SENSORS = (0.012, 2.2)  # the sensors' sd (A, rad/s): the same for every record


def process_noise_record(seed: int, n: int = 600, name: str = "pn") -> tuple[dcjax.Recording, np.ndarray]:
    """SD1's motor under a voltage stepped every 5 ms (held between samples), a white load-torque
    disturbance and the sensors' noise (`SENSORS`, about 0.5 % of the peaks): (recording, their sd)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 1e-4
    u = np.repeat(rng.uniform(40.0, 220.0, n // 50 + 1), 50)[:n]
    y = ref.simulate_sde(
        ref.dc_field, TRUTH, t, u[:, None], [0.0, 0.0], Q, rng, substeps=128, held=(0,)
    )  # Euler–Maruyama: fine, or its own error biases La
    r = np.asarray(SENSORS)
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
    if held:  # three steps ahead: the NumPy filter's state at i - 3 carried over three held intervals
        u = rec["u_a"]
        ahead = [
            ref.rk4_interval(ref.dc_field, TRUTH, xs[i - 3], [u[i - 3]], [u[i - 3]], rec.t[i - 2] - rec.t[i - 3], substeps)
            for i in range(3, 60)
        ]
        for k, i in enumerate(range(3, 60)):
            for j in (1, 2):
                ahead[k] = ref.rk4_interval(
                    ref.dc_field, TRUTH, ahead[k], [u[i - 3 + j]], [u[i - 3 + j]], rec.t[i - 2 + j] - rec.t[i - 3 + j], substeps
                )
        np.testing.assert_allclose(np.asarray(predict(x, prob, ekf, 3))[3:60], np.array(ahead), rtol=0, atol=1e-8 * np.abs(z).max())
    w = np.asarray(f.whitened)  # the right model (the input held, as simulated) with the right noise: unit variance
    assert not held or np.all(np.abs(w.mean(axis=0)) < 0.15) and np.all(np.abs(w.var(axis=0) - 1) < 0.2)


def test_the_written_out_ldl_solves_as_numpy_does():
    """The filter's square-root-free factorisation S = L D L' (`unrolled.ldl`): S^-1 b and det S
    as NumPy's, an indefinite S not `positive`; a covariance carried as its upper triangle comes
    back whole."""
    rng = np.random.default_rng(0)
    for n in (1, 2, 3):
        a = rng.standard_normal((n, n))
        s = a @ a.T + 0.1 * np.eye(n)
        b = rng.standard_normal(n)
        m = tuple(tuple(np.float64(s[i, j]) for j in range(n)) for i in range(n))
        f = um.ldl(m)
        np.testing.assert_allclose(np.array(um.solve(f, tuple(b))), np.linalg.solve(s, b), rtol=1e-10)
        assert float(np.prod(f.d)) == pytest.approx(np.linalg.det(s), rel=1e-10) and bool(um.positive(f))
        assert um.from_upper(um.upper(m), n) == m
    assert not bool(um.positive(um.ldl(((1.0, 2.0), (2.0, 1.0))))) and not bool(um.positive(um.ldl(((-1.0, 0.0), (0.0, -1.0)))))


def test_the_determinants_product_is_carried_exactly_and_differentiates():
    """`_renormalised` (the filter's log det S sum as the log of a product): m = mantissa
    2^exponent exactly, the mantissa in [1, 2) and differentiating as m / 2^exponent, across
    the range the filter admits; a product of 3,000 determinants far from 1 gives NumPy's sum of
    their logs."""
    from dcjax.simulation.kalman import _renormalised

    rng = np.random.default_rng(1)
    m = np.concatenate([2.0 ** rng.uniform(-1000, 1001, 500), [2.0**-1000, 1.0, 1.5, 2.0**1000, np.nextafter(2.0**1001, 0.0)]])
    mantissa, exponent = (np.asarray(a) for a in _renormalised(jnp.asarray(m)))
    assert np.all((mantissa >= 1.0) & (mantissa < 2.0)) and np.array_equal(np.ldexp(mantissa, exponent), m)
    grads = np.asarray(jax.vmap(jax.grad(lambda v: _renormalised(v)[0]))(jnp.asarray(m)))
    assert np.array_equal(grads, np.ldexp(1.0, -exponent))
    dets = 10.0 ** rng.uniform(-40, 40, 3000)

    def carry(c, d):
        mantissa, exponent = _renormalised(c[0] * d)
        return (mantissa, c[1] + exponent), None

    (carried, total), _ = jax.lax.scan(carry, (jnp.asarray(1.0), jnp.asarray(0)), jnp.asarray(dets))
    assert float(jnp.log(carried) + total * np.log(2.0)) == pytest.approx(np.sum(np.log(dets)), rel=1e-12)


@pytest.mark.slow  # 5 s of compiling; the fast run fits no filter
def test_the_filters_gradient_in_forward_mode_is_reverse_modes():
    """`dcjax.gradients.forward_gradient` (what a short prediction-error polish and the noise fit
    differentiate: P forward tangents, whatever mode the solver asks for) gives reverse mode's
    gradient of the filter's likelihood on the NumPy reference's record, jitted and vmapped over
    starts, and `forward_mode` takes it only below `FORWARD_WORK`."""
    from dcjax.gradients import FORWARD_WORK, forward_gradient, forward_mode

    rec, r = process_noise_record(2, n=60)
    ekf = EKF.of(dcjax.DC(), process={"omega": Q[1]}, measurement={"i_a": r[0], "omega": r[1]})
    prob = make_problem(rec, hold={"u_a": "zoh"}, predictor=ekf)
    x = np.array([TRUTH[n] for n in prob.model.names])

    def nll(z):  # of a relative step from the truth, as the polish's unbounded variable
        return prediction_error(jnp.asarray(x) * (1.0 + z), prob, ekf)

    starts = jnp.asarray(np.random.default_rng(0).uniform(-0.02, 0.02, (2, 7)))
    reverse = jax.jit(jax.vmap(jax.value_and_grad(nll)))(starts)
    forward = jax.jit(jax.vmap(jax.value_and_grad(forward_gradient(nll))))(starts)
    np.testing.assert_array_equal(forward[0], reverse[0])
    np.testing.assert_allclose(forward[1], reverse[1], rtol=1e-9, atol=1e-9 * float(jnp.max(jnp.abs(reverse[1]))))
    assert float(jnp.max(jnp.abs(reverse[1]))) > 1.0  # away from the optimum: a gradient to compare
    assert forward_mode(7, int(FORWARD_WORK) // 7 - 1) and not forward_mode(7, int(FORWARD_WORK) // 7 + 1)


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
def test_prediction_error_puts_the_truth_within_three_standard_errors(tmp_path, capsys):
    """Issue 56 (a), one seed here (30 in `experiments/bench_prediction.py`): under a load-torque
    disturbance the prediction-error fit through the CLI (noise fitted) puts Ra, La, cm, J within 3
    of its standard errors of the truth, and its fitted noise is the simulated one within 20 %;
    (b) at the optimum a second record's normalised innovations have mean within 0.1 and variance
    within 20 % of 1, and `validate --predict` prints them with the one-step prediction's figures."""
    rec, r = process_noise_record(0, n=1000)
    dcjax.save_csv(rec, tmp_path / "pn.csv")
    other, _ = process_noise_record(10, n=1000, name="held-out")
    dcjax.save_csv(other, tmp_path / "other.csv")
    argv = ["fit", str(tmp_path / "pn.csv"), "--focus", "prediction", "--hold", "u_a=zoh", "--bounds", "table4", "--initial", "i_a=0,omega=0",
            "--runs", "1", "--budget", "6000", "--polish", "--uncertainty", "--plots", "none", "--out", str(tmp_path / "fit")]  # fmt: skip
    assert cli.main(argv) == 0
    text = capsys.readouterr().out
    assert (
        "focus prediction: EKF (the innovations' -log L / N); process noise q_i_a, q_omega fitted; sensor noise r_i_a, r_omega fitted"
        in text
    )
    res = dcjax.load_result(tmp_path / "fit" / "result.json").uncertainty()
    u = res.uncertainties
    assert u is not None and res.observation.focus == "prediction"
    for n in ("Ra", "La", "cm", "J"):
        assert abs(res.best_values[n] - TRUTH[n]) <= 3 * u.se[n], (n, res.best_values[n], u.se[n])
    assert res.best_values["q_omega"] == pytest.approx(Q[1], rel=0.2) and np.isfinite(u.se["q_omega"])
    assert res.best_values["r_i_a"] == pytest.approx(r[0], rel=0.2) and res.best_values["r_omega"] == pytest.approx(r[1], rel=0.2)
    (v,) = res.validate([other], predict=1)
    for c, k in (v.calibration or {}).items():
        assert abs(k["mean"]) < 0.1 and abs(k["variance"] - 1) < 0.2, (c, k)
    assert not v.noise_estimated and v.noise is not None and v.noise["q_omega"] == res.best_values["q_omega"]
    assert (
        cli.main(
            ["validate", str(tmp_path / "fit" / "result.json"), str(tmp_path / "other.csv"), "--predict", "1", "--out", str(tmp_path / "v")]
        )
        == 0
    )
    text = capsys.readouterr().out
    assert "1-step-ahead prediction" in text and "normalised innovations (N(0, 1) and white for a right model): i_a mean" in text
    row = json.loads((tmp_path / "v" / "validation.json").read_text())[0]
    assert row["predict"] == 1 and set(row["calibration"]) == {"i_a", "omega"}
    simulated = res.validate([other])[0].channels["omega"]["rmse"]
    assert v.channels["omega"]["rmse"] < 0.5 * simulated  # the filter's one-step prediction beats the open-loop simulation


@pytest.mark.slow
def test_a_joint_fit_held_stacked_polishes_and_records_the_likelihood():
    """Two records of equal length with the noise given and nothing adjusted are held stacked
    (`StackedJoint`): their polish is still BFGS on the likelihood, and the OF recorded is the
    target's -log L / N (not a least-squares cost of whitened innovations)."""
    recs = [process_noise_record(s, n=300, name=f"r{s}")[0] for s in (0, 1)]
    obs = dcjax.Observation(hold={"u_a": "zoh"}, focus="prediction", initial={"i_a": 0.0, "omega": 0.0},
                            process={"i_a": 0.0, "omega": Q[1]}, measurement={"i_a": SENSORS[0], "omega": SENSORS[1]})  # fmt: skip
    res = dcjax.fit(recs, params="table4", search=dcjax.Search(runs=1, budget=600, polish=True), observation=obs)
    x = np.array([res.best_values[n] for n in res.names])
    assert res.of == pytest.approx(float(res.target().objective(x)), rel=1e-9, abs=1e-12)
    assert res.polish is not None and res.polish["of_after"][0] <= res.polish["of_before"][0]


@pytest.mark.slow
def test_nuts_samples_the_filters_likelihood_with_its_noise():
    """Item 2's last part: `sample` of a prediction-error fit draws from the filter's likelihood
    (its objective weighted by each recording's samples: the whole -log L), the noise sampled with
    the parameters; on a short record the 90 % posterior intervals of Ra, La, cm, J and of the
    sensors' sd hold the truth."""
    from dcjax.simulation.likelihood import filter_likelihood

    rec, _ = process_noise_record(3, n=250)
    obs = dcjax.Observation(hold={"u_a": "zoh"}, focus="prediction", initial={"i_a": 0.0, "omega": 0.0})
    res = dcjax.fit(rec, params="table4", search=dcjax.Search(runs=1, budget=3000, polish=True), observation=obs)
    likelihood, noise = filter_likelihood(res.target())
    assert likelihood.weights == (250.0,) and float(noise.active.sum()) == 0.0
    post = res.sample(draws=120, warmup=100, chains=1, seed=0)
    assert post.likelihood == "Kalman filter (Gaussian innovations)" and post.noise == {}
    draws = post.draws.reshape(-1, len(post.names))
    truth = {**TRUTH, "r_i_a": SENSORS[0], "r_omega": SENSORS[1]}
    for n in ("Ra", "La", "cm", "J", "r_i_a", "r_omega"):
        lo, hi = np.quantile(draws[:, post.names.index(n)], [0.05, 0.95])
        assert lo <= truth[n] <= hi, (n, lo, hi, truth[n])


@pytest.mark.slow
def test_track_follows_a_resistance_that_rises_by_a_fifth(tmp_path, capsys):
    """Issue 56 (c): Ra rising 20 % linearly through the record (the NumPy reference, no process
    noise, 0.5 % sensor noise), the other parameters known: `dcjax track --vary Ra` follows it
    within 2 % RMS over the second half; track.csv holds t, Ra and Ra_sd."""
    rng = np.random.default_rng(0)
    n = 3000
    t = np.arange(n) * 1e-4
    u = np.repeat(rng.uniform(40.0, 220.0, n // 50 + 1), 50)[:n]
    ra = TRUTH["Ra"] * (1 + 0.2 * t / t[-1])
    y = ref.simulate(lambda p, v, x: ref.dc_field({**p, "Ra": v[1]}, v[:1], x), TRUTH, t, np.column_stack([u, ra]), [0.0, 0.0], substeps=16)
    z = y + 0.005 * np.abs(y).max(axis=0) * rng.standard_normal(y.shape)
    rec = dcjax.Recording(t=t, u_a=u, i_a=z[:, 0], omega=z[:, 1], name="ramp")
    dcjax.save_csv(rec, tmp_path / "ramp.csv")
    known = ",".join(f"{k}={TRUTH[k]!r}" for k in ("La", "cm", "J", "Tla", "Tlb", "Tlc"))
    argv = ["fit", str(tmp_path / "ramp.csv"), "--bounds", "table4", "--fix", known, "--initial", "i_a=0,omega=0", "--runs", "1",
            "--budget", "600", "--polish", "--plots", "none", "--out", str(tmp_path / "fit")]  # fmt: skip
    assert cli.main(argv) == 0
    assert (
        cli.main(
            ["track", str(tmp_path / "fit" / "result.json"), str(tmp_path / "ramp.csv"), "--vary", "Ra", "--out", str(tmp_path / "tr")]
        )
        == 0
    )
    out = capsys.readouterr()
    assert "Ra: " in out.out and "goes below 0" not in out.err and (tmp_path / "tr" / "track.png").stat().st_size > 0
    data = np.genfromtxt(tmp_path / "tr" / "track.csv", delimiter=",", names=True)
    half = slice(n // 2, None)
    rms = np.sqrt(np.mean(((data["Ra"][half] - ra[half]) / ra[half]) ** 2))
    assert rms < 0.02 and np.all(data["Ra_sd"] > 0), rms
    assert np.mean(np.abs(data["Ra"][half] - ra[half]) <= 3 * data["Ra_sd"][half]) > 0.9  # the band holds the truth
    # another motor (cm halved) that the fit does not follow: Ra goes negative to take up the
    # model's error, which is no drift: a one-line warning (it printed the track as any other)
    y = ref.simulate(lambda p, v, x: ref.dc_field({**p, "Ra": v[1]}, v[:1], x), {**TRUTH, "cm": TRUTH["cm"] / 2}, t, np.column_stack([u, ra]),
                     [0.0, 0.0], substeps=16)  # fmt: skip
    dcjax.save_csv(dcjax.Recording(t=t, u_a=u, i_a=y[:, 0], omega=y[:, 1], name="other"), tmp_path / "other.csv")
    argv = ["track", str(tmp_path / "fit" / "result.json"), str(tmp_path / "other.csv"), "--vary", "Ra", "--out", str(tmp_path / "tr2")]
    assert cli.main(argv) == 0
    err = capsys.readouterr().err
    lowest = np.genfromtxt(tmp_path / "tr2" / "track.csv", delimiter=",", names=True)["Ra"].min()
    assert lowest < 0 and f"track: Ra goes below 0 on other (to {lowest:.4g} at t = " in err and err.count("\n") == 1, err
