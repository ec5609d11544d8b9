"""One cell of an experiment grid, how it is run and how it is stored.

A cell is a data set (or an ablation `case` of an emulated one, or a joint `A+B+C`) x method x
integrator x ND x weights x memory x runs x budget x seed, with optional known parameters
(`fixed`), DE bound/initialization rules and an LM polish with uncertainty.

The store is append-only JSONL with one compact line per finished cell (runs as columns, no
histories), written in one `write` + `fsync`. A kill can only cut the last line short; the
reader ignores a torn line, so a restart redoes exactly the cells that were not finished. Run r
of a cell uses the key fold_in(PRNGKey(seed), r), so a redone cell gives the same numbers.
`event` lines record whole invocations of `experiments.reproduce` (wall time, cells computed)."""

import dataclasses
import functools
import json
import os
from pathlib import Path

import numpy as np

import dcjax
from dcjax import INTEGRATORS, MEMORIES, datasets, load_csv
from dcjax.io.datasets import DATA_DIR
from dcjax.io.emulate import LAB_EFFECTS, Effects, emulate, md_settings

# Paper Section 4.3 labels: integrator and ND.
VARIANTS = {"EM": ("euler", 1), "EM5": ("euler", 5), "EM10": ("euler", 10), "RK": ("rk4", 1), "RK5": ("rk4", 5), "RK10": ("rk4", 10)}

# Ablation cases of the emulated drive (`dcjax.io.emulate`): DriveSettings overrides of MD1–MD4
# ("lab" regenerates the data files). `sample_factor` k samples k times as often over the same span.
# The paper's protocol: each state starts at its first sample, noisy or not (the default fits a
# noisy one: `dcjax.Observation.with_defaults`).
FIRST_SAMPLES = dcjax.Observation(initial={"i_a": "measured", "omega": "measured"})
NOISE = dict(noise_u=0.3, noise_i=0.5, noise_w=0.1, encoder_ppr=1024, speed_window=0.01)
ABLATION_CASES: dict[str, dict] = {
    "lab": dict(effects=LAB_EFFECTS),
    "clean": dict(effects=Effects()),
    "noise": dict(effects=Effects(**NOISE)),
    "armature": dict(effects=Effects(armature_reaction=LAB_EFFECTS.armature_reaction)),
    "static": dict(effects=Effects(static_friction=True)),
    "lab-noise-x3": dict(effects=dataclasses.replace(LAB_EFFECTS, **{k: 3 * NOISE[k] for k in ("noise_u", "noise_i", "noise_w")})),
    "clean-delay-1ms": dict(effects=Effects(), first_sample_delay=1e-3),
    "clean-sampling-11x": dict(effects=Effects(), sample_factor=11),
    "clean-slow-speed-loop": dict(effects=Effects(), kp_w=0.2, ki_w=0.2),
}


def emulated(name: str, case: str):
    """MD1–MD4's drive settings with an ablation case applied."""
    if case not in ABLATION_CASES:
        raise ValueError(f"unknown ablation case {case!r}; choose from {sorted(ABLATION_CASES)}")
    base = md_settings(name)
    kw = dict(ABLATION_CASES[case])
    k = kw.pop("sample_factor", 1)
    if k != 1:  # a grid holding the original sample instants, k - 1 more between, from switch-on
        dt = round(base.dt_sample / k, 9)
        before = int(base.delay // dt)
        kw.update(dt_sample=dt, first_sample_delay=round(base.delay - before * dt, 9), n_samples=(base.n_samples - 1) * k + 1 + before)
    return dataclasses.replace(base, **kw)


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
    case: str = ""  # an ABLATION_CASES name: the data set re-emulated with those effects
    fixed: str = ""  # known parameters, "Tlc=0,Ra=5"
    bounds_rule: str = ""  # DE/rand/1/exp bound handling ("" = the method's default)
    init_rule: str = ""  # DE/rand/1/exp initialization ("" = the method's default)
    polish: bool = False  # LM polish of every run and the uncertainty of the best

    @property
    def key(self) -> str:
        return "|".join(f"{k}={v}" for k, v in dataclasses.asdict(self).items())

    @property
    def variant(self) -> str:
        return variant_label(self.integrator, self.nd)

    @property
    def fixed_params(self) -> dict[str, float]:
        return {k: float(v) for k, v in (kv.split("=") for kv in self.fixed.split(",") if kv)}


@functools.lru_cache(maxsize=64)
def recording(name: str, case: str = ""):
    """SD1–SD4 (generated from Table 3), the emulated MD1–MD4 analogues in data/, or an MD set
    re-emulated with an ablation case's effects."""
    if case:
        return emulate(emulated(name, case))
    if name.upper() in datasets.SD_PARAMS:
        return datasets.load(name)
    return load_csv(DATA_DIR / f"{name}.csv")


def recordings(cell: Cell) -> list:
    return [recording(d, cell.case) for d in cell.data.split("+")]


def method_for(cell: Cell):
    """The cell's strategy object: its method with the cell's iteration limit (and bounds/init rules)."""
    from dcjax.strategies import DERand1Exp, make_strategy

    if not (cell.bounds_rule or cell.init_rule):
        strategy = make_strategy(cell.method)
        return strategy if cell.generations is None else dataclasses.replace(strategy, generations=cell.generations)
    if cell.method != "de-rand-1-exp":
        raise ValueError("bounds_rule/init_rule cells are DE/rand/1/exp cells")
    kw = {k: v for k, v in (("bounds_rule", cell.bounds_rule), ("init_rule", cell.init_rule)) if v}
    return DERand1Exp(generations=cell.generations, **kw)


def run_cell(cell: Cell) -> dict:
    """Run the cell (`dcjax.fit`); its store line."""
    recs = [dcjax.with_weights(r, {"i_a": cell.w1, "omega": cell.w2}) for r in recordings(cell)]
    params = dcjax.DC().parameters(recs[0].metadata.get("bounds", "table4"))
    for name, value in cell.fixed_params.items():
        params[name].set(value=value, vary=False)
    integrator = INTEGRATORS[cell.integrator](substeps=cell.nd)
    r = dcjax.fit(
        recs if len(recs) > 1 else recs[0],
        params=params,
        integrator=integrator,
        observation=FIRST_SAMPLES,
        search=dcjax.Search(
            method_for(cell),
            runs=cell.runs,
            budget=cell.budget,
            seed=cell.seed,
            memory=None if cell.memory is None else MEMORIES[cell.memory],
            polish=cell.polish,
        ),
    )
    line = {
        "key": cell.key,
        "cell": dataclasses.asdict(cell),
        "names": list(r.names),
        "of": [float(x) for x in r.run_of],
        "params": [[float(x) for x in row] for row in r.run_params],
        "fes": [int(x) for x in r.fes],
        "iterations": [int(x) for x in r.iterations],
        "dups": None if r.dups is None else [int(x) for x in r.dups],
        "run_s": r.timing["run_s"],
        "compile_s": r.timing["compile_s"],
        "devices": r.timing["devices"],
    }
    if cell.polish:
        u = r.uncertainty().uncertainties
        line["uncertainty"] = {n: {"value": float(u.params[n]), "se": float(u.se[n]), "verdict": u.verdict[n]} for n in r.names}
    return line


def cell_arrays(line: dict) -> dict:
    """A store line with NumPy arrays and the derived per-cell figures the report uses."""
    of = np.array(line["of"])
    params = np.array(line["params"])
    names = line["names"]
    return {
        "of": of,
        "params": params,
        "mean": dict(zip(names, params.mean(axis=0))),
        "best": dict(zip(names, params[int(np.argmin(of))])),
        "run_s": line["run_s"],
        "compile_s": line["compile_s"],
        "runs": len(of),
        "fes": np.array(line["fes"]),
        "iterations": np.array(line["iterations"]),
        "dups": None if line["dups"] is None else np.array(line["dups"]),
        "uncertainty": line.get("uncertainty"),
    }


class Store:
    """The JSONL store of finished cells and invocation events (see the module docstring)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)

    def _lines(self) -> list[dict]:
        if not self.path.is_file():
            return []
        out = []
        for text in self.path.read_text().splitlines():
            try:
                rec = json.loads(text)
            except json.JSONDecodeError:  # torn by a kill
                continue
            if isinstance(rec, dict):
                out.append(rec)
        return out

    def cells(self) -> dict[str, dict]:
        """{key: store line} of the finished cells (a later line for the same key wins)."""
        return {rec["key"]: rec for rec in self._lines() if "key" in rec and "of" in rec}

    def events(self) -> list[dict]:
        return [rec for rec in self._lines() if "event" in rec]

    def append(self, line: dict) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        data = (json.dumps(line, separators=(",", ":")) + "\n").encode()
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
