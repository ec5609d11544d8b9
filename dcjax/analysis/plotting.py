"""Figures of a fit: measured and simulated channels, residuals, inputs and convergence (paper
Figs. 8–11). Saving a figure never switches the user's matplotlib backend: a figure made for a
file is a bare `matplotlib.figure.Figure`, drawn without pyplot."""

from pathlib import Path

import numpy as np

LABELS = {"i_a": "i_a (A)", "omega": "ω (1/s)", "u_a": "u_a (V)"}


def _label(c: str) -> str:
    return LABELS.get(c, c)


def overlay(ax, recording, simulated: np.ndarray, channel: str, title: str = ""):
    """Measured (dots) and simulated (line) `channel` on `ax`."""
    ax.plot(recording.t, recording[channel], "k.", ms=3, label="measured")
    ax.plot(recording.t, simulated, "r-", lw=1, label="simulated")
    ax.set(xlabel="t (s)", ylabel=_label(channel), title=title or channel)
    ax.legend()
    return ax


def _figure(nrows, ncols, size, for_file: bool):
    if for_file:
        from matplotlib.figure import Figure

        fig = Figure(figsize=size)
        return fig, fig.subplots(nrows, ncols, squeeze=False)
    import matplotlib.pyplot as plt

    return plt.subplots(nrows, ncols, figsize=size, squeeze=False)


def plot_result(result, path: str | Path | None = None, ax=None, recordings=None):
    """Per recording: each measured channel against the simulation, its residual below it, the
    input(s); the convergence of every run beside the first. `ax`: an Axes (or one per measured
    channel) to draw only the overlays of the first recording into; returns what it drew on."""
    model = result.model
    outs = model.outputs
    recs = list(recordings if recordings is not None else result.recordings)
    if not recs:
        raise ValueError("no recording to plot: pass recordings= (a loaded result keeps no data it could not find)")
    if ax is not None:
        axes = list(np.atleast_1d(ax))
        sim = result.simulate(recs[0])
        for a, c in zip(axes, outs):
            overlay(a, recs[0], sim[:, model.states.index(c)], c, f"{recs[0].name}: {c}")
        return ax
    ncols = len(outs) + 2
    fig, axes = _figure(2 * len(recs), ncols, (4.2 * ncols, 6.5 * len(recs)), path is not None)
    for r, rec in enumerate(recs):
        top, bottom = axes[2 * r], axes[2 * r + 1]
        sim = result.simulate(rec)
        for j, c in enumerate(outs):
            y = sim[:, model.states.index(c)]
            overlay(top[j], rec, y, c, f"{rec.name}: {c}")
            bottom[j].plot(rec.t, y - rec[c], "b-", lw=0.8)
            bottom[j].axhline(0.0, color="k", lw=0.5)
            bottom[j].set(xlabel="t (s)", ylabel=f"residual {_label(c)}")
        for _k, c in enumerate(model.inputs):
            top[len(outs)].plot(rec.t, rec[c], lw=1, label=c)
        top[len(outs)].set(xlabel="t (s)", ylabel="input", title="inputs")
        if model.inputs:
            top[len(outs)].legend()
        bottom[len(outs)].axis("off")
        if r == 0 and np.any(np.isfinite(result.history)):
            for h in result.history:
                top[-1].semilogy(np.arange(1, h.size + 1), h, lw=0.7)
            top[-1].set(xlabel="iteration", ylabel="best OF", title=f"convergence ({len(result.history)} runs)")
        else:
            top[-1].axis("off")
        bottom[-1].axis("off")
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig
