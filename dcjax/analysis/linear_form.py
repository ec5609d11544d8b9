"""The state equations' linear form, found with JAX: the equation-error regression of a model that
writes no `regression()`.

A state equation dy_e/dt = f_e(theta, y, u) is linear in the parameters after multiplying by one
of them, its "mass" m (or by 1):

    theta_m dy_e/dt = g_e(theta, y, u),   g_e = theta_m f_e affine in theta,

as La di/dt = u - Ra i - cm w (paper eq. 8 times La) and J dw/dt = cm i - Tla - Tlb w - Tlc w^2
(eq. 9 times J). For each equation the candidates 1, theta_1, ..., theta_P are tried in turn on
rows of the recording: g_e is affine where its Jacobian in theta is the same at three random
parameter points (each column's change times the parameter's size within 1e-7 of g's scale). The Jacobian A at the data rows then gives the regression

    theta_m dy_e/dt - sum_k theta_k A_ek = g_e(0)        (columns and rhs of `Model.regression`),

g_e(0) = g_e(theta') - A theta' taken at a parameter point theta' (theta = 0 may divide by 0). A
discrete-time model's rate is (update(c, u, y, dt) - y) / dt. An equation with no parameter
(dq/dt = v) is left out; a model with an equation in no such form has none (None).

A state the recording lacks whose rate no parameter enters and that only recorded states and the
inputs drive (an angle, dth/dt = w1 - w2; a position, dx/dt = v) is their integral
(`integrated_states`), so that it can take its place in the rows."""

import jax
import jax.numpy as jnp
import numpy as np

from ..compiling import filter_jit
from ..models import DiscreteModel, Model
from ..models.parameters import Parameters

PROBE_ROWS = 64  # rows of the recording the affinity test reads
AFFINE_RTOL = 1e-7


def _rates(model: Model, x, Y, U, dt):
    """The state equations' right-hand sides at the rows, stacked: (S, rows)."""
    c = model.coefficients(model.as_dict(x))
    if isinstance(model, DiscreteModel):
        return jnp.stack([(a - b) / dt for a, b in zip(model.update(c, U, Y, dt), Y)])
    return jnp.stack(model.vector_field(c, U, Y))


def _scaled(model: Model, x, Y, U, dt):
    """(P + 1, S, rows): every equation's rate times 1 (first) and times each parameter."""
    f = _rates(model, x, Y, U, dt)
    return jnp.concatenate([jnp.ones((1,)), x])[:, None, None] * f[None]


@filter_jit
def _jacobians(model: Model, points, Y, U, dt):
    """_scaled and d(_scaled)/dx at each parameter point: (points, P + 1, S, rows) and
    (points, P + 1, S, rows, P)."""
    return jax.vmap(lambda x: (_scaled(model, x, Y, U, dt), jax.jacfwd(_scaled, argnums=1)(model, x, Y, U, dt)))(points)


@filter_jit
def _columns(model: Model, x, Y, U, dt):
    """(g, A) at every row: g = _scaled(x) (P + 1, S, rows) and its Jacobian (P + 1, S, rows, P)."""
    return _scaled(model, x, Y, U, dt), jax.jacfwd(_scaled, argnums=1)(model, x, Y, U, dt)


def _points(start: Parameters, k: int) -> np.ndarray:
    """`k` parameter points, positive, of each parameter's scale (its range where finite, else 1),
    from a fixed seed."""
    lo, hi = start.lower, start.upper
    scale = np.where(np.isfinite(lo) & np.isfinite(hi), np.maximum(np.abs(lo), np.abs(hi)), 1.0)
    scale = np.where(scale > 0, scale, 1.0)
    return scale * np.exp(np.random.default_rng(0).uniform(-1.0, 0.0, size=(k, len(lo))))


def linear_masses(model: Model, y: dict, u: dict, dt: float, start: Parameters) -> list[int] | None:
    """Per state equation the candidate that makes it affine in theta: 0 (the rate itself) or
    1 + k (times theta_k); None where some equation has none."""
    n = len(next(iter(y.values())))
    rows = np.unique(np.linspace(0, n - 1, min(PROBE_ROWS, n)).astype(int))
    Y = tuple(jnp.asarray(y[s][rows]) for s in model.states)
    U = tuple(jnp.asarray(u[c][rows]) for c in model.inputs)
    points = _points(start, 3)
    g, J = (np.asarray(a) for a in _jacobians(model, jnp.asarray(points), Y, U, jnp.asarray(dt, jnp.float64)))
    finite = np.all(np.isfinite(J), axis=(0, 3, 4)) & np.all(np.isfinite(g), axis=(0, 3))  # (P + 1, S)
    # affine: the Jacobian's change moves g by at most 1e-7 of g's scale (a column that is 0 but
    # for rounding is not compared with itself)
    moved = np.max(np.abs(J - J[:1]) * np.max(points, axis=0), axis=(0, 3, 4))
    same = moved <= AFFINE_RTOL * np.maximum(np.max(np.abs(g), axis=(0, 3)), 1e-300)
    masses: list[int] = []
    for e in range(len(model.states)):
        ok = np.flatnonzero(finite[:, e] & same[:, e])
        if ok.size == 0:
            return None
        masses.append(int(ok[0]))
    return masses


def linear_regression(
    model: Model, y: dict, dy: dict, u: dict, dt: float, start: Parameters, masses: list[int] | None = None
) -> list | None:
    """`Model.regression`'s blocks `(columns, rhs, mass)` found from the model's equations (module
    docstring); None where an equation is not linear in theta after any one parameter's factor.
    `masses`: `linear_masses` already found (probed here where not given)."""
    masses = linear_masses(model, y, u, dt, start) if masses is None else masses
    if masses is None:
        return None
    x = jnp.asarray(_points(start, 1)[0])
    Y = tuple(jnp.asarray(y[s]) for s in model.states)
    U = tuple(jnp.asarray(u[c]) for c in model.inputs)
    g, A = (np.asarray(a) for a in _columns(model, x, Y, U, jnp.asarray(dt, jnp.float64)))
    blocks = []
    for e, (state, m) in enumerate(zip(model.states, masses)):
        Ae = A[m, e]  # (rows, P)
        const = g[m, e] - Ae @ np.asarray(x)
        used = [k for k in range(model.n_params) if np.any(Ae[:, k] != 0) or m == k + 1]
        if not used:
            continue
        d = np.asarray(dy[state], float)
        if m == 0:  # dy/dt = sum_k theta_k A_k + g(0)
            blocks.append(({model.names[k]: Ae[:, k] for k in used}, d - const, None))
        else:  # theta_m dy/dt - sum_k theta_k A_k = g(0)
            cols = {model.names[k]: -Ae[:, k] for k in used}
            cols[model.names[m - 1]] = d - Ae[:, m - 1]
            blocks.append((cols, const, model.names[m - 1]))
    return blocks or None


FREE_RTOL = 1e-12  # a rate no parameter enters: the same at every probe point to this share of its scale
_compiled_rates = filter_jit(_rates)  # one program per shape, not each operation compiled on its own


def integrated_states(model: Model, y: dict, u: dict, dt: float) -> dict:
    """The states missing from `y` (name -> samples every `dt`) whose rate is the same at random
    parameter points and random values of the missing states (no parameter and no missing state
    enters it, as dth/dt = w1 - w2), integrated from 0 (the trapezoid rule), as the fit starts a
    state with no column; in turn, so that a state may integrate one integrated before it.
    Returns the new ones by name (none for a discrete-time model or a missing input)."""
    if isinstance(model, DiscreteModel) or any(c not in u for c in model.inputs):
        return {}
    known, out = dict(y), {}
    rng = np.random.default_rng(0)
    n = len(next(iter(known.values()), ()))
    rows = np.unique(np.linspace(0, n - 1, min(PROBE_ROWS, n)).astype(int)) if n else np.array([], int)
    while rows.size:
        missing = [s for s in model.states if s not in known]
        if not missing:
            break
        points = np.exp(rng.uniform(-3.0, 1.0, size=(2, model.n_params)))
        U = tuple(jnp.asarray(u[c][rows]) for c in model.inputs)
        draws = [
            (x, tuple(jnp.asarray(known[s][rows] if s in known else rng.standard_normal(rows.size)) for s in model.states))
            for x in points
            for _ in range(2)
        ]
        try:
            probes = np.stack(
                [np.asarray(_compiled_rates(model, jnp.asarray(x), Y, U, jnp.asarray(dt, jnp.float64))) for x, Y in draws]
            )  # (4, S, rows)
        except Exception:  # a vector field that cannot take these values: the caller's one-line refusal
            return out
        found = False
        for s in missing:
            e = model.states.index(s)
            r = probes[:, e]
            if np.all(np.isfinite(r)) and np.max(np.abs(r - r[0])) <= FREE_RTOL * max(np.max(np.abs(r)), 1e-300):
                Y = tuple(jnp.asarray(known[c] if c in known else np.zeros(n)) for c in model.states)
                U = tuple(jnp.asarray(u[c]) for c in model.inputs)
                rate = np.asarray(_compiled_rates(model, jnp.asarray(points[0]), Y, U, jnp.asarray(dt, jnp.float64)))[e]
                known[s] = out[s] = np.concatenate([[0.0], np.cumsum(0.5 * dt * (rate[1:] + rate[:-1]))])
                found = True
        if not found:
            break
    return out
