"""The response figures (Figs. 8-22 analogues) and the figure index."""

from pathlib import Path

import numpy as np

from ..cells import VARIANTS, recording
from .common import (
    MD_TABLES,
    PAPER,
    Results,
    _paper_em_rk,
    g,
    table,
    verdict,
)
from .thresholds import T


def response_figures(R: Results, L: list[str], figures: Path):
    import matplotlib.pyplot as plt

    from dcjax import INTEGRATORS, make_problem, simulate

    figures.mkdir(parents=True, exist_ok=True)
    made, verdicts = [], []

    def fig(name, title, rec, fits):
        f, ax = plt.subplots(1, 2, figsize=(11, 3.6))
        ax[0].plot(rec.t, rec.i_a, "k.", ms=3, label="measured")
        ax[1].plot(rec.t, rec.omega, "k.", ms=3, label="measured")
        for label, params, integ, nd in fits:
            sim = np.asarray(simulate(params, make_problem(rec, INTEGRATORS[integ](substeps=nd))))
            ax[0].plot(rec.t, sim[:, 0], lw=1, label=label)
            ax[1].plot(rec.t, sim[:, 1], lw=1, label=label)
        ax[0].set(xlabel="t (s)", ylabel="i_a (A)", title=title)
        ax[1].set(xlabel="t (s)", ylabel="ω (1/s)")
        ax[0].legend(fontsize=7)
        f.tight_layout()
        f.savefig(figures / name, dpi=100)
        plt.close(f)
        made.append((name, title))

    md1 = R.get("MD1", "de-rand-1-exp", "RK") if "MD1" in R.p["md"] else None
    if md1 is not None:
        from dcjax.analysis.report import fit_percent

        rec = recording("MD1")
        fig("fig16_md1_rk.png", "Fig. 16 analogue: MD1, the whole recording and the RK fit", rec, [("RK", md1["best"], "rk4", 1)])
        sim = np.asarray(simulate(md1["best"], make_problem(rec)))
        fits = [fit_percent(rec.i_a, sim[:, 0]), fit_percent(rec.omega, sim[:, 1])]
        verdicts.append(
            f"**Verdict (Fig. 16): {'reproduced' if min(fits) >= 90 else 'differs'}** — the MD1 RK fit follows the whole "
            f"recording with fit {fits[0]:.1f} % (current) and {fits[1]:.1f} % (speed) (100 (1 − ‖y − ŷ‖/‖y − ȳ‖); ≥ 90 % "
            "counts as the paper's visual agreement; its stationary points are Table 18's)."
        )
    sd1 = R.get("SD1", "de-rand-1-exp")
    if sd1 is not None:
        fig("fig02_sd1.png", "Fig. 2 analogue: SD1, DE/rand/1/exp + RK", recording("SD1"), [("RK", sd1["best"], "rk4", 1)])
        verdicts.append(
            f"**Verdict (Fig. 2): {'reproduced' if sd1['of'].min() <= T['of_floor'] else 'differs'}** — the best SD1 fit has OF "
            f"{g(float(sd1['of'].min()), 2)} (paper: 4.9e-19; at ≤ of_floor the simulated and measured curves coincide)."
        )
    em_rk, p_em_rk, nd10, p_nd10 = 0, 0, [], []
    mds = [d for d in R.p["md"] if R.get(d, "de-rand-1-exp", "EM") is not None and R.get(d, "de-rand-1-exp", "RK") is not None]
    for d in mds:
        rec = recording(d)
        fig(
            f"fig{8 + int(d[-1]) - 1:02d}_{d.lower()}_em_rk.png",
            f"Figs. 8–11 analogue: {d}, EM vs RK",
            rec,
            [(v, R.get(d, "de-rand-1-exp", v)["best"], *VARIANTS[v]) for v in ("EM", "RK")],
        )
        em_rk += R.get(d, "de-rand-1-exp", "RK")["of"].mean() < R.get(d, "de-rand-1-exp", "EM")["of"].mean()
        pe, pr, j = _paper_em_rk(d)
        p_em_rk += pr["OF_M"][j] < pe["OF_M"][j]
        if {"EM10", "RK10"} <= set(R.p["variants"]):
            fits = [(v, R.get(d, variant=v)["best"], *VARIANTS[v]) for v in ("EM10", "RK10")]
            num = {"MD1": "18-19", "MD2": "20", "MD3": "21", "MD4": "22"}[d]
            fig(
                f"fig{num}_{d.lower()}_nd.png", f"Fig{'s' if '-' in num else ''}. {num.replace('-', '–')} analogue: {d}, ND = 10", rec, fits
            )
            a, b = R.get(d, variant="EM10")["of"].mean(), R.get(d, variant="RK10")["of"].mean()
            nd10.append(abs(a - b) / b)
            P = PAPER[f"table{MD_TABLES[d][3]}"]
            pa, pb = P["OF_M"][P["columns"].index("EM10")], P["OF_M"][P["columns"].index("RK10")]
            p_nd10.append(abs(pa - pb) / pb)
    if mds:
        verdicts.append(
            f"**Verdict (Figs. 8–11, RK fits better than EM): {verdict(em_rk, len(mds))}** — RK's mean OF below EM's on "
            f"{em_rk}/{len(mds)} data sets (paper: {p_em_rk}/{len(mds)})."
        )
    if nd10:
        k = sum(x <= max(T["tol_factor"] * max(p_nd10), 0.1) for x in nd10)
        verdicts.append(
            f"**Verdict (Figs. 18–22, EM10 and RK10 agree): {verdict(k, len(nd10))}** — EM10's mean OF differs from RK10's by "
            f"{100 * min(nd10):.1f}–{100 * max(nd10):.1f} % (paper {100 * min(p_nd10):.1f}–{100 * max(p_nd10):.1f} %; within "
            f"tol_factor x the paper's largest, or 10 %, on {k}/{len(nd10)})."
        )
    cv = [d for d in ("MD1", "MD2", "MD3") if R.get(d, "de-rand-1-exp", "RK") is not None]
    if len(cv) >= 2:
        for d in cv:
            fits = [(f"fit {e}", R.get(e, "de-rand-1-exp", "RK")["best"], "rk4", 1) for e in cv]
            fig(
                f"fig{13 + int(d[-1]) - 1:02d}_crossval_{d.lower()}.png",
                f"Figs. 13–15 analogue: {d} simulated with each RK fit",
                recording(d),
                fits,
            )
    if made:
        L += ["## Figures", ""] + [f"- [{t}]({R.link(figures / n)})" for n, t in made] + [""]
        L += [x for v in verdicts for x in (v, "")]


FIGURE_INDEX = [
    ("1, 3", "drive schematics", "no data: `dcjax.models.DC` implements eq. 6–7"),
    ("2", "SD1–SD4 responses", "Verdict (Fig. 2)"),
    (
        "4, 17",
        "EM/RK algorithms, with ND sub-steps",
        "no data: `dcjax.simulation.integrate` (eq. 8–23, 28–29); checked in tests/test_simulate.py",
    ),
    ("5, 6", "the laboratory drive; preparing the measured data", "no data: `dcjax.io.emulate`, `dcjax.io.recording.trim_switch_on`"),
    ("7", "MD1–MD4 recordings", "Verdict (Table 7, Fig. 7)"),
    ("8–11", "EM vs RK fits of MD1–MD4", "Verdict (Figs. 8–11)"),
    ("12–15", "cross-validation", "Verdict (Figs. 12–15)"),
    ("16", "MD1, whole recording with the RK fit", "Verdict (Fig. 16)"),
    ("18–22", "EM5/EM10/RK5/RK10 fits", "Verdict (Figs. 18–22)"),
    ("23, 24", "STMA and LTMA algorithms", "no data: `dcjax.strategies.memory`; Tables 30–33"),
    ("25", "OF and memory-handling time per FE", "Verdict (Fig. 25)"),
]


def section_figure_index(L: list[str]):
    L += ["## Every figure of the paper", ""]
    L += table(["paper figure", "shows", "here"], [list(r) for r in FIGURE_INDEX])
