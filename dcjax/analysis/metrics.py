"""The figures of merit and residual tests of system identification (Ljung, *System
Identification*, 2nd ed., Sections 16.5-16.6; MATLAB's `compare`, `resid`, `aic`, `fpe`), plain
NumPy on one channel's measured and simulated samples.

- `channel_metrics`: rmse, nrmse (over the channel's range), fit % (`compare`'s
  100 (1 - ||y - y_sim|| / ||y - mean y||)), R^2 and mae;
- `whiteness`: the fraction of the residual's normalised autocorrelation at lags 1..M outside the
  band +-z/sqrt(N) (z = 2.58: 99 %), the test of an output-error model with sensor noise alone;
- `input_correlation`: the fraction of the residual's cross-correlation with an input at lags
  -M..M outside +-z sqrt(P/N), P = sum_tau r_e(tau) r_u(tau) (Ljung eq. 16.60: the variance when
  neither series is white), the test that holds with process noise too;
- `criteria`: AIC, AICc, BIC and FPE of a fit from its residuals and free parameters."""

import math

import numpy as np

from .report import fit_percent

LAGS = 25  # lags of the residual tests (MATLAB's `resid` default)
Z99 = 2.58  # the 99 % band's normal quantile


def channel_metrics(measured, simulated) -> dict[str, float]:
    """rmse, nrmse (rmse over max - min of the measured channel), fit_percent, r2 and mae."""
    y, s = np.asarray(measured, float), np.asarray(simulated, float)
    e = y - s
    rmse = float(np.sqrt(np.mean(e**2)))
    span = float(np.ptp(y))
    spread = float(np.sum((y - y.mean()) ** 2))
    return {
        "rmse": rmse,
        "nrmse": rmse / span if span > 0 else math.nan,
        "fit_percent": fit_percent(y, s),
        "r2": float(1 - np.sum(e**2) / spread) if spread > 0 else math.nan,
        "mae": float(np.mean(np.abs(e))),
    }


def autocorrelation(x, lags: int = LAGS) -> np.ndarray:
    """r(tau) / r(0), tau = 0..lags, of the mean-removed series (the biased 1/N estimate)."""
    x = np.asarray(x, float) - np.mean(x)
    n = len(x)
    r0 = float(np.dot(x, x)) / n
    if not r0 > 0:
        return np.full(lags + 1, math.nan)
    return np.array([float(np.dot(x[tau:], x[: n - tau])) / n / r0 for tau in range(lags + 1)])


def cross_correlation(e, u, lags: int = LAGS) -> np.ndarray:
    """r_eu(tau) / sqrt(r_e(0) r_u(0)), tau = -lags..lags, r_eu(tau) = 1/N sum_t e(t + tau) u(t)
    (mean-removed): a positive lag is the residual after the input."""
    e = np.asarray(e, float) - np.mean(e)
    u = np.asarray(u, float) - np.mean(u)
    n = len(e)
    norm = math.sqrt(float(np.dot(e, e)) * float(np.dot(u, u))) / n
    if not norm > 0:
        return np.full(2 * lags + 1, math.nan)
    out = [float(np.dot(e[tau:], u[: n - tau])) if tau >= 0 else float(np.dot(e[: n + tau], u[-tau:])) for tau in range(-lags, lags + 1)]
    return np.asarray(out) / n / norm


def whiteness(residual, lags: int = LAGS, z: float = Z99) -> float:
    """The fraction of lags 1..`lags` whose normalised autocorrelation lies outside +-z/sqrt(N)."""
    r = autocorrelation(residual, lags)
    if not np.all(np.isfinite(r)):
        return math.nan
    return float(np.mean(np.abs(r[1:]) > z / math.sqrt(len(residual))))


def input_band(residual, u, lags: int = LAGS, z: float = Z99) -> float:
    """The half-width of the cross-correlation's band: z sqrt(P / N), P = sum over tau = -lags..lags
    of r_e(tau) r_u(tau) (normalised autocorrelations; 1 where either series is white)."""
    re, ru = autocorrelation(residual, lags), autocorrelation(u, lags)
    p = float(re[0] * ru[0] + 2 * np.sum(re[1:] * ru[1:]))
    return z * math.sqrt(max(p, 0.0) / len(residual))


def input_correlation(residual, u, lags: int = LAGS, z: float = Z99) -> float:
    """The fraction of lags -`lags`..`lags` whose cross-correlation with the input `u` lies
    outside `input_band` (NaN for a constant input: it cannot correlate)."""
    r = cross_correlation(residual, u, lags)
    if not np.all(np.isfinite(r)):
        return math.nan
    return float(np.mean(np.abs(r) > input_band(residual, u, lags, z)))


def criteria(residuals: np.ndarray, free: int) -> dict[str, float]:
    """AIC, AICc, BIC and FPE (Ljung eq. 16.31-16.33; MATLAB's normalised forms) of residuals
    (N, C) from a model of `free` parameters: V = det(E^T E / N), AIC = N ln V + 2 d, AICc = AIC +
    2 d (d + 1) / (N - d - 1), BIC = N ln V + d ln N, FPE = V (1 + d/N) / (1 - d/N)."""
    e = np.asarray(residuals, float).reshape(len(residuals), -1)
    n, d = e.shape[0], int(free)
    v = float(np.linalg.det(e.T @ e / n))
    log_v = math.log(v) if v > 0 else -math.inf
    aic = n * log_v + 2 * d
    return {
        "aic": aic,
        "aicc": aic + 2 * d * (d + 1) / (n - d - 1) if n > d + 1 else math.inf,
        "bic": n * log_v + d * math.log(n),
        "fpe": v * (1 + d / n) / (1 - d / n) if n > d else math.inf,
    }


__all__ = ["LAGS", "Z99", "channel_metrics", "criteria", "input_band", "input_correlation", "whiteness"]
