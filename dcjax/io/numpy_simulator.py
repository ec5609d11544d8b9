"""A straightforward NumPy implementation of the simulator and objective.

Written independently of the JAX path (eq. 8–9 exactly as printed, no hoisting, a Python
loop over time, NumPy arrays over the population). It generates the SD data files (IEEE
element-wise arithmetic, so the bytes do not depend on XLA), is the baseline of the
benchmarks and a cross-check in the tests."""

import numpy as np


def _f(p, u, i, w):
    ra, la, cm, j, tla, tlb, tlc = p
    return (u - i * ra - cm * w) / la, (cm * i - (tla + tlb * w + tlc * w**2)) / j


def simulate_numpy(x, t, u, i0=0.0, w0=0.0, integrator="rk4", nd=1, i_limit=None) -> np.ndarray:
    """x: (P,) or (B, P) parameters of the paper's model (`DC.names` order). Returns (N, 2) or (B, N, 2): current and speed at t."""
    x = np.asarray(x, dtype=np.float64)
    single = x.ndim == 1
    p = tuple(np.atleast_2d(x).T)  # seven (P,) arrays
    n = len(t)
    out = np.empty((n, 2, p[0].shape[0]))
    i = np.full(p[0].shape, float(i0))
    w = np.full(p[0].shape, float(w0))
    out[0, 0], out[0, 1] = i, w
    for k in range(1, n):
        h = (t[k] - t[k - 1]) / nd
        for s in range(nd):
            ua = u[k - 1] + (u[k] - u[k - 1]) / nd * s  # eq. 29
            ub = u[k - 1] + (u[k] - u[k - 1]) / nd * (s + 1)
            if integrator == "euler":  # eq. 11-12
                di, dw = _f(p, ua, i, w)
                i, w = i + h * di, w + h * dw
            else:  # eq. 14-23
                um = 0.5 * (ua + ub)
                k1, l1 = _f(p, ua, i, w)
                k2, l2 = _f(p, um, i + 0.5 * h * k1, w + 0.5 * h * l1)
                k3, l3 = _f(p, um, i + 0.5 * h * k2, w + 0.5 * h * l2)
                k4, l4 = _f(p, ub, i + h * k3, w + h * l3)
                i = i + h * (k1 / 6 + k2 / 3 + k3 / 3 + k4 / 6)
                w = w + h * (l1 / 6 + l2 / 3 + l3 / 3 + l4 / 6)
            if i_limit is not None:
                i = np.clip(i, -i_limit, i_limit)
        out[k, 0], out[k, 1] = i, w
    out = np.moveaxis(out, 2, 0)
    return out[0] if single else out


def objective_numpy(x, t, u, i_meas, w_meas, weights=(1.0, 1.0), **kw) -> np.ndarray:
    """Eq. 27 (eq. 24 for weights (1, 1)); non-finite -> inf."""
    with np.errstate(all="ignore"):
        traj = simulate_numpy(x, t, u, i0=i_meas[0], w0=w_meas[0], **kw)
        ri = (traj[..., 0] - i_meas) / np.max(np.abs(i_meas))
        rw = (traj[..., 1] - w_meas) / np.max(np.abs(w_meas))
        of = np.mean(weights[0] * ri**2 + weights[1] * rw**2, axis=-1)
    return np.where(np.isfinite(of), of, np.inf)
