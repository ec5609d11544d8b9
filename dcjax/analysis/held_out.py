"""A fit judged on records it was not fitted to, as MATLAB's `compare` and `resid` judge a model:
per recording and output the figures of merit and the residual tests of `dcjax.analysis.metrics`,
and several models side by side with their information criteria (`compare`).

The protocol: each record is simulated from its first sample with the fit's parameters (its
local values, offsets and delays: the first fitted recording's) and an initial state that is
either the record's own (`initial="measured"`: a recorded state's first sample, as the fit's
specs say) or the fit's (`"fitted"`: its fitted initial states, for records that share their
start); `skip` samples at the start are left out of every figure (a benchmark's initialisation
window). The residual tests assume an output-error model: with sensor noise alone the residual
is white and uncorrelated with the inputs; with process noise only the input test applies."""

import dataclasses
import math
from collections.abc import Sequence

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..compiling import filter_jit
from ..errors import ConfigError
from ..io.recording import Recording
from ..simulation.joint import JointProblem
from .metrics import channel_metrics, criteria, input_correlation, whiteness

INITIAL_MODES = ("measured", "fitted")


@dataclasses.dataclass(frozen=True)
class Validation:
    """One record's held-out figures: `of` (the fit's objective on it), and per output channel
    rmse, nrmse, fit_percent, r2, mae, `whiteness` and `input_correlation` (input -> fraction)."""

    recording: str
    initial: str
    skip: int
    samples: int
    of: float
    channels: dict[str, dict]
    residuals: np.ndarray = dataclasses.field(repr=False, compare=False)  # (samples, C) measured - simulated, after `skip`

    def to_dict(self) -> dict:
        """The keys validation.json writes for this record."""
        return {"recording": self.recording, "initial": self.initial, "skip": self.skip, "samples": self.samples, "of": self.of,
                "channels": self.channels}  # fmt: skip


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


def _initial(result, mode: str) -> dict[str, float]:
    if mode not in INITIAL_MODES:
        raise ConfigError(f"initial must be one of {', '.join(INITIAL_MODES)}, got {mode!r}")
    if mode == "measured":
        return {}
    starts = fitted_starts(result)
    if not starts:
        raise ConfigError("initial: fitted, but the fit fitted no initial state (fit with --initial STATE=fit)")
    return starts


def validate(result, recordings: Sequence[Recording], initial: str = "measured", skip: int = 0) -> list[Validation]:
    """`Validation` of `result` on each of `recordings` (module docstring)."""
    if not isinstance(skip, (int, np.integer)) or isinstance(skip, bool) or skip < 0:
        raise ConfigError(f"skip must be a non-negative whole number of samples, got {skip!r}")
    start = _initial(result, initial)
    m = result.model
    x = jnp.asarray([result.best_values[n] for n in result.names], dtype=jnp.float64)
    out = []
    for rec in recordings:
        if len(rec) - skip < 3:
            raise ConfigError(f"{rec._where()}skip: {skip} leaves {len(rec) - skip} of {len(rec)} samples (need at least 3)")
        target = held_out_target(result, rec, start)
        sim, of = np.asarray(_outputs(x, target)), float(_objective(x, target))
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
        out.append(Validation(rec.name, initial, int(skip), len(rec) - skip, of, channels, np.stack(res, axis=1)))
    return out


def compare(recordings: Sequence[Recording], *results, initial: str = "measured", skip: int = 0) -> list[dict]:
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


__all__ = ["INITIAL_MODES", "Validation", "compare", "format_comparison", "validate"]
