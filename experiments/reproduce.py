"""Reproduce every quantitative result of the paper (Jesenik et al., Mathematics 2020, 8, 1269)
into the results store, then write experiments/REPORT.md from it beside the paper's numbers.

    python -m experiments.reproduce                          # full profile (50 runs)
    python -m experiments.reproduce profile=smoke            # a few runs, for CI
    python -m experiments.reproduce suites=[memory] profile.md=[MD1]

Suites (hydra config `conf/reproduce.yaml`, grids in `conf/profile/*.yaml`):
- `table5`: SD1–SD4 x 5 methods, RK (Tables 5–6);
- `md_methods`: MD1–MD4 x EM/RK x 5 methods (Tables 9–17, 19; Table 18 and Figs. 12–15 from its fits);
- `weights`: MD1–MD4 x w1 = 0.1 … 0.9, RK, DE/rand/1/exp (Tables 20–23);
- `nd`: MD1–MD4 x EM, EM5, EM10, RK, RK5, RK10, DE/rand/1/exp (Tables 24–28, Figs. 18–21);
- `memory`: the `nd` grid x STMA and indexed LTMA at the paper's 2000 iterations (Tables 30–33, Fig. 25);
- `bounds`: DE/rand/1/exp bound handling x initialization on SD1 (why Table 5's runs agree);
- `ablation`: MD sets re-emulated with each unmodelled effect, more noise, another first-sample
  delay, Tlc known (= 0) and RK10 (why RK's parameters differ from the paper's on the MD analogues);
- `uncertainty`: LM polish + standard errors of each RK fit and a joint MD1+MD2+MD3 fit.

Every finished cell goes to the store at once (`cells.Store`); a restart skips finished cells,
so an interrupted reproduction resumes where it stopped. The invocation's wall time is written
to the store as an `event` line, and the report is regenerated from the whole store
(`python -m experiments.report` does the same from the committed store, byte for byte)."""

import time

T_START = time.perf_counter()

import datetime  # noqa: E402
import math  # noqa: E402

import hydra  # noqa: E402
from omegaconf import DictConfig, OmegaConf  # noqa: E402
from tqdm import tqdm  # noqa: E402

import dcjax  # noqa: E402

from .cells import VARIANTS, Cell, Store, run_cell  # noqa: E402
from .report import write_report  # noqa: E402

SUITES = ("table5", "md_methods", "weights", "nd", "memory", "bounds", "ablation", "uncertainty")


def plan(cfg: DictConfig) -> list[Cell]:
    """The cells of the selected suites, in order, without repeats."""
    p = cfg.profile
    unknown = set(cfg.suites) - set(SUITES)
    if unknown:
        raise ValueError(f"unknown suites {sorted(unknown)}; choose from {SUITES}")
    common = {"budget": int(p.budget), "seed": int(cfg.seed)}
    runs = int(p.runs)
    cells: list[Cell] = []
    if "table5" in cfg.suites:
        cells += [Cell(d, m, "rk4", 1, runs=runs, **common) for d in p.sd for m in p.methods]
    if "md_methods" in cfg.suites:
        cells += [Cell(d, m, *VARIANTS[v], runs=runs, **common) for d in p.md for v in p.md_variants for m in p.methods]
    if "weights" in cfg.suites:
        cells += [
            Cell(d, "de-rand-1-exp", "rk4", 1, float(w), round(1.0 - float(w), 10), runs=runs, **common) for d in p.md for w in p.weights
        ]
    if "nd" in cfg.suites or "memory" in cfg.suites:
        cells += [Cell(d, "de-rand-1-exp", *VARIANTS[v], runs=runs, **common) for d in p.md for v in p.variants]
    if "memory" in cfg.suites:
        gens = int(p.memory_generations)
        # The memory-free reference at equal iterations; with the default budget the plain cell is it.
        ref_gens = None if gens == math.ceil((int(p.budget) - 70) / 70) else gens
        for d in p.md:
            for v in p.variants:
                for mem in p.memory:
                    cells.append(Cell(d, "de-rand-1-exp", *VARIANTS[v], memory=mem, runs=runs, generations=gens, **common))
                cells.append(Cell(d, "de-rand-1-exp", *VARIANTS[v], runs=runs, generations=ref_gens, **common))
    if "bounds" in cfg.suites:
        for rule in p.bounds_rules:
            for init in p.init_rules:
                br, ir = ("" if rule == "redraw" else rule), ("" if init == "uniform" else init)
                cells.append(Cell(p.bounds_data, "de-rand-1-exp", "rk4", 1, runs=runs, bounds_rule=br, init_rule=ir, **common))
    if "ablation" in cfg.suites:
        ar = int(p.ablation_runs)
        for d in p.ablation_md:
            for case in p.ablation_cases:
                cells.append(Cell(d, "de-rand-1-exp", "rk4", 1, runs=ar, case=case, **common))
            cells.append(Cell(d, "de-rand-1-exp", "rk4", 1, runs=ar, case="lab", fixed="Tlc=0", **common))
            cells.append(Cell(d, "de-rand-1-exp", "rk4", 10, runs=ar, case="clean", **common))
            cells.append(Cell(d, "de-rand-1-exp", "rk4", 10, runs=ar, case="lab", **common))
    if "uncertainty" in cfg.suites:
        ur = int(p.uncertainty_runs)
        cells += [Cell(d, "de-rand-1-exp", "rk4", 1, runs=ur, polish=True, **common) for d in p.md]
        joint = [d for d in p.md if d in ("MD1", "MD2", "MD3")]
        if len(joint) >= 2:
            cells.append(Cell("+".join(joint), "de-rand-1-exp", "rk4", 1, runs=ur, polish=True, **common))
    return list(dict.fromkeys(cells))


@hydra.main(version_base="1.3", config_path="conf", config_name="reproduce")
def main(cfg: DictConfig) -> None:
    dcjax.use_host_devices()  # one XLA CPU device per core, before any JAX computation
    dcjax.use_compiled_loops()
    dcjax.use_compilation_cache()  # executables persist across runs (DCJAX_NO_CACHE=1: off)
    started = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
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
    compile_s = 0.0
    with tqdm(total=total, initial=total - sum(c.runs for c in todo), unit="run", dynamic_ncols=True) as bar:
        for cell in todo:
            bar.set_description(f"{cell.data} {cell.method} {cell.variant} w1={cell.w1} {cell.memory or ''} {cell.case}".strip())
            time.sleep(float(cfg.pause_s))
            line = run_cell(cell)
            compile_s += line["compile_s"]
            store.append(line)
            bar.update(cell.runs)
    print(f"computed {len(todo)} cells in {time.perf_counter() - t0:.0f} s", flush=True)
    store.append(
        {
            "event": "reproduce",
            "started": started,
            "profile": str(cfg.profile.name),
            "suites": list(cfg.suites),
            "cells_planned": len(cells),
            "cells_computed": len(todo),
            "compile_s": round(compile_s, 1),
            "wall_s": round(time.perf_counter() - T_START, 1),
        }
    )
    if cfg.write_report:
        import matplotlib

        matplotlib.use("Agg")  # a script, not the library: figures go to files
        write_report(cfg.store, cfg.report, cfg.figures, OmegaConf.to_container(cfg, resolve=True))  # pyright: ignore[reportArgumentType]
        print(f"wrote {cfg.report} and figures in {cfg.figures}")


if __name__ == "__main__":
    main()
