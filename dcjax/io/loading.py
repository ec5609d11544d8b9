"""Loading a lab's own recordings: delimited text (CSV/TSV/TXT with preambles), `.npz` and
MATLAB `.mat` files, columns mapped to a model's channels, units converted to SI, and the
preprocessing (time window, decimation, switch-on trimming) recorded with the data's origin."""

import dataclasses
import warnings
import zipfile
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from ..errors import ConfigError, DataError
from ..models import Model, get_model
from .files import file_sha256
from .recording import Recording, channels_to_read, check_constants, data_file, read_sidecar, trim_switch_on
from .table import Table, read_table
from .units import named_columns, select_channels, unconverted_units

TEXT_SUFFIXES = (".csv", ".tsv", ".txt", ".dat", ".asc")


def _columns_of(name: str, a: np.ndarray, out: dict[str, np.ndarray]) -> None:
    """A numeric (or boolean) array of more than one value as columns: a vector (or a 1 x N / N x 1 matrix)
    is one, a matrix one per column (`name[j]`)."""
    if a.dtype.kind in "biuf" and a.size > 1:  # a logged flag (bool) is 0/1
        if a.ndim == 2 and min(a.shape) > 1:
            for j in range(a.shape[1]):
                out[f"{name}[{j}]"] = a[:, j].astype(float)
        else:
            out[name] = a.ravel().astype(float)


def _some_columns(path: Path, out: dict[str, np.ndarray], found: dict[str, str]) -> dict[str, np.ndarray]:
    """`out`, or a one-line error naming what the file holds where no array is a column."""
    if not out:
        held = ", ".join(f"{k} ({v})" for k, v in found.items()) or "nothing"
        raise DataError(f"{path}: no numeric array of more than one value at its top level; it holds {held}")
    return out


def read_npz(path: Path) -> dict[str, np.ndarray]:
    """The numeric arrays of a `.npz` file as columns (`_columns_of`); never unpickles (an object
    array is a one-line error)."""
    out: dict[str, np.ndarray] = {}
    found: dict[str, str] = {}
    if not zipfile.is_zipfile(path):
        raise DataError(f"{path}: not a .npz archive (a zip of named .npy arrays, as numpy.savez writes)")
    try:
        with np.load(path, allow_pickle=False) as z:
            for k in z.files:
                a = np.asarray(z[k])
                found[k] = f"{a.dtype} {a.shape}"
                _columns_of(k, a, out)
    except Exception as e:  # a pickled object array, a damaged member: NumPy raises several types
        raise DataError(f"{path}: not a readable .npz file of numeric arrays ({e})") from None
    return _some_columns(path, out, found)


def read_mat(path: Path) -> dict[str, np.ndarray]:
    try:
        from scipy.io import loadmat  # lazy: scipy adds 0.1-0.6 s to importing dcjax
    except ImportError:
        raise DataError("reading .mat files needs scipy (pip install scipy)") from None
    try:
        m = loadmat(path)
    except Exception as e:  # scipy raises several types for a bad file
        raise DataError(f"{path}: not a readable MATLAB file ({e})") from None
    out: dict[str, np.ndarray] = {}
    found: dict[str, str] = {}
    for k, v in m.items():
        if not k.startswith("__"):
            a = np.asarray(v)
            found[k] = "a struct" if a.dtype.names else f"{a.dtype} {a.shape}"
            _columns_of(k, a, out)
    return _some_columns(path, out, found)


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
    decimal: str | None = None
    constants: Mapping[str, float] | None = None
    drop_nan: bool = False

    @property
    def given(self) -> bool:
        """Anything but the defaults (a file in dcjax's own layout, SI units)."""
        return self != Reading()

    def to_dict(self) -> dict:
        """The non-default fields (result.json's `load` record)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        return {k: (dict(v) if isinstance(v, Mapping) else v) for k, v in out.items() if v not in (None, {}) and v is not False}

    @classmethod
    def from_record(cls, record: Mapping | None) -> "Reading":
        """The reading a result's `load` record holds (what is kept, window/every/trim, aside),
        each field of its type (a one-line error naming the field where not)."""
        names = {f.name for f in dataclasses.fields(cls)}
        given = {k: v for k, v in (record or {}).items() if k in names and v is not None}
        for k, v in given.items():
            check, what = RECORD_FIELDS[k]
            if not check(v):
                raise ConfigError(f"load.{k} of a result's data must be {what}, got {v!r}"[:200])
        return cls(**given)


def _mapping(values) -> Callable:
    return lambda v: (
        isinstance(v, Mapping) and all(isinstance(k, str) and isinstance(x, values) and not isinstance(x, bool) for k, x in v.items())
    )


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


RECORD_FIELDS = {  # a `Reading` field of a result's "load" record: its check and what it must be
    "columns": (_mapping((str, int)), "an object of channel -> column"),
    "units": (_mapping(str), "an object of channel -> unit"),
    "scale": (_mapping((int, float)), "an object of channel -> factor"),
    "dt": (_number, "a number"),
    "rate": (_number, "a number"),
    "delimiter": (lambda v: isinstance(v, str), "a string"),
    "decimal": (lambda v: isinstance(v, str), "a string"),
    "constants": (_mapping((int, float)), "an object of input -> number"),
    "drop_nan": (lambda v: isinstance(v, bool), "true or false"),
}


def _finite_rows(chans: dict[str, np.ndarray], where: str) -> dict[str, np.ndarray]:
    """The rows where every channel is finite; a one-line warning of how many were dropped."""
    keep = np.logical_and.reduce([np.isfinite(v) for v in chans.values()])
    if keep.all():
        return chans
    bad = [c for c, v in chans.items() if not np.all(np.isfinite(v))]
    warnings.warn(f"{where}: dropped {int((~keep).sum())} of {keep.size} rows with NaN/inf (in {', '.join(bad)})", stacklevel=3)
    return {c: v[keep] for c, v in chans.items()}


def _window(text_or_pair) -> tuple[float, float] | None:
    if text_or_pair is None:
        return None
    if isinstance(text_or_pair, str):
        parts = text_or_pair.split(":")
        if len(parts) != 2:
            raise ConfigError(f"window must be T0:T1 (seconds), got {text_or_pair!r}")
        try:
            return (float(parts[0]) if parts[0] else -np.inf, float(parts[1]) if parts[1] else np.inf)
        except ValueError:
            raise ConfigError(f"window must be T0:T1 (seconds), got {text_or_pair!r}") from None
    a, b = text_or_pair
    return float(a), float(b)


ALIAS_SHARE = 0.01  # a channel with more of its power above the new Nyquist frequency is named by `preprocess`


def aliasing(rec: Recording, every: int) -> tuple[str, float, float] | None:
    """(channel, share, new Nyquist frequency) of the channel with the largest share of its power
    above the Nyquist frequency of every `every`-th sample, where that share exceeds `ALIAS_SHARE`;
    None where no channel's does (or `every` is 1). The power is the periodogram of the channel less
    the line through its end samples, Hann-windowed: a smooth transient's leakage stays below 1e-10."""
    if every <= 1 or len(rec) < 4 * every:
        return None
    n = len(rec)
    k = np.arange(n)
    window = np.hanning(n)
    worst = None
    for c, y in rec.channels.items():
        detrended = (y - (y[0] + (y[-1] - y[0]) * k / (n - 1))) * window
        power = np.abs(np.fft.rfft(detrended)) ** 2
        total = float(power[1:].sum())
        if not total > 0:
            continue
        share = float(power[n // (2 * every) + 1 :].sum()) / total
        if share > ALIAS_SHARE and (worst is None or share > worst[1]):
            worst = (c, share, 0.5 / (every * float(np.median(np.diff(rec.t)))))
    return worst


def preprocess(rec: Recording, window=None, every: int | None = None, trim: bool | float = False, model: Model | None = None) -> Recording:
    """Keep t in `window` = (T0, T1) (s), then every `every`-th sample, then trim before the
    switch-on (`trim=True` or a threshold fraction of max|u|, `dcjax.trim_switch_on`) of the
    model's first input (default: the paper's drive, `u_a`)."""
    w = _window(window)
    if w is not None:
        keep = (rec.t >= w[0]) & (rec.t <= w[1])
        if keep.sum() < 3:
            raise DataError(f"window {w[0]}:{w[1]} keeps {int(keep.sum())} samples (need at least 3; t runs {rec.t[0]}..{rec.t[-1]} s)")
        rec = rec.select(keep)
    if every is not None:
        if not isinstance(every, (int, np.integer)) or isinstance(every, bool) or every < 1:
            raise ConfigError(f"every must be a positive integer, got {every!r}")
        aliased = aliasing(rec, int(every))
        if aliased:
            c, share, nyquist = aliased
            warnings.warn(
                f"every={every} keeps 1 sample in {every}: {c} has {100 * share:.2g} % of its power above the new Nyquist "
                f"frequency {nyquist:.4g} Hz, which folds into the samples kept (no anti-alias filter is applied): "
                "low-pass filter first, or keep more samples",
                stacklevel=3,
            )
        rec = rec.select(slice(None, None, int(every)))
    if trim:
        m = get_model(model)
        if not m.inputs:
            raise ConfigError(f"trim: model {m.name} has no input to find the switch-on in")
        rec = trim_switch_on(rec, threshold=0.02 if trim is True else float(trim), channel=m.inputs[0])
    return rec


def load_recording(
    path: str | Path,
    columns: dict | None = None,
    units: dict | None = None,
    delimiter: str | None = None,
    decimal: str | None = None,
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
    measured: bool = True,
) -> Recording:
    """A recording from a file, with the model's channels (default: the paper's `t, u_a, i_a,
    omega`) in SI units.

    - Text (`.csv .tsv .txt .dat`): the delimiter (`,` `;` tab, whitespace) is detected unless
      given; `#` lines and a preamble before the header are skipped; extra columns are ignored;
      `decimal` (`"."` or `","`) is detected unless given: a comma where the rows are numbers only
      with it (`1,5;220`). Also `.npz` (arrays by name; never unpickled) and MATLAB
      `.mat`: a matrix is a column each (`name[0]`, `name[1]`, ...).
    - `columns`: channel -> column name (or 0-based index), e.g. `{"t": "time_ms", "i_a": "I"}`;
      a channel not mapped is looked up by its own name, or else by the one column named so (the
      time also `time`) but for case and a unit at its end that is the channel's SI unit or the
      one `units` gives (`OMEGA`, `Time (s)`, `omega (rad/s)`; `time_ms` with `units={"t": "ms"}`).
    - `units`: channel -> unit (`t`: s, ms, us; voltage: V, mV, kV; current: A, mA; speed: rad/s,
      rpm, 1/min, rev/s, deg/s; a linear axis: m, mm, um; m/s, mm/s; N, kN: `io.units.UNITS`),
      converted to SI.
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
    given = Reading(columns or None, units or None, scale or None, dt, rate, delimiter, decimal, constants or None, bool(drop_nan))
    if reading is not None and given.given:
        raise ConfigError("load_recording: give the reading options either as reading=Reading(...) or as keywords, not both")
    read = reading if reading is not None else given
    m = get_model(model)
    check_constants(m, read.constants)
    path = Path(path)
    table = _table_of(path, read)
    meta = _sidecar(m, path)
    consts = {**(meta.get("constants") or {}), **(read.constants or {})}
    needed, unmeasured = channels_to_read(m, consts, measured)  # unmeasured: read where present (an initial state)
    columns, units = dict(read.columns or {}), dict(read.units or {})
    if not measured:  # an output's mapped column the file lacks: not read
        columns = {c: v for c, v in columns.items() if c not in unmeasured or _has_column(table.columns, v)}
    timed = read.dt is not None or read.rate is not None
    wanted = [c for c in ("t", *needed, *unmeasured) if c not in columns and not (c == "t" and timed)]
    named, why = named_columns(list(table.columns), table.units, wanted, m.quantities, units)
    columns |= named
    chans = select_channels(
        table.columns,
        needed,
        columns,
        units,
        m.quantities,
        where=f"{path.name}: ",
        scale=dict(read.scale or {}),
        dt=read.dt,
        rate=read.rate,
        inputs=tuple(m.inputs),
        optional=unmeasured,
        why=why,
    )
    by = "units line" if table.units_line is not None else "header"
    stated = {h: u for h, u in table.units.items() if h not in named.values()}  # a column named by the channel: in its SI unit
    unconverted_units(list(table.columns), stated, by, chans, columns, units, m.quantities, path.name, timed=timed)
    chans = _finite_rows(chans, path.name) if read.drop_nan else _no_nan(chans, table, path.name)
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
    load = read.to_dict() | {k: v for k, v in kept.items() if v not in (None, False)}
    return rec.replace(metadata={**meta, "source": _source(path, load, rec.name)})


def _sidecar(model: Model, path: Path) -> dict:
    """The sidecar of `path` (`read_sidecar`), with a one-line warning where its "constants" name
    no input of `model`: they are not used (a sidecar may describe the rig for other models too,
    so not an error, unlike a constant given to the fit: `check_constants`)."""
    meta = read_sidecar(path)
    unused = [c for c in meta.get("constants") or {} if c not in model.inputs]
    if unused:
        warnings.warn(
            f"{path.with_suffix('.json').name}: constants {', '.join(unused)} name no input of model {model.name} "
            f"(its inputs: {', '.join(model.inputs) or 'none'}): not used",
            stacklevel=3,
        )
    return meta


def _has_column(table: dict, source) -> bool:
    """Whether `table` has the column `source` (a header, or a 0-based index)."""
    if isinstance(source, int) or (isinstance(source, str) and source.isdigit()):
        return 0 <= int(source) < len(table)
    return source in table


def _table_of(path: Path, read: Reading) -> Table:
    """The file's table by its kind: delimited text, `.npz` or MATLAB `.mat`."""
    path = data_file(path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        return Table(read_npz(path), {}, np.array([]))
    if suffix == ".mat":
        return Table(read_mat(path), {}, np.array([]))
    if suffix in TEXT_SUFFIXES or suffix == "":
        return read_table(path, read.delimiter, read.decimal)
    raise DataError(f"{path}: unknown file type {suffix!r}; accepted: {', '.join(TEXT_SUFFIXES)}, .npz, .mat")


def _source(path: Path, load: dict, name: str) -> dict:
    """What a result records of a file it fitted: its path, size and sha256 (and its sidecar's),
    how it was read (`load`) and the recording's name."""
    source = {"path": str(path.resolve()), "sha256": file_sha256(path), "bytes": path.stat().st_size, "load": load, "name": name}
    sidecar = path.with_suffix(".json")
    if sidecar.is_file() and sidecar != path:
        source["sidecar_sha256"] = file_sha256(sidecar)
    return source


READING_KEYS = tuple(f.name for f in dataclasses.fields(Reading))
LOAD_KEYS = (*READING_KEYS, "window", "every", "trim", "limit", "model")  # a result's "load" record


def _no_nan(chans: dict[str, np.ndarray], table: Table, where: str) -> dict[str, np.ndarray]:
    """A one-line `DataError` naming the file's line of the first row with a NaN/inf in a channel read."""
    bad = {c: np.flatnonzero(~np.isfinite(v)) for c, v in chans.items()}
    bad = {c: k for c, k in bad.items() if k.size}
    if not bad:
        return chans
    c, rows = min(bad.items(), key=lambda kv: kv[1][0])
    k = int(rows[0])
    at = f"line {int(table.lines[k])}" if table.lines.size else f"row {k}"
    raise DataError(
        "nan",
        f"{where}: {at}: {c} is {'NaN' if np.isnan(chans[c][k]) else 'inf'} (a missing or non-finite field; "
        f"{int(np.sum(~np.logical_and.reduce([np.isfinite(v) for v in chans.values()])))} rows in all; "
        "drop_nan=True drops such rows)",
    )
