"""Delimited text as a lab's logger writes it: a preamble, a header (possibly in a comment line),
an optional line of units, then data rows, every one of which is read or named in an error.

The delimiter is detected from the file's last lines (read first, so that a file that is not a
table fails before it is read whole), and so is the decimal separator where it is not given: a
comma where the rows are numbers only with it (`0,5;220`: a European spreadsheet's export), else
a point; a last line that splits otherwise than the two before it is taken for a row cut short
(`data_lines`) and named as a broken row. A field in double quotes is its text, delimiters in
it included (`split_fields`). The text is UTF-8, or UTF-8 or UTF-16 by a byte-order mark
(as Excel and Windows tools write them; `text_encoding`). The data are the rows of the last full row's width from the
first such numeric row on; after it, every line that is not a comment (`#`, `%`) must be a data
row: a text cell, a missing or an extra field is a one-line error naming the line. A field that
is empty, `nan`, `NA`, `null` or `none` is NaN (a row of them only, as loggers write between
bursts, is a row of NaN: `drop_nan` drops it). A timestamp (ISO 8601, `2026-12-06 08:00:00.0001`,
`2026-12-06T08:00:00Z`; day.month.year `06.12.2026 08:00:00,0001`; a slashed date `12/6/2026 8:00:00.5 PM`,
`6/12/2026 20:00`, `2026/12/06 20:00:00`; or a time of day `8:00:00,0001`) is read as the seconds after the
column's first one, exact to the microsecond (`Clocks`). The header is the nearest line of that width
above the data (a commented one where there is no other); a line of units may stand between
them. Units, from that line or a header such as `speed_rpm`, `I [mA]`, are kept per column
(`Table.units`) for the caller to compare with what it converts."""

import csv
import dataclasses
import datetime
import math
import os
import re
from collections import deque
from pathlib import Path

import numpy as np

from ..errors import ConfigError, DataError
from .units import known_unit, split_unit

DELIMITERS = {",": ",", ";": ";", "tab": "\t", "\\t": "\t", "\t": "\t", "space": None, "whitespace": None, " ": None}
MISSING = ("", "nan", "na", "n/a", "null", "none")  # a field read as NaN (as pandas' read_csv does)
COMMENTS = ("#", "%")
SNIFF_BYTES = 1 << 16  # the tail read to detect the delimiter before the file is read whole


@dataclasses.dataclass(frozen=True)
class Table:
    """A text file's data: `columns` header -> values (columns named by 0-based index where the
    file has no header), `units` header -> unit as the file states it (a units line or the header
    name), `lines` the file's line number (1-based) of each row, `units_line` the units line's."""

    columns: dict[str, np.ndarray]
    units: dict[str, str]
    lines: np.ndarray
    units_line: int | None = None


QUOTED = re.compile(r'"((?:[^"]|"")*)"|([^"\s]+)')  # a whitespace-delimited line's fields: "quoted" or bare


def split_fields(line: str, delim: str | None) -> list[str]:
    """The fields of `line` split at `delim` (None: runs of whitespace), stripped. A field in
    double quotes is read as its text (RFC 4180: `""` is a quote), delimiters inside it included:
    `"Date Time, GMT+01:00","0,5"`."""
    if '"' not in line:
        return [f.strip() for f in (line.split() if delim is None else line.split(delim))]
    if delim is None:
        return [(m.group(1).replace('""', '"') if m.group(2) is None else m.group(2)).strip() for m in QUOTED.finditer(line)]
    return [f.strip() for f in next(csv.reader([line], delimiter=delim, skipinitialspace=True), [])]


TIMESTAMP = re.compile(
    r"^\d{4}-\d{2}-\d{2}(?:[T ]\d{2}:\d{2}(?::\d{2}(?:[.,]\d+)?)?)?(?:Z|[+-]\d{2}(?::?\d{2})?)?$"  # ISO 8601 date and time
    r"|^\d{1,2}\.\d{1,2}\.\d{4}(?:[T ]\d{1,2}:\d{2}(?::\d{2}(?:[.,]\d+)?)?)?$"  # day.month.year (a German logger's), and a time
    r"|^\d{1,2}:\d{2}:\d{2}(?:[.,]\d+)?$"  # a time of day
)
SLASHED = re.compile(  # 12/6/2026 8:00:00.5 PM, 6/12/26 20:00, 2026/12/06 20:00:00: `Clocks` tells month from day
    r"^(\d{1,2}|\d{4})/(\d{1,2})/(\d{1,2}|\d{4})(?:[T ](\d{1,2}:\d{2}(?::\d{2}(?:[.,]\d+)?)?)(?: ?([AaPp][Mm]))?)?$"
)
SLASHED_DATE = re.compile(r"\b\d{1,4}/\d{1,2}/\d{1,4}\b")  # in a last line that does not read: named in the error
DOTTED_DATE = re.compile(r"^(\d{1,2})\.(\d{1,2})\.(\d{4})(?:[T ](.*))?$")
DAY = datetime.date(2000, 1, 1)  # a time of day's date (its seconds are taken after the column's first)


class Clocks:
    """Timestamps read as the seconds after their column's first one (the first read sets it):
    the time differences exact to the microsecond, where seconds since 1970 in float64 would
    round them to 0.24 µs. A time of day that falls back by more than 12 h has passed midnight.
    A slashed date is year/month/day where the year comes first, else month/day/year or
    day/month/year: both are kept while they give the same seconds (a record within one day, or
    6/6), and where they part (the date changes) the one whose step from the row before is the
    smallest forward one is the column's (12/6 -> 12/7 past midnight: a day, not a month).
    One per file read; a throwaway one where only whether a field reads matters."""

    def __init__(self):
        self.origins: dict[int, datetime.datetime] = {}
        self.last: dict[int, datetime.datetime] = {}  # a time-of-day column's last stamp, its date advanced past midnights
        self.orders: dict[int, dict[str, tuple[datetime.datetime, datetime.datetime]]] = {}  # slashed: order -> (first, last)

    def seconds(self, column: int, text: str) -> float | None:
        """`text` as seconds after column `column`'s first timestamp, or None where it is none."""
        slashed = SLASHED.match(text)
        if slashed:
            return self._slashed(column, slashed.groups())
        if not TIMESTAMP.match(text):
            return None
        t = text.replace(",", ".")
        try:
            dotted = DOTTED_DATE.match(t)
            if dotted:
                day, month, year, clock = dotted.groups()
                stamp = datetime.datetime.combine(datetime.date(int(year), int(month), int(day)), _time_of_day(clock or "00:00"))
            elif "-" in t[:5]:
                stamp = datetime.datetime.fromisoformat(t)
            else:
                last = self.last.get(column)
                stamp = datetime.datetime.combine(DAY if last is None else last.date(), _time_of_day(t))
                if last is not None and last - stamp > datetime.timedelta(hours=12):
                    stamp += datetime.timedelta(days=1)
                self.last[column] = stamp
            origin = self.origins.setdefault(column, stamp)
            return (stamp - origin).total_seconds()
        except (ValueError, TypeError):  # not a date (month 13), or one with a time zone among ones without
            return None

    def _slashed(self, column: int, parts: tuple) -> float | None:
        """A slashed date's seconds after the column's first, in the orders still possible."""
        a, b, c, clock, half = parts
        try:
            time = _time_of_day(clock.replace(",", ".") if clock else "00:00", half)
        except ValueError:
            return None
        if len(a) == 4:
            fields = {"ymd": (int(a), int(b), int(c))}
        elif len(c) == 1:
            return None
        else:
            year = int(c) + (2000 if len(c) == 2 else 0)
            fields = {"mdy": (year, int(a), int(b)), "dmy": (year, int(b), int(a))}
        stamps = {}
        for order, (y, m, d) in fields.items():
            try:
                stamps[order] = datetime.datetime.combine(datetime.date(y, m, d), time)
            except ValueError:  # month 13 in this order
                pass
        known = self.orders.get(column)
        if known is None:
            if not stamps:
                return None
            self.orders[column] = {o: (s, s) for o, s in stamps.items()}
            self.origins[column] = next(iter(stamps.values()))
            return 0.0
        kept = {o: (first, stamps[o]) for o, (first, _) in known.items() if o in stamps}
        if not kept:
            return None
        if len({(s - first) for first, s in kept.values()}) > 1:  # the orders part: the nearest step forward decides
            step = {o: stamps[o] - known[o][1] for o in kept}
            best = min(kept, key=lambda o: (step[o] < datetime.timedelta(0), abs(step[o])))
            kept = {best: kept[best]}
        self.orders[column] = kept
        first, stamp = next(iter(kept.values()))
        self.origins[column] = first
        return (stamp - first).total_seconds()

    def forget(self, columns) -> None:
        """Drop what `columns` have read (a line that turned out to be no row)."""
        for column in columns:
            self.origins.pop(column, None)
            self.orders.pop(column, None)


def is_timestamp(text: str) -> bool:
    """Whether `text` has a timestamp's form (whether it is a valid one, `Clocks` tells)."""
    return bool(TIMESTAMP.match(text) or SLASHED.match(text))


def _time_of_day(text: str, half: str | None = None) -> datetime.time:
    """`8:00:00.5` / `08:00` as a time (ISO 8601 wants two digits for the hour); `half` "AM" or
    "PM": a 12-hour clock's (12:30 AM is 00:30)."""
    time = datetime.time.fromisoformat(text.zfill(len(text) + 1) if text.index(":") == 1 else text)
    if half is None:
        return time
    if not 1 <= time.hour <= 12:
        raise ValueError(f"hour {time.hour} on a 12-hour clock")
    return time.replace(hour=time.hour % 12 + (12 if half.upper() == "PM" else 0))


def row_values(fields: list[str], decimal: str, clocks: Clocks | None = None) -> list[float] | None:
    """The row's numbers (a `MISSING` field as NaN, a timestamp as `clocks` read it), or None
    where a field is neither. One pass that both tests and converts."""
    out = []
    clocks = clocks or Clocks()
    known = len(clocks.origins)
    for k, f in enumerate(fields):
        try:
            out.append(float(f if decimal == "." else f.replace(decimal, ".")))
        except ValueError:
            if f.lower() in MISSING:
                out.append(math.nan)
                continue
            stamp = clocks.seconds(k, f)
            if stamp is None:
                clocks.forget(list(clocks.origins)[known:])  # a line that is no row sets no column's first timestamp
                return None
            out.append(stamp)
    return out


def _all_missing(fields: list[str]) -> bool:
    return all(f.lower() in MISSING for f in fields)


def without_trailing_delimiter(line: str) -> str:
    """`1,2,3;` -> `1,2,3` (a logger that ends every line with a delimiter)."""
    line = line.rstrip()
    return line[:-1].rstrip() if line.endswith((";", ",")) else line


def _comment(line: str) -> str | None:
    """The text of a comment line without its marker, else None."""
    s = line.lstrip()
    return s[1:].strip() if s.startswith(COMMENTS) else None


def detect_delimiter(lines: list[str], decimal: str) -> str | None:
    """The first of `;`, tab, `,`, whitespace that splits the last line into >= 2 numeric fields
    (with the `decimal` separator; `,` with a decimal comma only where the line quotes fields)."""
    for d in (";", "\t", ",", None):
        if d == "," and decimal == "," and '"' not in lines[-1]:
            continue
        last = split_fields(lines[-1], d)
        if len(last) >= 2 and row_values(last, decimal) is not None and not _all_missing(last):
            return d
    slashed = SLASHED_DATE.search(lines[-1])
    if slashed:
        raise DataError(
            f"the last line holds a date with slashes ({slashed.group(0)!r}) that does not read as a timestamp field: "
            "month/day/year, day/month/year or year/month/day, then a space or T and a time (8:00:00.5, 8:00:00 PM); "
            "or write the dates as ISO 8601 (2026-12-06 08:00:00)"
        )
    raise DataError(
        "cannot detect the delimiter: the last line is not a row of numbers separated by ';', tab, ',' or whitespace; give delimiter="
    )


def detect_decimal(lines: list[str], delim: str | None) -> str:
    """The decimal separator of rows split by `delim`: a comma where a field of these lines is a
    number only with it (`0,5;220;1,25`, or quoted between commas: `"0,5",220`), else a point."""
    for line in lines:
        fields = split_fields(without_trailing_delimiter(line), delim)
        if any("," in f for f in fields) and row_values(fields, ",") is not None:
            return ","
    return "."


def _shape(line: str) -> tuple:
    """How `line` splits: per candidate delimiter, its number of fields and whether they are numbers."""
    return tuple(
        (len(f := split_fields(line, d)), row_values(f, ".") is not None or row_values(f, ",") is not None) for d in (";", "\t", ",", None)
    )


def data_lines(lines: list[str]) -> list[str]:
    """`lines` up to the one that shows the data's shape: the last, unless the two before it
    split alike and it does not (a last row cut short: a file still being written, a logger
    stopped mid-line) as rows of numbers, which the reading then names as a broken row."""
    if len(lines) >= 3 and _shape(lines[-2]) == _shape(lines[-3]) != _shape(lines[-1]):
        if any(n >= 2 and numbers for n, numbers in _shape(lines[-2])):
            return lines[:-1]
    return lines


def _detect(lines: list[str], decimal: str | None) -> tuple[str | None, str]:
    """(delimiter, decimal separator) of the last lines, the separator detected where None:
    the delimiter that splits them into numbers with a decimal point, else with a comma."""
    if decimal is not None:
        return detect_delimiter(lines, decimal), decimal
    try:
        delim = detect_delimiter(lines, ".")
    except DataError as point:
        try:
            return detect_delimiter(lines, ","), ","
        except DataError:
            raise point from None
    return delim, detect_decimal(lines, delim)


# A byte-order mark and the encoding it names (Python's "utf-8-sig" and "utf-16" read the mark and drop it).
BYTE_ORDER_MARKS = ((b"\xef\xbb\xbf", "utf-8-sig"), (b"\xff\xfe", "utf-16"), (b"\xfe\xff", "utf-16"))


def text_encoding(path: Path) -> str:
    """The encoding of a text file: the one its byte-order mark names (UTF-8 or UTF-16), else UTF-8."""
    with open(path, "rb") as f:
        head = f.read(3)
    return next((enc for mark, enc in BYTE_ORDER_MARKS if head.startswith(mark)), "utf-8")


def _tail_lines(path: Path) -> list[str]:
    """The last lines of the file (at most `SNIFF_BYTES`), without blanks and comments."""
    encoding = text_encoding(path)
    with open(path, "rb") as f:
        mark = f.read(3)
        f.seek(0, os.SEEK_END)
        size = f.tell()
        start = max(0, size - SNIFF_BYTES)
        if encoding == "utf-16":  # from a code unit's first byte, in the mark's byte order, after the mark
            start += start % 2
            f.seek(max(start, 2))
            text = f.read().decode("utf-16-le" if mark.startswith(b"\xff\xfe") else "utf-16-be", errors="replace")
        else:
            f.seek(start)
            text = f.read().decode(encoding if start == 0 else "utf-8", errors="replace")
    lines = text.splitlines()[1:] if size > SNIFF_BYTES else text.splitlines()
    return [without_trailing_delimiter(x) for x in lines if x.strip() and _comment(x) is None]


UNIT_LIKE = re.compile(r"^(\[.*\]|\(.*\)|[A-Za-zµ°%#/0-9.^*-]{1,12})$")


def _units_line(fields: list[str]) -> bool:
    """A line of units under the header (`s, V, A, rad/s`, `[ms]`, `(rpm)`, `degC`): every
    field unit-shaped (bracketed, or one short token, or empty), at least half of the
    non-empty ones bracketed or a unit dcjax knows."""

    filled = [f for f in fields if f not in ("", "-")]
    if not filled or not all(UNIT_LIKE.match(f) for f in filled):
        return False
    named = [f for f in filled if f[:1] in "[(" or known_unit(f)]
    return 2 * len(named) >= len(filled) and row_values(fields, ".") is None


def unit_text(field: str) -> str:
    """`[rpm]` / `(rpm)` / `rpm` -> `rpm`."""
    f = field.strip()
    return f[1:-1].strip() if len(f) >= 2 and f[0] + f[-1] in ("[]", "()") else f


def read_table(path: Path, delimiter: str | None = None, decimal: str | None = None) -> Table:
    """The data of a delimited text file (module docstring), or a one-line error naming the
    line that breaks it. `delimiter`, `decimal`: None detects them."""
    if decimal not in (None, ".", ","):
        raise ConfigError(f"decimal must be '.' or ',', got {decimal!r}")
    tail = _tail_lines(path)
    if tail:
        tail = data_lines(tail)
    if not tail:
        raise DataError(f"{path}: no data rows (the file is empty or holds comments only)")
    if delimiter is None:
        try:
            delim, decimal = _detect(tail, decimal)
        except ValueError as e:
            text = [x for x in tail if x.strip()]
            if len(text) <= 2 and path.stat().st_size <= SNIFF_BYTES:
                raise DataError(f"{path}: no data rows: the file holds {len(text)} line(s) of text and no row of numbers") from None
            raise DataError(f"{path}: {e}") from None
    elif delimiter in DELIMITERS:
        delim = DELIMITERS[delimiter]
    else:
        raise ConfigError(f"delimiter must be one of ',', ';', 'tab', 'whitespace', got {delimiter!r}")
    if decimal is None:
        decimal = detect_decimal(tail, delim)
    if delim == "," and decimal == "," and not any('"' in x for x in tail):
        raise ConfigError("delimiter and decimal separator cannot both be ',' (unless the fields holding a decimal comma are quoted)")
    width = len(split_fields(tail[-1], delim))
    if width < 2:
        raise DataError(f"{path}: no numeric data rows with delimiter {delim or 'whitespace'!r}; check delimiter= and decimal=")
    above: deque[tuple[int, list[str] | None, bool]] = deque(
        maxlen=64
    )  # the last lines above the data: (line, text fields of its width, commented)
    values: list[list[float]] = []
    lines: list[int] = []
    clocks = Clocks()
    with open(path, encoding=text_encoding(path), errors="replace", newline=None) as f:
        for lineno, raw in enumerate(f, start=1):
            if not raw.strip():
                continue
            note = _comment(raw)
            if note is not None:
                if not values:
                    above.append((lineno, _text_of_width(split_fields(without_trailing_delimiter(note), delim), width, decimal), True))
                continue
            fields = split_fields(without_trailing_delimiter(raw), delim)
            row = row_values(fields, decimal, clocks) if len(fields) == width else None
            if not values:  # the preamble, the header and the units: up to the first numeric row of the data's width
                if row is not None and not _all_missing(fields):
                    values.append(row)
                    lines.append(lineno)
                else:
                    above.append((lineno, _text_of_width(fields, width, decimal), False))
                continue
            if row is None:
                raise DataError(_bad_row(path, lineno, fields, width, decimal, lines[0], clocks))
            values.append(row)
            lines.append(lineno)
    if not values:
        raise DataError(f"{path}: no numeric data rows with delimiter {delim or 'whitespace'!r}; check delimiter= and decimal=")
    header, units, units_line = _header(above, width)
    if len(set(header)) != len(header):
        raise DataError(f"{path}: repeated column names in the header {header}")
    data = np.array(values, dtype=np.float64)
    units = {h: u for h, u in zip(header, units)} if units else {h: u for h in header if (u := split_unit(h)[1]) is not None}
    return Table({h: data[:, k] for k, h in enumerate(header)}, units, np.array(lines), units_line)


def _text_of_width(fields: list[str], width: int, decimal: str) -> list[str] | None:
    """`fields` where they are a line of text of the data's width (a header or units candidate)."""
    return fields if len(fields) == width and row_values(fields, decimal) is None else None


def _header(above, width: int) -> tuple[list[str], list[str], int | None]:
    """(header, units per column or [], the units line) from the lines above the data: the
    nearest uncommented line where it is text of the data's width (and the one above it where
    it is a line of units), else the comment lines between it and the data likewise; columns
    named by index where there is none."""
    above = list(above)
    plain = [k for k, a in enumerate(above) if not a[2]]
    last = plain[-1] if plain else -1
    for group in ([above[k] for k in plain], above[last + 1 :]):
        texts = [(line, fields) for line, fields, _ in group]
        if not texts or texts[-1][1] is None:
            continue
        line, near = texts[-1]
        head = texts[-2][1] if len(texts) > 1 else None
        if head is not None and _units_line(near):
            return _names(head), [unit_text(u) for u in near], line
        return _names(near), [], None
    return [str(k) for k in range(width)], [], None


def _names(fields: list[str]) -> list[str]:
    return [h.strip().strip('"').strip("'") for h in fields]


CUT_SHORT = "the file's last row, cut short (a file still being written, or a logger stopped mid-line?)"


def _is_last(path: Path, lineno: int) -> bool:
    """Whether `lineno` is the file's last line that is neither blank nor a comment."""
    with open(path, encoding=text_encoding(path), errors="replace", newline=None) as f:
        return lineno == max((k for k, raw in enumerate(f, start=1) if raw.strip() and _comment(raw) is None), default=0)


def _bad_row(path: Path, lineno: int, fields: list[str], width: int, decimal: str, first: int, clocks: Clocks) -> str:
    """The one-line error of a line inside the data that is not a data row."""
    where = f"{path}: line {lineno}"
    cut = _is_last(path, lineno)
    if len(fields) != width:
        return f"{where} has {len(fields)} field(s), the data rows from line {first} have {width}: {CUT_SHORT if cut else 'a ragged or broken row'}"
    stamp = next(((k, f) for k, f in enumerate(fields) if is_timestamp(f) and clocks.seconds(k, f) is None), None)
    if stamp is not None and stamp[0] in clocks.origins:
        return (
            f"{where}: field {stamp[0]} ({stamp[1]!r}) is a timestamp that cannot follow the column's first "
            f"({clocks.origins[stamp[0]].isoformat()}): a time zone in one and not the other, no date, or a date that is none "
            "(month 13)"
        )
    bad = next((k, f) for k, f in enumerate(fields) if row_values([f], decimal) is None)
    if cut:
        return f"{where}: field {bad[0]} ({bad[1]!r}) is not a number: {CUT_SHORT}"
    return (
        f"{where}: field {bad[0]} ({bad[1]!r}) is not a number, inside the data that start at line {first} "
        "(a row of text in the data is an error, not a new start; remove or fix the line)"
    )
