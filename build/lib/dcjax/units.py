"""Unit conversion to SI for recorded channels, and mapping of table columns to channels."""

import numpy as np

# Factor to SI, by quantity. Names are matched case-sensitively first, then case-insensitively.
UNITS: dict[str, dict[str, float]] = {
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6, "min": 60.0},
    "voltage": {"V": 1.0, "mV": 1e-3, "kV": 1e3},
    "current": {"A": 1.0, "mA": 1e-3, "kA": 1e3},
    "angular speed": {"rad/s": 1.0, "1/s": 1.0, "rpm": 2 * np.pi / 60, "1/min": 2 * np.pi / 60, "rev/s": 2 * np.pi, "deg/s": np.pi / 180},
    "angle": {"rad": 1.0, "deg": np.pi / 180, "rev": 2 * np.pi},
    "torque": {"Nm": 1.0, "mNm": 1e-3},
}


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
    raise ValueError(f"unknown unit {unit!r} for {channel}; accepted: {accepted}")


def parse_mapping(text: str | None, what: str) -> dict[str, str]:
    """`"a=x,b=y"` -> {"a": "x", "b": "y"} (CLI form of --columns, --units, --fix, --bound)."""
    if not text:
        return {}
    out = {}
    for item in text.split(","):
        key, sep, value = item.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise ValueError(f"{what} must be NAME=VALUE pairs separated by commas, got {item!r}")
        out[key.strip()] = value.strip()
    return out


def select_channels(
    table: dict[str, np.ndarray], needed: tuple[str, ...], columns: dict | None, units: dict | None, quantities: dict, where: str = ""
) -> dict[str, np.ndarray]:
    """Channels `needed` (and `t`) from `table` (column name -> values; columns may be named by
    header or by 0-based index), converted to SI with `units` (channel -> unit name)."""
    columns = dict(columns or {})
    units = dict(units or {})
    headers = list(table)
    known = ("t", *needed)
    bad = [c for c in (*columns, *units) if c not in known]
    if bad:
        raise ValueError(
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
                raise ValueError(f"{where}column index {k} for {c} is out of range (the file has {len(headers)} columns)")
            col = table[headers[k]]
        else:
            raise ValueError(
                f"{where}no column {src!r} for {c}; the columns are {', '.join(map(repr, headers))} (map them with columns/--columns {c}=NAME)"
            )
        factor = unit_factor(c, units[c], "time" if c == "t" else quantities.get(c)) if c in units else 1.0
        out[c] = np.asarray(col, dtype=np.float64) * factor
    return out
