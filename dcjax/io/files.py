"""Files written whole or not at all, under names that stay where they are put.

- `safe_name`: a recording's name (from a sidecar, a file stem) as a file name: no separator, no
  `..`, no leading dot, unique within a run; the folder is decided by the caller alone.
- `write_atomic`: a file written to a hidden temporary name beside it and renamed into place
  (`os.replace`): a reader sees the old file or the new one, never a part of either.
- `strict_json`: JSON that other tools read (no `NaN`/`Infinity`: a non-finite number is `null`).
- `OutputFolder`: the folder a command writes, chosen, checked writable and locked (`flock`,
  released by the OS when the process ends) before the work starts; an earlier run's products
  are kept (the run writes to `OUT-2`, ...) unless `overwrite`."""

import contextlib
import hashlib
import json
import math
import os
import re
import shutil
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
    return write_atomic(path, lambda tmp: tmp.write_text(text))


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


class FolderBusy(OSError):
    """Another process holds the folder's lock."""


class OutputFolder:
    """The folder a command writes, as a context manager:

        with OutputFolder(args.out, earlier=lambda f: [f / "result.json"], overwrite=False) as out:
            ...  # out.path: the folder; out.note: a line to print where it is not the one asked for

    On entry the folder is created (its parents too) and locked (`flock` on `.dcjax.lock`; a
    second writer gets the next folder, never the same); where `earlier(folder)` lists files of an
    earlier run, the run goes to the first free `OUT-2`, `OUT-3`, ... (with `overwrite`: into OUT,
    and the caller removes what it replaces). A folder this object created and nothing was
    written into is removed again; temporary files a killed writer left are removed."""

    def __init__(self, out: str | Path, earlier: Callable[[Path], list[Path]], overwrite: bool = False, what: str = "an earlier run",
                 cleanup: list | None = None):  # fmt: skip
        self.cleanup = cleanup  # where given, `abandon` is on it while the folder is open (a signal handler calls it)
        self.asked = Path(out)
        self.earlier = earlier
        self.overwrite = bool(overwrite)
        self.what = what
        self.path = self.asked
        self.note: str | None = None
        self.replaced: list[Path] = []  # with overwrite: the earlier run's files, for the caller to remove
        self._fd: int | None = None
        self._created = False

    def __enter__(self) -> "OutputFolder":
        for k in range(1, 1000):
            folder = self.asked if k == 1 else self.asked.with_name(f"{self.asked.name}-{k}")
            found = self._existing(folder)
            if found and not self.overwrite:
                continue
            try:
                self._lock(folder)
            except FolderBusy:
                if self.overwrite:
                    raise FolderBusy(f"--out {folder}: another dcjax process is writing it; wait for it or give another --out") from None
                continue
            self.path = folder
            self.replaced = found if self.overwrite else []
            if folder != self.asked:
                why = "is being written by another dcjax process" if not self._existing(self.asked) else f"holds {self.what}"
                self.note = f"note: {self.asked} {why}: writing to {folder} (--overwrite replaces {self.asked}'s files)"
            for tmp in stale_temporaries(folder):
                with contextlib.suppress(OSError):
                    tmp.unlink()
            if self.cleanup is not None:
                self.cleanup.append(self.abandon)
            return self
        raise OSError(f"--out {self.asked}: {self.asked}-2 .. -999 are all taken; give another --out")

    def _existing(self, folder: Path) -> list[Path]:
        if folder.exists() and not folder.is_dir():
            raise NotADirectoryError(f"--out {folder} is a file, not a folder")
        return [p for p in self.earlier(folder) if p.exists()] if folder.is_dir() else []

    def _lock(self, folder: Path) -> None:
        import fcntl

        if folder.exists() and not folder.is_dir():
            raise NotADirectoryError(f"--out {folder} is a file, not a folder")
        created = not folder.exists()
        try:
            folder.mkdir(parents=True, exist_ok=True)
            fd = os.open(folder / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as e:
            raise OSError(f"--out {folder}: cannot write there ({e.strerror or e})") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            raise FolderBusy(str(folder)) from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self._fd, self._created = fd, created

    def abandon(self) -> None:
        """What a run stopped now leaves: this process's temporary files removed, and the folder
        too where this run created it and wrote nothing into it."""
        with contextlib.suppress(OSError):
            for tmp in [*self.path.glob(f".*.tmp-{os.getpid()}"), *self.path.glob(f"*/.*.tmp-{os.getpid()}")]:
                tmp.unlink()
            if self._created and all(p.name == LOCK for p in self.path.iterdir()):
                shutil.rmtree(self.path, ignore_errors=True)

    def __exit__(self, exc_type, exc, tb) -> None:
        if self._fd is None:
            return
        if self.cleanup is not None and self.abandon in self.cleanup:
            self.cleanup.remove(self.abandon)
        self.abandon()  # a folder this run created and wrote nothing into is not left behind
        os.close(self._fd)  # releases the lock
        self._fd = None
