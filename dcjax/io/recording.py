"""Recorded (or simulated) drive responses: time and named channels (SI units).

The paper's drive has the channels `u_a` (V), `i_a` (A) and `omega` (rad/s); a model names the
channels it needs (`Model.channels`). CSV layout: header `t,<channel>,...`, one row per sample.
Metadata (name, current limit, true parameters, how the file was made) lives in an optional
JSON sidecar with the same stem (`SD1.csv` -> `SD1.json`). Other layouts and units:
`dcjax.load_recording`."""

import json
from pathlib import Path

import numpy as np

from ..errors import ConfigError, DataError
from ..extras import optional_module
from ..html_table import html_table
from ..models import get_model
from .units import select_channels

COLUMNS = ("t", "u_a", "i_a", "omega")
DC_CHANNELS = COLUMNS[1:]


def _constants(given, where: str = "") -> dict[str, float]:
    """A name -> finite number mapping (the inputs constant in a recording), checked."""
    if not isinstance(given, dict):
        raise DataError(f"{where}constants must be a name -> number mapping, got {given!r}")
    out = {}
    for k, v in given.items():
        try:
            f = float("nan") if isinstance(v, (bool, np.bool_)) else float(v)
        except (TypeError, ValueError):
            f = float("nan")
        if not np.isfinite(f):
            raise DataError(f"{where}constant {k} must be a finite number, got {v!r}")
        out[str(k)] = f
    return out


class Recording:
    """A validated response: strictly increasing time `t` (s), equally long finite channels,
    the clamp `limit` of the model (`Model.clamp`: on its `limited_state`, or its own; for the DC models the supply's current
    limit in A) or None, a name and
    free-form metadata.

    Channels are named by keyword or in `channels`, whatever the model calls them:
    `Recording(t=..., u_a=..., i_a=..., omega=...)` (the paper's drive) or
    `Recording(t=..., channels={"u": ..., "x": ...})`; they are read as attributes (`rec.i_a`)
    or by `rec[name]`. `constants` (name -> number, kept in `metadata["constants"]`): inputs that
    are constant in this recording (a controller gain, a supply voltage, a mass), given instead of
    a column; `rec[name]` reads one as a constant array."""

    __slots__ = ("t", "channels", "limit", "name", "metadata")

    def __init__(self, t, *, channels=None, limit=None, name: str = "", metadata=None, constants=None, **named_channels):
        object.__setattr__(self, "name", str(name or ""))
        chans = dict(channels or {})
        for key, v in named_channels.items():
            if v is None:  # a channel not recorded
                continue
            if key in chans:
                raise DataError(f"{self._where()}channel {key!r} is given twice (by keyword and in channels)")
            if np.ndim(v) == 0:  # a misspelt option, not a channel
                raise DataError(
                    f"{self._where()}{key}={v!r}: a keyword of Recording is a channel (a 1-D array); the options are "
                    "channels=, limit=, name=, metadata= and constants="
                )
            chans[key] = v
        if not chans:
            raise DataError(f"{self._where()}a recording needs at least one channel besides t")
        arrays = {}
        for col, v in {"t": t, **chans}.items():
            if np.iscomplexobj(v):  # float64 would drop the imaginary part with a warning only
                raise DataError(f"{self._where()}column {col!r} is complex; a channel is real")
            try:
                a = np.array(v, dtype=np.float64)
            except (TypeError, ValueError) as e:
                raise DataError(f"{self._where()}column {col!r} is not numeric: {e}") from None
            if a.ndim != 1:
                raise DataError(f"{self._where()}column {col!r} must be one-dimensional, got shape {a.shape}")
            arrays[col] = a
        lengths = {c: a.shape[0] for c, a in arrays.items()}
        if len(set(lengths.values())) != 1:
            raise DataError(f"{self._where()}columns have different lengths: {lengths}")
        n = lengths["t"]
        if n < 3:
            raise DataError(f"{self._where()}need at least 3 samples, got {n}")
        for col, a in arrays.items():
            bad = np.flatnonzero(~np.isfinite(a))
            if bad.size:
                raise DataError(
                    "nan",
                    f"{self._where()}column {col!r} has NaN/inf at row {int(bad[0])} ({bad.size} in all; "
                    "load_recording(drop_nan=True) drops such rows)",
                )
        tt = arrays.pop("t")
        dt = np.diff(tt)
        if np.any(dt <= 0):
            k = int(np.flatnonzero(dt <= 0)[0])
            raise DataError(
                "time", f"{self._where()}time must be strictly increasing: t[{k + 1}] = {float(tt[k + 1])!r} <= t[{k}] = {float(tt[k])!r}"
            )
        given = limit
        if limit is not None:
            try:
                limit = float("nan") if isinstance(limit, (bool, np.bool_)) else float(limit)
            except (TypeError, ValueError):
                limit = float("nan")
            if not np.isfinite(limit) or limit <= 0:
                raise DataError(
                    f"{self._where()}limit must be a positive number (the clamp on the limited state, e.g. the supply's current limit), got {given!r}"
                )
        for a in (tt, *arrays.values()):
            a.setflags(write=False)
        object.__setattr__(self, "t", tt)
        object.__setattr__(self, "channels", arrays)
        object.__setattr__(self, "limit", limit)
        meta = dict(metadata or {})
        if constants is not None or "constants" in meta:
            meta["constants"] = _constants(constants if constants is not None else meta["constants"], self._where())
            clash = [c for c in meta["constants"] if c in arrays]
            if clash:
                raise DataError(f"{self._where()}{', '.join(clash)} given both as a column and as a constant; give it once")
        object.__setattr__(self, "metadata", meta)

    @property
    def constants(self) -> dict[str, float]:
        """Name -> value of the inputs that are constant in this recording."""
        return dict(self.metadata.get("constants") or {})

    def has(self, name: str) -> bool:
        """A channel or a constant of that name."""
        return name in self.channels or name in self.constants

    def __getattr__(self, key):
        try:
            return object.__getattribute__(self, "channels")[key]
        except (KeyError, AttributeError):
            raise AttributeError(f"recording {object.__getattribute__(self, 'name')!r} has no channel {key!r}") from None

    def __getitem__(self, key: str) -> np.ndarray:
        if key == "t":
            return self.t
        if key not in self.channels:
            if key in self.constants:
                return np.full(self.t.shape, self.constants[key])
            raise DataError(f"{self._where()}no channel {key!r}; it has {', '.join(self.channels)}")
        return self.channels[key]

    def __setattr__(self, key, value):
        raise AttributeError("Recording is immutable; use .replace(...)")

    def __eq__(self, other):
        if not isinstance(other, Recording):
            return NotImplemented
        return (
            self.name == other.name
            and self.limit == other.limit
            and np.array_equal(self.t, other.t)
            and self.channels.keys() == other.channels.keys()
            and all(np.array_equal(self.channels[k], other.channels[k]) for k in self.channels)
        )

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"Recording(name={self.name!r}, n={len(self)}, channels={list(self.channels)}, limit={self.limit})"

    def _repr_html_(self) -> str:
        """A notebook's view: per channel its first value, range and mean; time's span and step."""
        t = self.t
        step = f", step {float(np.median(np.diff(t))):.3g} s" if len(t) > 1 else ""
        caption = f"Recording {self.name!r}: {len(self)} samples, t {t[0]:g} .. {t[-1]:g} s{step}" + (
            f", limit {self.limit:g}" if self.limit is not None else ""
        )
        rows = [(c, f"{v[0]:.6g}", f"{v.min():.6g}", f"{v.max():.6g}", f"{v.mean():.6g}") for c, v in self.channels.items()]
        rows += [(c, f"{v:.6g}", "", "", "constant") for c, v in self.constants.items()]
        return html_table(caption, ("channel", "first", "min", "max", "mean"), rows)

    def _where(self) -> str:
        name = object.__getattribute__(self, "name")
        return f"recording {name!r}: " if name else ""

    def __len__(self) -> int:
        return self.t.shape[0]

    def replace(self, **changes) -> "Recording":
        """A copy with fields (`t`, `limit`, `name`, `metadata`, `channels`) or single channels
        (`i_a=...`) replaced."""
        chans = dict(changes.pop("channels", self.channels))
        for k in list(changes):
            if k not in ("t", "limit", "name", "metadata", "constants"):
                chans[k] = changes.pop(k)
        kw = {"t": self.t, "limit": self.limit, "name": self.name, "metadata": self.metadata, **changes}
        return Recording(channels=chans, **kw)

    @classmethod
    def from_dataframe(
        cls, df, columns=None, units=None, model=None, name: str = "", limit=None, scale=None, dt=None, rate=None, constants=None,
        i_limit=None, measured: bool = True,
    ) -> "Recording":  # fmt: skip
        """From a pandas DataFrame (or a dict of arrays): `columns` maps channels to column names,
        `units` converts to SI, `scale` multiplies channels, `dt`/`rate` stand in for a missing
        time column (see `dcjax.load_recording`). The time may be the index (numbers in s, or
        datetimes/timedeltas: seconds from the first); `df.attrs` may give `units`, `name`,
        `limit` and `constants` (as `to_dataframe` writes them; the arguments win). `measured=False`:
        the model's outputs are read where present (a table of the inputs to simulate)."""
        if i_limit is not None:
            from ..deprecation import warn_deprecated

            warn_deprecated("from_dataframe(i_limit=)", "limit=", since="0.2")
            limit = i_limit if limit is None else limit
        return recording_from_table(
            df, columns=columns, units=units, model=model, name=name, limit=limit, scale=scale, dt=dt, rate=rate, constants=constants,
            measured=measured,
        )  # fmt: skip

    def to_dataframe(self):
        """A pandas DataFrame indexed by `t` (s) with a column per channel; `attrs` hold the name,
        limit and constants (`from_dataframe` reads them back). Needs pandas (`dcjax[notebook]`)."""
        pd = optional_module("pandas", "Recording.to_dataframe")
        df = pd.DataFrame({c: np.asarray(v) for c, v in self.channels.items()}, index=pd.Index(np.asarray(self.t), name="t"))
        df.attrs.update({"name": self.name, "limit": self.limit, "constants": self.constants})
        return df

    def select(self, index) -> "Recording":
        """The samples at `index` (a slice or index array) of every channel."""
        return self.replace(t=self.t[index], channels={k: v[index] for k, v in self.channels.items()})


def data_file(path: str | Path) -> Path:
    """`path`, a file that exists, or a one-line `DataError` (a folder is named as one: its files are the data)."""
    path = Path(path)
    if path.is_dir():
        raise DataError(f"{path} is a folder: give its data files (e.g. {path / '*.csv'})")
    if not path.is_file():
        raise DataError(f"no such file: {path}")
    return path


def load_csv(path: str | Path, name: str | None = None) -> Recording:
    """Read a `t,<channels>` CSV in SI units (dcjax's own layout; `t,u_a,i_a,omega` for the
    paper's drive) and its JSON sidecar, if present. Other layouts: `dcjax.load_recording`."""
    path = data_file(path)
    try:
        lines = path.read_text(encoding="utf-8-sig").splitlines()
    except UnicodeDecodeError as e:
        raise DataError(f"{path}: not UTF-8 text (byte {e.start}); load_recording reads other encodings") from None
    if not lines:
        raise DataError(f"{path}: file is empty")
    header = [h.strip() for h in lines[0].split(",")]
    if header[0] != "t" or len(header) < 2 or len(set(header)) != len(header) or not all(header):
        raise DataError(f"{path}: header must be t,<channel>,... (e.g. {','.join(COLUMNS)}), got {lines[0]!r}")
    rows = []
    for lineno, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        fields = line.split(",")
        if len(fields) != len(header):
            raise DataError(f"{path}:{lineno}: expected {len(header)} values, got {len(fields)} (ragged row)")
        try:
            rows.append([float(f) for f in fields])
        except ValueError:
            raise DataError(f"{path}:{lineno}: non-numeric value in {line!r}") from None
    if not rows:
        raise DataError(f"{path}: no data rows")
    data = np.asarray(rows, dtype=np.float64)
    meta = read_sidecar(path)
    return Recording(
        t=data[:, 0],
        channels={h: data[:, k] for k, h in enumerate(header) if k},
        limit=meta.get("i_a_limit"),
        name=name or meta.get("name") or path.stem,
        metadata=meta,
    )


def read_sidecar(path: Path) -> dict:
    sidecar = Path(path).with_suffix(".json")
    if not sidecar.is_file():
        return {}
    try:
        meta = json.loads(sidecar.read_text(encoding="utf-8-sig"))  # JSON is UTF-8; a byte-order mark is dropped
    except UnicodeDecodeError as e:
        raise DataError(f"{sidecar}: not UTF-8 text (byte {e.start}); save it as UTF-8") from None
    except json.JSONDecodeError as e:
        raise DataError(f"{sidecar}: invalid JSON: {e}") from None
    if not isinstance(meta, dict):
        raise DataError(f"{sidecar}: must hold a JSON object")
    for key, (ok, what) in SIDECAR_FIELDS.items():
        if key in meta and not ok(meta[key]):
            shown = repr(meta[key]) if len(repr(meta[key])) <= 60 else repr(meta[key])[:57] + "..."
            raise DataError(f"{sidecar}: {key} must be {what}, got {shown}")
    return meta


def _number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and bool(np.isfinite(v))


def _named_numbers(v) -> bool:
    return isinstance(v, dict) and all(isinstance(k, str) and _number(x) for k, x in v.items())


# The sidecar fields dcjax reads, each with its type (any other field is metadata, kept as it is).
SIDECAR_FIELDS = {
    "name": (lambda v: isinstance(v, str) and v.strip() != "", "a non-empty string"),
    "i_a_limit": (lambda v: v is None or (_number(v) and v > 0), "a positive number (the current limit, A) or null"),
    "limit": (lambda v: v is None or (_number(v) and v > 0), "a positive number or null"),
    "constants": (_named_numbers, "an object of input name -> number"),
    "bounds": (lambda v: v is None or isinstance(v, str), "a preset name (a string) or null"),
    "true_params": (lambda v: v is None or _named_numbers(v), "an object of parameter name -> number or null"),
    "weights": (lambda v: v is None or _named_numbers(v), "an object of channel name -> number or null"),
    "joint_weight": (lambda v: v is None or (_number(v) and v >= 0), "a number >= 0 or null"),
}


def save_csv(recording: Recording, path: str | Path, metadata: dict | None = None) -> None:
    """Write the CSV with full float64 precision (`repr`), and a JSON sidecar holding the
    name, the current limit and `metadata` (merged over `recording.metadata`)."""
    path = Path(path)
    names = list(recording.channels)
    cols = [recording.t] + [recording.channels[c] for c in names]
    lines = [",".join(["t", *names])]
    lines += [",".join(repr(float(c[k])) for c in cols) for k in range(len(recording))]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    meta = {**recording.metadata, **(metadata or {}), "name": recording.name, "i_a_limit": recording.limit}
    path.with_suffix(".json").write_text(json.dumps(meta, indent=2, sort_keys=True) + "\n", encoding="utf-8")


def trim_switch_on(recording: Recording, threshold: float = 0.02, rezero_time: bool = False, channel: str = "u_a") -> Recording:
    """Keep only the part after the armature is switched on (paper Fig. 6).

    Switch-on shows as the first sample whose |u| (input `channel`, the paper's drive: `u_a`) exceeds
    `threshold * max|u|`; it and the samples after it are kept, and the simulation starts from it
    (its measured states are the initial state). With `rezero_time`, time restarts at 0 there."""
    if not recording.has(channel):
        raise DataError(
            f"{recording._where()}trim: no input {channel!r} to find the switch-on in (channel=; it has {', '.join(recording.channels)})"
        )
    u = np.abs(recording[channel])
    if not u.max() > 0:
        raise DataError(f"{recording._where()}input {channel} is zero everywhere: no switch-on to find")
    start = int(np.flatnonzero(u > threshold * u.max())[0])
    out = recording.select(slice(start, None))
    return out.replace(t=out.t - out.t[0]) if rezero_time else out


def _index_seconds(index) -> np.ndarray | None:
    """A table's index as times in s (numbers as they are; datetimes or timedeltas from the
    first), or None for a default 0..N-1 range index."""
    kind = type(index).__name__
    if kind == "RangeIndex" and index.name is None:
        return None
    values = np.asarray(index)
    if np.issubdtype(values.dtype, np.datetime64) or np.issubdtype(values.dtype, np.timedelta64):
        return (values - values[0]) / np.timedelta64(1, "s")
    if np.issubdtype(values.dtype, np.number):
        return values.astype(np.float64)
    return None


def check_constants(model, constants) -> None:
    """A one-line error where `constants` (the ones given: `constants=`, `--const`) names what is
    no input of `model`: a constant stands in for an input's column, never for a parameter or a
    state (it would be ignored)."""
    bad = [c for c in constants or {} if c not in model.inputs]
    if bad:
        hint = f"; a parameter is held with params[{bad[0]!r}].set(value=V, vary=False)" if bad[0] in model.names else ""
        raise ConfigError(
            f"constants= names {', '.join(bad)}: not an input of model {model.name} (its inputs: {', '.join(model.inputs) or 'none'}); "
            f"a constant stands in for an input's column{hint}"
        )


def channels_to_read(model, constants, measured: bool = True) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(needed, optional): the model's channels a table must hold (an input given as a constant
    aside; `measured=False`: the inputs alone) and those read where present (the states, for
    their initial values, and the outputs not needed)."""
    needed = tuple(c for c in model.channels if (c not in constants or c not in model.inputs) and (measured or c in model.inputs))
    return needed, tuple(c for c in (*model.states, *model.outputs) if c not in needed)


def recording_from_table(
    table, columns=None, units=None, model=None, name: str = "", limit=None, scale=None, dt=None, rate=None, constants=None,
    measured: bool = True,
) -> Recording:  # fmt: skip
    """A recording from any column table (a pandas DataFrame, a dict of arrays, a structured array);
    `columns`, `units`, `scale`, `dt`/`rate` as in `load_recording`; a DataFrame's index may be
    its time, its `attrs` give `units`, `name`, `limit` and `constants` where not given."""
    m = get_model(model)
    check_constants(m, constants)
    attrs = dict(getattr(table, "attrs", None) or {})
    if hasattr(table, "columns") and hasattr(table, "__getitem__"):
        cols = {str(c): np.asarray(table[c]) for c in table.columns}
        index = getattr(table, "index", None)
        seconds = None if index is None else _index_seconds(index)
        time_given = "t" in (columns or {}) or dt is not None or rate is not None
        if index is not None and seconds is not None:
            if index.name is not None:
                cols.setdefault(str(index.name), seconds)
            if "t" not in cols and not time_given:
                cols["t"] = seconds
    elif isinstance(table, dict):
        cols = {str(k): np.asarray(v) for k, v in table.items()}
    elif getattr(table, "dtype", None) is not None and table.dtype.names:
        cols = {n: np.asarray(table[n]) for n in table.dtype.names}
    else:
        raise DataError("table must be a DataFrame, a dict of arrays or a structured array")
    units = units if units is not None else attrs.get("units")
    consts = _constants(constants if constants is not None else attrs.get("constants") or {}, f"{name or attrs.get('name') or 'table'}: ")
    needed, optional = channels_to_read(m, consts, measured)
    chans = select_channels(
        cols, needed, columns, units, m.quantities, scale=scale, dt=dt, rate=rate, inputs=tuple(m.inputs), optional=optional
    )
    t = chans.pop("t")
    limit = limit if limit is not None else attrs.get("limit")
    return Recording(t=t, channels=chans, limit=limit, name=name or attrs.get("name") or "", constants=consts or None)


def as_recording(data, model=None, measured: bool = True):
    """`data` as it is, or a pandas DataFrame as `Recording.from_dataframe(data, model=model,
    measured=measured)`."""
    if not isinstance(data, Recording) and hasattr(data, "columns") and hasattr(data, "index"):
        return Recording.from_dataframe(data, model=model, measured=measured)
    return data
