"""A design between a saved fit and files: the noise and the parameter scales a fit implies
(`noise_from_fit`, `scales_from_fit`), and what `dcjax design` writes (`write_design`: the
inputs, `design.json` and `design.png`)."""

from pathlib import Path

import numpy as np

from ..io.files import save_figure, strict_json, write_text
from ..models import Model, get_model
from ..numbers import csv_text
from .design import Design
from .plotting import channel_label


def noise_from_fit(result) -> dict[str, float] | None:
    """sigma per measured channel from a fit's residuals (rms over its first recording), or None
    where the fit left none (noise-free data: rms below 1e-9 of the channel's peak)."""
    rec = result.recording
    if rec is None:
        return None
    sim = result.simulate_outputs(rec)
    m = result.model
    out = {}
    for j, c in enumerate(m.outputs):
        y = np.asarray(rec[c])
        r = float(np.sqrt(np.mean((y - sim[:, j]) ** 2)))
        if not r > 1e-9 * np.max(np.abs(y)):
            return None
        out[c] = r
    return out


def scales_from_fit(result, fraction: float = 0.01) -> dict[str, float]:
    """`scale=` for `design_input` from a fit: a parameter that ended on a bound at (about) zero
    is scaled by `fraction` of its search range (its value says nothing of its size); the others
    by their value."""
    b = result.bounds
    out = {}
    for n in result.at_bound():
        if n not in result.model.names:  # a local copy, an offset or delay: not the model's to design for
            continue
        k = result.names.index(n)
        width = float(b.upper[k] - b.lower[k])
        if abs(result.best_values[n]) <= 1e-9 * width:
            out[n] = fraction * width
    return out


def write_design(design: Design, baselines: dict[str, Design], folder, model) -> list:
    """`input.csv` (t and the designed input), `design.json` (criterion, levels, predicted
    standard errors of the design and of each baseline) and `design.png`."""

    m = get_model(model)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rec = design.recording
    columns = [c for c in m.inputs if c in rec.channels]  # designed and kept inputs (constants: design.json)
    write_text(folder / "input.csv", csv_text(["t", *columns], np.column_stack([rec.t, *[rec[c] for c in columns]])))

    def errors(d: Design):
        return {k: {"stderr": d.stderr[k], "relative": d.relative_stderr()[k]} for k in d.free}

    info = {
        "criterion": design.criterion,
        "value": design.value,
        "hold_s": design.hold,
        "duration_s": float(rec.t[-1] - rec.t[0]),
        "dt_s": float(rec.t[1] - rec.t[0]),
        "inputs": list(design.inputs or m.inputs[:1]),
        "levels": design.levels.tolist(),
        "constants": rec.constants or None,
        "kept": [c for c in columns if c not in (design.inputs or m.inputs[:1])] or None,
        "i_limit": rec.limit,
        "noise": design.noise,
        "params": design.params,
        "free": list(design.free),
        "predicted": {"design": errors(design), **{k: errors(b) for k, b in baselines.items()}},
        "not_identifiable": design.unidentifiable,
    }
    write_text(folder / "design.json", strict_json(info) + "\n")
    _plot_design(design, baselines, m, folder / "design.png")
    return [folder / "input.csv", folder / "design.json", folder / "design.png"]


def _plot_design(design: Design, baselines: dict[str, Design], m: Model, path) -> None:
    from matplotlib.figure import Figure  # lazy: matplotlib adds ~0.3 s to importing dcjax

    rec = design.recording
    chans = [*[c for c in m.inputs if c in rec.channels], *m.outputs]
    fig = Figure(figsize=(11, 2.4 * (len(chans) + 1)), layout="constrained")
    axes = fig.subplots(len(chans) + 1, 1, squeeze=False)[:, 0]
    for ax, c in zip(axes, chans):
        ax.plot(rec.t, rec[c], "r-", lw=1.2, label="design")
        for label, b in baselines.items():
            if len(b.recording) == len(rec):
                ax.plot(b.recording.t, b.recording[c], lw=0.8, alpha=0.7, label=label)
        ax.set(ylabel=channel_label(m, c), xlabel="t (s)")
        ax.legend(fontsize=7)
    ax = axes[-1]
    k = np.arange(len(design.free))
    width = 0.8 / (1 + len(baselines))
    ax.bar(k, [100 * design.relative_stderr()[n] for n in design.free], width, color="tab:red", label="design")
    for j, (label, b) in enumerate(baselines.items(), start=1):
        ax.bar(k + j * width, [100 * b.relative_stderr()[n] for n in design.free], width, label=label)
    ax.set_xticks(k + 0.4 - width / 2, design.free)
    ax.set(yscale="log", ylabel="predicted rel. std. error (%)")
    ax.legend(fontsize=7)
    fig.suptitle(f"designed input ({design.criterion}-criterion, hold {design.hold:g} s)")
    save_figure(fig, path, dpi=90)
