"""What the commands write and where: the output folder of a run (`dcjax.io.files.OutputFolder`:
checked, locked, an earlier run's files kept unless --overwrite), a fit's files with result.json
written last as their manifest, and the recording names that become file names."""

import json
import sys
from pathlib import Path

from ..io.files import OutputFolder, file_sha256, safe_name

RESULT = "result.json"


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
        listed = json.loads(path.read_text()).get("files") or {}
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
        print(f"note: {len(paths) - len(kept)} sidecar file(s) (.json beside a data file of the same name) left out of the data",
              file=sys.stderr)  # fmt: skip
    return kept


def file_names(names: list[str]) -> list[str]:
    """One safe, distinct file name per recording name (`dcjax.io.files.safe_name`)."""
    taken: list[str] = []
    for n in names:
        taken.append(safe_name(n, taken))
    return taken
