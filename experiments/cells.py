"""One cell of an experiment grid (data set x method x integrator x ND x weights x memory x runs x
seed), how it is run and how its runs are stored.

The store is append-only JSONL: a finished cell writes one line per run and then a line marking
the cell complete, all in one write followed by fsync. A kill can only cut the last write short;
the reader ignores a torn line and every run line of a cell without its completion line, so a
restart redoes exactly the cells that were not finished. Run r of a cell uses the key
fold_in(PRNGKey(seed), r), so a redone cell gives the same numbers."""

import dataclasses
import json
import os
from pathlib import Path

from dcjax import PARAM_NAMES, datasets, identify, load_csv
from dcjax.datasets import DATA_DIR

# Paper Section 4.3 labels: integrator and ND.
VARIANTS = {"EM": ("euler", 1), "EM5": ("euler", 5), "EM10": ("euler", 10), "RK": ("rk4", 1), "RK5": ("rk4", 5), "RK10": ("rk4", 10)}


def variant_label(integrator: str, nd: int) -> str:
    return ("EM" if integrator == "euler" else "RK") + ("" if nd == 1 else str(nd))


@dataclasses.dataclass(frozen=True)
class Cell:
    data: str
    method: str = "de-rand-1-exp"
    integrator: str = "rk4"
    nd: int = 1
    w1: float = 1.0
    w2: float = 1.0
    memory: str | None = None
    runs: int = 50
    budget: int = 140_000
    generations: int | None = None
    seed: int = 0

    @property
    def key(self) -> str:
        return "|".join(f"{k}={v}" for k, v in dataclasses.asdict(self).items())

    @property
    def variant(self) -> str:
        return variant_label(self.integrator, self.nd)


def recording(name: str):
    """SD1–SD4 (generated from Table 3) or the emulated MD1–MD4 analogues in data/."""
    if name.upper() in datasets.SD_PARAMS:
        return datasets.load(name)
    return load_csv(DATA_DIR / f"{name}.csv")


def bounds_for(rec) -> str:
    return rec.metadata.get("bounds", "table4")


def run_cell(cell: Cell) -> list[dict]:
    """Run the cell; the store lines (one per run, then the completion line)."""
    rec = recording(cell.data)
    r = identify(
        rec,
        method=cell.method,
        integrator=cell.integrator,
        nd=cell.nd,
        weights=(cell.w1, cell.w2),
        bounds=bounds_for(rec),
        runs=cell.runs,
        budget=cell.budget,
        seed=cell.seed,
        memory=cell.memory,
        generations=cell.generations,
    )
    base = dataclasses.asdict(cell) | {"key": cell.key}
    lines = []
    for k in range(cell.runs):
        lines.append(
            base
            | {
                "run": k,
                "of": float(r.run_of[k]),
                "params": dict(zip(PARAM_NAMES, map(float, r.run_params[k]))),
                "fes": int(r.fes[k]),
                "iterations": int(r.iterations[k]),
                "dups": None if r.dups is None else int(r.dups[k]),
                "chunks": None if r.memory_chunks is None else int(r.memory_chunks[k]),
            }
        )
    lines.append(
        {
            "key": cell.key,
            "complete": True,
            "runs": cell.runs,
            "run_s": r.timing["run_s"],
            "compile_s": r.timing["compile_s"],
            "devices": r.timing["devices"],
        }
    )
    return lines


class Store:
    """The JSONL store of finished cells (see the module docstring)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)

    def cells(self) -> dict[str, dict]:
        """{key: {"meta": completion line, "runs": [run lines in run order]}} of complete cells."""
        if not self.path.is_file():
            return {}
        pending: dict[str, dict[int, dict]] = {}
        done: dict[str, dict] = {}
        for line in self.path.read_text().splitlines():
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:  # torn by a kill
                continue
            if rec.get("complete"):
                runs = pending.pop(rec["key"], {})
                if len(runs) == rec["runs"]:
                    done[rec["key"]] = {"meta": rec, "runs": [runs[k] for k in sorted(runs)]}
            else:
                pending.setdefault(rec["key"], {})[rec["run"]] = rec
        return done

    def append(self, lines: list[dict]) -> None:
        data = "".join(json.dumps(x) + "\n" for x in lines).encode()
        if self.path.is_file() and self.path.stat().st_size:
            with open(self.path, "rb") as f:
                f.seek(-1, os.SEEK_END)
                if f.read(1) != b"\n":  # a write torn by a kill: start on a fresh line
                    data = b"\n" + data
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(fd, data)
            os.fsync(fd)
        finally:
            os.close(fd)
