"""Loading a lab's own recordings: delimited text (CSV/TSV/TXT with preambles), `.npz` and
MATLAB `.mat` files, columns mapped to a model's channels, units converted to SI, and the
preprocessing (time window, decimation, switch-on trimming) recorded with the data's origin."""

import dataclasses
import hashlib
import math
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..models import Model, get_model
from .recording import Recording, read_sidecar, trim_switch_on
from .units import select_channels

DELIMITERS = {",": ",", ";": ";", "tab": "\t", "\\t": "\t", "\t": "\t", "space": None, "whitespace": None, " ": None}
TEXT_SUFFIXES = (".csv", ".tsv", ".txt", ".dat", ".asc")


MISSING = ("", "nan", "na", "n/a", "null", "none")  # a field read as NaN (as pandas' read_csv does)


def _split(line: str, delim: str | None) -> list[str]:
    return [f.strip() for f in (line.split() if delim is None else line.split(delim))]


def _row_values(fields: list[str], decimal: str) -> list[float] | None:
    """The row's numbers (a `MISSING` field as NaN), or None where it is not a data row: a field
    neither a number nor missing, or every field missing. One pass that both tests and converts
    (a file of 700 rows x 3: 2.2 -> 1.4 ms, against testing every row and converting it again)."""
    out = []
    for f in fields:
        try:
            out.append(float(f if decimal == "." else f.replace(decimal, ".")))
        except ValueError:
            if f.lower() not in MISSING:
                return None
            out.append(math.nan)
    if all(v != v for v in out) and all(f.lower() in MISSING for f in fields):
        return None  # a row of missing fields only is not data
    return out


def _units_row(fields: list[str]) -> bool:
    """A line of units under the header (`s, V, A, rad/s`, `[ms]`, `(rpm)`): every field a known unit or empty."""
    from .units import UNITS

    known = {u.lower() for table in UNITS.values() for u in table} | {"", "-"}
    return any(fields) and all(f.strip("[]()").strip().lower() in known for f in fields)


def _detect_delimiter(lines: list[str], decimal: str) -> str | None:
    """The first of `;`, tab, `,`, whitespace that splits the last line into >= 2 numeric fields
    (and the lines before it, as far as they are data, into as many)."""
    for d in (";", "\t", ",", None):
        if d == "," and decimal == ",":
            continue
        last = _split(lines[-1], d)
        if len(last) >= 2 and _row_values(last, decimal) is not None:
            return d
    raise ValueError("cannot detect the delimiter (tried ';', tab, ',', whitespace); give delimiter=/--delimiter")


def read_table(path: Path, delimiter: str | None = None, decimal: str = ".") -> dict[str, np.ndarray]:
    """Column name -> values of a delimited text file. `#` lines and a preamble are skipped: the
    data are the trailing block of numeric rows, the header the line just before it (or before a
    line of units under it; columns are named by 0-based index where there is none). A delimiter
    ending every line is dropped; an empty field or `nan`, `NA`, `null` is NaN (see `drop_nan`)."""
    if decimal not in (".", ","):
        raise ValueError(f"decimal must be '.' or ',', got {decimal!r}")
    text = path.read_text(errors="replace")
    lines = [_without_trailing_delimiter(x) for x in text.splitlines() if x.strip() and not x.lstrip().startswith("#")]
    if not lines:
        raise ValueError(f"{path}: no data rows")
    if delimiter is None:
        delim = _detect_delimiter(lines, decimal)
    elif delimiter in DELIMITERS:
        delim = DELIMITERS[delimiter]
    else:
        raise ValueError(f"delimiter must be one of ',', ';', 'tab', 'whitespace', got {delimiter!r}")
    if delim == "," and decimal == ",":
        raise ValueError("delimiter and decimal separator cannot both be ','")
    rows = [_split(x, delim) for x in lines]
    width = len(rows[-1])
    start, values = len(rows), []  # the trailing block of numeric rows, read from the end
    while start > 0 and len(rows[start - 1]) == width and (row := _row_values(rows[start - 1], decimal)) is not None:
        values.append(row)
        start -= 1
    if start == len(rows) or width < 2:
        raise ValueError(f"{path}: no numeric data rows with delimiter {delim or 'whitespace'!r}; check --delimiter/--decimal")
    if start > 1 and len(rows[start - 1]) == width == len(rows[start - 2]) and _units_row(rows[start - 1]):
        start -= 1  # a units line under the header (not read: give the units as units=/--units)
    header = rows[start - 1] if start > 0 and len(rows[start - 1]) == width else [str(k) for k in range(width)]
    header = [h.strip().strip('"').strip("'") for h in header]
    if len(set(header)) != len(header):
        raise ValueError(f"{path}: repeated column names in the header {header}")
    data = np.array(values[::-1], dtype=np.float64)
    return {h: data[:, k] for k, h in enumerate(header)}


def _without_trailing_delimiter(line: str) -> str:
    """`1,2,3;` -> `1,2,3` (a logger that ends every line with a delimiter)."""
    line = line.rstrip()
    return line[:-1].rstrip() if line.endswith((";", ",")) else line


def read_npz(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as z:
        return {k: np.asarray(z[k]).ravel() for k in z.files if np.asarray(z[k]).size > 1}


def read_mat(path: Path) -> dict[str, np.ndarray]:
    try:
        from scipy.io import loadmat
    except ImportError:
        raise ValueError("reading .mat files needs scipy (pip install scipy)") from None
    try:
        m = loadmat(path)
    except Exception as e:  # scipy raises several types for a bad file
        raise ValueError(f"{path}: not a readable MATLAB file ({e})") from None
    out = {}
    for k, v in m.items():
        if k.startswith("__"):
            continue
        a = np.asarray(v)
        if a.dtype.kind in "fiu" and a.size > 1:
            if a.ndim == 2 and min(a.shape) > 1:  # a matrix: one column each
                for j in range(a.shape[1]):
                    out[f"{k}[{j}]"] = a[:, j].astype(float)
            else:
                out[k] = a.ravel().astype(float)
    return out


@dataclasses.dataclass(frozen=True)
class Reading:
    """How a file is read (not what is kept of it): `columns` channel -> column name (or 0-based
    index), `units` channel -> unit (converted to SI), `scale` channel -> factor (after the
    units), `dt` (s) or `rate` (Hz) for a file without a time column, the `delimiter` and
    `decimal` separator of a text file, `constants` (inputs constant in the recording) and
    `drop_nan` (drop the rows with a NaN/inf in a channel read, with a one-line count).
    A fit records it with each file (result.json's `load`), so validate, simulate and design read
    a file in the fit's layout as the fit did (`Reading.from_record`)."""

    columns: Mapping[str, str] | None = None
    units: Mapping[str, str] | None = None
    scale: Mapping[str, float] | None = None
    dt: float | None = None
    rate: float | None = None
    delimiter: str | None = None
    decimal: str = "."
    constants: Mapping[str, float] | None = None
    drop_nan: bool = False

    @property
    def given(self) -> bool:
        """Anything but the defaults (a file in dcjax's own layout, SI units)."""
        return self != Reading()

    def to_dict(self) -> dict:
        """The non-default fields (result.json's `load` record)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        return {
            k: (dict(v) if isinstance(v, Mapping) else v)
            for k, v in out.items()
            if v not in (None, {}) and v is not False and not (k == "decimal" and v == ".")
        }

    @classmethod
    def from_record(cls, record: Mapping | None) -> "Reading":
        """The reading a result's `load` record holds (what is kept, window/every/trim, aside)."""
        names = {f.name for f in dataclasses.fields(cls)}
        return cls(**{k: v for k, v in (record or {}).items() if k in names and v is not None})


def _finite_rows(chans: dict[str, np.ndarray], where: str) -> dict[str, np.ndarray]:
    """The rows where every channel is finite; a one-line warning of how many were dropped."""
    keep = np.logical_and.reduce([np.isfinite(v) for v in chans.values()])
    if keep.all():
        return chans
    bad = [c for c, v in chans.items() if not np.all(np.isfinite(v))]
    warnings.warn(f"{where}: dropped {int((~keep).sum())} of {keep.size} rows with NaN/inf (in {', '.join(bad)})", stacklevel=3)
    return {c: v[keep] for c, v in chans.items()}


def sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _window(text_or_pair) -> tuple[float, float] | None:
    if text_or_pair is None:
        return None
    if isinstance(text_or_pair, str):
        parts = text_or_pair.split(":")
        if len(parts) != 2:
            raise ValueError(f"window must be T0:T1 (seconds), got {text_or_pair!r}")
        try:
            return (float(parts[0]) if parts[0] else -np.inf, float(parts[1]) if parts[1] else np.inf)
        except ValueError:
            raise ValueError(f"window must be T0:T1 (seconds), got {text_or_pair!r}") from None
    a, b = text_or_pair
    return float(a), float(b)


def preprocess(rec: Recording, window=None, every: int | None = None, trim: bool | float = False, model: Model | None = None) -> Recording:
    """Keep t in `window` = (T0, T1) (s), then every `every`-th sample, then trim before the
    switch-on (`trim=True` or a threshold fraction of max|u|, `dcjax.trim_switch_on`) of the
    model's first input (default: the paper's drive, `u_a`)."""
    w = _window(window)
    if w is not None:
        keep = (rec.t >= w[0]) & (rec.t <= w[1])
        if keep.sum() < 3:
            raise ValueError(f"window {w[0]}:{w[1]} keeps {int(keep.sum())} samples (need at least 3; t runs {rec.t[0]}..{rec.t[-1]} s)")
        rec = rec.select(keep)
    if every is not None:
        if not isinstance(every, (int, np.integer)) or isinstance(every, bool) or every < 1:
            raise ValueError(f"every must be a positive integer, got {every!r}")
        rec = rec.select(slice(None, None, int(every)))
    if trim:
        m = get_model(model)
        if not m.inputs:
            raise ValueError(f"trim: model {m.name} has no input to find the switch-on in")
        rec = trim_switch_on(rec, threshold=0.02 if trim is True else float(trim), channel=m.inputs[0])
    return rec


def load_recording(
    path: str | Path,
    columns: dict | None = None,
    units: dict | None = None,
    delimiter: str | None = None,
    decimal: str = ".",
    model: Model | str | None = None,
    name: str | None = None,
    limit: float | None = None,
    window=None,
    every: int | None = None,
    trim: bool | float = False,
    scale: dict | None = None,
    dt: float | None = None,
    rate: float | None = None,
    constants: dict | None = None,
    drop_nan: bool = False,
    reading: Reading | None = None,
) -> Recording:
    """A recording from a file, with the model's channels (default: the paper's `t, u_a, i_a,
    omega`) in SI units.

    - Text (`.csv .tsv .txt .dat`): the delimiter (`,` `;` tab, whitespace) is detected unless
      given; `#` lines and a preamble before the header are skipped; extra columns are ignored;
      `decimal=","` reads `1,5` as 1.5. Also `.npz` (arrays by name) and MATLAB `.mat`.
    - `columns`: channel -> column name (or 0-based index), e.g. `{"t": "time_ms", "i_a": "I"}`;
      a channel not mapped is looked up by its own name.
    - `units`: channel -> unit (`t`: s, ms, us; voltage: V, mV, kV; current: A, mA; speed: rad/s,
      rpm, 1/min, rev/s, deg/s), converted to SI.
    - `scale`: channel -> factor applied after the unit conversion (a speed logged in m/s at the
      wheel behind a 9.68:1 gear on a 30 mm wheel: `{"omega": 9.68 / 0.03}`).
    - `dt` (s) or `rate` (Hz): for a file without a time column, t = k dt.
    - A JSON sidecar with the same stem supplies the name, the current limit (`i_a_limit`), the
      inputs constant in this recording (`"constants": {"kp": 100}`) and metadata; `limit` and
      `constants` override them. An input given as a constant
      is not read from the file; one that is not is read from its column.
    - `window` (T0, T1) in seconds after conversion, `every` (keep every K-th sample), `trim`
      (cut before switch-on) — recorded, with the file's path and sha256, in
      `metadata["source"]`, so a saved result can reload the same data.
    - `drop_nan`: drop the rows with a NaN/inf (an empty field, `nan`) in a channel read, with a
      one-line warning of how many (default: such a row is a one-line error).
    - `reading`: a `Reading` holding `columns`, `units`, `scale`, `dt`, `rate`, `delimiter`,
      `decimal`, `constants` and `drop_nan` in one object (instead of those keywords)."""
    if reading is not None:
        if (columns, units, scale, dt, rate, delimiter, decimal, constants, drop_nan) != (
            None,
            None,
            None,
            None,
            None,
            None,
            ".",
            None,
            False,
        ):
            raise ValueError("load_recording: give the reading options either as reading=Reading(...) or as keywords, not both")
        as_dict = lambda m: None if m is None else dict(m)
        columns, units, scale, dt, rate = as_dict(reading.columns), as_dict(reading.units), as_dict(reading.scale), reading.dt, reading.rate
        delimiter, decimal, constants, drop_nan = reading.delimiter, reading.decimal, as_dict(reading.constants), reading.drop_nan
    m = get_model(model)
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"no such file: {path}")
    suffix = path.suffix.lower()
    if suffix == ".npz":
        table = read_npz(path)
    elif suffix == ".mat":
        table = read_mat(path)
    elif suffix in TEXT_SUFFIXES or suffix == "":
        table = read_table(path, delimiter, decimal)
    else:
        raise ValueError(f"{path}: unknown file type {suffix!r}; accepted: {', '.join(TEXT_SUFFIXES)}, .npz, .mat")
    meta = read_sidecar(path)
    consts = {**(meta.get("constants") or {}), **(constants or {})}
    needed = tuple(c for c in m.channels if c not in consts or c not in m.inputs)
    unmeasured = tuple(s for s in m.states if s not in needed)  # read where present: an initial state
    chans = select_channels(table, needed, columns, units, m.quantities, where=f"{path.name}: ", scale=scale, dt=dt, rate=rate,
                            inputs=tuple(m.inputs), optional=unmeasured)  # fmt: skip
    if drop_nan:
        chans = _finite_rows(chans, path.name)
    if consts:
        meta["constants"] = consts
    limit = limit if limit is not None else meta.get("limit", meta.get("i_a_limit"))
    t = chans.pop("t")
    rec = Recording(t=t, channels=chans, limit=limit, name=name or meta.get("name") or path.stem, metadata=meta)
    rec = preprocess(rec, window, every, trim, m)
    kept = {
        "window": None if window is None else list(_window(window) or ()),
        "every": every,
        "trim": trim,
        "limit": limit,
        "model": None if model is None else (m.name if isinstance(model, str) else None),
    }
    read = Reading(columns or None, units or None, scale or None, dt, rate, delimiter, decimal, constants or None, bool(drop_nan))
    load = read.to_dict() | {k: v for k, v in kept.items() if v not in (None, False)}
    return rec.replace(metadata={**meta, "source": {"path": str(path.resolve()), "sha256": sha256(path), "load": load, "name": rec.name}})
