"""Write REPORT.md (and its figures) from a results store, beside the paper's numbers
(`paper_tables.json`, transcribed from ../shared/paper/ by `transcribe_paper_tables.py`).

    .venv/bin/python experiments/report.py [--store experiments/results/full.jsonl] [--out experiments/REPORT.md]

Nothing here is typed by hand: every figure comes from the store, every paper number from the
JSON file. Measured times sit between `<!-- times -->` and `<!-- /times -->` markers; everything
else is a deterministic function of the store (same seeds, same report)."""

import argparse
import json
import math
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cells import VARIANTS, Cell, Store, recording

from dcjax import PARAM_NAMES

HERE = Path(__file__).resolve().parent
PAPER = json.loads((HERE / "paper_tables.json").read_text())
METHOD_NAMES = {"ga": "GA", "de-rand-1-exp": "DE/rand/1/exp", "de-best-1-bin": "DE/best/1/bin", "tlbo": "TLBO", "abc": "ABC"}
MD_TABLES = {"MD1": (9, 10, 20, 24, 30), "MD2": (11, 12, 21, 25, 31), "MD3": (13, 14, 22, 26, 32), "MD4": (15, 16, 23, 27, 33)}
TABLE18_TIMES = {"MD1": [2, 4, 6, 8, 10], "MD2": [2, 4, 6, 8, 10], "MD3": [2, 4, 6, 7, 8], "MD4": [4, 6, 8, 10, 12]}
DEFAULT_PROFILE = {
    "name": "full",
    "runs": 50,
    "budget": 140000,
    "sd": ["SD1", "SD2", "SD3", "SD4"],
    "md": ["MD1", "MD2", "MD3", "MD4"],
    "methods": list(METHOD_NAMES),
    "md_variants": ["EM", "RK"],
    "weights": [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9],
    "variants": list(VARIANTS),
    "memory": ["stma", "ltma-s1", "ltma-s2"],
    "memory_generations": 1999,
    "ltma_runs": 2,
}


def g(x: float | None, digits: int = 4) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    if x == 0:
        return "0"
    a = abs(x)
    return f"{x:.{digits - 1}e}" if a < 1e-3 or a >= 1e4 else f"{x:.{digits}g}"


def table(header: list[str], rows: list[list[str]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return out + [""]


class Results:
    """Look-up of finished cells by their settings."""

    def __init__(self, store: str | Path, profile: dict, seed: int):
        self.cells = Store(store).cells()
        self.p = profile
        self.seed = seed
        self.report_dir = Path(".")

    def link(self, path: Path) -> str:
        """A figure's path as the report links it: relative to the report's folder."""
        return os.path.relpath(path, self.report_dir).replace(os.sep, "/")

    def get(self, data, method="de-rand-1-exp", variant="RK", w=(1.0, 1.0), memory=None, runs=None, generations=None):
        integ, nd = VARIANTS[variant]
        c = Cell(
            data,
            method,
            integ,
            nd,
            float(w[0]),
            float(w[1]),
            memory,
            int(runs or self.p["runs"]),
            int(self.p["budget"]),
            generations,
            self.seed,
        )
        e = self.cells.get(c.key)
        if e is None:
            return None
        of = np.array([r["of"] for r in e["runs"]])
        params = np.array([[r["params"][n] for n in PARAM_NAMES] for r in e["runs"]])
        dups = [r["dups"] for r in e["runs"]]
        return {
            "of": of,
            "params": params,
            "mean": dict(zip(PARAM_NAMES, params.mean(axis=0))),
            "best": dict(zip(PARAM_NAMES, params[int(np.argmin(of))])),
            "run_s": e["meta"]["run_s"],
            "runs": len(of),
            "fes": np.array([r["fes"] for r in e["runs"]]),
            "iterations": np.array([r["iterations"] for r in e["runs"]]),
            "dups": None if dups[0] is None else np.array(dups),
            "chunks": [r["chunks"] for r in e["runs"]],
        }


def rel(a, b):
    return abs(a - b) / abs(b) if b else abs(a)


def section_table5(R: Results, L: list[str]):
    sds = [d for d in R.p["sd"] if R.get(d, R.p["methods"][0]) is not None]
    if not sds:
        return
    L += ["## Tables 5 and 6: simulated data SD1–SD4 (RK, 5 methods)", ""]
    L += [f"{R.p['runs']} runs per cell, NP = 70, {R.p['budget']} FEs, Table 4 bounds. Each cell: dcjax / paper.", ""]
    all_ok, rank_ok = True, True
    for d in sds:
        rows, means = [], {}
        paper = PAPER["table5"]["rows"][d]
        for m in R.p["methods"]:
            r = R.get(d, m)
            if r is None:
                continue
            f = r["of"]
            ours = [f.min(), f.max(), f.mean(), f.std()]
            means[m] = f.mean()
            n_ok = int(np.sum(f <= 1e-15))
            if m == "de-rand-1-exp":
                all_ok &= n_ok == f.size
            rows.append([METHOD_NAMES[m]] + [f"{g(o, 3)} / {g(p, 3)}" for o, p in zip(ours, paper[m])] + [f"{n_ok}/{f.size}"])
        L += [f"**{d}**", ""] + table(["method", "B", "W", "M", "SD", "OF ≤ 1e-15"], rows)
        order = sorted(means, key=means.get)
        paper_order = sorted(means, key=lambda m: paper[m][2])
        floor = [m for m in means if means[m] <= 1e-15]
        ours_ok = order[0] in floor and "de-rand-1-exp" in floor
        rank_ok &= ours_ok
        L += [
            f"Ranking by mean OF: dcjax {' < '.join(METHOD_NAMES[m] for m in order)}; paper {' < '.join(METHOD_NAMES[m] for m in paper_order)}.",
            "",
        ]
    L += [
        f"**Verdict (Table 5): {'reproduced' if all_ok and rank_ok else 'differs'}.** DE/rand/1/exp "
        + ("reaches OF ≤ 1e-15 in every run on every data set" if all_ok else "does NOT reach OF ≤ 1e-15 in every run")
        + (" and is best by mean OF (a tie at the float64 floor counts as best)." if rank_ok else " and is NOT best by mean OF.")
        + " Our OF floor is ~1e-32 where the paper's is ~5e-19 (its data were stored with fewer digits); our DE/best/1/bin "
        "also reaches the floor in most runs where the paper's stalls sometimes, so the middle of the ranking can differ.",
        "",
    ]
    if "SD1" in sds:
        rows = []
        truth = recording("SD1").metadata["true_params"]
        for n in PARAM_NAMES:
            row = [n, g(truth[n])]
            for m in R.p["methods"]:
                r = R.get("SD1", m)
                row.append(f"{g(r['mean'][n])} / {g(PAPER['table6']['rows'][n][list(METHOD_NAMES).index(m)])}")
            rows.append(row)
        L += ["**Table 6 (SD1, mean parameters over runs; dcjax / paper)**", ""]
        L += table(["param", "true"] + [METHOD_NAMES[m] for m in R.p["methods"]], rows)
        de = R.get("SD1", "de-rand-1-exp")
        err = max(rel(de["mean"][n], truth[n]) for n in PARAM_NAMES) if de else float("inf")
        L += [
            f"**Verdict (Table 6): {'reproduced' if err < 1e-6 else 'differs'}** — DE/rand/1/exp mean parameters within "
            f"{err:.1e} (relative) of the Table 3 values; the other methods' means scatter as in the paper.",
            "",
        ]


def section_md_methods(R: Results, L: list[str]):
    mds = [d for d in R.p["md"] if R.get(d, R.p["methods"][0], "RK") is not None]
    if not mds:
        return
    L += ["## Tables 9–17: controlled drive, EM vs RK, 5 methods (MD analogues)", ""]
    L += [
        "The paper's MD1–MD4 are measurements of a real drive that are not public; dcjax's MD1–MD4 are emulated "
        "analogues (`data/README.md`) with their own true parameters, so parameter values are compared with *our* truth "
        "and the paper's numbers are shown for the pattern, not the value. Each cell: dcjax / paper.",
        "",
    ]
    em_bad, rk_good, same, ga_worst, n_cells = [], [], 0, 0, 0
    for d in mds:
        t_em, t_rk = MD_TABLES[d][:2]
        truth = recording(d).metadata["true_params"]
        for variant, tab in (("EM", t_em), ("RK", t_rk)):
            if variant not in R.p["md_variants"]:
                continue
            P = PAPER[f"table{tab}"]
            rows = []
            for m in R.p["methods"]:
                r = R.get(d, m, variant)
                j = P["columns"].index(m)
                rows.append(
                    [METHOD_NAMES[m], f"{g(r['of'].mean())} / {g(P['OF_M'][j])}", f"{g(r['of'].std(), 2)} / {g(P['OF_SD'][j], 2)}"]
                    + [f"{g(r['mean'][n], 3)} / {g(P[n][j], 3)}" for n in PARAM_NAMES]
                )
            rows.append(["true (ours)", "", ""] + [g(truth[n], 3) for n in PARAM_NAMES])
            de = R.get(d, "de-rand-1-exp", variant)
            same += int(de["of"].std() <= 1e-9 * de["of"].mean())
            means = {m: R.get(d, m, variant)["of"].mean() for m in R.p["methods"]}
            ga_worst += int(max(means, key=means.get) == "ga")
            n_cells += 1
            L += [f"**Table {tab}: {d}, {variant}** (mean over runs)", ""]
            L += table(["method", "OF M", "OF SD"] + list(PARAM_NAMES), rows)
        em, rk = R.get(d, "de-rand-1-exp", "EM"), R.get(d, "de-rand-1-exp", "RK")
        if em is not None and rk is not None:
            em_bad.append(em["mean"]["Ra"] > 1.3 * truth["Ra"] and em["mean"]["Tla"] < 0.1 * truth["Tla"])
            rk_good.append(rel(rk["mean"]["Ra"], truth["Ra"]) < 0.25 and rel(rk["mean"]["Tla"], truth["Tla"]) < 0.25)
    if em_bad:
        L += [
            f"**Verdict (Tables 9–16):** EM's failure (Ra far above the truth, Tla → 0) appears on "
            f"{sum(em_bad)}/{len(em_bad)} data sets: **{'reproduced' if all(em_bad) else 'reproduced qualitatively' if any(em_bad) else 'differs'}**. "
            f"RK gives Ra and Tla within 25 % on {sum(rk_good)}/{len(rk_good)}: "
            f"**{'reproduced' if all(rk_good) else 'reproduced qualitatively' if any(rk_good) else 'differs'}** "
            "(where it fails, the friction moves from Tla into Tlc, or MD3's 0.132 s sampling biases Ra; see the ND tables). "
            f"DE/rand/1/exp gives the same OF in every run (SD ≤ 1e-9 of the mean) on {same}/{n_cells} cells (paper: all); "
            f"GA has the worst mean OF on {ga_worst}/{n_cells}.",
            "",
        ]
    rows = []
    for d in mds:
        r = R.get(d, "de-rand-1-exp", "RK")
        if r is not None:
            rows.append([d] + [g(r["mean"][n], 3) for n in PARAM_NAMES])
    L += ["**Table 17 analogue: DE/rand/1/exp + RK, mean parameters**", ""] + table(["data"] + list(PARAM_NAMES), rows)
    section_stationary_crossval(R, L, mds)


def section_stationary_crossval(R, L, mds):
    from dcjax.validation import cross_validation, stationary_check

    rows, du_all, di_all = [], [], []
    for d in mds:
        r = R.get(d, "de-rand-1-exp", "RK")
        rec = recording(d)
        times = [t for t in TABLE18_TIMES[d] if t <= rec.t[-1]]
        chk = stationary_check(r["best"], rec, times=times or None)
        du = max(c["u_dev_pct"] for c in chk)
        di = max(c["i_dev_pct"] for c in chk)
        du_all.append(du)
        di_all.append(di)
        rows.append(
            [
                d,
                ", ".join(f"{c['t']:.2f}" for c in chk),
                f"{du:.1f} / {PAPER['table18']['max_u_dev_pct'][d]}",
                f"{di:.1f} / {PAPER['table18']['max_i_dev_pct'][d]}",
            ]
        )
    L += ["**Table 18 analogue: stationary points (eq. 25–26) with the RK fits** — max deviation in % (dcjax / paper)", ""]
    L += table(["data", "t (s)", "u_calc dev", "i_calc dev"], rows)
    cv = [d for d in ("MD1", "MD2", "MD3") if d in mds]
    if len(cv) >= 2:
        fits = {d: R.get(d, "de-rand-1-exp", "RK")["best"] for d in cv}
        names, _, M = cross_validation(fits, {d: recording(d) for d in cv})
        rows = [[f"data {a}"] + [g(M[i, j], 3) for j in range(len(cv))] + [f"{M[i].max() / M[i, i]:.1f}"] for i, a in enumerate(names)]
        L += ["**Fig. 12 analogue: cross-validation** — OF of each recording (rows) with each fit (columns), RK", ""]
        L += table(["", *[f"fit {d}" for d in cv], "max / own"], rows)
        ratios = [M[i].max() / M[i, i] for i in range(len(cv))]
        L += [
            f"**Verdict (Fig. 12): {'reproduced' if max(ratios) <= 2 else 'differs'}.** The worst cross-fit OF is "
            f"{min(ratios):.1f}–{max(ratios):.1f}x each recording's own fit (paper: the fits of MD1–MD3 simulate each other's "
            "responses closely, Figs. 13–15). The emulated noise is smaller than the paper's measurements, so own-fit OFs are "
            "smaller and ratios larger, and the fits differ in Tla/Tlc and (MD3) Ra, see Table 17.",
            "",
        ]
    L += [
        f"**Verdict (Table 18): {'reproduced' if max(du_all) <= 3 else 'differs'} for voltages, "
        f"{'reproduced' if max(di_all) <= 13.1 else 'differs'} for currents.** Max voltage deviation {max(du_all):.1f} % "
        f"(paper ≤ 2.7 %), max current deviation {max(di_all):.1f} % (paper ≤ 13.1 %).",
        "",
    ]


def section_times(R: Results, L: list[str]):
    mds = [d for d in R.p["md"] if R.get(d, R.p["methods"][0], "RK") is not None]
    rows = []
    for d in mds:
        for v in R.p["md_variants"]:
            P = PAPER["table19"]["rows"].get(f"{d}/{v}")
            row = [f"{d}/{v}"]
            for m in R.p["methods"]:
                r = R.get(d, m, v)
                j = list(METHOD_NAMES).index(m)
                row.append(f"{r['run_s'] / r['runs']:.3f} / {P[j] if P else '–'}")
            rows.append(row)
    if rows:
        L += [
            "<!-- times -->",
            "**Table 19 analogue: time per run in s** (dcjax: wall time of the batch of runs / runs, "
            "2 CPU devices; paper: one run on its machine). dcjax / paper",
            "",
        ]
        L += table(["data/integrator"] + [METHOD_NAMES[m] for m in R.p["methods"]], rows) + ["<!-- /times -->", ""]


def section_weights(R: Results, L: list[str]):
    mds = [d for d in R.p["md"] if R.get(d, w=(R.p["weights"][0], round(1 - R.p["weights"][0], 10))) is not None]
    if not mds:
        return
    L += ["## Tables 20–23: weights w1, w2 = 1 − w1 (eq. 27), RK, DE/rand/1/exp", ""]
    L += ["Mean over runs; each cell dcjax / paper. The OF of different weights are not comparable (paper's remark).", ""]
    summary, pattern = [], []
    for d in mds:
        tab = MD_TABLES[d][2]
        truth = recording(d).metadata["true_params"]
        rows, good = [], []
        for w in R.p["weights"]:
            r = R.get(d, w=(float(w), round(1 - float(w), 10)))
            P = PAPER[f"table{tab}"]["rows"].get(f"{float(w):.1f}")
            pc = dict(zip(PAPER[f"table{tab}"]["columns"], P)) if P else {}
            rows.append(
                [f"{float(w):.1f}"]
                + [f"{g(r['mean'][n], 3)} / {g(pc.get(n), 3)}" for n in ("Ra", "La", "J", "Tla", "Tlb", "Tlc")]
                + [f"{g(r['of'].mean())} / {g(pc.get('OF'))}"]
            )
            if rel(r["mean"]["Tla"], truth["Tla"]) < 0.25:
                good.append(f"{float(w):.1f}")
        rows.append(["true (ours)"] + [g(truth[n], 3) for n in ("Ra", "La", "J", "Tla", "Tlb", "Tlc")] + [""])
        L += [f"**Table {tab}: {d}**", ""] + table(["w1", "Ra", "La", "J", "Tla", "Tlb", "Tlc", "OF"], rows)
        summary.append(f"{d}: Tla within 25 % for w1 ∈ {{{', '.join(good) or 'none'}}}")
        lo_w = R.get(d, w=(float(R.p["weights"][0]), round(1 - float(R.p["weights"][0]), 10)))
        pattern.append(rel(lo_w["mean"]["Tla"], truth["Tla"]) > 0.25 and len(good) > 0)
    verdict = "reproduced qualitatively" if all(pattern) else "partly reproduced" if any(pattern) else "differs"
    L += [
        f"**Verdict (Tables 20–23): {verdict}.** The paper finds that small w1 (speed-dominated OF) loses the friction "
        "torque Tla (it moves into Tlc) and larger w1 recovers it, with only w1 = 0.5 right on all four sets. Here the "
        f"smallest w1 gives a wrong Tla and some larger w1 a right one on {sum(pattern)}/{len(pattern)} data sets: "
        + "; ".join(summary)
        + ".",
        "",
    ]


def section_nd(R: Results, L: list[str]):
    mds = [d for d in R.p["md"] if R.get(d, variant=R.p["variants"][0]) is not None]
    if not mds:
        return
    L += ["## Tables 24–28: ND sub-steps (eq. 28–29), EM, EM5, EM10, RK, RK5, RK10, DE/rand/1/exp", ""]
    repaired, rk_moves = [], []
    for d in mds:
        tab = MD_TABLES[d][3]
        P = PAPER[f"table{tab}"]
        truth = recording(d).metadata["true_params"]
        rows = []
        for v in R.p["variants"]:
            r = R.get(d, variant=v)
            j = P["columns"].index(v)
            rows.append([v, f"{g(r['of'].mean())} / {g(P['OF_M'][j])}"] + [f"{g(r['mean'][n], 3)} / {g(P[n][j], 3)}" for n in PARAM_NAMES])
        rows.append(["true (ours)", ""] + [g(truth[n], 3) for n in PARAM_NAMES])
        L += [f"**Table {tab}: {d}** (mean over runs; dcjax / paper)", ""] + table(["variant", "OF M"] + list(PARAM_NAMES), rows)
        em10 = R.get(d, variant="EM10") if "EM10" in R.p["variants"] else None
        em = R.get(d, variant="EM")
        if em10 is not None:
            repaired.append(rel(em10["mean"]["Ra"], truth["Ra"]) < rel(em["mean"]["Ra"], truth["Ra"]))
        if "RK10" in R.p["variants"]:
            rk_moves.append(rel(R.get(d, variant="RK10")["mean"]["Ra"], R.get(d, variant="RK")["mean"]["Ra"]))
    if repaired:
        L += [
            f"**Verdict (Tables 24–27): {'reproduced' if all(repaired) else 'reproduced qualitatively'}** — dividing the "
            f"interval brings EM's Ra towards the truth on {sum(repaired)}/{len(repaired)} data sets (paper: EM5/EM10 repair "
            "EM)"
            + (f"; RK10 changes RK's mean Ra by {100 * min(rk_moves):.0f}–{100 * max(rk_moves):.0f} %" if rk_moves else "")
            + " (paper: 0.4–16 %). See the per-table rows for Tla.",
            "",
        ]
    rows = []
    for d in mds:
        P = PAPER["table28"]["rows"][d]
        rows.append(
            [d]
            + [f"{R.get(d, variant=v)['run_s'] / R.get(d, variant=v)['runs']:.3f} / {P[list(VARIANTS).index(v)]}" for v in R.p["variants"]]
        )
    L += ["<!-- times -->", "**Table 28 analogue: time per run in s** (dcjax / paper)", ""]
    L += table(["data"] + list(R.p["variants"]), rows) + ["<!-- /times -->", ""]


def section_memory(R: Results, L: list[str], figures: Path):
    p = R.p
    gens = int(p["memory_generations"])
    ref_gens = None if gens == math.ceil((int(p["budget"]) - 70) / 70) else gens
    mds = [
        d
        for d in p["md"]
        if R.get(
            d,
            variant=p["variants"][0],
            memory=p["memory"][0],
            generations=gens,
            runs=p["runs"] if p["memory"][0] == "stma" else p["ltma_runs"],
        )
        is not None
    ]
    if not mds:
        return
    L += ["## Tables 30–33 and Fig. 25: memory assistance (Section 4.4), DE/rand/1/exp, Table 29 precisions", ""]
    L += [
        f"{gens + 1} populations of 70 per run (the paper's 2000 iterations); STMA with {p['runs']} runs, LTMA with "
        f"{p['ltma_runs']} runs per cell (its linear history search is the slowest part of the reproduction). "
        "Dupl. % = candidates answered from memory / (70 × populations), the paper's convention. Time % = run time "
        "with memory / without, same runs and iterations, measured in this reproduction.",
        "",
    ]
    ranges, fig_rows, time_pct, time_by = {}, [], {}, {}
    for d in mds:
        tab = MD_TABLES[d][4]
        P = PAPER[f"table{tab}"]["rows"]
        dup_rows, time_rows = [], []
        for mem in p["memory"]:
            runs = p["runs"] if mem == "stma" else p["ltma_runs"]
            drow, trow = [mem.upper()], [mem.upper()]
            for v in p["variants"]:
                r = R.get(d, variant=v, memory=mem, runs=runs, generations=gens)
                ref = R.get(d, variant=v, runs=runs, generations=ref_gens)
                j = list(VARIANTS).index(v)
                cand = 70 * (r["iterations"] + 1)
                dup = float(np.mean(100 * r["dups"] / cand))
                ranges.setdefault(mem, []).append(dup)
                drow.append(f"{dup:.1f} / {P[mem]['dupl_pct'][j] if mem in P else '–'}")
                time_pct.setdefault(mem, []).append(100 * r["run_s"] / ref["run_s"])
                time_by.setdefault(mem, {})[(d, v)] = 100 * r["run_s"] / ref["run_s"]
                trow.append(f"{100 * r['run_s'] / ref['run_s']:.0f} / {P[mem]['time_pct'][j] if mem in P else '–'}")
                if mem == p["memory"][0] or mem == "ltma-s2":
                    t_fe = ref["run_s"] / float(ref["fes"].sum())
                    handling = (r["run_s"] - t_fe * float(r["fes"].sum())) / float(cand.sum())
                    fig_rows.append((d, v, mem, t_fe, handling))
            dup_rows.append(drow)
            time_rows.append(trow)
        L += [f"**Table {tab}: {d}, Dupl. (%)** (dcjax / paper)", ""] + table(["memory"] + list(p["variants"]), dup_rows)
        L += (
            ["<!-- times -->", f"**Table {tab}: {d}, Time (%)** (dcjax / paper)", ""]
            + table(["memory"] + list(p["variants"]), time_rows)
            + ["<!-- /times -->", ""]
        )
    lo = {m: min(v) for m, v in ranges.items()}
    hi = {m: max(v) for m, v in ranges.items()}
    paper_range = {"stma": (30, 60), "ltma-s1": (67, 86), "ltma-s2": (67, 86)}
    inside = {m: paper_range[m][0] - 5 <= lo[m] and hi[m] <= paper_range[m][1] + 5 for m in ranges}
    verdicts = ", ".join(f"{m.upper()} {'reproduced' if ok else 'differs'}" for m, ok in inside.items())
    L += [
        f"**Verdict (Tables 30–33, duplications): {verdicts}.** "
        + "; ".join(f"{m.upper()} {lo[m]:.0f}–{hi[m]:.0f} %" for m in ranges)
        + " (paper: STMA 30–60 %, LTMA 67–86 %). Where STMA is above the paper's range, our DE population has collapsed "
        "inside the Table 29 precision box sooner than the paper's, so most trial vectors repeat the previous population "
        "and STMA catches nearly all that LTMA catches; the emulated data are smoother than the measurements, which the "
        "paper notes changes duplication.",
        "",
    ]
    t_mean = {m: float(np.mean(v)) for m, v in time_pct.items()}
    stma = time_by.get("stma", {})
    saves = sorted(f"{d} {v}" for (d, v), t in stma.items() if t < 100)
    falls = [
        d
        for d in mds
        if all(stma.get((d, a), 0) >= stma.get((d, b), 0) for a, b in (("EM", "EM10"), ("RK", "RK10")) if (d, a) in stma and (d, b) in stma)
    ]
    L += [
        "<!-- times -->",
        f"**Verdict (Tables 30–33, time): STMA {'reproduced qualitatively' if stma and len(falls) == len(mds) else 'differs'}, "
        f"LTMA differs.** STMA is below 100 % in {len(saves)}/{len(stma)} cells ({', '.join(saves) or 'none'}) and its Time % "
        f"falls from ND = 1 to ND = 10 on {len(falls)}/{len(mds)} data sets, the paper's pattern (little or no gain at EM/RK, "
        "more as the simulation gets dearer). LTMA is far slower than no memory here, where the paper saw 57–434 %.",
        "<!-- /times -->",
        "",
    ]
    L += [
        "<!-- times -->",
        "**Time:** a duplicate's simulation is really skipped (the non-duplicates of all runs on a device "
        "are compacted and evaluated in the smallest of the buckets n, n/2, n/4, …; `dcjax/strategies/compact.py`). Mean "
        "Time % over the cells: " + ", ".join(f"{m.upper()} {t:.0f} %" for m, t in t_mean.items()) + ". LTMA searches the "
        "whole history linearly, as the paper's Fig. 24 does; one of our simulations costs microseconds per member, about "
        "10^4 times less than the paper's run time per FE, so the search dominates — the paper's own conclusion that the "
        'problem is "not time-consuming enough" for LTMA holds more strongly here. S2 (newest first) can stop sooner than '
        "S1 only when every candidate of a population is found; one new candidate forces a full scan.",
        "<!-- /times -->",
        "",
    ]
    if fig_rows:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        figures.mkdir(parents=True, exist_ok=True)
        fig, ax = plt.subplots(figsize=(9, 4))
        labels = [f"{d}\n{v}\n{m}" for d, v, m, _, _ in fig_rows]
        x = np.arange(len(fig_rows))
        ax.bar(x - 0.2, [1e6 * t for *_, t, _ in fig_rows], 0.4, label="OF evaluation per FE")
        ax.bar(x + 0.2, [1e6 * max(h, 0) for *_, h in fig_rows], 0.4, label="memory handling per candidate")
        ax.set_yscale("log")
        ax.set(ylabel="µs", title="Fig. 25 analogue (derived from run times)")
        ax.set_xticks(x, labels, fontsize=5)
        ax.legend()
        fig.tight_layout()
        fig.savefig(figures / "fig25_memory_times.png", dpi=110)
        plt.close(fig)
        rows = [[d, v, m, f"{1e6 * t:.2f}", f"{1e6 * h:.2f}"] for d, v, m, t, h in fig_rows]
        L += [
            "<!-- times -->",
            "**Fig. 25 analogue** (µs; OF time per FE = memory-free run time / FEs; handling = "
            "(run time with memory − FEs × OF time) / candidates, derived, not timed separately): "
            f"[fig25_memory_times.png]({R.link(figures / 'fig25_memory_times.png')})",
            "",
        ]
        L += table(["data", "variant", "memory", "OF per FE", "handling per candidate"], rows) + ["<!-- /times -->", ""]


def response_figures(R: Results, L: list[str], figures: Path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from dcjax import Params, make_problem, simulate

    figures.mkdir(parents=True, exist_ok=True)
    made = []

    def fig(name, title, rec, fits):
        f, ax = plt.subplots(1, 2, figsize=(11, 3.6))
        ax[0].plot(rec.t, rec.i_a, "k.", ms=3, label="measured")
        ax[1].plot(rec.t, rec.omega, "k.", ms=3, label="measured")
        for label, params, integ, nd in fits:
            sim = np.asarray(simulate(Params.from_dict(params), make_problem(rec, integrator=integ, nd=nd)))
            ax[0].plot(rec.t, sim[:, 0], lw=1, label=label)
            ax[1].plot(rec.t, sim[:, 1], lw=1, label=label)
        ax[0].set(xlabel="t (s)", ylabel="i_a (A)", title=title)
        ax[1].set(xlabel="t (s)", ylabel="ω (1/s)")
        ax[0].legend(fontsize=7)
        f.tight_layout()
        f.savefig(figures / name, dpi=100)
        plt.close(f)
        made.append((name, title))

    if R.get("SD1", "de-rand-1-exp") is not None:
        fig(
            "fig02_sd1.png",
            "Fig. 2 analogue: SD1, DE/rand/1/exp + RK",
            recording("SD1"),
            [("RK", R.get("SD1", "de-rand-1-exp")["best"], "rk4", 1)],
        )
    for _k, d in enumerate(p for p in R.p["md"] if R.get(p, "de-rand-1-exp", "EM") is not None):
        rec = recording(d)
        fits = [(v, R.get(d, "de-rand-1-exp", v)["best"], *VARIANTS[v]) for v in ("EM", "RK") if R.get(d, "de-rand-1-exp", v)]
        fig(f"fig{8 + int(d[-1]) - 1:02d}_{d.lower()}_em_rk.png", f"Figs. 8–11 analogue: {d}, EM vs RK", rec, fits)
        nd_fits = [(v, R.get(d, variant=v)["best"], *VARIANTS[v]) for v in ("EM10", "RK10") if v in R.p["variants"] and R.get(d, variant=v)]
        if nd_fits:
            fig(f"fig{18 + int(d[-1]) - 1:02d}_{d.lower()}_nd.png", f"Figs. 18–22 analogue: {d}, ND = 10", rec, nd_fits)
    cv = [d for d in ("MD1", "MD2", "MD3") if R.get(d, "de-rand-1-exp", "RK") is not None]
    if len(cv) >= 2:
        for d in cv:
            fig(
                f"fig{13 + int(d[-1]) - 1:02d}_crossval_{d.lower()}.png",
                f"Figs. 13–15 analogue: {d} simulated with each RK fit",
                recording(d),
                [(f"fit {e}", R.get(e, "de-rand-1-exp", "RK")["best"], "rk4", 1) for e in cv],
            )
    if made:
        L += ["## Figures", ""] + [f"- [{t}]({R.link(figures / n)})" for n, t in made] + [""]


def infer_profile(store) -> dict:
    """The grid a store holds, when no profile is given (e.g. a store of `cell.py` sweeps)."""
    from collections import Counter

    firsts = [e["runs"][0] for e in Store(store).cells().values()]
    if not firsts:
        return dict(DEFAULT_PROFILE, name="empty")
    common = lambda xs, default: Counter(xs).most_common(1)[0][0] if xs else default
    plain = [f for f in firsts if f["memory"] is None]
    mem = [f for f in firsts if f["memory"] is not None]
    data = sorted({f["data"] for f in firsts})
    present_variants = {VARIANT for VARIANT in VARIANTS if any((f["integrator"], f["nd"]) == VARIANTS[VARIANT] for f in firsts)}
    return {
        "name": "inferred",
        "runs": common([f["runs"] for f in plain], 50),
        "budget": common([f["budget"] for f in firsts], 140000),
        "sd": [d for d in data if d.startswith("SD")],
        "md": [d for d in data if d.startswith("MD")],
        "methods": [m for m in METHOD_NAMES if any(f["method"] == m for f in firsts)],
        "md_variants": [v for v in ("EM", "RK") if v in present_variants],
        "weights": sorted({f["w1"] for f in firsts if f["w1"] != 1.0}),
        "variants": [v for v in VARIANTS if v in present_variants],
        "memory": [m for m in ("stma", "ltma-s1", "ltma-s2") if any(f["memory"] == m for f in mem)],
        "memory_generations": common([f["generations"] for f in mem], 1999),
        "ltma_runs": common([f["runs"] for f in mem if f["memory"] != "stma"], 2),
    }


def write_report(store, out, figures, cfg: dict | None = None) -> str:
    """REPORT.md from `store`; `cfg` = the hydra config of `reproduce.py` (profile, seed), or
    None to infer the grid from the store."""
    cfg = cfg or {}
    profile = cfg.get("profile") or infer_profile(store)
    R = Results(store, profile, int(cfg.get("seed", 0)))
    figures = Path(figures)
    R.report_dir = Path(out).resolve().parent
    figures = figures.resolve()
    n_runs = sum(len(e["runs"]) for e in R.cells.values())
    run_s = sum(e["meta"]["run_s"] + e["meta"]["compile_s"] for e in R.cells.values())
    L = [
        "# dcjax reproduction of Jesenik et al., Mathematics 2020, 8, 1269",
        "",
        f"Generated by `experiments/report.py` from the store `{Path(store).name}` (profile `{profile['name']}`, seed {cfg.get('seed', 0)}, "
        f"{len(R.cells)} cells, {n_runs} runs). Paper numbers: `experiments/paper_tables.json` (typo readings listed there "
        "under `notes`). Each comparison cell reads *dcjax / paper*.",
        "",
        "<!-- times -->",
        f"Compute time in the store (compile + run, all cells): {run_s:.0f} s on this machine "
        "(2-core CPU, 2 XLA host devices). The paper's timings are from another machine: compare ratios, not seconds.",
        "<!-- /times -->",
        "",
    ]
    section_table5(R, L)
    section_md_methods(R, L)
    section_times(R, L)
    section_weights(R, L)
    section_nd(R, L)
    section_memory(R, L, figures)
    response_figures(R, L, figures)
    text = "\n".join(L).rstrip() + "\n"
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    Path(out).write_text(text)
    return text


def without_times(text: str) -> str:
    """The report with the measured-time blocks removed (what must match between runs)."""
    out, skip = [], False
    for line in text.splitlines():
        if line.strip() == "<!-- times -->":
            skip = True
        elif line.strip() == "<!-- /times -->":
            skip = False
        elif not skip:
            out.append(line)
    return "\n".join(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--store", default="experiments/results/full.jsonl")
    ap.add_argument("--out", default="experiments/REPORT.md")
    ap.add_argument("--figures", default="experiments/figures")
    ap.add_argument("--profile", default=None, help="conf/profile/<name>.yaml the store was made with (default: inferred)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    profile = None
    if args.profile:
        from omegaconf import OmegaConf

        profile = OmegaConf.to_container(OmegaConf.load(HERE / "conf" / "profile" / f"{args.profile}.yaml"))
    write_report(args.store, args.out, args.figures, {"profile": profile, "seed": args.seed})
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
