"""result.json as data: its format and version, and a typed reader that checks every field it
uses and imports nothing.

A result names its model and integrator by a string. Reading it resolves only dcjax's built-in
names; a user's own model (`file.py:Name`, `module:attr`) or integrator is never imported on the
file's word: the reader gets it from the caller (`load_result(path, model=...)`) or
says so in one line. Numbers that a file could make huge (sub-steps, sizes) are bounded; a
non-finite objective is `null` in the file (strict JSON) and +inf when read; an edited value
that breaks the result (a NaN, a parameter outside its fitted range) is a one-line error
naming the field."""

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..errors import ResultFileError
from ..models import model_spec
from ..simulation.integrators import integrator_spec
from ..version import __version__
from .vector import unit_of

FORMAT = "dcjax result"
VERSION = 2  # 2: strict JSON (null for a non-finite number), data paths relative to the result's folder, "files"
MAX_BYTES = 256 << 20  # a result.json larger than this is refused before it is parsed
MAX_SUBSTEPS = 1 << 14  # settings.nd at most (an edited 1e9 would simulate for days)
MAX_RUNS = 100_000


def _short(v) -> str:
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


_ABSENT = object()  # no value passed: the field's own


class Fields:
    """Typed reads of one JSON object, each error naming the file and the field's path."""

    def __init__(self, path: Path, data, where: str = ""):
        self.path, self.data, self.where = path, data, where

    def error(self, field: str, what: str, value) -> ResultFileError:
        return ResultFileError(f"{self.path}: {self.where}{field} must be {what}, got {_short(value)}")

    def sub(self, field: str, required: bool = True) -> "Fields | None":
        v = self.data.get(field)
        if v is None and not required:
            return None
        if not isinstance(v, dict):
            raise self.error(field, "an object", v)
        return Fields(self.path, v, f"{self.where}{field}.")

    def number(self, field: str, value=_ABSENT, *, null=None, positive=False, lower=-math.inf) -> float:
        if value is _ABSENT and field not in self.data:
            raise ResultFileError(f"{self.path}: {self.where}{field} is missing")
        v = self.data.get(field) if value is _ABSENT else value
        if v is None and null is not None:
            return null
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < lower or (positive and not v > 0):
            what = "a positive number" if positive else "a finite number" + (f" >= {lower:g}" if lower > -math.inf else "")
            raise self.error(field, what + (" or null" if null is not None else ""), v)
        return float(v)

    def integer(self, field: str, lo: int = 0, hi: int | None = None, default=None) -> int:
        v = self.data.get(field, default)
        if isinstance(v, bool) or not isinstance(v, int) or v < lo or (hi is not None and v > hi):
            raise self.error(field, f"an integer {lo}..{hi}" if hi is not None else f"an integer >= {lo}", v)
        return int(v)

    def text(self, field: str, default=None, null_ok: bool = False) -> str | None:
        v = self.data.get(field, default)
        if v is None and null_ok:
            return None
        if not isinstance(v, str):
            raise self.error(field, "a string", v)
        return v

    def names(self, field: str, default=()) -> tuple[str, ...]:
        v = self.data.get(field, default)
        v = default if v is None else v
        if not isinstance(v, (list, tuple)) or not all(isinstance(n, str) for n in v):
            raise self.error(field, "a list of names", v)
        return tuple(v)

    def numbers(self, field: str, n: int | None = None, null=None, lower=-math.inf) -> list[float]:
        v = self.data.get(field)
        if not isinstance(v, list) or (n is not None and len(v) != n):
            raise self.error(field, f"a list of {n} numbers" if n is not None else "a list of numbers", v)
        return [self.number(f"{field}[{k}]", x, null=null, lower=lower) for k, x in enumerate(v)]

    def named_numbers(self, field: str, names=None, null=None, required: bool = True) -> dict[str, float]:
        v = self.data.get(field)
        if v is None and not required:
            return {}
        if not isinstance(v, dict):
            raise self.error(field, "an object of name -> number", v)
        out = {str(k): self.number(f"{field}.{k}", x, null=null) for k, x in v.items()}
        missing = [n for n in names or () if n not in out]
        if missing:
            raise ResultFileError(f"{self.path}: {self.where}{field} has no value of {', '.join(missing)}")
        return out


def read_record(path: Path) -> dict:
    """The checked content of a result file: the JSON object, or a one-line `ResultFileError`
    (no such file, too large, not JSON, not a dcjax result, a newer format)."""

    if not path.is_file():
        raise ResultFileError(f"no such result file: {path}")
    size = path.stat().st_size
    if size > MAX_BYTES:
        raise ResultFileError(f"{path}: {size / 2**20:.0f} MiB is not a result file (a result.json is at most {MAX_BYTES >> 20} MiB)")
    try:
        d = json.loads(path.read_bytes(), parse_constant=lambda c: None)  # a 0.2 file's NaN/Infinity: null
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise ResultFileError(f"{path}: not a result file (invalid JSON: {e})") from None
    if not isinstance(d, dict) or not {"params", "runs", "settings"} <= set(d):
        raise ResultFileError(f"{path}: not a dcjax result file (needs params, runs and settings)")
    version = d.get("version", 1)
    if d.get("format", FORMAT) != FORMAT or isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise ResultFileError(f"{path}: not a dcjax result file (format {d.get('format')!r}, version {version!r})")
    if version > VERSION:
        raise ResultFileError(f"{path}: a result of format version {version}, newer than this dcjax reads ({VERSION}): update dcjax")
    return d


def builtin_name(record: Fields, field: str, default: str, builtin, argument: str) -> str:
    """The result's `field` (its model, or settings.integrator) where it is a built-in name, else a
    one-line error: the file names code, which dcjax does not import on its word (`argument`: how
    the caller gives it instead)."""
    spec = record.text(field, default=default)
    assert spec is not None
    if spec.lower() in builtin:
        return spec.lower()
    if spec.startswith("__main__:"):
        name = spec.split(":", 1)[1]
        raise ResultFileError(
            f"{record.path}: {record.where}{field} {spec!r} was defined in a notebook or a script (__main__), which no other "
            f"process can import: give the file that defines it, {argument}='path/to/file.py:{name}', or in Python the model "
            f"itself ({name}(), as load_result's model argument)"
        )
    raise ResultFileError(
        f"{record.path}: {record.where}{field} {spec!r} is not built in ({', '.join(builtin)}), and dcjax does not import code a "
        f"result file names: give it yourself as {argument}={spec!r}"
    )


def within_bounds(path: Path, values: Mapping[str, float], names, lower, upper, fixed: Mapping[str, float]) -> None:
    """Each value inside its fitted range (a fixed one at its value): else the file was edited."""
    for n, lo, hi in zip(names, lower, upper):
        v = values[n]
        slack = 1e-9 * max(abs(lo) if math.isfinite(lo) else 0.0, abs(hi) if math.isfinite(hi) else 0.0, abs(v))
        if n not in fixed and not lo - slack <= v <= hi + slack:
            raise ResultFileError(
                f"{path}: params.{n} = {v:g} lies outside its fitted range [{lo:g}, {hi:g}]: the file was edited or damaged"
            )


def relative_to(path: str, folder: Path) -> str:
    """`path` relative to `folder` where it can be (a result moved with its data still finds
    it), else absolute."""

    try:
        return Path(os.path.relpath(Path(path).resolve(), folder.resolve())).as_posix()
    except ValueError:  # another drive
        return str(Path(path).resolve())


def settings_record(result) -> dict:
    """A `FitResult`'s configuration as result.json records it ("settings"), from its typed fields."""
    b, o = result.bounds, result.observation
    observed = {} if o.plain and result.layout is None else {**o.to_dict(), "names": list(result.names), "local": sorted(result.local)}
    names = list(result.recording_names)
    out = (
        observed
        | ({"log": list(result.log)} if result.log else {})
        | ({"priors": dict(result.priors)} if result.priors else {})
        | {
            "recording": names[0] if len(names) == 1 else names,
            "data": [dict(src) if isinstance(src, dict) else src for src in result.sources],
            "model": model_spec(result.model),
            "joint_weights": None if result.joint_weights is None else list(result.joint_weights),
            "method": result.search.method,
            "integrator": integrator_spec(result.integrator),
            "nd": result.integrator.substeps,
            "weights": list(result.weights),
            "bounds": {"lower": np.asarray(b.lower).tolist(), "upper": np.asarray(b.upper).tolist()},
            "fixed": dict(result.fixed),
            "x0": result.start or None,
            "runs": result.search.runs,
            "budget": result.search.budget,
            "seed": result.search.seed,
            "pop_size": result.search.pop_size,
            "polish": result.search.polish,
            "memory": result.search.memory,
            "precision": None if result.precision is None else list(result.precision),
            "generations": result.search.generations,
            "strategy": result.search.strategy,
            "ndata": result.ndata,
        }
    )
    if result.search.stop is not None:
        out["stop"] = dict(result.search.stop)
    if result.nd_auto is not None:
        out["nd_auto"] = result.nd_auto
    if result.limit_setting is not None:
        out["i_limit"] = result.limit_setting
    return out


def result_record(result) -> dict:
    """A `FitResult` as result.json holds it (strict JSON once `dcjax.io.files.strict_json` writes it)."""

    names = result.names
    return {
        "format": FORMAT,
        "version": VERSION,
        "params": dict(result.best_values),
        "parameters": result.params.to_dict(),  # value, min, max, vary, unit, precision, stderr
        "of": result.of,
        "runs": [
            {
                "of": float(o),
                "status": status.value,
                "params": dict(zip(names, map(float, p))),
                "fes": int(n),
                "iterations": int(it),
            }
            | ({} if result.dups is None else {"dups": int(result.dups[r])})
            for r, (o, p, n, it, status) in enumerate(
                zip(result.run_of, result.run_params, result.fes, result.iterations, result.run_status)
            )
        ],
        "stats": result.stats,
        "duplicates": result.duplicates,
        "mean_params": result.mean_params,
        "polish": result.polish,
        "settings": result.settings,
        "timing": result.timing,
        "model": model_spec(result.model),
        "names": list(names),
        "units": {n: unit_of(n, result.model) for n in names},
        "fixed": result.fixed,
        "free": [n for n in names if n not in result.fixed],
        "at_bound": result.at_bound(),
        "statistics": {
            "success": result.success,
            "nfev": result.nfev,
            "ndata": result.ndata,
            "nvarys": result.nvarys,
            "chisqr": result.chisqr,
            "redchi": result.redchi,
            "aic": result.aic,
            "bic": result.bic,
        },
        "checks": [f.to_dict() for f in result.checks],
        "history_best": [float(np.nanmin(h)) if np.any(np.isfinite(h)) else None for h in result.history],
        "dcjax_version": __version__,
    }
