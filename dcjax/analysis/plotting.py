"""Figures of a fit: measured and simulated channels, residuals, inputs and convergence (paper
Figs. 8–11). Saving a figure never switches the user's matplotlib backend: a figure made for a
file is a bare `matplotlib.figure.Figure`, drawn without pyplot."""

from pathlib import Path

import numpy as np

from ..errors import ConfigError
from ..io.files import save_figure
from ..io.units import SI_UNITS
from ..numbers import significant_digits
from .metrics import LAGS, Z99, autocorrelation, cross_correlation, input_band


def channel_label(model, c: str) -> str:
    """`c (unit)` from the model's quantity of the channel (the loader converts to SI), else `c`."""
    unit = SI_UNITS.get(model.quantities.get(c, ""), "") if model is not None else ""
    return f"{c} ({unit})" if unit else c


def _label(c: str, model=None) -> str:
    return channel_label(model, c)


def overlay(ax, recording, simulated: np.ndarray, channel: str, title: str = "", model=None):
    """Measured (dots, where the recording holds `channel`) and simulated (line) `channel` on `ax`."""
    if channel in recording.channels:
        ax.plot(recording.t, recording[channel], "k.", ms=3, label="measured")
    ax.plot(recording.t, simulated, "r-", lw=1, label="simulated")
    ax.set(xlabel="t (s)", ylabel=_label(channel, model), title=title or channel)
    ax.legend()
    return ax


def _figure(nrows, ncols, size, for_file: bool):
    if for_file:
        from matplotlib.figure import Figure  # lazy: matplotlib adds ~0.3 s to importing dcjax

        fig = Figure(figsize=size)
        return fig, fig.subplots(nrows, ncols, squeeze=False)
    import matplotlib.pyplot as plt  # lazy: matplotlib adds ~0.3 s to importing dcjax

    return plt.subplots(nrows, ncols, figsize=size, squeeze=False)


def _canvas(size, for_file: bool):
    if for_file:
        from matplotlib.figure import Figure  # lazy: matplotlib adds ~0.3 s to importing dcjax

        return Figure(figsize=size)
    import matplotlib.pyplot as plt  # lazy: matplotlib adds ~0.3 s to importing dcjax

    return plt.figure(figsize=size)


MAX_RECORDINGS = 4  # a joint fit of many recordings plots the first few (a fit.png stays small)


def constant_inputs(recording, inputs) -> dict[str, float]:
    """The inputs that hold one value over the whole recording (a step from rest, a fixed supply)."""
    return {c: float(recording[c][0]) for c in inputs if c in recording.channels and np.ptp(recording[c]) == 0}


def _constants_title(recording, constants: dict[str, float], model) -> str:
    units = {c: SI_UNITS.get(model.quantities.get(c, ""), "") for c in constants}
    return ", ".join(f"{c} = {v:g}{' ' + units[c] if units[c] else ''}" for c, v in constants.items()) + " (constant)"


def plot_result(result, path: str | Path | None = None, ax=None, recordings=None, convergence: bool = True):
    """Per recording (the first `MAX_RECORDINGS`): each measured channel against the simulation
    with its residual below it, and the varying input(s) (an input constant over the recording is
    named in the row's title instead); with `convergence`, the convergence of every run in a column
    of its own. Axes carry the channels' SI units (`Model.quantities`); no panel is left empty.
    `ax`: an Axes (or one per measured channel) to draw only the overlays of the first recording
    into; returns what it drew on. A recording of the inputs alone shows the simulation without
    residuals."""
    model = result.model
    outs = model.outputs
    recs = list(recordings if recordings is not None else result.recordings)
    if not recs:
        raise ConfigError("no recording to plot: pass recordings= (a loaded result keeps no data it could not find)")
    if ax is not None:
        axes = list(np.atleast_1d(ax))
        sim = result.simulate_outputs(recs[0])
        for j, (a, c) in enumerate(zip(axes, outs)):
            overlay(a, recs[0], sim[:, j], c, f"{recs[0].name}: {c}", model)
        return ax
    shown = recs[:MAX_RECORDINGS]
    constants = [constant_inputs(rec, model.inputs) for rec in shown]
    varying = any(len(k) < len(model.inputs) for k in constants)
    history = convergence and np.any(np.isfinite(result.history))
    ncols = len(outs) + int(varying) + int(history)
    per = 2 if any(c in rec.channels for rec in shown for c in outs) else 1  # a residual row where something is measured
    fig = _canvas((3.6 * ncols, 2.3 * per * len(shown)), path is not None)
    grid = fig.add_gridspec(per * len(shown), ncols)
    for r, rec in enumerate(shown):
        sim = result.simulate_outputs(rec)
        title = f"{rec.name}: " + (_constants_title(rec, constants[r], model) + "; " if constants[r] else "")
        for j, c in enumerate(outs):
            y = sim[:, j]
            measured = c in rec.channels
            overlay(
                fig.add_subplot(grid[per * r, j] if measured or per == 1 else grid[per * r : per * r + 2, j]), rec, y, c, title + c, model
            )
            if not measured:
                continue
            bottom = fig.add_subplot(grid[per * r + 1, j])
            bottom.plot(rec.t, y - rec[c], "b-", lw=0.8)
            bottom.axhline(0.0, color="k", lw=0.5)
            bottom.set(xlabel="t (s)", ylabel=f"residual {_label(c, model)}")
        moving = [c for c in model.inputs if c not in constants[r]]
        if moving:
            a = fig.add_subplot(grid[per * r : per * r + per, len(outs)])
            for c in moving:
                a.plot(rec.t, rec[c], lw=1, label=_label(c, model))
            a.set(xlabel="t (s)", ylabel=", ".join(_label(c, model) for c in moving), title="inputs")
            a.legend()
    if history:
        a = fig.add_subplot(grid[:, ncols - 1])
        linear = bool(np.any(np.asarray(result.history)[np.isfinite(result.history)] <= 0))  # a -log L can be negative
        for h in result.history:
            (a.plot if linear else a.semilogy)(np.arange(1, h.size + 1), h, lw=0.7)
        a.set(
            xlabel="iteration", ylabel="best OF", title=f"convergence ({len(result.history)} run{'s' if len(result.history) > 1 else ''})"
        )
    if len(recs) > len(shown):
        fig.suptitle(f"the first {len(shown)} of {len(recs)} recordings")
    fig.tight_layout()
    if path is not None:
        save_figure(fig, path, dpi=90)
    return fig


def plot_residual_tests(validation, recording, inputs: tuple[str, ...], path: str | Path | None = None, lags: int = LAGS):
    """MATLAB's `resid` plot of a `Validation`: per output, the residual's autocorrelation at
    lags 0..`lags` with the whiteness band +-2.58/sqrt(N), and below it its cross-correlation
    with each of `inputs` at lags -`lags`..`lags` with that pair's band (`input_band`)."""
    e = validation.residuals
    outs = list(validation.channels)
    u = {c: np.asarray(recording[c], float)[validation.skip :] for c in inputs if c in recording.channels}
    fig, axes = _figure(2, len(outs), (4.2 * len(outs), 6.0), path is not None)
    n = e.shape[0]
    for j, c in enumerate(outs):
        top, bottom = axes[0][j], axes[1][j]
        top.stem(np.arange(lags + 1), autocorrelation(e[:, j], lags), basefmt="k-")
        top.axhspan(-Z99 / np.sqrt(n), Z99 / np.sqrt(n), color="C0", alpha=0.15, lw=0)
        top.set(xlabel="lag (samples)", title=f"{validation.recording}: {c} residual autocorrelation")
        varying = {name: v for name, v in u.items() if np.ptp(v) > 0}  # a constant input cannot correlate
        for k, (name, v) in enumerate(varying.items()):
            band = input_band(e[:, j], v, lags)
            bottom.plot(np.arange(-lags, lags + 1), cross_correlation(e[:, j], v, lags), ".-", color=f"C{k}", lw=0.8, label=name)
            bottom.axhline(band, color=f"C{k}", ls="--", lw=0.6)
            bottom.axhline(-band, color=f"C{k}", ls="--", lw=0.6)
        bottom.set(xlabel="lag (samples)", title=f"{c} residual x inputs (99 % bands)")
        if varying:
            bottom.legend(fontsize=7)
    fig.tight_layout()
    if path is not None:
        save_figure(fig, path, dpi=90)
    return fig


def _span(x: np.ndarray) -> tuple[float, float]:
    """A histogram's range: the draws' own, widened where they are (nearly) constant (matplotlib's
    bins cannot split a range of a few ulps)."""
    lo, hi = float(np.min(x)), float(np.max(x))
    pad = max(abs(lo), abs(hi), 1e-300) * 1e-9
    return (lo, hi) if hi - lo > pad else (lo - pad, hi + pad)


def _ticks(axis, x: np.ndarray) -> None:
    """Three ticks, each labelled with the digits the draws' spread needs (no offset text to
    collide with a neighbour's labels)."""
    from matplotlib.ticker import FuncFormatter, MaxNLocator

    lo, hi = _span(x)
    digits = significant_digits(max(abs(lo), abs(hi)), (hi - lo) / 20)
    axis.set_major_locator(MaxNLocator(3))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.{digits}g}"))


def corner(posterior, path: str | Path, units: dict[str, str] | None = None) -> Path:
    """Pairwise scatter and marginal histograms of a `Posterior`'s draws (all chains), the fit's
    optimum marked, axes labelled with `units` (name -> unit) and three ticks each; written to
    `path` (a bare `Figure`, no pyplot)."""
    from matplotlib.figure import Figure  # lazy: matplotlib adds ~0.3 s to importing dcjax

    names, d = posterior.names, posterior.draws.reshape(-1, len(posterior.names))
    units = units or {}
    label = {n: f"{n} ({units[n]})" if units.get(n) else n for n in names}
    k = len(names)
    fig = Figure(figsize=(1.9 * k + 1, 1.9 * k + 1))
    for i in range(k):
        for j in range(i + 1):  # the lower triangle only: an empty axes costs as much to build and lay out
            ax = fig.add_subplot(k, k, i * k + j + 1)
            if i == j:
                ax.hist(d[:, i], bins=40, range=_span(d[:, i]), color="0.4")
                ax.axvline(posterior.optimum[names[i]], color="r", lw=1)
                ax.set_yticks([])
            else:
                ax.plot(d[:, j], d[:, i], ".", ms=1, color="0.3", alpha=0.3)
                ax.plot(posterior.optimum[names[j]], posterior.optimum[names[i]], "r+", ms=8)
                _ticks(ax.yaxis, d[:, i])
            _ticks(ax.xaxis, d[:, j])
            ax.tick_params(labelsize=7, labelbottom=i == k - 1, labelleft=j == 0 and i > 0)
            ax.tick_params(axis="x", labelrotation=45)
            if i == k - 1:
                ax.set_xlabel(label[names[j]], fontsize=9)
            if j == 0 and i > 0:
                ax.set_ylabel(label[names[i]], fontsize=9)
    fig.tight_layout()
    path = Path(path)
    save_figure(fig, path, dpi=90)
    return path
