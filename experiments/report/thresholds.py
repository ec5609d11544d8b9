"""The named thresholds behind every verdict of the report, each derived from the paper's own
numbers (the reason stands beside it)."""

from .common import PAPER, _paper_rk, _spread, rel, verdict

THRESHOLDS = {
    "of_floor": (
        1e-15,
        "OF at the global optimum of noise-free data: the paper's DE/rand/1/exp reaches 3e-19–6e-19 on SD1–SD4 in 50/50 runs (Table 5)",
    ),
    "param_tol": (
        0.25,
        "a parameter is right within 25 % of the truth: the paper accepts its RK Ra within 14 % of the nameplate and Tla "
        f"within 15 % over MD1–MD4 (Table 17; Tla spread {100 * _spread(_paper_rk('Tla')):.0f} % about its mean); 25 % leaves "
        "room for comparing with an emulator's exact truth",
    ),
    "same_runs": (1e-9, "every run the same: the paper's DE/rand/1/exp OF SD is 0–1.7e-18 on means of ~3e-3 (Tables 9–16)"),
    "tol_factor": (1.25, "a deviation or ratio is within the paper's if it is at most 1.25x the paper's worst"),
    "time_factor": (1.5, "a time ratio (Tables 19, 28) matches if within a factor 1.5 of the paper's"),
    "time_spread": (
        1.25,
        "run-to-run spread of one time on this machine: the same code's median SD1 run over six fresh processes ranged "
        "0.2585–0.3231 s (experiments/bench_one_run.py, BENCHMARKS.md), so a ratio of two times can differ by time_spread^2 "
        "between two runs; a cell counts as inside or outside a time threshold only when it clears it by time_spread, so two "
        "runs cannot put it on opposite sides",
    ),
    "cross_ratio": (
        1.25 * PAPER["fig12"]["OF"][2] / PAPER["fig12"]["OF"][0],
        f"Fig. 12: the paper calls its worst cross-fit OF ({PAPER['fig12']['OF'][2]:.4g} = "
        f"{PAPER['fig12']['OF'][2] / PAPER['fig12']['OF'][0]:.2f}x the own fit of MD1) confirming; threshold 1.25x that",
    ),
    "dup_margin": (5.0, "duplication ranges match if inside the paper's (STMA 30–60 %, LTMA 67–86 %, Section 4.4) ± 5 points"),
}
T = {k: v[0] for k, v in THRESHOLDS.items()}
PAPER_DUP_RANGE = {"stma": (30, 60), "ltma": (67, 86)}


def right(params: dict, truth: dict, names=("Ra", "Tla")) -> bool:
    return all(rel(params[n], truth[n]) <= T["param_tol"] for n in names)


def time_side(ratio: float, lo: float, hi: float) -> str:
    """Where a ratio of two measured times lies against [lo, hi]: "in" (inside by a factor s =
    time_spread), "out" (outside by s) or "near". Another run moves the ratio by at most s^2, so
    it cannot turn an "in" into an "out" or back."""
    s = T["time_spread"]
    if lo * s <= ratio <= hi / s:
        return "in"
    if ratio < lo / s or ratio > hi * s:
        return "out"
    return "near"


def time_verdict(sides: list[str]) -> str:
    """The verdict of cells judged by `time_side`: the same whether the "near" ones count as in or
    as out, or else "not decided by the timing". Two runs whose ratios differ by less than the
    spread cannot reach opposite verdicts (a cell only moves between a side and "near")."""
    k, near, n = sides.count("in"), sides.count("near"), len(sides)
    lo, hi = verdict(k, n), verdict(k + near, n)
    return lo if lo == hi else f"not decided by the timing ({near}/{n} within the spread)"


def near_note(sides: list[str]) -> str:
    near = sides.count("near")
    return f"; {near}/{len(sides)} too near a bound for the timing spread to decide" if near else ""
