"""Unit conversion to SI for recorded channels, and mapping of table columns to channels."""

import re
import warnings

import numpy as np

from ..errors import ConfigError, DataError

# Factor to SI, by quantity. Names are matched case-sensitively first, then case-insensitively.
UNITS: dict[str, dict[str, float]] = {
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "min": 60.0},
    "voltage": {"V": 1.0, "mV": 1e-3, "kV": 1e3},
    "current": {"A": 1.0, "mA": 1e-3, "kA": 1e3},
    "angular speed": {
        "rad/s": 1.0,
        "1/s": 1.0,
        "rpm": 2 * np.pi / 60,
        "1/min": 2 * np.pi / 60,
        "rev/s": 2 * np.pi,
        "turns/s": 2 * np.pi,
        "deg/s": np.pi / 180,
    },
    "angle": {"rad": 1.0, "deg": np.pi / 180, "rev": 2 * np.pi, "turns": 2 * np.pi},
    "torque": {"Nm": 1.0, "mNm": 1e-3, "Ncm": 1e-2},
    "position": {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "um": 1e-6, "µm": 1e-6},
    "speed": {"m/s": 1.0, "mm/s": 1e-3, "cm/s": 1e-2, "m/min": 1 / 60},
    "force": {"N": 1.0, "mN": 1e-3, "kN": 1e3},
}

# Units that a name's last word does not state (`omega_m`, `T_N`: more often a subscript, the
# motor's, the rated); in brackets (`x [m]`), a units line or `units=` they do.
SUBSCRIPT_LIKE = ("m", "N")

# The SI unit a loaded channel is in, by the model's quantity.
SI_UNITS = {
    "time": "s",
    "voltage": "V",
    "current": "A",
    "angular speed": "rad/s",
    "angle": "rad",
    "torque": "Nm",
    "position": "m",
    "speed": "m/s",
    "force": "N",
}


def checked_quantities(quantities: dict) -> dict:
    """A model's `quantities` (channel -> quantity), each a quantity of `UNITS`; else a one-line
    error (a misspelt "length" or "velocity" would leave its channel unconverted, silently)."""
    for c, q in quantities.items():
        if q not in UNITS:
            raise ConfigError(f"Model.quantities: {q!r} (channel {c}) is not one of {', '.join(UNITS)}; leave {c} out to read it as it is")
    return quantities


class ColumnError(DataError):
    """A channel's column is not in the file (a one-line error naming it and the file's columns)."""


def known_unit(text: str) -> bool:
    """Whether `text` names a unit of `UNITS` (exactly, or without case where longer than 2 characters: `RPM`, `MS`)."""
    t = text.strip()
    return any(t in table or (len(t) > 2 and t.lower() in {u.lower() for u in table}) for table in UNITS.values())


def unit_factor(channel: str, unit: str, quantity: str | None) -> float:
    """SI factor of `unit` for `channel` of `quantity` (None: any known quantity)."""
    tables = {quantity: UNITS[quantity]} if quantity in UNITS else UNITS
    for table in tables.values():
        if unit in table:
            return table[unit]
    for table in tables.values():
        for name, f in table.items():
            if name.lower() == unit.lower():
                return f
    accepted = ", ".join(u for t in tables.values() for u in t)
    raise ConfigError(f"unknown unit {unit!r} for {channel}; accepted: {accepted}")


def sample_times(n: int, dt: float | None = None, rate: float | None = None) -> np.ndarray:
    """t = k dt (k = 0 .. n-1) for a file without a time column; `rate` (Hz) gives dt = 1/rate."""
    if dt is not None and rate is not None:
        raise ConfigError("give either dt (s) or rate (Hz) for a file without a time column, not both")
    step = dt if dt is not None else None if rate is None else 1.0 / _positive(rate, "rate")
    step = _positive(step, "dt")
    return np.arange(n) * step


def _positive(v, what: str) -> float:
    try:
        f = float(v)
    except (TypeError, ValueError):
        f = float("nan")
    if not (np.isfinite(f) and f > 0):
        raise ConfigError(f"{what} must be a positive number, got {v!r}")
    return f


def scale_factors(scale: dict | None, known: tuple[str, ...], where: str = "") -> dict[str, float]:
    """Channel -> finite non-zero factor (applied after unit conversion: value_SI = value x factor)."""
    out = {}
    for c, f in (scale or {}).items():
        if c not in known:
            raise ConfigError(f"{where}scale: unknown channel {c!r}; this model's channels are {', '.join(known)}")
        try:
            out[c] = float(f)
        except (TypeError, ValueError):
            out[c] = float("nan")
        if not (np.isfinite(out[c]) and out[c] != 0):
            raise ConfigError(f"{where}scale of {c} must be a finite non-zero number, got {f!r}")
    return out


def split_unit(name: str) -> tuple[str, str | None]:
    """(the rest, the unit) of a column name that states a unit dcjax knows at its end: `speed
    [rpm]`, `I(mA)`, `x [m]`, `Time, s` (a quoted header's), `speed_rpm`, `time ms` (the last
    word, but not `m` or `N`: `SUBSCRIPT_LIKE`); else (the name, None)."""
    h = name.strip()
    m = re.search(r"[\[(]\s*([^\[\]()]+?)\s*[\])]\s*$", h) or re.search(r",\s*([^,]+?)\s*$", h)
    if m and known_unit(m.group(1)):
        return h[: m.start()].strip(), m.group(1)
    words = re.split(r"[_\s]+", h)
    if len(words) > 1 and words[-1] not in SUBSCRIPT_LIKE and known_unit(words[-1]):
        return h[: -len(words[-1])].rstrip("_ \t"), words[-1]
    return h, None


def _is_si(unit: str | None, channel: str, quantity: str | None) -> bool:
    """Whether a column stated in `unit` (None: no unit) reads as `channel`'s SI unit as it is (a
    channel of no known quantity: only with no unit stated)."""
    if not unit or unit == SI_UNITS.get(quantity or ""):
        return True
    if quantity not in UNITS:
        return False
    try:
        return known_unit(unit) and unit_factor(channel, unit, quantity) == 1.0
    except ConfigError:
        return False


def named_columns(
    headers: list[str], stated: dict[str, str], wanted, quantities: dict, units: dict | None = None
) -> tuple[dict[str, str], dict[str, str]]:
    """(channel -> column, channel -> why not) for each `wanted` channel that no column is named
    exactly: the one column named after it (the time also `time`) but for case and a unit at its
    end that is the channel's SI unit, or the one `units` gives it (`OMEGA`, `Omega`, `t [s]`,
    `Time (s)`, `omega (rad/s)`, `i_a_A`; `stated`: header -> unit, as `Table.units`). A name
    that matches in another unit (`t [ms]`), or two that match, are not taken: the second dict
    says how to map it (`select_channels` puts it in its error)."""
    out, why = {}, {}
    for c in wanted:
        if c in headers:
            continue
        quantity = "time" if c == "t" else quantities.get(c)
        names = {c.lower(), "time", "timestamp"} if c == "t" else {c.lower()}  # the time column: `t`, `time` or `timestamp`
        near = []
        for h in headers:
            unit = stated.get(h)  # the units line's, else the name's
            if split_unit(h)[0].lower() in names:
                near.append((h, unit))
            elif h.strip().lower() in names:  # the "unit" is the name's last word (`U_A`): the whole name is the channel's
                near.append((h, None))
        if len(near) > 1:
            both = "both" if len(near) == 2 else "all"
            why[c] = f"{' and '.join(repr(h) for h, _ in near)} {both} name it but for case or unit: map one with columns={{{c!r}: NAME}}"
        elif near:
            h, unit = near[0]
            if c in (units or {}) or _is_si(unit, c, quantity):
                out[c] = h
                continue
            ours = quantity in UNITS and any(unit.lower() == u.lower() for u in UNITS[quantity])  # pyright: ignore[reportOptionalMemberAccess]
            fix = (
                f"map it with columns={{{c!r}: {h!r}}} and units={{{c!r}: {unit!r}}}"
                if ours
                else f"map {c}'s column with columns={{{c!r}: NAME}}"
            )
            why[c] = (
                f"column {h!r} names {c} in {unit}, not {SI_UNITS[quantity]}: {fix}"
                if quantity in SI_UNITS
                else f"column {h!r} states the unit {unit}, and the model gives {c} no quantity to check it against "
                f"(Model.quantities): map it with columns={{{c!r}: {h!r}}} to read it as it is"
            )
    return out, why


def select_channels(
    table: dict[str, np.ndarray],
    needed: tuple[str, ...],
    columns: dict | None,
    units: dict | None,
    quantities: dict,
    where: str = "",
    scale: dict | None = None,
    dt: float | None = None,
    rate: float | None = None,
    inputs: tuple[str, ...] = (),
    optional: tuple[str, ...] = (),
    why: dict[str, str] | None = None,
) -> dict[str, np.ndarray]:
    """Channels `needed` (and `t`) from `table` (column name -> values; columns may be named by
    header or by 0-based index), converted to SI with `units` (channel -> unit name), then
    multiplied by `scale` (channel -> factor: a gear ratio, a wheel radius, a sensor gain). With
    `dt` (s) or `rate` (Hz) the time is t = k dt and the table needs no time column. Channels
    `optional` (a state that is not compared) are read the same way where the table has them.
    `why`: channel -> why a column that nearly names it was not taken (`named_columns`), for the
    error where it has none."""
    checked_quantities(quantities)
    columns = dict(columns or {})
    units = dict(units or {})
    headers = list(table)
    known = ("t", *needed, *(c for c in optional if c not in needed))
    factors = scale_factors(scale, known, where)
    if dt is not None or rate is not None:
        if "t" in columns or "t" in factors:
            raise ConfigError(f"{where}dt/rate replace the time column: do not map or scale t as well")
        n = len(next(iter(table.values()))) if table else 0
        times = sample_times(n, dt, rate)
        _time_column_unread(table.get("t"), times, where)
        table = {**table, "\0t": times}
        columns["t"] = "\0t"
        units.pop("t", None)
    bad = [c for c in (*columns, *units) if c not in known]
    if bad:
        raise ConfigError(
            f"{where}unknown channel(s) {', '.join(map(repr, sorted(set(bad))))}; this model's channels are {', '.join(known)}"
        )
    out = {}
    for c in known:
        src = columns.get(c, c)
        if src in table:
            col = table[src]
        elif isinstance(src, int) or (isinstance(src, str) and src.isdigit()):
            k = int(src)
            if not 0 <= k < len(headers):
                raise ConfigError(f"{where}column index {k} for {c} is out of range (the file has {len(headers)} columns)")
            col = table[headers[k]]
        elif c in optional and c not in needed and c not in columns:
            continue
        else:
            hint = " or give the sample time with dt= or rate=" if c == "t" else ""
            if c in inputs:  # an input may be constant in a recording
                hint = f"; or, as the model's inputs ({', '.join(inputs)}) may be, a constant: constants={{{c!r}: V}} or the sidecar's 'constants'"
            logged = [s for s in needed if s not in inputs and s != c and columns.get(s, s) in table]
            if c in needed and c not in inputs and logged:  # a compared state the file does not log: a speed-only log of a motor
                hint = f", or, where the file does not log {c}, compare the states it logs alone: measure={tuple(logged)!r}"
            if c in (why or {}) and c not in columns:
                raise ColumnError(f"{where}no column {src!r} for {c}; {why[c]}")  # pyright: ignore[reportOptionalSubscript]
            raise ColumnError(
                f"{where}no column {src!r} for {c}; the columns are {', '.join(map(repr, headers))} (map them with columns={{{c!r}: NAME}}{hint})"
            )
        factor = unit_factor(c, units[c], "time" if c == "t" else quantities.get(c)) if c in units else 1.0
        out[c] = np.asarray(col, dtype=np.float64) * factor * factors.get(c, 1.0)
    return out


def _time_column_unread(column, times: np.ndarray, where: str) -> None:
    """A one-line warning where the table has a time column `t` (`column`) that `dt`/`rate`
    replace (`times`) and whose median step differs from theirs by more than 1 %: one of the
    two is wrong, and the column is not the one read."""
    if column is None or len(times) < 2:
        return
    steps = np.diff(np.asarray(column, dtype=np.float64))
    steps = steps[np.isfinite(steps)]
    if steps.size == 0:
        return
    step, stated = float(times[1] - times[0]), float(np.median(steps))
    if abs(stated - step) > 0.01 * step:
        warnings.warn(
            f"{where}dt/rate give {step:.6g} s between samples where the file's column 't' steps {stated:.6g} s "
            "(median): the column is not read, the time is k dt",
            stacklevel=4,
        )


def unconverted_units(
    headers: list[str], stated: dict[str, str], by: str, chans, columns, units, quantities: dict, where: str, timed: bool = False
) -> None:
    """A one-line warning for each channel read (`chans`) whose column the file gives a unit
    (`stated`, header -> unit, from its units line or its header name: `by`) that nothing
    converts: a unit other than the channel's SI unit that `units` does not name, or a unit dcjax
    does not know. `columns` maps the channels as `select_channels` took them."""

    columns, units = dict(columns or {}), dict(units or {})
    for c in chans:
        if c in units or (c == "t" and timed):
            continue
        src = str(columns.get(c, c))
        name = src if src in stated or src in headers else headers[int(src)] if src.isdigit() and int(src) < len(headers) else None
        unit = stated.get(name) if name is not None else None
        if not unit or (unit in ("-", "#") and c != "t"):  # dimensionless; a time column of sample numbers is named
            continue
        quantity = "time" if c == "t" else quantities.get(c)
        si = SI_UNITS.get(quantity or "", "SI")
        if not known_unit(unit):
            warnings.warn(
                f"{where}: the {by} gives column {name!r} ({c}) the unit {unit!r}, which dcjax does not know: it is read "
                f"as {si}; convert it (units={{{c!r}: UNIT}}, scale={{{c!r}: FACTOR}}) or check it",
                stacklevel=3,
            )
            continue
        try:
            factor = unit_factor(c, unit, quantity)
        except ValueError:
            warnings.warn(
                f"{where}: the {by} gives column {name!r} ({c}) the unit {unit!r}, not one of {quantity or 'its quantity'} "
                f"({', '.join(UNITS.get(quantity or '', {})) or si}): check the column mapping",
                stacklevel=3,
            )
            continue
        if factor != 1.0:
            warnings.warn(
                f"{where}: column {name!r} ({c}) is in {unit} by its {by}, but read as {si}: units={{{c!r}: {unit!r}}} converts it",
                stacklevel=3,
            )
