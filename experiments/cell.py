"""One identification cell (data set x method x integrator x ND x weights x memory x runs x
seed) into the results store; with hydra multirun, any sweep of them:

    python -m experiments.cell data=MD1 integrator=euler nd=5
    python -m experiments.cell -m data=MD1,MD2,MD3 memory=null,stma runs=10

A cell already in the store is not run again; `python -m experiments.report --store ...`
tabulates whatever the store holds."""

import hydra
from omegaconf import DictConfig

import dcjax

from .cells import Cell, Store, cell_arrays, run_cell


@hydra.main(version_base="1.3", config_path="conf", config_name="cell")
def main(cfg: DictConfig) -> None:
    dcjax.use_host_devices()  # one XLA CPU device per core, before any JAX computation
    dcjax.use_compiled_loops()
    dcjax.use_compilation_cache()  # executables persist across runs (DCJAX_NO_CACHE=1: off)
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
        case=str(cfg.case or ""),
        fixed=str(cfg.fixed or ""),
    )
    store = Store(cfg.store)
    line = store.cells().get(cell.key)
    if line is None:
        line = run_cell(cell)
        store.append(line)
    r = cell_arrays(line)
    print(
        f"{cell.key}\n  OF best {r['of'].min():.4e} mean {r['of'].mean():.4e} worst {r['of'].max():.4e}; "
        f"run {r['run_s']:.2f} s\n  best: " + ", ".join(f"{k}={v:.5g}" for k, v in r["best"].items())
    )


if __name__ == "__main__":
    main()
