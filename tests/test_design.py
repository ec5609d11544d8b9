"""Optimal input design (`dcjax.analysis.design`): the Fisher information against finite differences of
the independent NumPy integrator, the limits a design must respect, the predicted gain over the
paper's step, the null directions, and the `dcjax design` command."""

import json
import re
from typing import ClassVar

import jax.numpy as jnp
import numpy as np
import pytest

import dcjax
from dcjax import cli, datasets
from dcjax.analysis.design import design_input, evaluate_input, information, null_parameters, predicted_stderr, template_problem
from dcjax.io.numpy_simulator import simulate_numpy

SD1 = datasets.true_params("SD1")
NAMES = dcjax.DC.names
FAST = dict(starts=3, steps=25)
TINY = dict(starts=2, steps=3)  # where the optimum does not matter (limits, null directions, errors)


def test_information_matches_finite_differences_of_the_numpy_integrator():
    t = np.arange(201) * 1e-4
    u = np.where(t < 0.01, 220.0, 0.0)
    x = np.array([SD1[n] for n in NAMES])
    sigma = np.array([0.05, 4.0])
    prob = template_problem(dcjax.DC(), SD1, t, u, None)
    F = np.asarray(information(prob, jnp.asarray(x), jnp.arange(7), jnp.asarray(sigma)))
    cols = []
    for k in range(7):  # d y / d log x_k by central differences, RK4 with 2 sub-steps (the design's)
        h = 1e-6
        up, dn = x.copy(), x.copy()
        up[k] *= np.exp(h)
        dn[k] *= np.exp(-h)
        d = (simulate_numpy(up, t, u, nd=2) - simulate_numpy(dn, t, u, nd=2)) / (2 * h)
        cols.append((d / sigma).ravel())
    S = np.column_stack(cols)
    np.testing.assert_allclose(F, S.T @ S, rtol=1e-5, atol=1e-6 * np.abs(F).max())


@pytest.mark.slow
def test_design_respects_range_hold_and_current_limit():
    d = design_input("dc", SD1, duration=0.02, dt=1e-4, u_range=(-50.0, 150.0), hold=2e-3, limit=1.5, **TINY)
    u = d.recording.u_a
    assert u.min() >= -50.0 - 1e-9 and u.max() <= 150.0 + 1e-9
    per = 20
    for k in range(0, len(u), per):
        assert np.ptp(u[k : k + per]) == 0.0  # one level per hold interval
    assert np.ptp(u[-per - 1 :]) == 0.0  # the last level lasts a full hold (and the final sample), never one sample
    assert np.max(np.abs(d.recording.i_a)) <= 1.5 + 1e-12
    assert len(d.levels) == (len(u) - 1) // per


@pytest.mark.slow
def test_design_beats_the_papers_step_in_the_prediction():
    d = design_input("dc", SD1, duration=0.05, dt=1e-4, u_range=(0.0, 220.0), hold=2.5e-3, **FAST)
    step = evaluate_input(d, "dc", np.full_like(d.recording.t, 220.0))
    for n in ("J", "Tla", "Tlb", "Tlc"):
        assert d.stderr[n] < 0.5 * step.stderr[n], n
    assert d.unidentifiable == []


@pytest.mark.slow
def test_design_against_baselines_never_worse_and_checks_their_grid():
    t = np.arange(201) * 1e-4
    coast = np.where(t < 0.008, 220.0, 0.0)
    d = design_input("dc", SD1, duration=0.02, dt=1e-4, u_range=(0.0, 220.0), hold=1e-3, baselines=[coast], **TINY)
    ref = evaluate_input(d, "dc", coast)
    assert d.value <= 0.0  # the largest log variance ratio to the baseline (the baseline itself is a start)
    assert all(d.stderr[n] <= ref.stderr[n] * (1 + 1e-9) for n in d.free)
    with pytest.raises(ValueError, match="baselines: each input must be 201 finite values"):
        design_input("dc", SD1, duration=0.02, dt=1e-4, u_range=(0.0, 220.0), baselines=[coast[:-1]], **TINY)


def test_a_parameter_the_structure_hides_is_named():
    class Product(dcjax.Model):  # only a * b enters the dynamics
        names: ClassVar = ("a", "b", "c")
        states: ClassVar = ("y",)
        inputs: ClassVar = ("u",)
        bounds: ClassVar = {"default": {"a": (0, 10), "b": (0, 10), "c": (0, 10)}}

        def vector_field(self, c, u, y):
            return (-c["a"] * c["b"] * y[0] + c["c"] * u[0],)

    d = design_input(Product(), {"a": 2.0, "b": 3.0, "c": 1.0}, duration=1.0, dt=0.01, u_range=(0, 1), hold=0.1, **TINY)
    assert set(d.unidentifiable) == {"a", "b"}
    F = np.eye(2)
    assert null_parameters(F, ("p", "q")) == []
    # ill-conditioned is not null: a 1e-11 eigenvalue is a large but finite error (a full step on a
    # motor with a slow mechanical time constant); only a numerically zero one is a null direction
    np.testing.assert_allclose(predicted_stderr(np.diag([1.0, 1e-11]), np.ones(2)), [1.0, 1e-11**-0.5])
    assert predicted_stderr(np.diag([1.0, 1e-14]), np.ones(2)).tolist() == [1.0, np.inf]


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"u_range": (1.0, 0.0)}, "u_min < u_max"),
        ({"hold": 1.0}, "hold must lie between"),
        ({"criterion": "Xa"}, "unknown parameter"),
        ({"noise": {"speed": 1.0}}, "unknown channel"),
        ({"duration": -1.0}, "duration must be a positive"),
    ],
)
def test_design_errors_are_clear(kw, match):
    args = dict(duration=0.01, dt=1e-4, u_range=(0.0, 220.0), **TINY)
    args.update(kw)
    with pytest.raises(ValueError, match=match):
        design_input("dc", SD1, **args)


@pytest.mark.slow
def test_cli_design_writes_the_three_files(tmp_path, capsys):
    assert cli.main(["fit", "SD1", "--runs", "2", "--budget", "14000", "--out", str(tmp_path / "fit")]) == 0
    args = ["design", str(tmp_path / "fit" / "result.json"), "--duration", "0.05", "--dt", "1e-4", "--umin", "0", "--umax", "220"]
    t = np.arange(501) * 1e-4
    np.savetxt(tmp_path / "coast.csv", np.column_stack([t, np.where(t < 0.02, 220.0, 0.0)]), delimiter=",", header="t,u_a", comments="")
    design = [*args, "--hold", "1e-3", "--criterion", "J,Tla,Tlb,Tlc", "--baseline", str(tmp_path / "coast.csv")]
    assert cli.main([*design, "--starts", "2", "--steps", "50", "--out", str(tmp_path / "d")]) == 0
    out = capsys.readouterr().out
    assert "predicted relative std. errors" in out and "does not beat" not in out and "never reached" not in out
    assert re.search(r"noise \(std\. dev\.\): i_a \S+ A, omega \S+ rad/s, (the fit's residuals|assumed: 1%)", out), out
    t, u = np.loadtxt(tmp_path / "d" / "input.csv", delimiter=",", skiprows=1).T
    assert len(t) == 501 and u.min() >= 0 and u.max() <= 220
    info = json.loads((tmp_path / "d" / "design.json").read_text())
    pred = info["predicted"]
    for n in ("J", "Tla", "Tlb", "Tlc"):  # below the paper's step and the hand-made coast-down in every one
        assert pred["design"][n]["stderr"] < pred["recording SD1"][n]["stderr"]
        assert pred["design"][n]["stderr"] < pred["baseline coast"][n]["stderr"]
    assert (tmp_path / "d" / "design.png").stat().st_size > 0
    assert cli.main([*args, "--hold", "1", "--out", str(tmp_path / "e")]) == 2
    reverse = [*args[:6], "--umin", "-220", "--umax", "-20", "--starts", "1", "--steps", "5", "--out", str(tmp_path / "r")]
    assert cli.main(reverse) == 0  # the model was fitted at positive speeds only: driving it backwards is a warning
    assert re.search(
        r"warning: the designed input drives omega to -\S+ rad/s, a sign the fitted recording SD1 never reached", capsys.readouterr().out
    )
