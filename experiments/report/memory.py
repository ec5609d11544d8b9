"""Memory assistance (Tables 30-33, Fig. 25) and the bound-handling study."""

from pathlib import Path

import numpy as np

from ..cells import VARIANTS
from .common import (
    MD_TABLES,
    MEMORY_LABEL,
    PAPER,
    Results,
    g,
    table,
    verdict,
)
from .thresholds import PAPER_DUP_RANGE, T, near_note, time_side, time_verdict


def section_memory(R: Results, L: list[str], figures: Path):
    p = R.p
    gens = int(p["memory_generations"])
    ref_gens = None if gens == -(-(int(p["budget"]) - 70) // 70) else gens
    mds = [d for d in p["md"] if R.get(d, variant=p["variants"][0], memory=p["memory"][0], generations=gens) is not None]
    if not mds:
        return
    L += ["## Tables 30–33 and Fig. 25: memory assistance (Section 4.4), DE/rand/1/exp, Table 29 precisions", ""]
    L += [
        f"{gens + 1} populations of 70 per run (the paper's 2000 iterations), {p['runs']} runs per cell. LTMA uses the index "
        '(`memory="ltma-hash"`: Table 29 precision-grid cells in a hash table, O(1) per candidate): with an index the search '
        "order of the paper's S1 (oldest first) and S2 (newest first) no longer matters, so one LTMA row is compared with both "
        "of the paper's. Dupl. % = candidates answered from memory / (70 × populations), the paper's convention. Time % = wall "
        "time of the runs with memory / without (same runs, iterations and devices; per run, as the paper's mean of single "
        "runs, since both batches hold the same runs).",
        "",
    ]
    ranges, fig_rows, fig_sides, time_by = {}, [], [], {}
    for d in mds:
        tab = MD_TABLES[d][4]
        P = PAPER[f"table{tab}"]["rows"]
        dup_rows, time_rows = [], []
        for mem in p["memory"]:
            prow = ["stma"] if mem == "stma" else ["ltma-s1", "ltma-s2"]
            drow, trow = [MEMORY_LABEL[mem]], [MEMORY_LABEL[mem]]
            for v in p["variants"]:
                r = R.get(d, variant=v, memory=mem, generations=gens)
                ref = R.get(d, variant=v, generations=ref_gens)
                j = list(VARIANTS).index(v)
                cand = 70 * (r["iterations"] + 1)
                dup = float(np.mean(100 * r["dups"] / cand))
                ranges.setdefault(mem, []).append(dup)
                pct = 100 * r["run_s"] / ref["run_s"]
                time_by.setdefault(mem, {})[(d, v)] = pct
                drow.append(f"{dup:.1f} / {' & '.join(str(P[q]['dupl_pct'][j]) for q in prow)}")
                trow.append(f"{pct:.0f} / {' & '.join(str(P[q]['time_pct'][j]) for q in prow)}")
                t_fe = ref["run_s"] / float(ref["fes"].sum())
                fig_rows.append((d, v, mem, t_fe, (r["run_s"] - t_fe * float(r["fes"].sum())) / float(cand.sum())))
                # handling < OF time per FE  <=>  run_s / ref run_s < (candidates + FEs) / ref FEs
                bound = (float(cand.sum()) + float(r["fes"].sum())) / float(ref["fes"].sum())
                fig_sides.append(time_side(r["run_s"] / ref["run_s"], 0.0, bound))
            dup_rows.append(drow)
            time_rows.append(trow)
        L += [f"**Table {tab}: {d}, Dupl. (%)** (dcjax / paper; LTMA: paper S1 & S2)", ""] + table(
            ["memory"] + list(p["variants"]), dup_rows
        )
        L += (
            ["<!-- times -->", f"**Table {tab}: {d}, Time (%)** (dcjax / paper)", ""]
            + table(["memory"] + list(p["variants"]), time_rows)
            + ["<!-- /times -->", ""]
        )
    parts = []
    for mem, vals in ranges.items():
        lo, hi = PAPER_DUP_RANGE["stma" if mem == "stma" else "ltma"]
        k = sum(lo - T["dup_margin"] <= x <= hi + T["dup_margin"] for x in vals)
        parts.append(
            f"{MEMORY_LABEL[mem]} {verdict(k, len(vals))} ({min(vals):.0f}–{max(vals):.0f} %, inside the paper's {lo}–{hi} % ± dup_margin in {k}/{len(vals)} cells)"
        )
    L += [f"**Verdict (Tables 30–33, duplications):** {'; '.join(parts)}.", ""]
    if "stma" in ranges and any(m != "stma" for m in ranges):
        ltma = next(m for m in ranges if m != "stma")
        gap = float(np.mean(ranges[ltma]) - np.mean(ranges["stma"]))
        p_gap = [
            float(
                np.mean(PAPER[f"table{MD_TABLES[d][4]}"]["rows"][q]["dupl_pct"])
                - np.mean(PAPER[f"table{MD_TABLES[d][4]}"]["rows"]["stma"]["dupl_pct"])
            )
            for d in mds
            for q in ("ltma-s1", "ltma-s2")
        ]
        L += [
            f"LTMA (index) finds {gap:+.1f} points of duplicates against STMA on average here (paper: LTMA-S1/S2 "
            f"{min(p_gap):+.0f} to {max(p_gap):+.0f} points per data set). The index tests the precision-grid cell, STMA the "
            "±precision box, so a near-copy across a cell border counts for STMA and not for the index: the two are not "
            "nested here as S1/S2 and STMA are in the paper.",
            "",
        ]
    _memory_time_verdicts(L, mds, time_by)
    if fig_rows:
        _fig25(R, L, p, figures, fig_rows, fig_sides)


def _memory_time_verdicts(L: list[str], mds: list[str], time_by: dict) -> None:
    """The time verdicts of Tables 30–33 (STMA's Time % from RK to RK10; each LTMA's Time %)."""
    lines = ["<!-- times -->"]
    stma = time_by.get("stma", {})
    if stma:
        falls = [d for d in mds if (d, "RK") in stma and (d, "RK10") in stma and stma[(d, "RK10")] < stma[(d, "RK")]]
        below = sum(t < 100 for (d, v), t in stma.items() if v.endswith("10"))
        n10 = sum(1 for (d, v) in stma if v.endswith("10"))
        lines += [
            f"**Verdict (Tables 30–33, STMA time): {verdict(len(falls) + below, len(mds) + n10)}** — STMA's Time % falls from "
            f"RK to RK10 on {len(falls)}/{len(mds)} data sets and is below 100 % at ND = 10 in {below}/{n10} cells (paper: both "
            f"on all; STMA {min(stma.values()):.0f}–{max(stma.values()):.0f} % here).",
            "",
        ]
    for mem, by in time_by.items():
        if mem == "stma":
            continue
        p_lo = min(min(PAPER[f"table{MD_TABLES[d][4]}"]["rows"][q]["time_pct"]) for d in mds for q in ("ltma-s1", "ltma-s2"))
        p_hi = max(max(PAPER[f"table{MD_TABLES[d][4]}"]["rows"][q]["time_pct"]) for d in mds for q in ("ltma-s1", "ltma-s2"))
        sides = [time_side(t, p_lo / T["time_factor"], p_hi * T["time_factor"]) for t in by.values()]
        lines += [
            f"**Verdict (Tables 30–33, {MEMORY_LABEL[mem]} time): {time_verdict(sides)}** — {min(by.values()):.0f}–"
            f"{max(by.values()):.0f} % (paper S1/S2 {p_lo}–{p_hi} %; inside that range widened by time_factor in "
            f"{sides.count('in')}/{len(by)} cells{near_note(sides)}).",
            "",
        ]
    L += lines + ["<!-- /times -->", ""]


def _fig25(R: Results, L: list[str], p: dict, figures: Path, fig_rows: list, sides: list[str]) -> None:
    """Fig. 25 analogue: OF time per FE and memory handling per candidate, derived from run times."""
    import matplotlib.pyplot as plt

    figures.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(9, 4))
    labels = [f"{d}\n{v}\n{m}" for d, v, m, _, _ in fig_rows]
    x = np.arange(len(fig_rows))
    ax.bar(x - 0.2, [1e6 * t for *_, t, _ in fig_rows], 0.4, label="OF evaluation per FE")
    ax.bar(x + 0.2, [1e6 * max(h, 0) for *_, h in fig_rows], 0.4, label="memory handling per candidate")
    ax.set_yscale("log")
    ax.set(ylabel="µs", title="Fig. 25 analogue (derived from run times)")
    ax.set_xticks(x, labels, fontsize=4)
    ax.legend()
    fig.tight_layout()
    fig.savefig(figures / "fig25_memory_times.png", dpi=110)
    plt.close(fig)
    rows = [[d, v, MEMORY_LABEL[m], f"{1e6 * t:.2f}", f"{1e6 * h:.2f}"] for d, v, m, t, h in fig_rows]
    by_memory = {m: [s for r, s in zip(fig_rows, sides) if r[2] == m] for m in p["memory"]}
    L += [
        "<!-- times -->",
        "**Fig. 25 analogue** (µs; OF time per FE = memory-free run time / FEs; handling = (run time with memory − FEs × "
        f"OF time) / candidates, derived, not timed separately): [fig25_memory_times.png]({R.link(figures / 'fig25_memory_times.png')})",
        "",
    ]
    L += table(["data", "variant", "memory", "OF per FE", "handling per candidate"], rows)
    L += [
        "**Verdict (Fig. 25): "
        + "; ".join(
            f"{MEMORY_LABEL[m]} handling below the OF time per FE in {s.count('in')}/{len(s)} cells, above in {s.count('out')}"
            + (f", too near to tell in {s.count('near')}" if s.count("near") else "")
            for m, s in by_memory.items()
        )
        + "** (paper: STMA's handling is small against an OF evaluation, LTMA-S1's is not).",
        "<!-- /times -->",
        "",
    ]


def section_bounds(R: Results, L: list[str]):
    p = R.p
    if "bounds_rules" not in p:
        return
    data = p["bounds_data"]
    rows, all_ok = [], []
    from dcjax.models.dc import table4

    hi = table4().upper
    for rule in p["bounds_rules"]:
        for init in p["init_rules"]:
            r = R.get(data, bounds_rule="" if rule == "redraw" else rule, init_rule="" if init == "uniform" else init)
            if r is None:
                continue
            n_ok = int(np.sum(r["of"] <= T["of_floor"]))
            at_hi = int(np.sum(np.any(np.isclose(r["params"], hi, rtol=1e-9), axis=1) & (r["of"] > T["of_floor"])))
            rows.append([rule, init, f"{n_ok}/{r['runs']}", str(at_hi), g(float(r["of"].max()), 3)])
            all_ok.append((rule, init, n_ok == r["runs"]))
    if not rows:
        return
    L += [f"## Bound handling and initialization (why Table 5's runs agree): {data}, DE/rand/1/exp, RK", ""]
    L += table(["bounds rule", "init", "OF ≤ of_floor", "runs stuck at an upper bound", "worst OF"], rows)
    good = [f"{a}/{b}" for a, b, ok in all_ok if ok]
    L += [
        f"**Verdict (bound handling): {len(good)}/{len(all_ok)} rule/initialization pairs give every run at the optimum** "
        f"({', '.join(good) or 'none'}; paper: 50/50 in Table 5); "
        f"{', '.join(f'{a}/{b}' for a, b, ok in all_ok if not ok) or 'none'} leave runs short of it. dcjax's default is "
        "redraw/uniform.",
        "",
    ]
