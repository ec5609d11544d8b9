"""Write REPORT.md (and its figures) from a results store, beside the paper's numbers
(`paper_tables.json`, transcribed from ../shared/paper/ by `transcribe_paper_tables.py`).

    python -m experiments.report                       # the committed store -> experiments/REPORT.md
    python -m experiments.report --store experiments/results/cells.jsonl --out /tmp/R.md

Nothing here is typed by hand: every figure comes from the store, every paper number from the
JSON file, every verdict from a named threshold in `THRESHOLDS` (each derived from the paper's
own numbers) applied to both. Measured times sit between `<!-- times -->` markers; the report is
a deterministic function of the store, so the committed store regenerates it byte for byte."""

import argparse
from pathlib import Path

from .common import HERE, Results
from .figures import response_figures, section_figure_index
from .measured import section_md_methods, section_nd, section_times, section_weights
from .memory import section_bounds, section_memory
from .simulated import section_header, section_table5, section_table7
from .studies import section_ablation, section_uncertainty


def load_profile(name: str) -> dict:
    from omegaconf import OmegaConf

    return OmegaConf.to_container(OmegaConf.load(HERE / "conf" / "profile" / f"{name}.yaml"))  # pyright: ignore[reportReturnType]


def write_report(store, out, figures, cfg: dict | None = None) -> str:
    """REPORT.md from `store`; `cfg` = the hydra config of `experiments.reproduce` (profile, seed)."""
    cfg = cfg or {}
    profile = cfg.get("profile") or load_profile("full")
    R = Results(store, profile, int(cfg.get("seed", 0)))
    R.report_dir = Path(out).resolve().parent
    figures = Path(figures).resolve()
    L: list[str] = []
    section_header(R, L, Path(store).name)
    section_table5(R, L)
    section_bounds(R, L)
    section_table7(R, L, figures)
    section_md_methods(R, L)
    section_times(R, L)
    section_ablation(R, L)
    section_uncertainty(R, L)
    section_weights(R, L)
    section_nd(R, L)
    section_memory(R, L, figures)
    response_figures(R, L, figures)
    section_figure_index(L)
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
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--store", default=str(HERE / "store" / "full.jsonl"))
    ap.add_argument("--out", default=str(HERE / "REPORT.md"))
    ap.add_argument("--figures", default=str(HERE / "figures"))
    ap.add_argument("--profile", default="full", help="conf/profile/<name>.yaml the store was made with")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    if not Path(args.store).is_file():
        raise SystemExit(f"error: --store {args.store}: no such store (run python -m experiments.reproduce first)")
    import matplotlib

    matplotlib.use("Agg")  # a script, not the library: no display needed
    write_report(args.store, args.out, args.figures, {"profile": load_profile(args.profile), "seed": args.seed})
    print(f"wrote {args.out}")
