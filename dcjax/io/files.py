"""Files written whole or not at all, under names that stay where they are put.

- `safe_name`: a recording's name (from a sidecar, a file stem) as a file name: no separator, no
  `..`, no leading dot, unique within a run; the folder is decided by the caller alone.
- `write_atomic`: a file written to a hidden temporary name beside it and renamed into place
  (`os.replace`): a reader sees the old file or the new one, never a part of either.
- `strict_json`: JSON that other tools read (no `NaN`/`Infinity`: a non-finite number is `null`).
- `stale_temporaries`: what a writer that was killed left (the command line's output folder
  removes them)."""

import contextlib
import hashlib
import json
import math
import os
import re
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

LOCK = ".dcjax.lock"
_UNSAFE = re.compile(r"[^A-Za-z0-9._+-]+")
MAX_NAME = 100


def safe_name(name: str, taken: Iterable[str] = ()) -> str:
    """`name` as one path component: runs of characters outside `A-Z a-z 0-9 . _ + -` (a `/`, a
    `\\`, spaces, control characters) as `_`, no leading dot (so no `.` or `..`), at most
    `MAX_NAME` characters, `recording` if nothing is left; `_2`, `_3`, ... appended while it is
    in `taken` (compared without case: one name on a case-insensitive disk)."""
    text = _UNSAFE.sub("_", str(name)).strip("._")[:MAX_NAME].strip("._") or "recording"
    used = {t.lower() for t in taken}
    out, k = text, 1
    while out.lower() in used:
        k += 1
        out = f"{text}_{k}"
    return out


def temporary_name(path: Path) -> Path:
    """The hidden name `path` is written under before it is renamed into place."""
    return path.with_name(f".{path.name}.tmp-{os.getpid()}")


def write_atomic(path: str | Path, write: Callable[[Path], object]) -> Path:
    """`write(tmp)` writes the file at `tmp` (a hidden name in the same folder), then it is
    renamed to `path` in one step; on any error (or an interrupt) the temporary file is removed
    and `path` is as it was."""
    path = Path(path)
    tmp = temporary_name(path)
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    return path


def write_text(path: str | Path, text: str) -> Path:
    """`text` written atomically (`write_atomic`)."""
    return write_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def save_figure(fig, path: str | Path, **kw) -> Path:
    """A matplotlib figure saved atomically, in the format of `path`'s suffix."""
    path = Path(path)
    return write_atomic(path, lambda tmp: fig.savefig(tmp, format=path.suffix.lstrip(".") or "png", **kw))


def _finite_or_none(x):
    if isinstance(x, dict):
        return {str(k): _finite_or_none(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite_or_none(v) for v in x]
    if isinstance(x, np.ndarray):
        return [_finite_or_none(v) for v in x.tolist()]
    if isinstance(x, (np.bool_, bool)):
        return bool(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    return x


def strict_json(obj, indent: int | None = 2) -> str:
    """`obj` as strict JSON (RFC 8259): NumPy scalars and arrays as numbers and lists, a NaN or
    infinite number as `null` (the reader says what a null means)."""
    return json.dumps(_finite_or_none(obj), indent=indent, allow_nan=False)


def file_sha256(path: str | Path) -> str:
    """The sha256 of a file's bytes, read in chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def stale_temporaries(folder: Path) -> list[Path]:
    """Temporary files a killed writer left in `folder` and its sub-folders (`temporary_name`)."""
    return [p for p in [*folder.glob(".*.tmp-*"), *folder.glob("*/.*.tmp-*")] if p.is_file()]
