"""Many independent recordings, one fit each: `fit_each`, the per-recording failure that does not
stop the others, and the summary of a batch (one row per recording, robust outlier flags)."""

import dataclasses
import math
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from ..io.recording import Recording
from ..models import get_model
from ..simulation.integrators import AutoSubsteps, Integrator
from ..strategies import Strategy
from .result import FitResult

OUTLIER_Z = 3.5  # modified z-score (Iglewicz & Hoaglin): 0.6745 |x - median| / MAD


@dataclasses.dataclass
class FailedFit:
    """A recording that could not be loaded, validated or fitted, with its one-line error."""

    name: str
    error: str
    source: str | None = None
    success: bool = False


def fit_each(
    items: Sequence[Recording | str | Path],
    model=None,
    params=None,
    method: "str | Strategy" = "de-rand-1-exp",
    *,
    load: Callable[[str], Recording] | None = None,
    integrator=None,
    runs: int = 50,
    budget: int = 140_000,
    generations: int | None = None,
    seed: int = 0,
    memory=None,
    polish: bool = False,
    progress=None,
) -> list[FitResult | FailedFit]:
    """`dcjax.fit` on each recording on its own (not a joint fit), with the same options.

    `items`: recordings, or paths loaded with `load` (default `dcjax.load_recording` with the
    model). A recording that fails to load, validate or prepare (its channels, a dead sensor, its
    first estimate) gets a `FailedFit` with its one-line error and every other one is fitted.
    `params`: as `fit` takes it, for every recording, or a list with one entry per item; None takes
    each recording's sidecar preset, else `"auto"`. Recordings of one shape (length, channels,
    limit, free parameters, weights) are fitted in one compiled call
    (`dcjax.fitting.batch.fit_setups`: the same results as one fit each); with `AutoSubsteps` or
    `progress` they are fitted one after another. An error of the batched call itself (not of one
    recording) is raised."""
    from ..io.loading import load_recording
    from .batch import fit_setups
    from .engine import prepare, resolve_parameters
    from .fit import check_integrator, fit, search_of

    m = get_model(model)
    integ = check_integrator(integrator)
    search = search_of(method, runs, budget, generations, seed, memory, polish)
    loader = load or (lambda p: load_recording(p, model=m))
    if isinstance(params, (list, tuple)):
        if len(params) != len(items):
            raise ValueError(f"params: one entry per recording ({len(items)}), got {len(params)}")
        each = list(params)
    else:
        each = [params] * len(items)
    out: list = [None] * len(items)
    setups: list = []
    for k, item in enumerate(items):
        name = item.name if isinstance(item, Recording) else Path(str(item)).stem
        source = None if isinstance(item, Recording) else str(item)
        try:  # one broken recording fails alone, whatever broke in loading or preparing it
            rec = item if isinstance(item, Recording) else loader(str(item))
            if isinstance(integ, AutoSubsteps) or progress:
                out[k] = fit(rec, m, each[k], search.strategy, integrator=integ, runs=runs, budget=budget, generations=generations,
                             seed=seed, memory=memory, polish=polish, progress=progress)  # fmt: skip
                continue
            assert isinstance(integ, Integrator)
            setups.append((k, prepare([rec], m, resolve_parameters(each[k], [rec], m), integ)))
        except Exception as e:
            out[k] = _failed(name, e, source)
    if setups:
        for (k, _), res in zip(setups, fit_setups([s for _, s in setups], search)):
            out[k] = res
    return out


def _failed(name: str, e: Exception, source: str | None) -> FailedFit:
    return FailedFit(name=name, error=(str(e).splitlines() or [type(e).__name__])[0], source=source)


def robust_outliers(values: np.ndarray, z: float = OUTLIER_Z) -> np.ndarray:
    """Modified z-score rule: |0.6745 (x - median) / MAD| > z, on log10 |x| where every value is
    positive (parameters and OFs spread over decades). Needs 4 values; else nothing is flagged."""
    x = np.asarray(values, float)
    ok = np.isfinite(x)
    flags = np.zeros(x.shape, bool)
    if ok.sum() < 4:
        return flags
    v = np.log10(x[ok]) if np.all(x[ok] > 0) else x[ok]
    med = np.median(v)
    mad = np.median(np.abs(v - med))
    if mad == 0:
        dev = np.abs(v - med)
        flags[ok] = dev > 1e-9 * max(1.0, abs(med))  # all alike but these
        return flags if flags.sum() < 0.5 * ok.sum() else np.zeros(x.shape, bool)
    flags[ok] = np.abs(0.6745 * (v - med) / mad) > z
    return flags


def summary_rows(results: Sequence[FitResult | FailedFit], model=None) -> list[dict]:
    """One row per recording: status, error, OF, parameters, fit % per channel, at-bound
    parameters and the outlier flags (`robust_outliers` of the OF and of each free parameter)."""
    from ..analysis.report import channel_fit

    m = get_model(model) if model is not None else next((r.model for r in results if isinstance(r, FitResult)), get_model())
    rows = []
    for r in results:
        if isinstance(r, FailedFit):
            rows.append({"name": r.name, "file": r.source or "", "status": "failed", "error": r.error})
            continue
        row = {"name": r.recording.name if r.recording else "", "file": _source(r), "status": "ok", "error": "", "of": r.of}
        row.update({n: r.best_values[n] for n in m.names})
        for rec in r.recordings[:1]:
            row.update({f"fit_{c}": v for c, v in channel_fit(r, rec).items()})
        row["at_bound"] = " ".join(r.at_bound())
        rows.append(row)
    ok = [k for k, row in enumerate(rows) if row["status"] == "ok"]
    flags = {k: [] for k in ok}
    fixed = set().union(*(r.fixed for r in results if isinstance(r, FitResult))) if ok else set()
    for col in ("of", *[n for n in m.names if n not in fixed]):
        bad = robust_outliers(np.array([rows[k][col] for k in ok]))
        for k, b in zip(ok, bad):
            if b:
                flags[k].append(col)
    for k in ok:
        rows[k]["outlier"] = " ".join(flags[k])
    return rows


def _source(r: FitResult) -> str:
    data = r.settings.get("data") or [{}]
    return str(data[0].get("path", "")) if isinstance(data[0], dict) else ""


def write_summary(rows: list[dict], folder: Path, model=None) -> tuple[Path, Path]:
    """`summary.csv` (every row, failed ones with their error) and `summary.png` (each
    parameter's spread over the recordings, outliers marked)."""
    import csv

    m = get_model(model)
    folder.mkdir(parents=True, exist_ok=True)
    channels = [f"fit_{c}" for c in m.outputs]
    cols = ["name", "file", "status", "error", "of", *m.names, *channels, "at_bound", "outlier"]
    csv_path = folder / "summary.csv"
    with csv_path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols, extrasaction="ignore")
        w.writeheader()
        for row in rows:
            w.writerow({c: (f"{row[c]:.10g}" if isinstance(row.get(c), float) else row.get(c, "")) for c in cols})
    png = folder / "summary.png"
    _plot_summary(rows, m, png)
    return csv_path, png


def _plot_summary(rows, m, path: Path) -> None:
    from matplotlib.figure import Figure

    ok = [r for r in rows if r["status"] == "ok"]
    cols = ["of", *m.names]
    n = len(cols)
    ncol = min(4, n)
    fig = Figure(figsize=(3.2 * ncol, 2.6 * math.ceil(n / ncol)), layout="constrained")
    axes = fig.subplots(math.ceil(n / ncol), ncol, squeeze=False).ravel()
    for ax, c in zip(axes, cols):
        v = np.array([r[c] for r in ok], float)
        out = np.array([c in r.get("outlier", "").split() for r in ok], bool)
        k = np.arange(len(v))
        ax.plot(k[~out], v[~out], "o", color="tab:blue", ms=4)
        ax.plot(k[out], v[out], "x", color="tab:red", ms=7, label="outlier")
        if len(v) and np.all(v > 0):
            ax.set_yscale("log")
        if len(v):
            ax.axhline(float(np.median(v)), color="0.5", lw=0.8)
        ax.set(title=c if c != "of" else "OF", xlabel="recording")
        if 0 < len(ok) <= 30:
            ax.set_xticks(k, [r["name"] for r in ok], rotation=90, fontsize=6)
    for ax in axes[n:]:
        ax.set_visible(False)
    failed = len(rows) - len(ok)
    fig.suptitle(f"{len(ok)} fitted, {failed} failed; x: outlier (modified z > {OUTLIER_Z:g})")
    fig.savefig(path, dpi=110)
