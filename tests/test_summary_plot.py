"""A folder's `summary.png` (`dcjax.fitting.summary`): each parameter over the files, on a log
axis only where its values spread over decades, its tick labels plain text (mathtext's 2x10^-5
took a third of the plot's time), the files' names under the lowest panel of each column."""

import numpy as np

import dcjax
from dcjax.fitting import summary


def test_a_spread_over_decades_is_log_a_narrow_one_linear_and_no_label_is_mathtext(tmp_path, monkeypatch):
    model = dcjax.get_model("dc")
    rng = np.random.default_rng(0)
    rows = []
    for k in range(12):
        row = {"name": f"motor{k:02d}", "status": "ok", "of": 10.0 ** rng.uniform(-9, -6), "outlier": "", "at_bound": ""}
        row |= {n: v * (1 + 1e-4 * rng.standard_normal()) for n, v in dcjax.datasets.true_params("SD1").items()}
        rows.append(row)
    rows[3]["outlier"] = "Ra"
    drawn = []
    monkeypatch.setattr(summary, "save_figure", lambda fig, path, dpi: (drawn.append(fig), fig.savefig(path, dpi=dpi)))
    summary.write_summary(rows, tmp_path, model)
    assert (tmp_path / "summary.png").stat().st_size > 0
    (fig,) = drawn
    axes = {ax.get_title(): ax for ax in fig.axes if ax.get_visible()}
    assert axes["OF"].get_yscale() == "log" and axes["Ra (Ohm)"].get_yscale() == "linear", {t: a.get_yscale() for t, a in axes.items()}
    labels = [t.get_text() for ax in axes.values() for t in [*ax.get_yticklabels(), *ax.get_yticklabels(minor=True)]]
    assert labels and not any("$" in s for s in labels), labels
    named = [t for t, ax in axes.items() if any(lab.get_text() and lab.get_visible() for lab in ax.get_xticklabels())]
    assert len(named) == 4 and "OF" not in named, named  # 8 panels in 2 rows of 4: the lower row names the files
