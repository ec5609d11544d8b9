"""Recorded (or simulated) drive responses: time, armature voltage, current and speed.

CSV layout: header `t,u_a,i_a,omega` (s, V, A, rad/s), one row per sample. Metadata
(name, current limit, true parameters, how the file was made) lives in an optional JSON
sidecar with the same stem (`SD1.csv` -> `SD1.json`)."""

import dataclasses
import json
from pathlib import Path

import numpy as np

COLUMNS = ("t", "u_a", "i_a", "omega")


@dataclasses.dataclass(frozen=True)
class Recording:
    """A validated response. `i_a_limit` is the supply's current limit (A) or None."""

    t: np.ndarray
    u_a: np.ndarray
    i_a: np.ndarray
    omega: np.ndarray
    i_a_limit: float | None = None
    name: str = ""
    metadata: dict = dataclasses.field(default_factory=dict, compare=False)

    def __post_init__(self):
        arrays = {}
        for col in COLUMNS:
            try:
                a = np.asarray(getattr(self, col), dtype=np.float64)
            except (TypeError, ValueError) as e:
                raise ValueError(f"{self._where()}column {col!r} is not numeric: {e}") from None
            if a.ndim != 1:
                raise ValueError(f"{self._where()}column {col!r} must be one-dimensional, got shape {a.shape}")
            arrays[col] = a
        lengths = {c: a.shape[0] for c, a in arrays.items()}
        if len(set(lengths.values())) != 1:
            raise ValueError(f"{self._where()}columns have different lengths: {lengths}")
        n = lengths["t"]
        if n < 3:
            raise ValueError(f"{self._where()}need at least 3 samples, got {n}")
        for col, a in arrays.items():
            bad = np.flatnonzero(~np.isfinite(a))
            if bad.size:
                raise ValueError(f"{self._where()}column {col!r} has NaN/inf at row {int(bad[0])} ({bad.size} in all)")
        dt = np.diff(arrays["t"])
        if np.any(dt <= 0):
            k = int(np.flatnonzero(dt <= 0)[0])
            raise ValueError(
                f"{self._where()}time must be strictly increasing: t[{k + 1}] = {arrays['t'][k + 1]!r} <= t[{k}] = {arrays['t'][k]!r}"
            )
        for col in ("i_a", "omega"):
            if not np.any(arrays[col] != 0):
                raise ValueError(f"{self._where()}column {col!r} is all zero (the objective divides by its maximum)")
        limit = self.i_a_limit
        if limit is not None:
            limit = float(limit)
            if not np.isfinite(limit) or limit <= 0:
                raise ValueError(f"{self._where()}current limit must be a positive number, got {self.i_a_limit!r}")
        for col, a in arrays.items():
            a.setflags(write=False)
            object.__setattr__(self, col, a)
        object.__setattr__(self, "i_a_limit", limit)

    def _where(self) -> str:
        return f"recording {self.name!r}: " if self.name else ""

    def __len__(self) -> int:
        return self.t.shape[0]

    def replace(self, **changes) -> "Recording":
        return dataclasses.replace(self, **changes)


def load_csv(path: str | Path, name: str | None = None) -> Recording:
    """Read `t,u_a,i_a,omega` from `path` (and its JSON sidecar, if present)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"no such file: {path}")
    lines = path.read_text().splitlines()
    if not lines:
        raise ValueError(f"{path}: file is empty")
    header = [h.strip() for h in lines[0].split(",")]
    if tuple(header) != COLUMNS:
        raise ValueError(f"{path}: header must be {','.join(COLUMNS)}, got {lines[0]!r}")
    rows = []
    for lineno, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        fields = line.split(",")
        if len(fields) != len(COLUMNS):
            raise ValueError(f"{path}:{lineno}: expected {len(COLUMNS)} values, got {len(fields)} (ragged row)")
        try:
            rows.append([float(f) for f in fields])
        except ValueError:
            raise ValueError(f"{path}:{lineno}: non-numeric value in {line!r}") from None
    if not rows:
        raise ValueError(f"{path}: no data rows")
    data = np.asarray(rows, dtype=np.float64)
    meta = {}
    sidecar = path.with_suffix(".json")
    if sidecar.is_file():
        try:
            meta = json.loads(sidecar.read_text())
        except json.JSONDecodeError as e:
            raise ValueError(f"{sidecar}: invalid JSON: {e}") from None
    return Recording(
        t=data[:, 0],
        u_a=data[:, 1],
        i_a=data[:, 2],
        omega=data[:, 3],
        i_a_limit=meta.get("i_a_limit"),
        name=name or meta.get("name") or path.stem,
        metadata=meta,
    )


def save_csv(recording: Recording, path: str | Path, metadata: dict | None = None) -> None:
    """Write the CSV with full float64 precision (`repr`), and a JSON sidecar holding the
    name, the current limit and `metadata` (merged over `recording.metadata`)."""
    path = Path(path)
    cols = [getattr(recording, c) for c in COLUMNS]
    lines = [",".join(COLUMNS)]
    lines += [",".join(repr(float(c[k])) for c in cols) for k in range(len(recording))]
    path.write_text("\n".join(lines) + "\n")
    meta = {**recording.metadata, **(metadata or {}), "name": recording.name, "i_a_limit": recording.i_a_limit}
    path.with_suffix(".json").write_text(json.dumps(meta, indent=2, sort_keys=True) + "\n")


def trim_switch_on(recording: Recording, threshold: float = 0.02, rezero_time: bool = False) -> Recording:
    """Keep only the part after the armature is switched on (paper Fig. 6).

    Switch-on shows as the first sample whose |u_a| exceeds `threshold * max|u_a|`; it and the
    samples after it are kept, and the simulation starts from it (its measured current and speed
    are the initial state). With `rezero_time`, time restarts at 0 there."""
    u = np.abs(recording.u_a)
    if not u.max() > 0:
        raise ValueError(f"{recording._where()}voltage is zero everywhere: no switch-on to find")
    start = int(np.flatnonzero(u > threshold * u.max())[0])
    t = recording.t[start:]
    return recording.replace(
        t=t - t[0] if rezero_time else t,
        u_a=recording.u_a[start:],
        i_a=recording.i_a[start:],
        omega=recording.omega[start:],
    )
