"""One identification cell (data set x method x integrator x ND x weights x memory x runs x
seed) into the results store; with hydra multirun, any sweep of them:

    .venv/bin/python experiments/cell.py data=MD1 integrator=euler nd=5
    .venv/bin/python experiments/cell.py -m data=MD1,MD2,MD3 memory=null,stma runs=10

A cell already in the store is not run again; `report.py --store experiments/results/cells.jsonl`
tabulates whatever the store holds."""

import sys
from pathlib import Path

import hydra
import numpy as np
from omegaconf import DictConfig

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cells import Cell, Store, run_cell

import dcjax

dcjax.use_host_devices()  # one XLA CPU device per core, before any JAX computation
dcjax.use_compilation_cache()  # executables persist across runs (DCJAX_NO_CACHE=1: off)


@hydra.main(version_base="1.3", config_path="conf", config_name="cell")
def main(cfg: DictConfig) -> None:
    cell = Cell(
        str(cfg.data),
        str(cfg.method),
        str(cfg.integrator),
        int(cfg.nd),
        float(cfg.w1),
        float(cfg.w2),
        None if cfg.memory is None else str(cfg.memory),
        int(cfg.runs),
        int(cfg.budget),
        None if cfg.generations is None else int(cfg.generations),
        int(cfg.seed),
    )
    store = Store(cfg.store)
    entry = store.cells().get(cell.key)
    if entry is None:
        store.append(run_cell(cell))
        entry = store.cells()[cell.key]
    of = np.array([r["of"] for r in entry["runs"]])
    best = entry["runs"][int(np.argmin(of))]["params"]
    print(
        f"{cell.key}\n  OF best {of.min():.4e} mean {of.mean():.4e} worst {of.max():.4e}; "
        f"run {entry['meta']['run_s']:.2f} s\n  best: " + ", ".join(f"{k}={v:.5g}" for k, v in best.items())
    )


if __name__ == "__main__":
    main()
