"""The extended Kalman filter over a recording (`EKF`, `dcjax.simulation.predictors`): prediction
error instead of output error.

At sample 0 the state is x_{0|-1} = y0 with P_{0|-1} = diag(s0^2). At each sample k the measured
outputs z_k correct it (the update; Joseph form, Simon 2006 eq. 5.19):

    nu_k = z_k - h(x_{k|k-1}, u_k) - o        H_k = dh/dx at x_{k|k-1}
    S_k  = H_k P_{k|k-1} H_k' + R             K_k = P_{k|k-1} H_k' S_k^-1
    x_{k|k} = x_{k|k-1} + K_k nu_k            P_{k|k} = (I - K_k H_k) P_{k|k-1} (I - K_k H_k)' + K_k R K_k'

and between samples the model's own integrator step Phi (ND sub-steps, eq. 28-29, the clamp,
input delays) carries it on (the prediction):

    x_{k+1|k} = Phi(x_{k|k})                  F_k = dPhi/dx at x_{k|k} (forward differentiation)
    P_{k+1|k} = F_k P_{k|k} F_k' + diag(q) h_k

The innovations' Gaussian log-likelihood (log det S included) is

    log L = -1/2 sum_k (nu_k' S_k^-1 nu_k + log det S_k + C log 2 pi),

with S_k = L D L' factored without a square root (`unrolled.ldl`): log det S_k = sum_j log d_j.
The sum of the log-determinants is taken as the log of their product, carried as a mantissa in
[1, 2) and a binary exponent (`_renormalised`): one log per recording, not one per sample (the
log was a fifth of the filter's time).

The K-step-ahead prediction of sample i simulates K intervals open loop from x_{i-K|i-K}."""

import math
from typing import cast

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from ..compiling import compiled_when_eager
from ..errors import ConfigError
from . import unrolled as um
from .adjustments import Adjustments, input_pieces
from .integrate import advance_pieces, initial_state, prepare, sample_inputs
from .predictors import EKF
from .problem import Problem


class Filtered(eqx.Module):
    """What the filter gives over a recording of N samples, C outputs and S states (each with the
    parameters' leading axes first)."""

    innovations: Float[Array, "*batch n c"]  # nu_k: the measured outputs less their one-step prediction
    innovation_covariances: Float[Array, "*batch n c c"]  # S_k
    whitened: Float[Array, "*batch n c"]  # L_k^-1 nu_k, L_k the Cholesky factor of S_k: N(0, 1) and white for a right model
    predicted: Float[Array, "*batch n c"]  # h(x_{k|k-1}): the one-step-ahead outputs (with the offsets)
    states: Float[Array, "*batch n s"]  # x_{k|k}
    covariances: Float[Array, "*batch n s s"]  # P_{k|k}
    log_likelihood: Float[Array, "*batch"]


def _vector(y: tuple) -> Array:
    return jnp.stack(y, axis=-1)


def _units(batch, n: int) -> tuple[tuple[Array, ...], ...]:
    """The unit tangents e_1 .. e_n, each a tuple of `batch`-shaped arrays."""
    one, zero = jnp.ones(batch), jnp.zeros(batch)
    return tuple(tuple(one if i == j else zero for i in range(n)) for j in range(n))


def _jacobian(fn, xt, units, one=None):
    """(fn(xt), d fn / d x as rows): the primal once and a forward tangent per state (vmapped).
    `one`, a traced 1: the results are divided by it (exact). XLA fuses a cheap producer into
    every consumer, so the step and its tangents were computed again for each entry of x and F
    that reads them; a division counts as expensive, so they are computed once (the filter 15 %
    faster, `experiments/bench_ekf.py`)."""
    n = len(units)
    tangents = tuple(jnp.stack([units[j][i] for j in range(n)]) for i in range(n))
    out, cols = jax.vmap(lambda t: jax.jvp(fn, (xt,), (t,)), out_axes=(None, 0))(tangents)
    if one is not None:
        out, cols = jax.tree.map(lambda a: a / one, (out, cols))
    return out, tuple(tuple(cols[i][j] for j in range(n)) for i in range(len(out)))


_TINY, _HUGE = 2.0**-1000, 2.0**1000  # det S within: its product with a mantissa in [1, 2) has a normal reciprocal


def _renormalised(m):
    """(mantissa in [1, 2), exponent) with m = mantissa 2^exponent, `m` positive and within
    2^-1000 .. 2^1001: the exponent from m's bits (IEEE 754 binary64, bias 1023), the mantissa
    m times the exact power of two 2^-exponent (so that it differentiates as m does)."""
    biased = jax.lax.bitcast_convert_type(jax.lax.stop_gradient(m), jnp.int64) >> 52
    scale = jax.lax.bitcast_convert_type((2046 - biased) << 52, jnp.float64)  # 2^-(biased - 1023)
    return m * scale, biased - 1023


def _corrector(measure, selection, units, r2):
    """The update of the module docstring, Joseph form: (x, P, measured z, inputs u) -> (x, P,
    (nu, S, L^-1 nu, h(x)), log N(nu; 0, S) without its -1/2 log det S, det S); H by
    linearising `measure`, or the `selection` of measured states (known entries). Where S is
    not positive definite, or det S outside 2^-1000 .. 2^1000, the first is NaN (the
    candidate fails) and the second 1."""
    n_states, n_out = len(units), len(r2)
    log_2pi = n_out * math.log(2.0 * math.pi)

    def update(xt, p, z, u_k):
        if selection is None:
            zh, h = _jacobian(lambda y: measure(y, u_k), xt, units)
        else:  # measured states: H selects them (known entries, `unrolled.mul` skips the zeros)
            zh, h = measure(xt, u_k), selection
        nu = tuple(z[j] - zh[j] for j in range(n_out))
        pht = um.matmul_t(p, h)  # P H'
        s = um.symmetric(um.add_diagonal(um.matmul(h, pht), r2))
        f = um.ldl(s)  # S = L D L': no square root
        gain = tuple(um.solve(f, row) for row in pht)  # P H' S^-1, row by row
        y = um.solve_unit_lower(f, nu)  # nu' S^-1 nu = sum_j y_j^2 / d_j
        det = f.d[0]
        for j in range(1, n_out):
            det = det * f.d[j]
        quadratic = sum(y[j] * y[j] * f.inverse[j] for j in range(n_out))
        valid = um.positive(f) & (det >= _TINY) & (det <= _HUGE)
        ll = jnp.where(valid, -0.5 * (quadratic + log_2pi), jnp.nan)
        det = jnp.where(valid, det, 1.0)
        white = tuple(y[j] * jnp.sqrt(f.inverse[j]) for j in range(n_out))  # L_c^-1 nu, L_c = L D^1/2: only the record keeps it
        moved = tuple(xt[i] + sum(gain[i][j] * nu[j] for j in range(n_out)) for i in range(n_states))
        kh = um.matmul(gain, h)
        ikh = tuple(tuple(um.sub(1.0 if i == k else 0.0, kh[i][k]) for k in range(n_states)) for i in range(n_states))
        kr = tuple(tuple(g * r2[j] for j, g in enumerate(row)) for row in gain)
        krk = um.matmul_t(kr, gain)
        p_new = um.symmetric(um.add(um.matmul_t(um.matmul(ikh, p), ikh), krk))  # Joseph form
        return moved, p_new, (nu, s, white, zh), ll, det

    return update


def kalman_filter(params, problem: Problem, ekf: EKF, adjustments: Adjustments | None = None) -> Filtered:
    """The EKF of the module docstring over `problem`'s recording at `params` (a vector, a dict,
    or a population (*batch, P): one filter per member, its small matrices written out,
    `dcjax.simulation.unrolled`); `adjustments` (batched like `params`): a fitted initial
    state, sensor offsets, input delays, the noise a fit searches."""
    return _recorded(problem.model.as_array(params), problem, ekf, adjustments)  # pyright: ignore[reportReturnType]


@compiled_when_eager
def _recorded(x, problem: Problem, ekf: EKF, adjustments: Adjustments | None) -> "Filtered | Array":
    return _filter(x, problem, ekf, adjustments, record=True)


def _filter(params, problem: Problem, ekf: EKF, adjustments: Adjustments | None, record: bool) -> "Filtered | Array":
    """`kalman_filter`; without `record` only the log-likelihood (the scan stores nothing)."""
    if not isinstance(ekf, EKF):
        raise ConfigError(f"ekf must be a dcjax.EKF, got {type(ekf).__name__}")
    model = problem.model
    x = model.as_array(params)
    batch = x.shape[:-1]
    adj = adjustments if adjustments is not None else Adjustments()
    c, _ = prepare(x, problem)
    n_states, n_out = len(model.states), len(model.outputs)
    if ekf.process.shape != (n_states,) or ekf.initial.shape != (n_states,) or ekf.measurement.shape != (n_out,):
        raise ConfigError(
            f"ekf: sized for another model (states {ekf.process.shape}, outputs {ekf.measurement.shape}); use EKF.of(model, ...)"
        )
    offset = jnp.zeros((*batch, n_out)) if adj.offset is None else jnp.broadcast_to(adj.offset, (*batch, n_out))
    process = jnp.broadcast_to(ekf.process if adj.process is None else adj.process, (*batch, n_states))
    sd = jnp.broadcast_to(ekf.measurement if adj.measurement is None else adj.measurement, (*batch, n_out))
    steady = problem.steady_inputs()
    u = sample_inputs(problem)
    m = u.shape[1]
    r2 = tuple(sd[..., j] ** 2 for j in range(n_out))
    q = tuple(process[..., i] for i in range(n_states))
    units = _units(batch, n_states)

    def measure(xt, u_k):
        out = model.compared(c, tuple(u_k[j] for j in range(m)), xt)
        return tuple(o + offset[..., j] for j, o in enumerate(out))

    selection = (
        None if model.has_output_equation else tuple(tuple(1.0 if k == o else 0.0 for k in range(n_states)) for o in model.output_index)
    )
    update = _corrector(measure, selection, units, r2)

    def transition(xt, lengths, inputs):
        return advance_pieces(c, problem, xt, lengths, inputs, steady)

    def pack(xt, p, parts):
        nu, s, white, zh = parts
        vec = lambda v: jnp.stack(v, axis=-1)
        return vec(nu), um.stacked(s), vec(white), vec(zh), vec(xt), um.stacked(p)

    x0 = initial_state(problem, batch, adj.y0)
    s0 = ekf.initial_sd(sd)
    p0 = um.add_diagonal(
        tuple(tuple(jnp.zeros(batch) for _ in range(n_states)) for _ in range(n_states)), [s0[..., i] ** 2 for i in range(n_states)]
    )
    x00, p00, parts0, ll0, det0 = update(x0, p0, tuple(problem.y_meas[0, j] for j in range(n_out)), u[0])
    mask = jnp.ones(problem.n) if problem.mask is None else problem.mask

    one = 1.0 + 0.0 * problem.h[0]  # a 1 that XLA cannot fold (`_jacobian`)

    def body(carry, xs):
        xt, p_upper, ll, det_mantissa, det_exponent = carry
        p = um.from_upper(p_upper, n_states)
        lengths, inputs, z, u_k, dt, counted = xs
        xp, f = _jacobian(lambda y: transition(y, lengths, inputs), xt, units, one)
        pp = um.symmetric(um.add_diagonal(um.matmul_t(um.matmul(f, p), f), [qi * dt for qi in q]))
        xu, pu, parts, llk, det = update(xp, pp, tuple(z[j] for j in range(n_out)), u_k)
        if problem.mask is not None:
            keep = counted > 0  # a padded sample (`dcjax.simulation.joint.padded`): no step, no measurement
            xu = tuple(jnp.where(keep, a, b) for a, b in zip(xu, xt))
            pu = tuple(tuple(jnp.where(keep, a, b) for a, b in zip(ra, rb)) for ra, rb in zip(pu, p))
            llk = jnp.where(keep, llk, 0.0)
            det = jnp.where(keep, det, 1.0)
        mantissa, exponent = _renormalised(det_mantissa * det)
        return (xu, um.upper(pu), ll + llk, mantissa, det_exponent + exponent), pack(xu, pu, parts) if record else None

    lengths, inputs = input_pieces(problem, adj)
    xs = (lengths, inputs, problem.y_meas[1:], u[1:], problem.h, mask[1:])
    (_, _, ll, det_mantissa, det_exponent), rows = jax.lax.scan(
        body, (x00, um.upper(p00), ll0, *_renormalised(det0)), xs, unroll=problem.unroll
    )
    ll = ll - 0.5 * (jnp.log(det_mantissa) + det_exponent * math.log(2.0))  # the sum of -1/2 log det S_k
    ll = jnp.where(jnp.isfinite(ll), ll, -jnp.inf)
    if not record:
        return ll
    assert rows is not None
    first = pack(x00, p00, parts0)
    nu, s, white, zh, states, covs = (jnp.moveaxis(jnp.concatenate([a[None], b], axis=0), 0, len(batch)) for a, b in zip(first, rows))
    return Filtered(
        innovations=nu,
        innovation_covariances=s,
        whitened=white,
        predicted=zh,
        states=states,
        covariances=covs,
        log_likelihood=ll,
    )


def prediction_error(params, problem: Problem, ekf: EKF, adjustments: Adjustments | None = None) -> Float[Array, "*batch"]:
    """-log L / N of the innovations (module docstring; N the recorded samples), +inf where the
    filter fails; batched `params` (and `adjustments`) give one value per member."""
    n = problem.n if problem.mask is None else jnp.sum(problem.mask)
    nll = -cast(Array, _filter(params, problem, ekf, adjustments, record=False)) / n
    return jnp.where(jnp.isfinite(nll), nll, jnp.inf)


def predict(params, problem: Problem, ekf: EKF, steps: int, adjustments: Adjustments | None = None) -> Float[Array, "n c"]:
    """The `steps`-step-ahead outputs: sample i simulated open loop over `steps` intervals from the
    filtered state x_{i-steps|i-steps} (the first `steps` samples from the initial state, with no
    measurement); `steps=1` is the filter's one-step prediction."""
    if not isinstance(steps, int) or isinstance(steps, bool) or steps < 1:
        raise ConfigError(f"steps must be a positive integer, got {steps!r}")
    model = problem.model
    x = model.as_array(params)
    if x.ndim != 1:
        raise ConfigError(f"predict: one parameter vector at a time (jax.vmap for a batch), got shape {x.shape}")
    adj = adjustments if adjustments is not None else Adjustments()
    c, _ = prepare(x, problem)
    n_states, m = len(model.states), problem.u_start.shape[1]
    offset = jnp.zeros(len(model.outputs)) if adj.offset is None else adj.offset
    steady = problem.steady_inputs()
    filtered = kalman_filter(x, problem, ekf, adjustments).states
    lengths, inputs = input_pieces(problem, adj)
    lengths, inputs = jnp.asarray(lengths), tuple(None if a is None else jnp.asarray(a) for a in inputs)  # indexed by a traced k
    u = sample_inputs(problem)
    n = problem.n
    x0 = _vector(initial_state(problem, (), adj.y0))

    def ahead(i):
        start = jnp.maximum(i - steps, 0)
        xv = jnp.where(i >= steps, filtered[start], x0)

        def one(j, xv):  # interval start + j, while it ends at or before sample i
            k = start + j
            moved = _vector(
                advance_pieces(
                    c,
                    problem,
                    tuple(xv[s] for s in range(n_states)),
                    lengths[k],
                    tuple(None if a is None else a[k] for a in inputs),
                    steady,
                )
            )
            return jnp.where(k < i, moved, xv)

        xv = jax.lax.fori_loop(0, steps, one, xv)
        return jnp.stack(model.compared(c, tuple(u[i, j] for j in range(m)), tuple(xv[s] for s in range(n_states))), axis=-1) + offset

    return jax.vmap(ahead)(jnp.arange(n))


__all__ = ["Filtered", "kalman_filter", "predict", "prediction_error"]
