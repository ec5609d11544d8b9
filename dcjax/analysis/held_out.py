"""A fit judged on records it was not fitted to, as MATLAB's `compare` and `resid` judge a model:
per recording and output the figures of merit and the residual tests of `dcjax.analysis.metrics`,
and several models side by side with their information criteria (`compare`).

The protocol: each record is simulated from its first sample with the fit's parameters (its
local values, offsets and delays: the first fitted recording's) and an initial state per state
(`initial`): as the fit started its own (`"auto"`, the default: a state whose start the fit
fitted is estimated on the record, as MATLAB's `compare` estimates it, the others as the fit's specs
say), the record's own (`"measured"`: a recorded state's first sample, as the fit's specs
say), the fit's (`"fitted"`: its fitted initial state, for records that share their start),
estimated on the record with the parameters fixed (`"estimate"` over the whole record,
`"estimate:K"` over its first K samples: MATLAB's `findstates`), or a number. A bare mode applies
to every state (`"fitted"`: to every fitted one); `"x1=estimate,y=measured"` (or a dict) sets
them one by one. `skip` samples at the start are left out of every figure (a benchmark's
initialisation window). The residual tests assume an output-error model: with sensor noise alone the residual
is white and uncorrelated with the inputs; with process noise only the input test applies.
`predict=K` judges the K-step-ahead prediction instead (`dcjax.analysis.prediction`)."""

import dataclasses
import math
import warnings
from collections.abc import Sequence

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..compiling import filter_jit
from ..errors import ConfigError
from ..extras import optional_module
from ..io.recording import Recording, as_recording
from ..simulation.joint import JointProblem
from .initial_states import estimate_states, released, with_start
from .metrics import channel_metrics, criteria, input_correlation, whiteness
from .prediction import calibration, predicted

INITIAL_MODES = ("auto", "measured", "fitted", "estimate")
DEFAULT_INITIAL = "auto"  # validate's, compare's and the CLI's
Mode = str | float | tuple[str, int | None]  # "measured" | "fitted" | ("estimate", samples or None) | a value


@dataclasses.dataclass(frozen=True)
class Validation:
    """One record's held-out figures: `of` (the fit's objective on it), and per output channel
    rmse, nrmse, fit_percent, r2, mae, `whiteness` and `input_correlation` (input -> fraction);
    `start`: the initial state it was simulated from (state -> value)."""

    recording: str
    initial: str
    skip: int
    samples: int
    of: float
    channels: dict[str, dict]
    start: dict[str, float]
    residuals: np.ndarray = dataclasses.field(repr=False, compare=False)  # (samples, C) measured - simulated, after `skip`
    predict: int | None = None  # the figures are of the K-step-ahead prediction (None: of the simulation)
    calibration: dict | None = None  # with predict: per output the normalised innovations' mean, variance, whiteness
    noise: dict | None = None  # with predict: the filter's q_<state>, r_<output>
    noise_estimated: bool = False  # estimated on this record with the parameters fixed (a simulation-error fit)

    def to_dataframe(self):
        """The figures as a pandas DataFrame, a row per output channel (`input_correlation` a
        column per input, `input_correlation[u]`). Needs pandas (`dcjax[notebook]`)."""
        pd = optional_module("pandas", "Validation.to_dataframe")
        rows = {}
        for c, f in self.channels.items():
            rows[c] = {k: v for k, v in f.items() if k != "input_correlation"} | {
                f"input_correlation[{u}]": v for u, v in f["input_correlation"].items()
            }
        df = pd.DataFrame.from_dict(rows, orient="index")
        df.index.name = "output"
        df.attrs.update({"recording": self.recording, "initial": self.initial, "skip": self.skip, "of": self.of, "start": self.start})
        return df

    def to_dict(self) -> dict:
        """The keys validation.json writes for this record."""
        out = {"recording": self.recording, "initial": self.initial, "skip": self.skip, "samples": self.samples, "of": self.of,
               "start": self.start, "channels": self.channels}  # fmt: skip
        if self.predict is not None:
            out |= {"predict": self.predict, "calibration": self.calibration, "noise": self.noise, "noise_estimated": self.noise_estimated}
        return out


@filter_jit
def _outputs(x, target: JointProblem):
    return target.simulate_outputs(x, 0)


@filter_jit
def _objective(x, target: JointProblem):
    return target.objective(x)


def fitted_starts(result) -> dict[str, float]:
    """State -> the fit's value of every fitted initial state (`y0_<state>`; a joint fit's first
    recording's): the start `initial="fitted"` gives a held-out record."""
    out = {}
    for s in result.model.states:
        for key in (f"y0_{s}", f"y0_{s}[0]"):
            if key in result.best_values:
                out[s] = float(result.best_values[key])
                break
    return out


def held_out_target(result, recording: Recording, initial: dict[str, float]) -> JointProblem:
    """`result.target([recording])` with the states of `initial` (state -> value) starting there."""
    target = result.target([recording])
    if not initial:
        return target
    p = target.problems[0]
    y0 = np.asarray(p.y0, float).copy()
    for s, v in initial.items():
        y0[result.model.states.index(s)] = float(v)
    return eqx.tree_at(lambda t: t.problems, target, (eqx.tree_at(lambda q: q.y0, p, y0), *target.problems[1:]))


def _mode(text, state: str) -> Mode:
    """A state's mode: "measured", "fitted", ("estimate", K | None) or a number."""
    if isinstance(text, (int, float, np.number)) and not isinstance(text, bool):
        return float(text)
    t = str(text).strip()
    if t in ("measured", "fitted", "estimate"):
        return t if t != "estimate" else ("estimate", None)
    if t.startswith("estimate:"):
        k = t.split(":", 1)[1]
        if k.isdigit() and int(k) >= 2:
            return ("estimate", int(k))
    try:
        v = float(t)
    except ValueError:
        v = float("nan")
    if math.isfinite(v):
        return v
    modes = "measured, fitted, estimate, estimate:K (K >= 2 samples) or a finite number"
    raise ConfigError(f"initial: {state} {text!r}: give {modes}" if state else f"initial: mode {text!r}: give auto, {modes}")


def initial_modes(result, initial) -> dict[str, Mode]:
    """State -> mode of `initial` (module docstring): a bare mode for every state, or
    `"STATE=MODE,..."` / a dict for some (the others measured); one-line errors. `"auto"` (None):
    every state whose start the fit fitted estimated over the record."""
    states = result.model.states
    if _is_auto(initial):
        return dict.fromkeys(fitted_starts(result), ("estimate", None))
    if isinstance(initial, str) and "=" not in initial:
        mode = _mode(initial, "")
        if mode == "fitted":
            starts = fitted_starts(result)
            if not starts:
                raise ConfigError("initial: fitted, but the fit fitted no initial state (fit with --initial STATE=fit)")
            return dict.fromkeys(starts, "fitted")
        return {} if mode == "measured" else dict.fromkeys(states, mode)
    if isinstance(initial, str):
        pairs = {}
        for item in initial.split(","):
            key, sep, value = item.partition("=")
            if not sep or not key.strip():
                raise ConfigError(f"initial: {item!r} is not STATE=MODE (e.g. x1=estimate,y=measured)")
            pairs[key.strip()] = value
        initial = pairs
    if not isinstance(initial, dict):
        raise ConfigError(f"initial must be a mode or STATE=MODE pairs (a str or a dict), got {initial!r}")
    bad = [s for s in initial if s not in states]
    if bad:
        raise ConfigError(f"initial: unknown state(s) {', '.join(map(repr, bad))}; the model's states are {', '.join(states)}")
    modes = {s: _mode(v, s) for s, v in initial.items()}
    fitted = fitted_starts(result)
    missing = [s for s, m in modes.items() if m == "fitted" and s not in fitted]
    if missing:
        raise ConfigError(
            f"initial: {', '.join(missing)}=fitted, but the fit did not fit its initial state (fitted: {', '.join(fitted) or 'none'})"
        )
    return {s: m for s, m in modes.items() if m != "measured"}


def _is_auto(initial) -> bool:
    """Whether `initial` is the default mode, "auto" (or None)."""
    return initial is None or (isinstance(initial, str) and initial.strip() == "auto")


def _mode_text(initial, modes: dict[str, Mode]) -> str:
    """How the starts were set: `initial` as given, `"auto"` as what it chose (`"measured"` where
    the fit fitted no start, else `"auto: S=estimate,..."`)."""
    if _is_auto(initial):
        return "measured" if not modes else "auto: " + ",".join(f"{s}=estimate" for s in modes)
    return initial if isinstance(initial, str) else ",".join(f"{s}={v}" for s, v in initial.items())


def held_out_start(result, recording: Recording, modes: dict[str, Mode], x) -> JointProblem:
    """The target of `recording` with its initial state as `modes` say (`initial_modes`)."""
    starts = fitted_starts(result)
    fixed: dict[str, float] = {}
    spans: dict[str, int | None] = {}
    for s, m in modes.items():
        if isinstance(m, tuple):
            spans[s] = m[1]
        elif isinstance(m, float):
            fixed[s] = m
        elif m == "fitted":
            fixed[s] = starts[s]
    target = held_out_target(result, recording, fixed)
    if not spans:
        return target
    if len(set(spans.values())) > 1:
        raise ConfigError("initial: estimate the states over one span (estimate, or estimate:K with the same K)")
    k, est = next(iter(spans.values())), tuple(spans)
    if k is not None and k > len(recording):
        raise ConfigError(f"{recording._where()}initial: estimate:{k} but the recording has {len(recording)} samples")
    idx = tuple(result.model.states.index(s) for s in est)
    z, _, converged = estimate_states(target, x, idx, k)
    if not converged:
        warnings.warn(f"{recording.name}: the estimate of the initial state(s) {', '.join(est)} did not converge", stacklevel=3)
    return with_start(released(target, idx), z, np.asarray(idx))


def validate(
    result, recordings: Sequence[Recording], initial: "str | dict | None" = DEFAULT_INITIAL, skip: int = 0, predict: int | None = None
) -> list[Validation]:
    """`Validation` of `result` on each of `recordings` (module docstring); `predict=K`: the
    figures of the K-step-ahead prediction by the fit's Kalman filter, with the innovations'
    calibration (`dcjax.analysis.prediction`)."""
    if not isinstance(skip, (int, np.integer)) or isinstance(skip, bool) or skip < 0:
        raise ConfigError(f"skip must be a non-negative whole number of samples, got {skip!r}")
    if predict is not None and (not isinstance(predict, (int, np.integer)) or isinstance(predict, bool) or predict < 1):
        raise ConfigError(f"predict must be a whole number of samples >= 1, got {predict!r}")
    modes = initial_modes(result, initial)
    m = result.model
    recordings = [as_recording(r, m) for r in recordings]  # a pandas DataFrame: Recording.from_dataframe
    x = jnp.asarray([result.best_values[n] for n in result.names], dtype=jnp.float64)
    out = []
    for rec in recordings:
        if len(rec) - skip < 3:
            raise ConfigError(
                f"{rec._where()}skip: {skip} samples of {len(rec)} leave {max(len(rec) - skip, 0)} (need at least 3 after the skipped ones)"
            )
        target = held_out_start(result, rec, modes, x)
        sim, of = np.asarray(_outputs(x, target)), float(_objective(x, target))
        forecast = None if predict is None else predicted(result, target, x, int(predict))
        sim = sim if forecast is None else forecast.outputs
        adj = target.adjustments(x, 0)
        y0 = np.asarray(target.problems[0].y0 if adj is None or adj.y0 is None else adj.y0, float)
        inputs = {u: np.asarray(rec[u], float)[skip:] for u in m.inputs if u in rec.channels and u not in rec.constants}
        channels, res = {}, []
        for j, c in enumerate(m.outputs):
            y, s = np.asarray(rec[c], float)[skip:], sim[skip:, j]
            e = y - s
            res.append(e)
            channels[c] = {
                **channel_metrics(y, s),
                "whiteness": whiteness(e),
                "input_correlation": {u: input_correlation(e, v) for u, v in inputs.items()},
            }
        start = {s: float(v) for s, v in zip(m.states, y0)}
        extra = {}
        if forecast is not None:
            extra = {"predict": int(predict), "calibration": calibration(forecast.whitened[skip:], m.outputs),  # pyright: ignore[reportArgumentType]
                     "noise": forecast.noise, "noise_estimated": forecast.estimated}  # fmt: skip
        out.append(
            Validation(
                rec.name, _mode_text(initial, modes), int(skip), len(rec) - skip, of, channels, start, np.stack(res, axis=1), **extra
            )
        )
    return out


def compare(recordings: Sequence[Recording], *results, initial: "str | dict | None" = DEFAULT_INITIAL, skip: int = 0) -> list[dict]:
    """Several fits on the same held-out `recordings`, side by side (MATLAB's `compare` with
    `aic`/`fpe`): per result its model, free parameters, each record's `Validation` and the
    information criteria AIC, AICc, BIC, FPE of all the records' residuals together (each channel
    scaled by its measured range, so channels of other units weigh alike)."""
    if not results:
        raise ConfigError("compare: give at least one result")
    rows = []
    for res in results:
        vals = validate(res, recordings, initial=initial, skip=skip)
        scale = np.array([max(float(np.ptp(np.concatenate([np.asarray(r[c], float)[skip:] for r in recordings]))), 1e-300)
                          for c in res.model.outputs])  # fmt: skip
        e = np.concatenate([v.residuals / scale for v in vals])
        rows.append({"model": res.model.name, "free": res.nvarys, "validations": vals, **criteria(e, res.nvarys)})
    return rows


def format_comparison(rows: list[dict]) -> str:
    """`compare`'s rows as a table: per model its free parameters, mean fit % per output and the criteria."""
    lines = [f"{'model':>20} {'free':>5} {'AIC':>12} {'AICc':>12} {'BIC':>12} {'FPE':>12}  fit % (mean over the records)"]
    for row in rows:
        fits = {}
        for v in row["validations"]:
            for c, f in v.channels.items():
                fits.setdefault(c, []).append(f["fit_percent"])
        fit_text = ", ".join(f"{c} {np.mean(v):.2f}" for c, v in fits.items())
        crit = " ".join(f"{row[k]:12.5g}" if math.isfinite(row[k]) else f"{'inf':>12}" for k in ("aic", "aicc", "bic", "fpe"))
        lines.append(f"{row['model']:>20} {row['free']:5d} {crit}  {fit_text}")
    return "\n".join(lines)


__all__ = ["INITIAL_MODES", "Validation", "compare", "format_comparison", "initial_modes", "validate"]
