"""Discrete-time models (issue 28, item 4): `update(c, u, y, dt) -> y_next` instead of a vector
field; no integrator applies."""

import numpy as np
import pytest

import dcjax
from dcjax import cli, datasets
from dcjax.models.dc import vector_field


class EulerDC(dcjax.DiscreteModel):
    """The paper's DC motor as its forward-Euler map from one sample to the next (eq. 11-12)."""

    names = dcjax.DC.names
    units = dcjax.DC.units
    states = ("i_a", "omega")
    inputs = ("u_a",)
    limited_state = "i_a"
    quantities = dcjax.DC.quantities

    def presets(self):
        return dcjax.DC().presets()

    def coefficients(self, p):
        return dcjax.DC().coefficients(p)

    def update(self, c, u, y, dt):
        di, dw = vector_field(c, u[0], y[0], y[1])
        return (y[0] + dt * di, y[1] + dt * dw)


@pytest.mark.slow
def test_a_discrete_model_gives_the_trajectory_and_the_fit_of_the_euler_ode_with_one_substep():
    md = datasets.load("MD1")  # a recorded voltage and a current limit
    truth = dict(Ra=9.0, La=0.1, cm=0.5, J=0.02, Tla=1.0, Tlb=0.01, Tlc=1e-5)
    ode = np.asarray(dcjax.simulate(truth, dcjax.make_problem(md, dcjax.Euler())))
    disc = np.asarray(dcjax.simulate(truth, dcjax.make_problem(md, model=EulerDC())))
    np.testing.assert_array_equal(disc, ode)
    a = dcjax.fit(md, "dc", "table8", search=dcjax.Search(runs=2, budget=1400), integrator=dcjax.Euler())
    b = dcjax.fit(md, EulerDC(), "table8", dcjax.Search(runs=2, budget=1400))
    np.testing.assert_array_equal(a.run_params, b.run_params)
    assert b.settings["integrator"] == "discrete" and b.settings["nd"] == 1
    np.testing.assert_array_equal(b.simulate(), a.simulate())


def test_an_integrator_for_a_discrete_model_is_a_one_line_error(sd1, tmp_path, capsys):
    with pytest.raises(ValueError, match="discrete-time model .* takes no integrator"):
        dcjax.fit(sd1, EulerDC(), "table4", search=dcjax.Search(runs=1, budget=70), integrator=dcjax.RK4())
    with pytest.raises(ValueError, match="AutoSubsteps"):
        dcjax.fit(sd1, EulerDC(), "table4", search=dcjax.Search(runs=1, budget=70), integrator=dcjax.AutoSubsteps())
    spec = f"{__file__}:EulerDC"
    assert cli.main(["fit", "SD1", "--model", spec, "--integrator", "rk4", "--out", str(tmp_path)]) == 2
    assert "--integrator and --nd do not apply" in capsys.readouterr().err


def test_the_first_estimate_of_a_discrete_model(sd1):
    est = dcjax.initial_estimate(sd1, EulerDC(), cutoff=2000.0)
    truth = datasets.true_params("SD1")
    for n in ("Ra", "cm"):  # the one-step map at 0.1 ms is the ODE's rate: the estimate sees them
        assert est[n].value == pytest.approx(truth[n], rel=0.05), n
