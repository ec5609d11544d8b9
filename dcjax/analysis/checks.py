"""Data checks: what makes a recording unfit to identify from, found before (and after) its fit.

Each finding names its check and has a severity: an `error` fails the recording alone with one
line, a `warning` fits it and flags it (the CLI prints them; `summary.csv` lists them in `checks`).

| check         | severity | rule                                                                         |
|---------------|----------|------------------------------------------------------------------------------|
| `nan`         | error    | a NaN/inf in a column (raised by `Recording`)                                |
| `time`        | error    | times not strictly increasing, duplicates included (raised by `Recording`)  |
| `dead`        | error    | a measured channel all zero (the objective divides by its peak)              |
| `alternating` | error    | among consecutive samples both above 10 % of the peak, > 40 % change sign    |
| `near-dead`   | warning  | peak within 5 noise steps (MAD of differences) or 3 quantisation steps of 0, |
|               |          | or below 5 % of the fleet's median peak of that channel (`fleet_findings`)   |
| `reversed`    | warning  | a channel the model says follows an input (`Model.follows`) opposes it:      |
|               |          | cos(u, y) = sum(u y) / (|u| |y|) < -0.5                                      |
| `saturated`   | warning  | held exactly at its extreme for >= max(5, 2 %) samples, entered steeply: the |
|               |          | change over the 3 samples before is >= 20 % of the channel's steepest such   |
|               |          | change and > 3 quantisation steps (not an approach to a steady state)        |
| `gap`         | warning  | sample intervals longer than 5x the median                                   |
| `irregular`   | warning  | the sample intervals' spread (std / median) above 10 % (none is a gap)       |
| `no-input`    | warning  | every recorded input zero throughout (the motor moved by hand, or a free     |
|               |          | response only), or constant while no measured channel moves (a steady state) |
| `pulse`       | warning  | an input reaches half its peak in fewer than two samples (a pulse the        |
|               |          | sampling barely resolves; not a unit slip)                                   |
| `slow-rate`   | warning  | after the fit: the median sample interval exceeds a time constant of the     |
|               |          | fitted model (`Model.time_constants`; DC: La/Ra); where the integration step |
|               |          | (Euler, RK4: the interval over ND) does too, the fit is biased: --nd auto    |
| `no-follow`   | warning  | after the fit: fit % <= 0 on a channel (the model does not follow it)        |
| `held`        | warning  | after the fit: an input interpolated linearly steps between held values (at  |
|               |          | most 10 % of its intervals change) and a channel's residual in the 3 samples |
|               |          | from each step is over 5x its rms elsewhere and 0.1 % of its peak: a         |
|               |          | zero-order hold, or a delay?                                                 |
| `few-data`    | warning  | after the fit: its compared values (samples x compared channels, every       |
|               |          | recording) are no more than its free parameters (initial states and local    |
|               |          | values included): many parameter sets match them, none is determined         |
"""

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from ..errors import DataError
from ..io.recording import Recording
from ..models import DiscreteModel, Model
from ..simulation.integrators import RK4, Euler
from .report import channel_fit

ERROR, WARNING = "error", "warning"


@dataclasses.dataclass(frozen=True)
class Finding:
    """One check's finding on a recording: `check` (its name), `severity` ("error" or
    "warning"), the `channel` it concerns (or None) and a one-line `message`."""

    check: str
    severity: str
    message: str
    channel: str | None = None

    @property
    def label(self) -> str:
        """`check:channel` (or `check`), as `summary.csv` lists it."""
        return self.check if self.channel is None else f"{self.check}:{self.channel}"

    def __str__(self) -> str:
        return f"{self.severity}: {self.label}: {self.message}"

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def from_error(error: Exception) -> Finding | None:
    """The finding a `DataError` carries (NaN, bad times, a dead channel), else None."""
    if isinstance(error, DataError) and error.check:
        return Finding(error.check, ERROR, str(error).partition(": ")[2] or str(error))
    return None


def median(a: np.ndarray) -> float:
    """`np.median` of a 1-D float array, the same value (the middle sample, or the mean of the two
    middle ones; NaN where any is NaN) from one `np.partition`: 2 us instead of 10 for 700 samples,
    three times a recording's checks."""
    n = a.size
    if n == 0 or np.isnan(a).any():
        return float(np.median(a)) if n else float("nan")
    half = n // 2
    if n % 2:
        return float(np.partition(a, half)[half]) + 0.0  # (+0.0: as np.median, no negative zero)
    part = np.partition(a, (half - 1, half))
    return float((part[half - 1] + part[half]) / 2.0) + 0.0


def noise_step(y: np.ndarray, order: int = 1) -> float:
    """The channel's white-noise sd from its `order`-th differences: 1.4826 MAD / sqrt(C(2k, k))
    (white noise of sd s gives k-th differences of sd s sqrt(C(2k, k)): sqrt 2 for the first,
    sample to sample; sqrt 70 for the fourth, which a smooth signal's own shape hardly reaches:
    its differences shrink by about its sample step times its bandwidth per order; the median lets
    steps and kinks count little). 0 for too few samples."""
    d = np.diff(np.asarray(y, float), order)
    if d.size == 0:
        return 0.0
    return float(1.4826 * median(np.abs(d - median(d))) / np.sqrt(math.comb(2 * order, order)))


def quantisation_step(y: np.ndarray) -> float:
    """The smallest non-zero difference between the channel's distinct values (0: none)."""
    v = np.unique(y)
    d = np.diff(v)
    d = d[d > 0]
    return float(d.min()) if d.size else 0.0


def _cos(a: np.ndarray, b: np.ndarray) -> float:
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    return float(a @ b / (na * nb)) if na > 0 and nb > 0 else 0.0


def _alternating(y: np.ndarray, peak: float) -> Finding | None:
    big = np.abs(y) > 0.1 * peak
    both = big[:-1] & big[1:]
    if both.sum() < 10:
        return None
    flips = (np.sign(y[:-1]) != np.sign(y[1:])) & both
    share = flips.sum() / both.sum()
    if share > 0.4:  # a sign bug flips nearly every pair; a real signal crosses zero a few times
        return Finding("alternating", ERROR, f"the sign changes between {100 * share:.0f} % of consecutive samples", None)
    return None


def _saturated(y: np.ndarray, peak: float, q: float) -> Finding | None:
    """A run at the channel's extreme entered steeply (`q`: its `quantisation_step`)."""
    k = int(np.argmax(np.abs(y)))
    ext = y[k]
    at = np.abs(y - ext) <= 1e-12 * abs(ext)
    runs = np.diff(np.concatenate([[0], at.astype(int), [0]]))
    starts, ends = np.flatnonzero(runs == 1), np.flatnonzero(runs == -1)
    length = ends - starts
    j = int(np.argmax(length))
    need = max(5, int(np.ceil(0.02 * y.size)))
    if length[j] < need or starts[j] < 3:
        return None
    entry = abs(y[starts[j]] - y[starts[j] - 3])
    steepest = float(np.max(np.abs(y[3:] - y[:-3])))
    if entry < 0.2 * steepest or entry <= 3 * q:  # an approach to a steady state, or a quantised one
        return None
    return Finding("saturated", WARNING, f"held at {ext:.6g} for {int(length[j])} samples from t index {int(starts[j])} (clipped?)")


def pulse_width(u: np.ndarray) -> int:
    """How many samples of `u` reach half its peak magnitude (0 for an input that is all zero)."""
    peak = float(np.max(np.abs(u))) if u.size else 0.0
    return int(np.sum(np.abs(u) >= 0.5 * peak)) if peak > 0 else 0


def _moves(y: np.ndarray, step: float | None = None, q: float | None = None) -> bool:
    """The channel changes by more than its noise (the range of 10^4 Gaussian samples is ~8 sigma)
    and its quantisation (`step`, `q`: its `noise_step` and `quantisation_step`, if known)."""
    step = noise_step(y) if step is None else step
    q = quantisation_step(y) if q is None else q
    return float(np.ptp(y)) > max(10 * step, 3 * q)


def input_findings(recording: Recording, model: Model, moving: list[str] | None = None) -> list[Finding]:
    """`no-input` (every recorded input zero throughout, or constant while nothing moves) and
    `pulse` (an input at half its peak in fewer than two samples); module docstring. `moving`:
    the measured channels that move (`_moves`), where the caller has found them already."""
    recorded = [c for c in model.inputs if c in recording.channels and c not in recording.constants]
    if not recorded:
        return []
    u = {c: np.asarray(recording[c], float) for c in recorded}
    if moving is None:
        moving = [c for c in model.outputs if c in recording.channels and _moves(np.asarray(recording[c], float))]
    out = []
    if all(not np.any(v) for v in u.values()):
        out.append(
            Finding(
                "no-input",
                WARNING,
                f"input {', '.join(recorded)} is zero throughout"
                + (
                    f" while {', '.join(moving)} moves: moved by hand, or a free response from the initial state only?"
                    if moving
                    else " and nothing moves"
                ),
                recorded[0],
            )
        )
    elif all(np.ptp(v) == 0 for v in u.values()) and not moving:
        out.append(
            Finding(
                "no-input",
                WARNING,
                f"input {', '.join(recorded)} is constant and nothing moves: the recording shows a steady state only",
                recorded[0],
            )
        )
    for c, v in u.items():
        if np.any(v) and (width := pulse_width(v)) < 2:
            out.append(
                Finding(
                    "pulse",
                    WARNING,
                    f"input {c} reaches half its peak {np.max(np.abs(v)):.4g} in {width} sample only: "
                    "a pulse shorter than two samples, which the sampling barely resolves",
                    c,
                )
            )
    return out


def check_recording(recording: Recording, model: Model) -> list[Finding]:
    """The findings on one recording for `model` (module docstring), before any fit."""
    out: list[Finding] = []
    t = recording.t
    dt = np.diff(t)
    med = median(dt)
    long = dt > 5 * med
    if np.any(long):
        k = int(np.argmax(dt))
        out.append(
            Finding(
                "gap",
                WARNING,
                f"{int(long.sum())} sample interval(s) longer than 5x the median {med:.3g} s "
                f"(the longest {dt[k]:.3g} s at t = {t[k]:.6g} s)",
            )
        )
    elif dt.size > 1 and (spread := float(np.std(dt)) / med) > 0.1:
        out.append(
            Finding(
                "irregular",
                WARNING,
                f"the sample intervals vary by {100 * spread:.0f} % (std / median {med:.3g} s, "
                f"{dt.min():.3g}..{dt.max():.3g} s): simulated on the recorded times",
            )
        )
    moving = []  # the measured channels that move (`input_findings`)
    for c in model.outputs:
        if c not in recording.channels:
            continue
        y = np.asarray(recording[c], float)
        peak = float(np.max(np.abs(y)))
        if peak == 0:
            out.append(Finding("dead", ERROR, f"column {c!r} is all zero", c))
            continue
        step, q = noise_step(y), quantisation_step(y)
        if _moves(y, step, q):
            moving.append(c)
        flips = _alternating(y, peak)
        if flips is not None:  # (an alternating channel also looks like noise to the near-dead rule)
            out.append(dataclasses.replace(flips, channel=c))
            continue
        if peak <= 5 * step or peak <= 3 * q:
            out.append(
                Finding(
                    "near-dead",
                    WARNING,
                    f"peak {peak:.3g} is within a few noise/quantisation steps of zero "
                    f"(noise {step:.2g}, step {q:.2g}): a sensor that is all but dead",
                    c,
                )
            )
            continue
        saturated = _saturated(y, peak, q)
        if saturated is not None:
            out.append(dataclasses.replace(saturated, channel=c))
        source = model.follows.get(c)
        if source is not None and source in recording.channels:
            cos = _cos(np.asarray(recording[source], float), y)
            if cos < -0.5:
                out.append(
                    Finding(
                        "reversed",
                        WARNING,
                        f"{c} opposes {source} (cos {cos:+.2f}) where the model says it follows it: wired or signed in reverse?",
                        c,
                    )
                )
    return out + input_findings(recording, model, moving)


def fleet_findings(recordings: Sequence[Recording], model: Model, ratio: float = 0.05) -> list[list[Finding]]:
    """Per recording, a `near-dead` warning for a channel whose peak is below `ratio` of the
    fleet's median peak of that channel (needs 4 recordings)."""
    out: list[list[Finding]] = [[] for _ in recordings]
    if len(recordings) < 4:
        return out
    for c in model.outputs:
        peaks = np.array([float(np.max(np.abs(r[c]))) if c in r.channels else np.nan for r in recordings])
        med = float(np.nanmedian(peaks))
        for k, p in enumerate(peaks):
            if np.isfinite(p) and 0 < p < ratio * med:
                out[k].append(
                    Finding("near-dead", WARNING, f"peak {p:.3g} is {100 * p / med:.1f} % of the fleet's median peak {med:.3g}", c)
                )
    return out


def fit_findings(result, recording: Recording | None = None, fits: dict[str, float] | None = None) -> list[Finding]:
    """After a fit: `slow-rate` (a sample interval longer than a time constant of the fitted
    model), `no-follow` (fit % <= 0 on a channel; `fits` as `channel_fit` gives them) and `held`
    (not where the integration step is named first: its error sits at the input's steps too)."""
    rec = recording if recording is not None else result.recording
    out: list[Finding] = []
    if rec is None:
        return out
    dt = float(np.median(np.diff(rec.t)))
    values = (
        result.values(0) if hasattr(result, "values") else result.best_values
    )  # the model's parameters (a local one: the first recording's)
    integrator = getattr(result, "integrator", None)
    substeps = int(integrator.substeps) if isinstance(integrator, (Euler, RK4)) else None  # a fixed step: dt / ND
    biased = False  # an integration step longer than a time constant
    for name, tau in result.model.time_constants(values).items():
        if not (np.isfinite(tau) and dt > tau):
            continue
        if substeps is not None and dt / substeps > tau:
            biased = True
            if getattr(result, "nd_auto", None):  # ND was chosen already (it did not converge): a fixed ND that resolves tau
                nd = 2 ** math.ceil(math.log2(dt / tau))
                fix = f"--nd auto stopped at ND={substeps} (nd_auto in result.json); refit with integrator=dcjax.{type(integrator).__name__}(substeps={nd})"
            else:
                fix = "refit with integrator=dcjax.AutoSubsteps() (ND chosen against a converged reference)"
            message = (
                f"the integration step {dt / substeps:.3g} s (the sample interval over ND={substeps}) is longer than the fitted "
                f"{name} = {tau:.3g} s: the simulation is far from converged there, which biases the fit; {fix}"
            )
        else:
            message = (
                f"the sample interval {dt:.3g} s is longer than the fitted {name} = {tau:.3g} s: only the samples right after "
                f"each change of the input show it; its standard error says how well they do"
            )
        out.append(Finding("slow-rate", WARNING, message))
    sim = None
    if fits is None:
        sim = np.asarray(result.simulate_outputs(rec))
        fits = channel_fit(result, rec, sim)
    for c, v in fits.items():
        if not v > 0:
            out.append(Finding("no-follow", WARNING, f"fit % {v:.1f} <= 0: the model does not follow {c}", c))
    return out if biased else out + _held(result, rec, sim)


def result_findings(result) -> list[Finding]:
    """Every finding of a fit: those it carries (`result.checks`: before the fit, and `few-data`)
    and the after-fit ones of each of its recordings (`fit_findings`), each message prefixed with
    its recording's name in a joint fit."""
    recs = result.recordings
    after = [
        g if len(recs) == 1 else dataclasses.replace(g, message=f"{r.name}: {g.message}") for r in recs for g in fit_findings(result, r)
    ]
    return [*result.checks, *after]


HELD_CHANGES = 0.1  # an input that changes in at most this share of its intervals steps between held values
HELD_RATIO = 5.0  # a residual this many times its rms elsewhere in the samples from each step: the steps are mistimed
HELD_SAMPLES = 3  # the samples from each step (the step's own and the next two)
HELD_LEVEL = 1e-3  # ... and above this share of the channel's peak (not an integrator's rounding at the steps of noise-free data)


def _steps(u: np.ndarray) -> np.ndarray:
    """The samples where a stepwise input takes a new value (after its first), or none where it
    changes in more than `HELD_CHANGES` of its intervals (a measured, continuous signal)."""
    k = np.flatnonzero(np.diff(u) != 0) + 1
    return k if 0 < k.size <= HELD_CHANGES * (u.size - 1) else k[:0]


def _held(result, rec: Recording, sim: np.ndarray | None = None) -> list[Finding]:
    """`held`: an input that steps between held values, interpolated linearly between samples
    (eq. 29: each step moved into the interval before it), where a channel's residual is
    concentrated in the samples from the steps (module docstring). `sim`: the fit's outputs on
    `rec`, where the caller has them."""
    if isinstance(result.model, DiscreteModel):  # its map reads the inputs at the samples: nothing is interpolated
        return []
    obs = getattr(result, "observation", None)
    held = dict(getattr(obs, "hold", {}) or {})
    stepwise = {
        c: k
        for c in result.model.inputs
        if c in rec.channels and c not in rec.constants and c not in held and (k := _steps(np.asarray(rec[c], float))).size >= 2
    }
    if not stepwise:
        return []
    sim = np.asarray(result.simulate_outputs(rec)) if sim is None else sim
    out = []
    for c, k in stepwise.items():
        near = np.zeros(len(rec), bool)
        for j in range(HELD_SAMPLES):
            near[np.minimum(k + j, len(rec) - 1)] = True
        if near.all():
            continue
        for j, ch in enumerate(result.model.outputs):
            if ch not in rec.channels:
                continue
            e = np.asarray(rec[ch], float) - sim[:, j]
            inside, outside = (float(np.sqrt(np.mean(e[m] ** 2))) for m in (near, ~near))
            peak = float(np.max(np.abs(np.asarray(rec[ch], float))))
            if outside > 0 and inside > HELD_RATIO * outside and inside > HELD_LEVEL * peak:
                out.append(
                    Finding(
                        "held",
                        WARNING,
                        f"the residual of {ch} in the {HELD_SAMPLES} samples from each of the {k.size} steps of input {c} is "
                        f"{inside / outside:.0f}x its rms elsewhere: if the input is held between samples (a DAQ's or a "
                        f"controller's output), refit with hold={{{c!r}: 'zoh'}} (the default interpolates linearly between "
                        f"samples, which moves each step into the interval before it); else an input delay, delays=({c!r},)?",
                        c,
                    )
                )
                break
    return out


def count_findings(data_points: int, free: int) -> list[Finding]:
    """`few-data` where a fit's `data_points` residuals (samples times compared channels, all its
    recordings) are no more than its `free` parameters: N equations in P >= N unknowns are matched
    by many parameter sets, so the fitted values are one of them, not what the data determine."""
    if data_points > free:
        return []
    return [
        Finding(
            "few-data",
            WARNING,
            f"{data_points} compared values (samples x channels) for {free} free parameters: the data do not determine them; "
            f"fit a longer recording, or fix parameters (--fix NAME=VALUE)",
        )
    ]


def recording_findings(recordings: Sequence[Recording], model: Model) -> list[Finding]:
    """The findings of every recording of one fit, each message prefixed with its recording's
    name in a joint fit."""
    out = []
    for r in recordings:
        for f in check_recording(r, model):
            out.append(f if len(recordings) == 1 else dataclasses.replace(f, message=f"{r.name}: {f.message}"))
    return out


def batch_findings(recordings: Sequence[Recording], model: Model) -> list[list[Finding]]:
    """Per recording of a batch of independent fits: its own findings and the fleet's (`fleet_findings`)."""
    return [check_recording(r, model) + fleet for r, fleet in zip(recordings, fleet_findings(recordings, model))]
