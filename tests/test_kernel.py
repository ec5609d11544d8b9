"""The Pallas kernels (objective and simulate), run in interpret mode on CPU, against the scan:
SD and MD data, Euler and RK4, ND sub-steps, the current limit, channel weights, non-uniform
steps, a model from outside the package, non-finite candidates, and a whole identification."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import dcjax
from dcjax import Recording, datasets, make_problem, objective, simulate
from dcjax.simulation.kernel import objective_kernel_jit, simulate_kernel_jit


def _preset(name):
    p = dcjax.DC().parameters(name)
    return dcjax.Bounds(p.lower, p.upper, dcjax.DC.names)


BOX4, BOX8 = _preset("table4"), _preset("table8")


def _population(bounds, n=12, seed=0, truth=None):
    x = bounds.to_physical(jax.random.uniform(jax.random.PRNGKey(seed), (n, 7)))
    return x if truth is None else x.at[0].set(jnp.asarray([truth[k] for k in dcjax.DC.names]))


def _agree(a, b):
    a, b = np.asarray(a), np.asarray(b)
    assert np.array_equal(np.isfinite(a), np.isfinite(b))
    fin = np.isfinite(b)
    np.testing.assert_allclose(a[fin], b[fin], rtol=1e-12, atol=0)


CASES = [
    ("SD1", dict(), BOX4),
    ("SD3", dict(integrator=dcjax.Euler(substeps=3), weights=(0.3, 0.7)), BOX4),
    ("MD1", dict(integrator=dcjax.RK4(substeps=5)), BOX8),  # current limit
    ("MD4", dict(integrator=dcjax.Euler()), BOX8),
]


@pytest.mark.parametrize("name,kw,bounds", CASES, ids=[c[0] for c in CASES])
def test_kernel_matches_the_scan(name, kw, bounds):
    prob = make_problem(datasets.load(name), **kw)
    truth = datasets.true_params(name) if name.startswith("SD") else None
    x = _population(bounds, truth=truth)
    _agree(objective_kernel_jit(x, prob, interpret=True, block=8), objective(x, prob))
    _agree(simulate_kernel_jit(x[:5], prob, interpret=True, block=8), simulate(x[:5], prob))


def test_kernel_non_uniform_steps_and_a_custom_model():
    from test_models import SERIES_TRUE, SeriesWound, series_recording

    rec = series_recording()
    t = rec.t.copy()
    t[1:] += np.linspace(0, 2e-4, len(t) - 1) ** 2 * 1e3  # uneven sampling, still increasing
    rec = Recording(t=t, u_a=rec.u_a, i_a=rec.i_a, omega=rec.omega)
    prob = make_problem(rec, dcjax.RK4(substeps=2), model=SeriesWound())
    x = jnp.stack([jnp.asarray([v * (1 + 0.1 * k) for v in SERIES_TRUE.values()]) for k in range(9)])
    _agree(objective_kernel_jit(x, prob, interpret=True, block=8), objective(x, prob))
    _agree(simulate_kernel_jit(x, prob, interpret=True, block=8), simulate(x, prob))


@pytest.mark.slow
def test_identify_through_the_kernel_equals_the_scan(sd1, monkeypatch):
    a = dcjax.fit(sd1, params="table4", search=dcjax.Search(runs=2, budget=350, seed=3))
    monkeypatch.setenv("DCJAX_KERNEL", "interpret")
    b = dcjax.fit(sd1, params="table4", search=dcjax.Search(runs=2, budget=350, seed=3))
    assert not b.timing["reused_executable"]  # the kernel mode is part of the executable's key
    np.testing.assert_allclose(b.run_of, a.run_of, rtol=1e-12)
    np.testing.assert_allclose(b.run_params, a.run_params, rtol=1e-12)


def test_gpu_default_falls_back_to_the_scan_when_the_kernel_does_not_compile(monkeypatch):
    """On a GPU backend the kernel is the default only if it compiles there: here (CPU, not
    interpreted) Pallas cannot lower it, which stands in for a Triton failure on a real GPU."""
    import dcjax.simulation.kernel as kernel

    monkeypatch.delenv("DCJAX_KERNEL", raising=False)
    monkeypatch.setattr(kernel.jax, "default_backend", lambda: "gpu")
    kernel._probe.cache_clear()
    try:
        with pytest.warns(UserWarning, match="uses the lax.scan"):
            assert kernel.kernel_mode() is None
        assert kernel.kernel_mode() is None  # tried once per process and backend
    finally:
        kernel._probe.cache_clear()
    monkeypatch.setattr(kernel, "_probe", lambda backend: True)
    assert kernel.kernel_mode() == "compiled"
