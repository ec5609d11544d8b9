"""Simulator: order of convergence, exact linear solution, ND, current limit, transforms."""

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.linalg

import dcjax
from dcjax import RK4, Recording, make_problem, objective, simulate
from dcjax.io.numpy_simulator import simulate_numpy
from dcjax.models import DC
from dcjax.models.dc import Coefficients, derivatives, vector_field


def _problem(rec, integrator="rk4", nd=1, start=None, limit=None):
    """`make_problem` with the integrator by name, a start state (i, w) and a current limit."""
    rec = rec if limit is None else rec.replace(limit=limit)
    initial = None if start is None else {"i_a": start[0], "omega": start[1]}
    return make_problem(rec, dcjax.INTEGRATORS[integrator](substeps=nd), initial=initial)


def _table4():
    p = DC().parameters("table4")
    return dcjax.Bounds(p.lower, p.upper)


SD1 = dict(Ra=42.5, La=0.08, cm=0.4781, J=2e-5, Tla=0.01, Tlb=3.27e-5, Tlc=8.55e-8)


def _varying_voltage_recording(n=41, dt=1e-3):
    """A coarse grid with a non-constant voltage (ramp + ripple); i, w are placeholders."""
    t = np.arange(n) * dt
    u = 150.0 + 70.0 * t / t[-1] + 20.0 * np.sin(300.0 * t)
    return Recording(t=t, u_a=u, i_a=np.ones(n), omega=np.ones(n))


def _diffrax_solution(p: dict, rec: Recording):
    """Tsit5 at tight tolerance on the same ODE with the same piecewise-linear voltage."""
    t = jnp.asarray(rec.t)
    u = jnp.asarray(rec.u_a)

    def f(s, y, args):
        return jnp.stack(derivatives(p, jnp.interp(s, t, u), y[0], y[1]))

    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(f),
        diffrax.Tsit5(),
        t0=t[0],
        t1=t[-1],
        dt0=1e-6,
        y0=jnp.zeros(2),
        saveat=diffrax.SaveAt(ts=t),
        stepsize_controller=diffrax.ClipStepSizeController(diffrax.PIDController(rtol=1e-13, atol=1e-13), jump_ts=t),
        max_steps=200_000,
    )
    return np.asarray(sol.ys)


def test_float64(sd1, sd1_true):
    prob = make_problem(sd1)
    assert simulate(sd1_true, prob).dtype == jnp.float64
    assert objective(sd1_true, prob).dtype == jnp.float64
    assert DC().as_array(np.ones(7, np.float32)).dtype == jnp.float64


@pytest.mark.parametrize("integrator,order", [("euler", 1.0), ("rk4", 4.0)])
def test_order_of_convergence(integrator, order):
    """Log-log slope of the error against the sub-step (diffrax's test_ode_order style)."""
    rec = _varying_voltage_recording()
    p = dict(SD1)
    exact = _diffrax_solution(p, rec)
    scale = np.max(np.abs(exact), axis=0)
    nds = [4, 8, 16, 32] if integrator == "rk4" else [16, 32, 64, 128]
    errors = []
    for nd in nds:
        prob = _problem(rec, integrator, nd, start=(0.0, 0.0))
        traj = np.asarray(simulate(p, prob))
        errors.append(np.max(np.abs(traj - exact) / scale))
    slope = np.polyfit(np.log(1.0 / np.asarray(nds)), np.log(errors), 1)[0]
    print(integrator, "errors", errors, "slope", slope)
    assert abs(slope - order) < 0.15 * order, (errors, slope)


def test_linear_case_matches_matrix_exponential(sd1):
    """Tla = Tlb = Tlc = 0 and constant u: x(t) = e^{At} x0 + A^{-1}(e^{At} - I) b u."""
    p = dict(SD1, Tla=0.0, Tlb=0.0, Tlc=0.0)
    A = np.array([[-p["Ra"] / p["La"], -p["cm"] / p["La"]], [p["cm"] / p["J"], 0.0]])
    b = np.array([1.0 / p["La"], 0.0])
    u = 220.0
    exact = np.stack([np.linalg.solve(A, (scipy.linalg.expm(A * t) - np.eye(2)) @ b * u) for t in sd1.t])
    prob = _problem(sd1, nd=8)
    traj = np.asarray(simulate(dict(p), prob))
    rel = np.max(np.abs(traj - exact), axis=0) / np.max(np.abs(exact), axis=0)
    assert np.all(rel < 1e-10), rel
    # Euler is first order: clearly worse on the same grid.
    traj_em = np.asarray(simulate(dict(p), _problem(sd1, "euler")))
    assert np.max(np.abs(traj_em - exact)[:, 1]) / np.max(np.abs(exact[:, 1])) > 1e-4


@pytest.mark.parametrize("integrator", ["euler", "rk4"])
@pytest.mark.parametrize("nd", [1, 3])
def test_matches_numpy_reference(integrator, nd):
    rec = _varying_voltage_recording()
    x = np.array(list(SD1.values()))
    ref = simulate_numpy(x, rec.t, rec.u_a, integrator=integrator, nd=nd, i_limit=2.0)
    prob = _problem(rec, integrator, nd, start=(0.0, 0.0), limit=2.0)
    out = np.asarray(simulate(jnp.asarray(x), prob))
    np.testing.assert_allclose(out, ref, rtol=1e-12, atol=1e-12)


def test_nd1_is_the_plain_integrator(sd1, sd1_true):
    """ND = 1 equals stepping `RK4.step` once per sample interval (bit for bit)."""
    model = DC()
    k = Coefficients.from_params(sd1_true)
    i, w = jnp.float64(0.0), jnp.float64(0.0)
    rows = [(i, w)]
    step = jax.jit(lambda k, y, h, u0, uh, u1: RK4().step(lambda u, y: model.vector_field(k, u, y), y, (u0,), (u1,), h))
    for n in range(1, len(sd1)):
        h = sd1.t[n] - sd1.t[n - 1]
        i, w = step(k, (i, w), h, sd1.u_a[n - 1], 0.5 * (sd1.u_a[n - 1] + sd1.u_a[n]), sd1.u_a[n])
        rows.append((i, w))
    plain = np.asarray(rows)
    out = np.asarray(simulate(sd1_true, _problem(sd1)))
    np.testing.assert_allclose(out, plain, rtol=1e-14, atol=1e-13)


@pytest.mark.parametrize("integrator", ["euler", "rk4"])
def test_nd_approaches_fine_solution(sd1, sd1_true, integrator):
    """Constant voltage: the error at the samples against ND = 256 shrinks as ND grows."""
    fine = np.asarray(simulate(sd1_true, _problem(sd1, integrator, 256)))
    errs = [np.max(np.abs(np.asarray(simulate(sd1_true, _problem(sd1, integrator, nd))) - fine)) for nd in (1, 2, 5, 10)]
    assert all(a > b for a, b in zip(errs, errs[1:])), errs


def test_current_limit(sd1, sd1_true):
    peak = float(np.max(np.abs(sd1.i_a)))
    limited = np.asarray(simulate(sd1_true, _problem(sd1, limit=0.5 * peak)))
    assert np.max(np.abs(limited[:, 0])) <= 0.5 * peak
    assert np.isclose(np.max(limited[:, 0]), 0.5 * peak)  # it binds
    free = np.asarray(simulate(sd1_true, make_problem(sd1)))
    above = np.asarray(simulate(sd1_true, _problem(sd1, limit=2.0 * peak)))
    np.testing.assert_array_equal(free, above)


def test_current_limit_every_substep():
    """With ND > 1 the clamp acts inside the interval too (paper Fig. 17)."""
    rec = _varying_voltage_recording()
    p = dict(SD1)
    x = jnp.asarray([p[n] for n in DC.names])
    for nd in (1, 4):
        prob = _problem(rec, nd=nd, start=(0.0, 0.0), limit=1.0)
        ref = simulate_numpy(np.asarray(x), rec.t, rec.u_a, nd=nd, i_limit=1.0)
        np.testing.assert_allclose(np.asarray(simulate(p, prob)), ref, rtol=1e-12, atol=1e-12)
        assert np.max(np.abs(ref[:, 0])) <= 1.0


def test_population_vmap_loop_jit(sd1):
    prob = make_problem(sd1)
    X = _table4().to_physical(jax.random.uniform(jax.random.PRNGKey(3), (6, 7)))
    batched = simulate(jnp.asarray(X), prob)
    assert batched.shape == (6, len(sd1), 2)
    vmapped = jax.vmap(lambda x: simulate(jnp.asarray(x), prob))(X)
    looped = jnp.stack([simulate(jnp.asarray(x), prob) for x in X])
    jitted = jax.jit(lambda X: simulate(jnp.asarray(X), prob))(X)
    np.testing.assert_allclose(batched, looped, rtol=1e-13, equal_nan=True)
    np.testing.assert_allclose(vmapped, looped, rtol=1e-13, equal_nan=True)
    np.testing.assert_allclose(jitted, looped, rtol=1e-13, equal_nan=True)
    of_b = objective(jnp.asarray(X), prob)
    of_l = jnp.stack([objective(jnp.asarray(x), prob) for x in X])
    np.testing.assert_allclose(of_b, of_l, rtol=1e-13)


def test_an_eager_call_is_one_program_compiled_once_and_a_traced_one_part_of_its_caller(sd1, sd1_true):
    """`simulate`, `objective` and a joint objective called eagerly run one compiled program
    (`compiled_when_eager`): a second call of the same structure compiles nothing, and equals
    the function traced inside the caller's `jit` (which compiles no program of its own)."""
    from dcjax.compiling import compiled_when_eager
    from dcjax.simulation import joint
    from dcjax.simulation import objectives as O

    short = Recording(t=sd1.t[:123], channels={c: sd1[c][:123] for c in ("u_a", "i_a", "omega")}, name="SD1-123")
    prob = make_problem(short)
    x = jnp.asarray([sd1_true[n] for n in DC.names])
    pop = x * (1.0 + 0.01 * jnp.arange(6.0))[:, None]
    target = joint.joint_problem([prob, make_problem(short.replace(name="again"))], None)
    for fn, args in ((O._simulate, (x, prob, None)), (O._objective, (pop, prob, None))):
        once = fn(*args)
        np.testing.assert_allclose(jax.jit(lambda *a, fn=fn: fn(*a))(*args), once, rtol=1e-13)
        outer = jax.make_jaxpr(lambda *a, fn=fn: fn(*a))(*args).jaxpr
        assert "compiled" not in [e.params.get("name") for e in outer.eqns if e.primitive.name in ("pjit", "jit")]
    odd = compiled_when_eager(lambda a, b: a * len(b))  # an unhashable argument: run as it is
    assert np.array_equal(odd(jnp.ones(2), bytearray(b"abc")), [3.0, 3.0])
    compiles = []

    def listen(name, duration, **kw):
        if "backend_compile" in name:
            compiles.append(name)

    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        for fn, args in ((simulate, (x, prob)), (objective, (pop, prob)), (target.objective, (pop[:, : len(x)],))):
            fn(*args)
            before = len(compiles)
            fn(*args)
            assert len(compiles) == before, fn
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)


def test_objective_at_truth_and_sensitivity(sd1, sd1_true):
    prob = make_problem(sd1)
    of0 = float(objective(sd1_true, prob))
    assert of0 < 1e-25
    x = np.asarray(jnp.asarray([sd1_true[n] for n in DC.names]))
    for k, name in enumerate(DC.names):
        for s in (0.99, 1.01):
            xk = x.copy()
            xk[k] *= s
            of = float(objective(jnp.asarray(xk), prob))
            assert of > 1e3 * max(of0, 1e-30) and of > 1e-16, (name, s, of)


def test_objective_weights(sd1, sd1_true):
    x = np.asarray(jnp.asarray([sd1_true[n] for n in DC.names])) * np.array([1.02, 1, 1, 1, 1, 1, 1])
    p = jnp.asarray(x)
    full = float(objective(p, make_problem(sd1)))
    only_i = float(objective(p, make_problem(sd1, weights=(1.0, 0.0))))
    only_w = float(objective(p, make_problem(sd1, weights=(0.0, 1.0))))
    half = float(objective(p, make_problem(sd1, weights=(0.5, 0.5))))
    np.testing.assert_allclose(full, only_i + only_w, rtol=1e-12)
    np.testing.assert_allclose(half, 0.5 * full, rtol=1e-12)


def test_grad_matches_finite_differences(sd1, sd1_true):
    prob = make_problem(sd1)
    x0 = np.asarray(jnp.asarray([sd1_true[n] for n in DC.names])) * np.array([1.01, 0.99, 1.01, 1.02, 0.98, 1.05, 0.95])
    f = lambda x: objective(jnp.asarray(x), prob)
    g = np.asarray(jax.grad(f)(jnp.asarray(x0)))
    jac = np.asarray(jax.jacfwd(f)(jnp.asarray(x0)))
    assert np.all(np.isfinite(g))
    np.testing.assert_allclose(g, jac, rtol=1e-10)
    for k in range(7):
        h = 1e-6 * abs(x0[k])
        e = np.zeros(7)
        e[k] = h
        fd = (float(f(x0 + e)) - float(f(x0 - e))) / (2 * h)
        np.testing.assert_allclose(g[k], fd, rtol=1e-4, atol=1e-12 * abs(fd) + 1e-30)


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("field", ["La", "J"])
def test_degenerate_parameters_give_inf(sd1, sd1_true, field):
    p = dict({**sd1_true, field: 0.0})
    assert float(objective(p, make_problem(sd1))) == np.inf
    huge = dict({**sd1_true, "La": 1e-300})
    of = objective(huge, make_problem(sd1))
    assert not np.isnan(of) and of > 0


def test_vector_field_matches_eq_8_9():
    p = dict(SD1)
    k = Coefficients.from_params(p)
    a = vector_field(k, 200.0, 1.5, 120.0)
    b = derivatives(p, 200.0, 1.5, 120.0)
    np.testing.assert_allclose(a, b, rtol=1e-13)


def test_a_host_array_goes_on_the_device_without_compiling_and_a_traced_one_stays_in_its_program():
    """`dcjax.compiling.on_device`: what `jnp.asarray` gives (values, dtype, not weakly typed), but
    no program compiled for new shapes (`jnp.asarray` of a host array compiles one per shape)."""
    from jax._src import monitoring

    from dcjax.compiling import on_device

    compiles = []
    listen = lambda name, duration, **kw: compiles.append(name) if "backend_compile" in name else None
    monitoring.register_event_duration_secs_listener(listen)
    try:
        for host, dtype in (
            (np.arange(137.0), None),
            ([1.5, 2.5, 3.5], None),
            (7, np.int64),
            (0.25, np.float64),
            (np.arange(5), np.float64),
        ):
            got = on_device(host, dtype)
            want = np.asarray(host, dtype)
            assert isinstance(got, jax.Array) and got.dtype == want.dtype and not got.weak_type and np.array_equal(got, want)
        assert compiles == [], compiles
    finally:
        monitoring.unregister_event_duration_listener(listen)
    already = jnp.arange(3.0)
    assert on_device(already) is already
    traced = jax.jit(lambda a: on_device(a, np.float64) * 2)(jnp.arange(3))
    assert traced.dtype == np.float64 and np.array_equal(traced, [0.0, 2.0, 4.0])
