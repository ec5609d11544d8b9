"""The engine in the typed vocabulary: integrators and memories carry their behaviour, the strategy
object's settings are the ones recorded, errors are not swallowed, and the 0.1 names warn."""

import dataclasses
import re
import warnings
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest

import dcjax
from dcjax import datasets
from dcjax.fitting.polish import polish
from dcjax.strategies import DERand1Exp

ROOT = Path(__file__).resolve().parent.parent
SMALL = dict(search=dcjax.Search(runs=2, budget=1400, seed=3))


class MyEuler(dcjax.Integrator):
    """Forward Euler written by a user."""

    def step(self, field, y, u0, u1, h):
        return tuple(a + h * b for a, b in zip(y, field(u0, y)))


def test_a_users_euler_gives_the_bits_of_euler(sd1):
    a = dcjax.fit(sd1, params="table4", integrator=MyEuler(substeps=2), **SMALL)
    b = dcjax.fit(sd1, params="table4", integrator=dcjax.Euler(substeps=2), **SMALL)
    np.testing.assert_array_equal(a.run_params, b.run_params)
    np.testing.assert_array_equal(a.run_of, b.run_of)
    assert a.settings["integrator"] == f"{__name__}:MyEuler" and b.settings["integrator"] == "euler"
    np.testing.assert_array_equal(a.simulate(), b.simulate())  # the result keeps its integrator object


def test_integrator_errors_are_one_line(sd1):
    with pytest.raises(ValueError, match="substeps must be a positive integer"):
        dcjax.RK4(substeps=0)
    with pytest.raises(ValueError, match="integrator must be dcjax.Euler"):
        dcjax.fit(sd1, integrator="rk4", **SMALL)  # pyright: ignore[reportArgumentType]
    with pytest.raises(TypeError):
        dcjax.Integrator()  # abstract: no step  # pyright: ignore[reportAbstractUsage]


def test_the_strategy_objects_pop_size_is_recorded_with_its_duplicate_share(sd1):
    r = dcjax.fit(sd1, params="table4", search=dcjax.Search(DERand1Exp(pop_size=40), runs=2, budget=2000, seed=1, memory=dcjax.STMA()))
    assert r.settings["pop_size"] == 40 and r.settings["method"] == "de-rand-1-exp"
    expect = 100 * np.mean(r.dups / (40 * (r.iterations + 1)))
    assert r.duplicates is not None and r.duplicates["percent"] == pytest.approx(expect)


@pytest.mark.slow
def test_a_polish_stopped_at_its_step_limit_is_not_success(sd1):
    prob = dcjax.make_problem(sd1)
    space = dcjax.make_space(dcjax.DC(), dcjax.Bounds(*dcjax.DC().bound_arrays("table4"), dcjax.DC.names))
    x = jnp.asarray([40.0, 0.07, 0.45, 2.2e-5, 0.02, 3e-5, 8e-8])
    short = polish(x, prob, space, max_steps=2)
    assert not bool(short.converged) and float(short.of_after) <= float(short.of_before)
    r = dcjax.fit(sd1, params="table4", search=dcjax.Search(runs=2, budget=1400, seed=3, polish=True))
    assert r.polish is not None and len(r.polish["converged"]) == 2
    stopped = dataclasses.replace(r, polish={**r.polish, "converged": [False, True]})
    assert r.success == all(r.polish["converged"]) and not stopped.success
    assert "stopped at its step limit" in stopped.message


def test_the_batched_fit_each_raises_what_is_not_a_recordings_own_failure(sd1, monkeypatch):
    import dcjax.fitting.engine as engine

    def broken(*a, **k):
        raise RuntimeError("the compiled call broke")

    monkeypatch.setattr(engine, "run_setups", broken)
    with pytest.raises(RuntimeError, match="the compiled call broke"):
        dcjax.fit_each([sd1, sd1], params="table4", **SMALL)


@pytest.mark.slow
def test_the_package_paths_use_no_deprecated_name(tmp_path):
    """fit, fit_each, uncertainty and the CLI commands with dcjax's DeprecationWarnings as errors
    (the reproduction and the notebooks run so in their own tests)."""
    from dcjax.cli import main

    with warnings.catch_warnings():
        warnings.filterwarnings("error", message=".*deprecated since dcjax", category=DeprecationWarning)
        r = dcjax.fit(datasets.load("SD1"), search=dcjax.Search(runs=2, budget=700)).uncertainty()
        r.report()
        dcjax.fit_each([datasets.load("SD1"), datasets.load("SD2")], search=dcjax.Search(runs=1, budget=700))
        assert main(["fit", "SD1", "--runs", "2", "--budget", "700", "--memory", "stma", "--out", str(tmp_path)]) == 0
        assert main(["validate", str(tmp_path / "result.json"), "SD2", "--out", str(tmp_path / "v")]) == 0
        assert main(["simulate", str(tmp_path / "result.json"), "SD2", "--out", str(tmp_path / "s")]) == 0
        assert main(["report", str(tmp_path / "result.json")]) == 0


@pytest.mark.parametrize(
    "page",
    [
        "own-strategy.md",
        "own-integrator.md",
        pytest.param("pmsm.md", marks=pytest.mark.slow),
        pytest.param("servo.md", marks=pytest.mark.slow),
    ],
)
def test_guide_examples_run(page):
    """The complete examples of the guide pages 'Your own strategy', 'Your own integrator' and the PMSM's and the servo's."""
    text = (ROOT / "docs" / "guide" / page).read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        exec(compile("\n".join(blocks), page, "exec"), {"__name__": f"guide_{page[:-3].replace('-', '_')}"})
