"""The built-in PMSM (`dcjax.PMSM`, `--model pmsm`) against the independent NumPy reference
(`tests/reference.py`, written without dcjax): its trajectories, its first estimate, a fit that
recovers the truth, `design` and the CLI with its per-recording constants."""

import time

import matrix_models
import numpy as np
import pytest
import reference as ref

import dcjax
from dcjax import cli

TRUTH = dict(Rs=0.5, Ld=1.0e-3, Lq=1.5e-3, psi_m=0.05, J=1e-4, B=2e-3)
CONSTANTS = {"pp": 4.0, "Tl": 0.02}
DT = 1e-4


def field(p, u, y):
    """The reference's PMSM (its own names: psi for psi_m, Tl a parameter) with Tl as the fourth input."""
    return ref.pmsm_field({**p, "psi": p["psi_m"], "Tl": u[3]}, u[:3], y)


def recording(substeps: int = 8) -> dcjax.Recording:
    t = np.arange(400) * DT
    ud = np.where(t < 0.01, 0.5, np.where(t < 0.02, -1.0, 1.5))
    uq = np.where(t < 0.015, 4.0, np.where(t < 0.03, 8.0, 5.0))
    u = np.column_stack([ud, uq, np.full_like(t, CONSTANTS["pp"]), np.full_like(t, CONSTANTS["Tl"])])
    y = ref.simulate(field, TRUTH, t, u, np.zeros(3), substeps=substeps)
    return dcjax.Recording(t=t, ud=ud, uq=uq, id=y[:, 0], iq=y[:, 1], omega=y[:, 2], constants=CONSTANTS, name="pmsm")


def test_trajectories_equal_the_numpy_reference_and_the_estimate_is_a_regression():
    rec = recording()
    model = dcjax.get_model("pmsm")
    assert isinstance(model, dcjax.PMSM) and dcjax.models.model_spec(model) == "pmsm"
    prob = dcjax.make_problem(rec, dcjax.RK4(substeps=8), model=model, initial={"id": 0.0, "iq": 0.0, "omega": 0.0})
    sim = np.asarray(dcjax.simulate(TRUTH, prob))
    y = np.column_stack([rec["id"], rec["iq"], rec["omega"]])
    assert np.max(np.abs(sim - y) / np.max(np.abs(y), axis=0)) < 1e-10
    est = dcjax.initial_estimate(rec, model, cutoff=0.2 / DT)
    t0 = time.perf_counter()  # the second call (compiled): a regression takes ~0.01 s, the LM fallback 0.7-1.1 s
    dcjax.initial_estimate(rec, model, cutoff=0.2 / DT)
    assert time.perf_counter() - t0 < 0.3
    for n, v in TRUTH.items():  # noise-free: the equation error of the filtered derivatives only
        assert est[n].value == pytest.approx(v, rel=0.05) and 0 < est[n].min < v < est[n].max, (n, est[n])
    assert set(model.derived(TRUTH)) == {"electrical time constant Ld/Rs", "electrical time constant Lq/Rs", "mechanical time constant J/B"}


def test_the_current_vector_limit_equals_the_reference_clamp():
    """`Recording(limit=...)` clamps sqrt(id^2 + iq^2) after every sub-step, as the reference's
    own NumPy clamp does; without it the currents exceed the limit."""
    rec = recording()
    limit = 0.8 * float(np.max(np.hypot(rec["id"], rec["iq"])))

    def clamp(y):
        m = np.hypot(y[0], y[1])
        return y if m <= limit else np.array([y[0] * limit / m, y[1] * limit / m, y[2]])

    t = rec.t
    u = np.column_stack([rec["ud"], rec["uq"], rec["pp"], rec["Tl"]])
    y = ref.simulate(field, TRUTH, t, u, np.zeros(3), substeps=8, clamp=clamp)
    prob = dcjax.make_problem(
        rec.replace(limit=limit), dcjax.RK4(substeps=8), model=dcjax.PMSM(), initial={"id": 0.0, "iq": 0.0, "omega": 0.0}
    )
    sim = np.asarray(dcjax.simulate(TRUTH, prob))
    assert np.max(np.abs(sim - y) / np.max(np.abs(y), axis=0)) < 1e-10
    assert np.max(np.hypot(sim[:, 0], sim[:, 1])) == pytest.approx(limit, rel=1e-12)
    assert dcjax.PMSM().has_limit and dcjax.DC().measuring("omega").has_limit and not matrix_models.PMSM().has_limit


@pytest.mark.slow
def test_a_fit_recovers_the_truth_and_design_and_the_cli_run(tmp_path):
    rec = recording()
    res = dcjax.fit(rec, "pmsm", integrator=dcjax.RK4(substeps=8), search=dcjax.Search(runs=1, budget=1400, polish=True))
    assert max(abs(res.best_values[n] / v - 1) for n, v in TRUTH.items()) < 1e-6, res.best_values
    d = dcjax.design_input(dcjax.PMSM(), TRUTH, duration=0.02, dt=DT, u_range={"ud": (-2.0, 2.0), "uq": (0.0, 10.0)}, hold=2e-3,
                           given=CONSTANTS, starts=2, steps=5)  # fmt: skip
    assert d.inputs == ("ud", "uq") and d.unidentifiable == [] and all(np.isfinite(v) for v in d.stderr.values())
    path = tmp_path / "run1.csv"
    cols = ["t", "ud", "uq", "id", "iq", "omega"]
    np.savetxt(path, np.column_stack([rec[c] for c in cols]), delimiter=",", header=",".join(cols), comments="")
    out = tmp_path / "out"
    assert cli.main(["fit", str(path), "--model", "pmsm", "--const", "pp=4,Tl=0.02", "--nd", "8", "--runs", "1", "--budget", "1400",
                     "--polish", "--out", str(out)]) == 0  # fmt: skip
    back = dcjax.load_result(out / "result.json")
    assert max(abs(back.best_values[n] / v - 1) for n, v in TRUTH.items()) < 1e-6
    assert "electrical time constant Ld/Rs" in back.report()
