"""Checks of a fit beyond its OF: stationary points (paper Section 4.2.7, eq. 25–26, Table 18)
and cross-validation between recordings of one drive (Section 4.2.6, Fig. 12)."""

import numpy as np

from .objectives import objective
from .params import PARAM_NAMES, Params
from .problem import make_problem
from .recording import Recording


def stationary_instants(recording: Recording, count: int = 5, tol: float = 0.01, after: float | None = None) -> np.ndarray:
    """Indices of `count` samples in steady operation, spread evenly over the steady part: the
    speed changes by less than `tol * max|w|` to both neighbours (and t >= `after` if given)."""
    w = recording.omega
    scale = np.max(np.abs(w))
    steady = np.zeros(len(w), bool)
    steady[1:-1] = (np.abs(np.diff(w)[:-1]) < tol * scale) & (np.abs(np.diff(w)[1:]) < tol * scale)
    if after is not None:
        steady &= recording.t >= after
    idx = np.flatnonzero(steady)
    if idx.size < count:
        raise ValueError(f"only {idx.size} stationary samples found (need {count}); loosen tol")
    return idx[np.round(np.linspace(0, idx.size - 1, count)).astype(int)]


def stationary_check(params: dict | Params, recording: Recording, times=None, count: int = 5) -> list[dict]:
    """Eq. 25–26 at stationary samples (di/dt = dw/dt = 0):

        u_calc = i_meas Ra + cm w_meas,    i_calc = (Tla + Tlb w_meas + Tlc w_meas^2) / cm

    with deviations |calc - meas| / |meas| in %. `times`: the instants to use (nearest samples);
    default `stationary_instants`. La and J do not enter (Table 18)."""
    p = params.to_dict() if isinstance(params, Params) else dict(params)
    if times is None:
        idx = stationary_instants(recording, count)
    else:
        idx = np.array([int(np.argmin(np.abs(recording.t - t))) for t in times])
    rows = []
    for k in idx:
        i, w, u = recording.i_a[k], recording.omega[k], recording.u_a[k]
        u_calc = i * p["Ra"] + p["cm"] * w
        i_calc = (p["Tla"] + p["Tlb"] * w + p["Tlc"] * w * w) / p["cm"]
        rows.append(
            {
                "t": float(recording.t[k]),
                "i_meas": float(i),
                "w_meas": float(w),
                "u_meas": float(u),
                "u_calc": float(u_calc),
                "u_dev_pct": float(100 * abs(u_calc - u) / abs(u)),
                "i_calc": float(i_calc),
                "i_dev_pct": float(100 * abs(i_calc - i) / abs(i)),
            }
        )
    return rows


def cross_validation(
    fits: dict[str, dict | Params], recordings: dict[str, Recording], integrator: str = "rk4", nd: int = 1
) -> tuple[list[str], list[str], np.ndarray]:
    """OF (eq. 24) of each recording simulated with the parameters fitted on each recording
    (Fig. 12): `M[r, f]` = OF of recording `r` with the fit of `f`; the diagonal is each fit on
    its own data. Each recording keeps its own voltage, current limit and initial state."""
    rec_names = list(recordings)
    fit_names = list(fits)
    m = np.empty((len(rec_names), len(fit_names)))
    for a, rn in enumerate(rec_names):
        prob = make_problem(recordings[rn], integrator=integrator, nd=nd)
        for b, fn in enumerate(fit_names):
            p = fits[fn]
            p = p if isinstance(p, Params) else Params.from_dict({n: p[n] for n in PARAM_NAMES})
            m[a, b] = float(objective(p, prob))
    return rec_names, fit_names, m
