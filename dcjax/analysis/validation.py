"""Checks of a fit beyond its OF: stationary points (paper Section 4.2.7, eq. 25–26, Table 18)
and cross-validation between recordings of one drive (Section 4.2.6, Fig. 12)."""

import numpy as np

from ..errors import ConfigError
from ..io.recording import Recording
from ..models import Model, get_model
from ..simulation.integrators import Integrator
from ..simulation.objectives import objective
from ..simulation.problem import make_problem


def stationary_instants(
    recording: Recording, count: int = 5, tol: float = 0.01, after: float | None = None, channel: str = "omega"
) -> np.ndarray:
    """Indices of `count` samples in steady operation, spread evenly over the steady part: the
    speed (`channel`) changes by less than `tol * max|w|` to both neighbours (and t >= `after`)."""
    w = recording[channel]
    scale = np.max(np.abs(w))
    steady = np.zeros(len(w), bool)
    steady[1:-1] = (np.abs(np.diff(w)[:-1]) < tol * scale) & (np.abs(np.diff(w)[1:]) < tol * scale)
    if after is not None:
        steady &= recording.t >= after
    idx = np.flatnonzero(steady)
    if idx.size < count:
        raise ConfigError(f"only {idx.size} stationary samples found (need {count}); loosen tol")
    return idx[np.round(np.linspace(0, idx.size - 1, count)).astype(int)]


SHORT = {"u_a": "u", "i_a": "i", "omega": "w"}  # row keys of the paper's channels (Table 18)


def stationary_check(params, recording: Recording, times=None, count: int = 5, model: Model | str | None = None) -> list[dict]:
    """The model's stationary relations at steady samples (for the paper's model eq. 25–26,
    di/dt = dw/dt = 0):

        u_calc = i_meas Ra + cm w_meas,    i_calc = (Tla + Tlb w_meas + Tlc w_meas^2) / cm

    For every channel the model predicts, the row has `<c>_meas`, `<c>_calc` and
    `<c>_dev_pct` = |calc - meas| / |meas| in %. `times`: the instants to use (nearest samples);
    default `stationary_instants`. La and J do not enter (Table 18)."""
    model = get_model(model)
    p = model.to_floats(params)
    if times is None:
        idx = stationary_instants(recording, count)
    else:
        idx = np.array([int(np.argmin(np.abs(recording.t - t))) for t in times])
    rows = []
    for k in idx:
        chans = {c: float(v[k]) for c, v in recording.channels.items()}
        calc = model.steady_state(p, chans)
        row = {"t": float(recording.t[k])}
        row.update({f"{SHORT.get(c, c)}_meas": v for c, v in chans.items()})
        for c, v in calc.items():
            row[f"{SHORT.get(c, c)}_calc"] = float(v)
            row[f"{SHORT.get(c, c)}_dev_pct"] = float(100 * abs(v - chans[c]) / abs(chans[c]))
        rows.append(row)
    return rows


def cross_validation(
    fits: dict, recordings: dict[str, Recording], integrator: Integrator | None = None, model: Model | str | None = None
) -> tuple[list[str], list[str], np.ndarray]:
    """OF (eq. 24) of each recording simulated with the parameters fitted on each recording
    (Fig. 12): `M[r, f]` = OF of recording `r` with the fit of `f`; the diagonal is each fit on
    its own data. Each recording keeps its own voltage, current limit and initial state."""
    model = get_model(model)
    rec_names = list(recordings)
    fit_names = list(fits)
    m = np.empty((len(rec_names), len(fit_names)))
    for a, rn in enumerate(rec_names):
        prob = make_problem(recordings[rn], integrator, model=model)
        for b, fn in enumerate(fit_names):
            m[a, b] = float(objective(model.as_array(fits[fn]), prob))
    return rec_names, fit_names, m
