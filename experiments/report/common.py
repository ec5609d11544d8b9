"""What every section of the report shares: the paper's numbers, number formatting, tables and the
results store with its lookups."""

import json
import os
from pathlib import Path

import numpy as np

from ..cells import VARIANTS, Cell, Store, cell_arrays

HERE = Path(__file__).resolve().parent.parent  # experiments/
PAPER = json.loads((HERE / "paper_tables.json").read_text())
METHOD_NAMES = {"ga": "GA", "de-rand-1-exp": "DE/rand/1/exp", "de-best-1-bin": "DE/best/1/bin", "tlbo": "TLBO", "abc": "ABC"}
MD_TABLES = {"MD1": (9, 10, 20, 24, 30), "MD2": (11, 12, 21, 25, 31), "MD3": (13, 14, 22, 26, 32), "MD4": (15, 16, 23, 27, 33)}
TABLE18_TIMES = {"MD1": [2, 4, 6, 8, 10], "MD2": [2, 4, 6, 8, 10], "MD3": [2, 4, 6, 7, 8], "MD4": [4, 6, 8, 10, 12]}
MEMORY_LABEL = {"stma": "STMA", "ltma-s1": "LTMA-S1", "ltma-s2": "LTMA-S2", "ltma-hash": "LTMA (index)"}


def _paper_rk(name: str) -> list[float]:
    """The paper's RK DE/rand/1/exp means of `name` on MD1–MD4 (Tables 10, 12, 14, 16 = Table 17)."""
    return [PAPER[f"table{t}"][name][PAPER[f"table{t}"]["columns"].index("de-rand-1-exp")] for t in (10, 12, 14, 16)]


def _spread(values) -> float:
    v = np.asarray(values, float)
    return float(np.max(np.abs(v - v.mean())) / abs(v.mean()))


# Every verdict's threshold, with the paper numbers it comes from.


def g(x: float | None, digits: int = 4) -> str:
    if x is None or (isinstance(x, float) and np.isnan(x)):
        return "–"
    if x == 0:
        return "0"
    a = abs(x)
    return f"{x:.{digits - 1}e}" if a < 1e-3 or a >= 1e4 else f"{x:.{digits}g}"


def table(header: list[str], rows: list[list[str]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return out + [""]


def rel(a, b):
    return abs(a - b) / abs(b) if b else abs(a)


def verdict(k: int, n: int) -> str:
    """all: reproduced; at least half: reproduced qualitatively; fewer: differs."""
    return "reproduced" if n and k == n else "reproduced qualitatively" if n and 2 * k >= n else "differs"


class Results:
    """Look-up of finished cells by their settings (defaults from the profile)."""

    def __init__(self, store: str | Path, profile: dict, seed: int):
        self.store = Store(store)
        self.cells = self.store.cells()
        self.p = profile
        self.seed = seed
        self.report_dir = Path(".")

    def link(self, path: Path) -> str:
        return os.path.relpath(path, self.report_dir).replace(os.sep, "/")

    def get(self, data, method="de-rand-1-exp", variant="RK", w=(1.0, 1.0), memory=None, runs=None, generations=None, **extra):
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
            **extra,
        )
        line = self.cells.get(c.key)
        return None if line is None else cell_arrays(line)


def _paper_em_rk(d: str):
    t_em, t_rk = MD_TABLES[d][:2]
    j = PAPER[f"table{t_em}"]["columns"].index("de-rand-1-exp")
    return PAPER[f"table{t_em}"], PAPER[f"table{t_rk}"], j


def _paper_rk_of() -> list[float]:
    return [PAPER[f"table{t}"]["OF_M"][PAPER[f"table{t}"]["columns"].index("de-rand-1-exp")] for t in (10, 12, 14, 16)]
