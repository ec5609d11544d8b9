"""Reproduce every quantitative result of the paper (Jesenik et al., Mathematics 2020, 8, 1269)
and write experiments/REPORT.md beside the paper's numbers.

    .venv/bin/python experiments/reproduce.py                    # full profile (50 runs)
    .venv/bin/python experiments/reproduce.py profile=smoke      # a few runs, for CI
    .venv/bin/python experiments/reproduce.py suites=[memory] profile.md=[MD1]

Suites (hydra config `conf/reproduce.yaml`, grids in `conf/profile/*.yaml`):
- `table5`: SD1–SD4 x 5 methods, RK (Tables 5–6);
- `md_methods`: MD1–MD4 x EM/RK x 5 methods (Tables 9–17, 19; Table 18 and Fig. 12 from its fits);
- `weights`: MD1–MD4 x w1 = 0.1 … 0.9, RK, DE/rand/1/exp (Tables 20–23);
- `nd`: MD1–MD4 x EM, EM5, EM10, RK, RK5, RK10, DE/rand/1/exp (Tables 24–28);
- `memory`: the `nd` grid x STMA, LTMA-S1, LTMA-S2 at 2000 iterations (Tables 30–33, Fig. 25).

Every finished cell goes to the store at once (`cells.Store`); a restart skips finished cells,
so an interrupted reproduction (Ctrl-C or kill) resumes where it stopped. The report is then
regenerated from the whole store (`report.py`)."""

import math
import sys
import time
from pathlib import Path

import hydra
from omegaconf import DictConfig, OmegaConf
from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cells import VARIANTS, Cell, Store, run_cell
from report import write_report

import dcjax

dcjax.use_host_devices()  # one XLA CPU device per core, before any JAX computation
dcjax.use_compilation_cache()  # executables persist across runs (DCJAX_NO_CACHE=1: off)

SUITES = ("table5", "md_methods", "weights", "nd", "memory")


def plan(cfg: DictConfig) -> list[Cell]:
    """The cells of the selected suites, in order, without repeats."""
    p = cfg.profile
    unknown = set(cfg.suites) - set(SUITES)
    if unknown:
        raise ValueError(f"unknown suites {sorted(unknown)}; choose from {SUITES}")
    common = {"budget": int(p.budget), "seed": int(cfg.seed)}
    cells: list[Cell] = []
    if "table5" in cfg.suites:
        cells += [Cell(d, m, "rk4", 1, runs=p.runs, **common) for d in p.sd for m in p.methods]
    if "md_methods" in cfg.suites:
        cells += [Cell(d, m, *VARIANTS[v], runs=p.runs, **common) for d in p.md for v in p.md_variants for m in p.methods]
    if "weights" in cfg.suites:
        cells += [
            Cell(d, "de-rand-1-exp", "rk4", 1, float(w), round(1.0 - float(w), 10), runs=p.runs, **common) for d in p.md for w in p.weights
        ]
    if "nd" in cfg.suites or "memory" in cfg.suites:
        cells += [Cell(d, "de-rand-1-exp", *VARIANTS[v], runs=p.runs, **common) for d in p.md for v in p.variants]
    if "memory" in cfg.suites:
        gens = int(p.memory_generations)
        # The memory-free reference at equal iterations; with the default budget the plain cell is it.
        ref_gens = None if gens == math.ceil((int(p.budget) - 70) / 70) else gens
        for d in p.md:
            for v in p.variants:
                for mem in p.memory:
                    runs = int(p.runs) if mem == "stma" else int(p.ltma_runs)
                    cells.append(Cell(d, "de-rand-1-exp", *VARIANTS[v], memory=mem, runs=runs, generations=gens, **common))
                    cells.append(Cell(d, "de-rand-1-exp", *VARIANTS[v], runs=runs, generations=ref_gens, **common))
    return list(dict.fromkeys(cells))


@hydra.main(version_base="1.3", config_path="conf", config_name="reproduce")
def main(cfg: DictConfig) -> None:
    store = Store(cfg.store)
    cells = plan(cfg)
    done = store.cells()
    todo = [c for c in cells if c.key not in done]
    total = sum(c.runs for c in cells)
    print(
        f"{len(cells)} cells ({total} runs) in suites {list(cfg.suites)}, profile {cfg.profile.name}; "
        f"{len(cells) - len(todo)} already in {cfg.store}",
        flush=True,
    )
    t0 = time.perf_counter()
    with tqdm(total=total, initial=total - sum(c.runs for c in todo), unit="run", dynamic_ncols=True) as bar:
        for cell in todo:
            bar.set_description(f"{cell.data} {cell.method} {cell.variant} w1={cell.w1} {cell.memory or ''}".strip())
            store.append(run_cell(cell))
            bar.update(cell.runs)
    print(f"computed {len(todo)} cells in {time.perf_counter() - t0:.0f} s", flush=True)
    if cfg.write_report:
        write_report(cfg.store, cfg.report, cfg.figures, OmegaConf.to_container(cfg, resolve=True))
        print(f"wrote {cfg.report} and figures in {cfg.figures}")


if __name__ == "__main__":
    main()
