"""What `dcjax validate` and `dcjax fit --validate` print and write of a held-out validation
(`dcjax.analysis.held_out`): the table per recording and output, validation.json and the plots."""

from pathlib import Path

from ..analysis.held_out import validate
from ..analysis.metrics import LAGS
from ..analysis.plotting import plot_residual_tests
from ..errors import ConfigError
from ..io.files import strict_json, write_text
from .output import file_names

INITIAL_HELP = (
    "each record's initial state: auto (the default: a state whose start the fit fitted is estimated on the record, the "
    "others as the fit's specs say), measured (a recorded state's first sample, as the fit's specs say), fitted "
    "(the fit's fitted initial states: records that share their start), estimate (estimated on the record with the parameters "
    "fixed; estimate:K on its first K samples), or STATE=MODE|VALUE pairs, e.g. x1=estimate,y=measured"
)
SKIP_HELP = "samples left out of every figure at the start (a benchmark's initialisation window)"


def skip_samples(text: str, flag: str) -> int:
    """`flag`'s whole number of samples >= 0; a one-line error otherwise."""
    try:
        n = int(text)
    except ValueError:
        n = -1
    if n < 0:
        raise ConfigError(f"{flag} must be a whole number of samples >= 0, got {text!r}")
    return n


PREDICT_HELP = (
    "judge the K-step-ahead prediction instead of the simulation: filtered by an extended Kalman filter to K samples "
    "before, then simulated (a prediction-error fit's own filter; another fit's noise is estimated on the record)"
)


def validation_report(res, recs, initial: str, skip: int, out: Path, predict: int | None = None) -> list[str]:
    """Validate `res` on `recs`, write validation.json and the plots in `out`; the lines to print."""
    vals = validate(res, recs, initial=initial, skip=skip, predict=predict)
    width = max(12, *(len(r.name) for r in recs))
    lines = []
    mode = "simulation" if predict is None else f"{predict}-step-ahead prediction"
    lines.append(
        f"{mode}; initial state {vals[0].initial if vals else initial}; {skip} sample(s) skipped; residual tests over lags 1..{LAGS} (99 % bands)"
    )
    lines.append(
        f"{'recording':>{width}} {'output':>10} {'OF':>12} {'rmse':>12} {'nrmse':>9} {'fit %':>9} {'R2':>9} {'mae':>12} "
        f"{'white':>6} {'input':>6}"
    )
    rows = []
    for v, rec, name in zip(vals, recs, file_names([r.name for r in recs])):
        for c, f in v.channels.items():
            corr = max(f["input_correlation"].values(), default=float("nan"))
            lines.append(
                f"{v.recording:>{width}} {c:>10} {v.of:12.4e} {f['rmse']:12.4e} {f['nrmse']:9.4f} {f['fit_percent']:9.3f} "
                f"{f['r2']:9.4f} {f['mae']:12.4e} {f['whiteness']:6.2f} {corr:6.2f}"
            )
            if not f["fit_percent"] > 0:
                lines.append(
                    f"warning: {v.recording}: fit % of {c} is {f['fit_percent']:.1f} <= 0: the model does not follow {c} on this recording"
                )
        if v.predict is not None:
            said = "estimated on this record with the parameters fixed" if v.noise_estimated else "the fit's"
            lines.append(f"{v.recording}: filter noise ({said}): " + ", ".join(f"{k} {x:.3g}" for k, x in (v.noise or {}).items()))
            lines.append(
                f"{v.recording}: normalised innovations (N(0, 1) and white for a right model): "
                + "; ".join(
                    f"{c} mean {k['mean']:+.3f}, variance {k['variance']:.3f}, white {k['whiteness']:.2f}"
                    for c, k in (v.calibration or {}).items()
                )
            )
        rows.append(
            {**v.to_dict(), "fit_percent": {c: f["fit_percent"] for c, f in v.channels.items()}, "plot": f"validate_{name}.png",
             "residual_plot": f"resid_{name}.png"}
        )  # fmt: skip
        res.plot(out / f"validate_{name}.png", recordings=[rec], convergence=False)
        plot_residual_tests(v, rec, res.model.inputs, out / f"resid_{name}.png")
    write_text(out / "validation.json", strict_json(rows) + "\n")
    lines.append(
        "white: the fraction of the residual's autocorrelation lags outside its band; input: the largest over the inputs of the "
        "fraction of cross-correlation lags outside theirs (an output-error model with sensor noise alone: both near 0)"
    )
    lines.append(f"wrote {out / 'validation.json'}, {len(recs)} plot(s) and {len(recs)} residual plot(s) in {out}")
    return lines
