"""What the commands write and where: the output folder of a run (`OutputFolder`: created,
checked writable and locked with `flock` before the work starts, an earlier run's files kept
unless --overwrite), a fit's files with result.json written last as their manifest, and the
recording names that become file names."""

import contextlib
import fcntl
import json
import os
import shutil
import sys
from collections.abc import Callable
from pathlib import Path

from ..io.files import LOCK, file_sha256, safe_name, stale_temporaries

RESULT = "result.json"


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

    def __init__(
        self,
        out: str | Path,
        earlier: Callable[[Path], list[Path]],
        overwrite: bool = False,
        what: str = "an earlier run",
        cleanup: list | None = None,
    ):
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
        """Create `folder` (checked by `_existing` first) and take its lock, or `FolderBusy`."""
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


def output_folder(args, earlier, what: str) -> OutputFolder:
    """The command's --out as an `OutputFolder` (a note printed where it writes elsewhere)."""
    return OutputFolder(
        args.out, earlier, overwrite=bool(getattr(args, "overwrite", False)), what=what, cleanup=getattr(args, "cleanup", None)
    )


def announce(out: OutputFolder) -> Path:
    """The folder the run writes; its note (another folder than the one asked for) on stderr."""
    if out.note:
        print(out.note, file=sys.stderr)
    return out.path


def fit_products(folder: Path) -> list[Path]:
    """An earlier fit's files in `folder`: its result.json."""
    return [folder / RESULT]


def each_products(folder: Path) -> list[Path]:
    """An earlier `fit --each`'s files in `folder`: its summary and every sub-folder's result.json."""
    return [folder / "summary.csv", folder / "summary.png", *sorted(folder.glob(f"*/{RESULT}"))]


def remove_result(path: Path) -> None:
    """An earlier result.json and the files its manifest lists ("files"), result.json first: a
    run stopped in between never leaves a result beside another run's files."""
    try:
        listed = json.loads(path.read_text(encoding="utf-8")).get("files") or {}
    except (OSError, ValueError, AttributeError):
        listed = {}
    path.unlink(missing_ok=True)
    for name in listed if isinstance(listed, dict) else ():
        sibling = path.parent / str(name)
        if sibling.parent == path.parent and sibling.is_file():  # a name, not a path
            sibling.unlink()


def remove_earlier(files: list[Path]) -> None:
    """What --overwrite replaces: each earlier result (with its listed files) and any other file;
    a folder left empty is removed (an `--each` run's sub-folder: the locked --out never is)."""
    for f in files:
        if f.name == RESULT:
            remove_result(f)
        else:
            f.unlink(missing_ok=True)
        if f.parent.is_dir() and not any(f.parent.iterdir()):
            f.parent.rmdir()


def save_fit(result, folder: Path, plot: bool = True) -> None:
    """fit.png (unless not `plot`), then result.json listing it with its sha256."""
    folder.mkdir(parents=True, exist_ok=True)
    files = {}
    if plot:
        result.plot(folder / "fit.png")
        files["fit.png"] = file_sha256(folder / "fit.png")
    result.to_json(folder / RESULT, files=files)


def drop_sidecars(paths: list[str]) -> list[str]:
    """`paths` without the JSON sidecars of the data files among them (`DIR/*` names both
    `run.csv` and `run.json`); a note says how many were left out."""
    stems = {(str(Path(p).parent), Path(p).stem) for p in paths if Path(p).suffix.lower() != ".json"}
    kept = [p for p in paths if not (Path(p).suffix.lower() == ".json" and (str(Path(p).parent), Path(p).stem) in stems)]
    if len(kept) < len(paths):
        print(
            f"note: {len(paths) - len(kept)} sidecar file(s) (.json beside a data file of the same name) left out of the data",
            file=sys.stderr,
        )
    return kept


def file_names(names: list[str]) -> list[str]:
    """One safe, distinct file name per recording name (`dcjax.io.files.safe_name`)."""
    taken: list[str] = []
    for n in names:
        taken.append(safe_name(n, taken))
    return taken
