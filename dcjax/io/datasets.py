"""The simulated data sets SD1–SD4 (paper Section 3, Tables 2–3).

Table 2: u_a = 220 V step, t from 0 to 0.05 s with Δt = 1e-4 s, i_a(0) = 0, ω(0) = 0.
The file holds the initial instant t = 0 and the 500 computed instants t = 1e-4 … 0.05 s
(501 rows), integrated with RK4 (eq. 14–23) as in the paper. The objective sums over all
rows; the t = 0 residual is zero by construction (the initial state is the first sample)."""

import tempfile
from pathlib import Path

import numpy as np

from ..errors import ConfigError
from ..models.dc import NAMES as PARAM_NAMES
from .emulate import emulate, md_settings
from .numpy_simulator import simulate_numpy
from .recording import Recording, load_csv, save_csv

# Table 3. SD2: larger inertia; SD3: smaller La (faster electrical time constant); SD4: smaller J.
SD_PARAMS: dict[str, dict[str, float]] = {
    "SD1": dict(Ra=42.5, La=0.08, cm=0.4781, J=2e-5, Tla=0.01, Tlb=3.27e-5, Tlc=8.55e-8),
    "SD2": dict(Ra=42.5, La=0.08, cm=0.4781, J=6e-5, Tla=0.01, Tlb=3.27e-5, Tlc=8.55e-8),
    "SD3": dict(Ra=42.5, La=0.008, cm=0.4781, J=2e-5, Tla=0.01, Tlb=3.27e-5, Tlc=8.55e-8),
    "SD4": dict(Ra=42.5, La=0.08, cm=0.4781, J=2e-6, Tla=0.01, Tlb=3.27e-5, Tlc=8.55e-8),
}
SD_VOLTAGE = 220.0
SD_DT = 1e-4
SD_STEPS = 500

# Shipped inside the package (so an installed dcjax runs `dcjax fit MD1`); the repository's
# top-level data/ holds the same files beside their generators (tests check they are identical).
DATA_DIR = Path(__file__).resolve().parents[1] / "data"  # dcjax/data
MD_NAMES = ("MD1", "MD2", "MD3", "MD4")
EMBEDDED = tuple(SD_PARAMS) + MD_NAMES


def true_params(name: str) -> dict[str, float]:
    """Table 3 parameters of SD1–SD4."""
    key = name.upper()
    if key not in SD_PARAMS:
        raise ConfigError(f"unknown data set {name!r}; the simulated ones are {sorted(SD_PARAMS)}")
    return dict(SD_PARAMS[key])


def generate_sd(name: str) -> Recording:
    """Simulate SD1–SD4 from Tables 2–3 with the NumPy RK4 reference."""
    p = true_params(name)
    t = np.arange(SD_STEPS + 1) * SD_DT
    u = np.full_like(t, SD_VOLTAGE)
    x = np.array([p[n] for n in PARAM_NAMES])
    traj = simulate_numpy(x, t, u, i0=0.0, w0=0.0, integrator="rk4")
    meta = {
        "source": "Jesenik et al. 2020, Tables 2-3 (simulated data, RK4)",
        "true_params": p,
        "generator": "dcjax.io.datasets.generate_sd (NumPy RK4, eq. 14-23)",
        "u_a": SD_VOLTAGE,
        "dt": SD_DT,
        "computed_instants": SD_STEPS,
        "bounds": "table4",
    }
    return Recording(t=t, u_a=u, i_a=traj[:, 0], omega=traj[:, 1], name=name.upper(), metadata=meta)


def load(name: str) -> Recording:
    """An embedded data set by name (`"SD1"` … `"SD4"`, `"MD1"` … `"MD4"`): the file shipped in
    the package, or, where it is missing, regenerated (the two are byte-identical, see the tests)."""
    key = name.upper()
    if key not in EMBEDDED:
        raise ConfigError(f"unknown data set {name!r}; embedded ones are {', '.join(EMBEDDED)}")
    path = DATA_DIR / f"{key}.csv"
    if path.is_file():
        rec = load_csv(path)
    elif key in SD_PARAMS:
        rec = generate_sd(key)
    else:
        rec = emulate(md_settings(key))
    return rec.replace(metadata={**rec.metadata, "source": {"embedded": key, "name": key}})


def write_or_check(makers: dict, folders: Path | list[Path], check: bool) -> int:
    """Write `NAME.csv` (+ sidecar) for each `makers[NAME]()` recording into every folder of
    `folders` (the repository's data/ and the package's dcjax/data/), or with `check` compare a
    fresh generation with the files there byte for byte (1 if any differs)."""

    folders = [folders] if isinstance(folders, Path) else list(folders)

    def write_all(where: Path) -> None:
        for name, make in makers.items():
            save_csv(make(), where / f"{name}.csv")

    if not check:
        for folder in folders:
            write_all(folder)
            print(f"wrote {', '.join(makers)} to {folder}")
        return 0
    with tempfile.TemporaryDirectory() as tmp:
        write_all(Path(tmp))
        bad = [
            str(folder / f.name)
            for folder in folders
            for f in sorted(Path(tmp).iterdir())
            if not (folder / f.name).is_file() or f.read_bytes() != (folder / f.name).read_bytes()
        ]
    print("identical" if not bad else f"differ: {bad}")
    return 1 if bad else 0
