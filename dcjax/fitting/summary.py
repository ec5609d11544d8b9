"""The summary of a batch of fits (`fit_each`, and the command line's fit of each file): one row per recording,
robust outlier flags, `summary.csv` and `summary.png`."""

import csv
import io
import math
import textwrap
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..analysis.checks import fit_findings
from ..analysis.report import channel_fit, loose_parameters
from ..errors import ConfigError
from ..io.files import save_figure, write_atomic
from ..models import Model
from .result import FailedFit, FitResult

OUTLIER_Z = 3.5  # modified z-score (Iglewicz & Hoaglin): 0.6745 |x - median| / MAD


def robust_outliers(values: np.ndarray, z: float = OUTLIER_Z, above_only: bool = False) -> np.ndarray:
    """Modified z-score rule: |0.6745 (x - median) / MAD| > z (with `above_only`, only above the
    median), on log10 |x| where every value is positive (parameters and OFs spread over decades).
    NaN values are not judged. Needs 4 values; else nothing is flagged."""
    x = np.asarray(values, float)
    ok = np.isfinite(x)
    flags = np.zeros(x.shape, bool)
    if ok.sum() < 4:
        return flags
    v = np.log10(x[ok]) if np.all(x[ok] > 0) else x[ok]
    med = np.median(v)
    mad = np.median(np.abs(v - med))
    dev = v - med if above_only else np.abs(v - med)
    if mad == 0:
        flags[ok] = dev > 1e-9 * max(1.0, abs(med))  # all alike but these
        return flags if flags.sum() < 0.5 * ok.sum() else np.zeros(x.shape, bool)
    flags[ok] = 0.6745 * dev / mad > z
    return flags


AT_BOUND_RTOL = 1e-3  # within 0.1 % of the range from a bound: "at the bound", not an outlier for being there


def outlier_flags(rows: list[dict], results: Sequence[FitResult], names: Sequence[str]) -> list[list[str]]:
    """The outlier rule of a batch (one list of flags per fitted row):

    - `of`: an OF far above the fleet's (modified z of log10 OF > 3.5, above the median only);
    - `fit_<channel>`: fit % <= 0 on that channel, always;
    - a free parameter: modified z > 3.5 (on log10 where all positive) among the fits where it is
      not at a bound: a parameter at (or within `AT_BOUND_RTOL` of the range from) a bound, such as
      a load coefficient fitted to its zero bound, carries no information on the fleet's spread and
      is neither judged nor used for the median."""
    flags: list[list[str]] = [[] for _ in rows]
    for k, bad in enumerate(robust_outliers(np.array([r["of"] for r in rows]), above_only=True)):
        if bad:
            flags[k].append("of")
    for k, row in enumerate(rows):
        flags[k] += [c for c in row if c.startswith("fit_") and not row[c] > 0]
    at = [set(r.at_bound(rtol=AT_BOUND_RTOL)) for r in results]
    fixed = set().union(*(r.fixed for r in results)) if results else set()
    for n in names:
        if n in fixed:
            continue
        values = np.array([np.nan if n in at[k] else rows[k][n] for k in range(len(rows))])
        for k, bad in enumerate(robust_outliers(values)):
            if bad:
                flags[k].append(n)
    return flags


def summary_rows(results: Sequence[FitResult | FailedFit]) -> list[dict]:
    """One row per recording: status, error, OF, parameters, fit % per channel, at-bound
    parameters, the data checks' findings (`checks`: before and after the fit), the outlier
    flags (`outlier_flags`, over the model's parameters) and the parameters its equally good runs
    spread in (`loose`: `loose_parameters`, a direction the data do not determine)."""

    rows = []
    for r in results:
        if isinstance(r, FailedFit):
            rows.append(
                {
                    "name": r.name,
                    "file": r.source or "",
                    "status": "failed",
                    "error": r.error,
                    "checks": " ".join(f.label for f in r.checks),
                }
            )
            continue
        row = {"name": r.recording.name if r.recording else "", "file": _source(r), "status": "ok", "error": "", "of": r.of}
        row |= dict(r.best_values)  # the model's parameters, then any fitted y0_*, offset_*, delay_*
        findings = list(r.checks)
        for rec in r.recordings[:1]:
            fits = channel_fit(r, rec)
            row |= {f"fit_{c}": v for c, v in fits.items()}
            findings += fit_findings(r, rec, fits)
        row["at_bound"] = " ".join(r.at_bound())
        row["checks"] = " ".join(f.label for f in findings)
        row["loose"] = " ".join(loose_parameters(r)[1])
        rows.append(row)
    ok = [k for k, row in enumerate(rows) if row["status"] == "ok"]
    fitted = [r for r in results if isinstance(r, FitResult)]
    names = fitted[0].model.names if fitted else ()
    for k, f in zip(ok, outlier_flags([rows[k] for k in ok], fitted, names)):
        rows[k]["outlier"] = " ".join(f)
    return rows


def _source(r: FitResult) -> str:
    data = r.settings.get("data") or [{}]
    return str(data[0].get("path", "")) if isinstance(data[0], dict) else ""


def write_summary(rows: list[dict], folder: Path, model: Model, plot: bool = True) -> tuple[Path, Path]:
    """`summary.csv` (every row, failed ones with their error) and `summary.png` (each
    parameter's spread over the recordings, outliers marked): `model`'s parameters and channels."""

    if not isinstance(model, Model):
        raise ConfigError(f"write_summary: model must be a dcjax Model (dcjax.get_model(name) gives one), got {model!r}")
    m = model
    folder.mkdir(parents=True, exist_ok=True)
    channels = [f"fit_{c}" for c in m.outputs]
    known = {"name", "file", "folder", "status", "error", "of", *m.names, *channels, "at_bound", "checks", "outlier", "loose"}
    extra = list(dict.fromkeys(k for row in rows for k in row if k not in known))  # the experiment's y0_*, offset_*, delay_*
    folder_col = ["folder"] if any("folder" in row for row in rows) else []  # the command line's sub-folder of each result
    cols = ["name", "file", *folder_col, "status", "error", "of", *m.names, *extra, *channels, "at_bound", "checks", "outlier", "loose"]
    csv_path = folder / "summary.csv"
    text = io.StringIO(newline="")
    w = csv.DictWriter(text, fieldnames=cols, extrasaction="ignore")
    w.writeheader()
    for row in rows:
        w.writerow({c: (f"{row[c]:.10g}" if isinstance(row.get(c), float) else row.get(c, "")) for c in cols})
    write_atomic(csv_path, lambda tmp: tmp.write_bytes(text.getvalue().encode()))
    png = folder / "summary.png"
    if plot:
        _plot_summary(rows, m, png)
    return csv_path, png


def _plot_summary(rows, m, path: Path) -> None:
    """Each parameter (and the OF) over the fitted recordings, x labelled by their names on the
    bottom row (the panels share x), the outliers marked and named, the failed recordings named
    under the title. A fixed layout: constrained layout of ~100 rotated names took seconds."""

    from matplotlib.figure import Figure  # lazy: matplotlib adds ~0.3 s to importing dcjax
    from matplotlib.ticker import LogFormatter

    ok = [r for r in rows if r["status"] == "ok"]
    cols = ["of", *m.names]
    n = len(cols)
    ncol = min(4, n)
    nrow = math.ceil(n / ncol)
    names = [r["name"] for r in ok]
    label_in = 0.09 * max((len(s) for s in names), default=1) + 0.3  # room for the rotated names
    width, height = max(3.2, 0.11 * len(ok) + 1.2) * ncol, 2.4 * nrow + label_in + 1.0
    fig = Figure(figsize=(width, height))
    axes = fig.subplots(nrow, ncol, squeeze=False, sharex=True)
    fig.subplots_adjust(left=0.06, right=0.99, top=1 - 0.9 / height, bottom=label_in / height, hspace=0.35, wspace=0.3)
    k = np.arange(len(ok))
    every = max(1, len(ok) // 80)  # at most ~80 names on an axis
    for j, ax in enumerate(axes.ravel()):
        if j >= n:
            ax.set_visible(False)
            continue
        c = cols[j]
        v = np.array([r[c] for r in ok], float)
        out = np.array([c in r.get("outlier", "").split() for r in ok], bool)
        at = np.array([c in r.get("at_bound", "").split() for r in ok], bool) & ~out
        ax.plot(k[~out & ~at], v[~out & ~at], "o", color="tab:blue", ms=4)
        ax.plot(k[at], v[at], "o", mfc="none", color="0.6", ms=4)  # at a bound: no information on the spread
        ax.plot(k[out], v[out], "x", color="tab:red", ms=7)
        for i in np.flatnonzero(out):
            ax.text(k[i], v[i], " " + names[i], fontsize=6, color="tab:red")
        if len(v) and np.all(v > 0) and v.max() >= 10 * v.min():  # a spread over decades; a narrow one reads best linear
            ax.set_yscale("log")
            for set_formatter in (ax.yaxis.set_major_formatter, ax.yaxis.set_minor_formatter):
                set_formatter(LogFormatter())  # 2e-05, not mathtext's 2x10^-5 (parsing it took a third of the plot's time)
        if len(v):
            ax.axhline(float(np.median(v)), color="0.5", lw=0.8)
        unit = m.units.get(c, "")
        ax.set_title("OF" if c == "of" else f"{c} ({unit})" if unit else c, fontsize=9, pad=12)  # clear of a linear axis' scale (1e-5)
        if j >= n - ncol:  # the names under the lowest panel of each column (the panels share x, its ticks)
            ax.set_xticks(k[::every], names[::every], rotation=90, fontsize=6 if len(ok) <= 40 else 5)
        else:
            ax.tick_params(labelbottom=False)
    failed = [r["name"] for r in rows if r["status"] != "ok"]
    flagged = [r["name"] for r in ok if r.get("outlier")]
    lines = [
        f"{len(ok)} fitted, {len(failed)} failed; x: outlier (modified z > {OUTLIER_Z:g}, fit % <= 0, OF far above the fleet's); "
        "open grey: at a bound"
    ]
    if flagged:
        lines.append("outliers: " + ", ".join(flagged))
    if failed:
        lines.append("failed: " + ", ".join(failed))
    fig.suptitle("\n".join(textwrap.fill(x, int(12 * width)) for x in lines), fontsize=8)
    save_figure(fig, path, dpi=90)
