"""Restoring a saved result (`load_result`): result.json read by the typed reader of
`dcjax.fitting.result_file` (nothing it names is imported), its recordings read again only where
their bytes are the ones fitted."""

import warnings
from pathlib import Path

import numpy as np

from ..analysis.checks import Finding
from ..errors import ConfigError
from ..io import datasets
from ..io.files import file_sha256
from ..io.loading import LOAD_KEYS, READING_KEYS, Reading, load_recording
from ..io.recording import Recording
from ..models import MODELS, Model, get_model
from ..models.bounds import Bounds
from ..models.priors import prior_from_spec
from ..simulation.integrators import INTEGRATORS, Integrator, get_integrator
from ..strategies.stopping import Converged
from .observation import Observation
from .result import FitResult
from .result_file import MAX_RUNS, MAX_SUBSTEPS, Fields, ResultFileError, builtin_name, read_record, within_bounds
from .search import RunStatus, SearchRecord
from .vector import layout_of


def load_result(
    path: str | Path,
    recordings: list[Recording] | None = None,
    model: Model | str | None = None,
    *,
    integrator: Integrator | None = None,
    allow_changed_data: bool = False,
) -> FitResult:
    """Restore a saved result (`result.json`) without refitting: parameters, runs, settings and,
    where they can be read, the recordings. Reading it runs no code the file names
    (`dcjax.fitting.result_file`): a built-in model and integrator by name; a model of your own
    as `model=` (a `Model`, or `"file.py:Name"` / `"module:attr"`, imported because you name it),
    an integrator of your own as `integrator=`. The recordings: `recordings`, else the data files
    the result names (relative to its folder), each read only where its bytes are the ones fitted
    (size and sha256; `allow_changed_data=True` reads a changed one, with a warning), and the
    embedded data sets; a file not read is named in a warning."""

    path = Path(path)
    top = Fields(path, read_record(path))
    s = top.sub("settings")
    assert s is not None
    base = get_model(model if model is not None else builtin_name(top, "model", "dc", MODELS, "model"))
    try:
        observation = Observation.from_settings(s.data)
        m = observation.check(base).observed(base)
    except (TypeError, ValueError) as e:
        raise ResultFileError(f"{path}: settings: {e}") from None
    names = s.names("names") or m.names
    params = top.named_numbers("params", names)
    nd = s.integer("nd", 1, MAX_SUBSTEPS, default=1)
    if integrator is None:
        integrator = get_integrator(builtin_name(s, "integrator", "rk4", (*INTEGRATORS, "discrete"), "integrator"), nd)
    elif not isinstance(integrator, Integrator):
        raise ConfigError(f"integrator must be a dcjax.Integrator, got {integrator!r}")
    b = s.sub("bounds")
    assert b is not None
    lower, upper = b.numbers("lower", len(names), null=-np.inf), b.numbers("upper", len(names), null=np.inf)
    fixed = top.named_numbers("fixed", required=False)
    within_bounds(path, params, names, lower, upper, fixed)
    runs = top.data["runs"]
    if not isinstance(runs, list) or not 1 <= len(runs) <= MAX_RUNS or not all(isinstance(r, dict) for r in runs):
        raise top.error("runs", f"a list of 1..{MAX_RUNS} objects", runs)
    run = [Fields(path, r, f"runs[{k}].") for k, r in enumerate(runs)]
    dups = [r.integer("dups", default=None) for r in run] if "dups" in runs[0] else None
    n_data = len(s.data.get("data") or [0])
    checks, polish, timing = _checked_rest(top)
    try:
        layout = None if "names" not in s.data else layout_of(names, m, observation, n_data)
    except ValueError as e:
        raise ResultFileError(f"{path}: settings.names: {e}") from None
    if recordings is None:
        recordings = _recorded_data(path, s, m, allow_changed_data)
    return FitResult(
        best_values=params,
        of=top.number("of", null=np.inf),
        run_of=np.array([r.number("of", null=np.inf) for r in run], float),
        run_params=np.array([[p[n] for n in names] for p in (r.named_numbers("params", names, null=np.nan) for r in run)], float),
        fes=np.array([r.integer("fes", default=0) for r in run]),
        iterations=np.array([r.integer("iterations", default=0) for r in run]),
        converged=np.array([r.data.get("status") == RunStatus.CONVERGED.value for r in run]),
        history=np.full((len(runs), 1), np.nan),  # the file keeps each run's last best only (history_best)
        timing=timing,
        polish=polish,
        dups=None if dups is None else np.array(dups),
        recordings=list(recordings),
        model=m,
        fixed=fixed,
        integrator=integrator,
        checks=checks,
        observation=observation,
        layout=layout,
        bounds=Bounds(lower, upper, names),
        **_recorded(s, m, names, n_data),
    )


def _checked_rest(top: Fields):
    """(checks, polish, timing) of a result, each checked (one-line errors naming the field)."""
    checks = top.data.get("checks") or []
    if not isinstance(checks, list) or not all(isinstance(c, dict) for c in checks):
        raise top.error("checks", "a list of objects", checks)
    for k, c in enumerate(checks):
        f = Fields(top.path, c, f"checks[{k}].")
        for field in ("check", "message"):
            f.text(field)
        f.text("channel", null_ok=True)
        if c.get("severity") not in ("error", "warning"):
            raise f.error("severity", "error or warning", c.get("severity"))
    polish = top.sub("polish", required=False)
    if polish is not None and "converged" in polish.data:
        conv = polish.data["converged"]
        if not isinstance(conv, list) or not all(isinstance(v, bool) for v in conv):
            raise polish.error("converged", "a list of true/false", conv)
    timing = top.data.get("timing") or {}
    if not isinstance(timing, dict):
        raise top.error("timing", "an object", timing)
    checks = tuple(Finding(c["check"], c["severity"], c["message"], c.get("channel")) for c in checks)
    return checks, None if polish is None else polish.data, timing


def _stop(s: Fields) -> dict | None:
    """The stopping rule a result's search ran with (`Converged.spec`), each value checked."""
    stop = s.sub("stop", required=False)
    if stop is None:
        return None
    try:
        return Converged(stop.number("rtol"), stop.number("atol"), stop.integer("patience", 1)).spec()
    except ConfigError as e:
        raise ResultFileError(f"{s.path}: settings.stop: {e}") from None


def _recorded(s: Fields, m: Model, names, n_data: int) -> dict:
    """The typed fields of a `FitResult` that its settings record: the search, the channel and
    joint weights, the data's sources, the start values, priors, local and log-scale names, the
    memory's precisions, the number of residuals, the automatic ND, a 0.1 limit; each checked."""
    optional = lambda what, n: None if s.data.get(what) is None else tuple(s.numbers(what, n, lower=0.0))
    generations = s.data.get("generations")
    memory, strategy = s.data.get("memory"), s.data.get("strategy", "")
    if memory is not None and not isinstance(memory, str):
        raise s.error("memory", "a memory's kind or null", memory)
    for n, spec in (s.sub("priors", required=False) or Fields(s.path, {})).data.items():
        try:
            prior_from_spec(spec)
        except ValueError as e:
            raise ResultFileError(f"{s.path}: settings.priors.{n}: {e}") from None
    sources = s.data.get("data") or []
    if not isinstance(sources, list) or not all(isinstance(d, (dict, str)) for d in sources):
        raise s.error("data", "a list of objects", sources)
    recording = s.data.get("recording")
    recording = [recording] if isinstance(recording, str) else recording or []
    if not isinstance(recording, list) or not all(isinstance(r, str) for r in recording):
        raise s.error("recording", "a name or a list of names", recording)
    nd_auto = s.sub("nd_auto", required=False)
    return dict(
        search=SearchRecord(
            s.text("method") or "",
            s.integer("runs", 1),
            s.integer("budget", 1),
            s.integer("seed", -(2**63)),
            s.integer("pop_size", 1, default=1),
            None if generations is None else s.integer("generations", 1),
            memory,
            bool(s.data.get("polish", False)),
            strategy if isinstance(strategy, str) else "",
            _stop(s),
        ),
        weights=optional("weights", len(m.outputs)) or (),
        joint_weights=optional("joint_weights", n_data),
        sources=tuple(sources),
        recording_names=tuple(recording),
        start=s.named_numbers("x0", required=False) or None,
        priors=dict((s.sub("priors", required=False) or Fields(s.path, {})).data),
        local=s.names("local"),
        log=s.names("log"),
        precision=optional("precision", len(names)),
        data_points=None if s.data.get("ndata") is None else s.integer("ndata", 0),
        nd_auto=None if nd_auto is None else nd_auto.data,
        limit_setting=None if s.data.get("i_limit") is None else s.number("i_limit", positive=True),
    )


def _recorded_data(path: Path, settings: Fields, model: Model, allow_changed: bool) -> list[Recording]:
    """The recordings a result names (`load_result`): each data file resolved against the
    result's folder and read only where its bytes are the fitted ones; an embedded data set by
    name. A recording that is not read is named in a warning; the others are kept."""

    data = settings.data.get("data") or []
    if not isinstance(data, list):
        raise settings.error("data", "a list", data)
    out = []
    for k, src in enumerate(data):
        if not isinstance(src, dict):
            continue
        f = Fields(path, src, f"settings.data[{k}].")
        if src.get("embedded"):
            try:
                rec = datasets.load(f.text("embedded") or "")
            except ValueError as e:
                raise ResultFileError(f"{path}: settings.data[{k}].embedded: {e}") from None
        elif src.get("path"):
            file = Path(f.text("path") or "")
            file = file if file.is_absolute() else path.parent / file
            why = _changed(f, file)
            if why is not None and (not allow_changed or why.startswith("is not")):
                warnings.warn(
                    f"{path.name}: its data file {file} {why}: loaded without it (give the recordings: "
                    "recordings=[...]; a changed file: allow_changed_data=True)",
                    stacklevel=3,
                )
                continue
            if why is not None:
                warnings.warn(f"{path.name}: its data file {file} {why}; read anyway (allow_changed_data=True)", stacklevel=3)
            load = f.sub("load", required=False)
            kw = {} if load is None else load.data
            bad = [key for key in kw if key not in LOAD_KEYS]
            if bad:
                raise ResultFileError(f"{path}: settings.data[{k}].load has unknown field(s) {', '.join(bad)}")
            try:  # the reading options checked by type (`Reading.from_record`); the result's model names the channels
                kept = {key: v for key, v in kw.items() if key not in READING_KEYS and key != "model"}
                rec = load_recording(file, reading=Reading.from_record(kw), model=model, **kept)
            except (TypeError, ValueError) as e:
                raise ResultFileError(f"{path}: settings.data[{k}]: {(str(e).splitlines() or [''])[0]}") from None
        else:
            continue
        if "limit" in src:  # the limit fitted (given on the command line, or the sidecar's)
            limit = None if src["limit"] is None else f.number("limit", positive=True)
            rec = rec if limit == rec.limit else rec.replace(limit=limit)
        out.append(rec)
    return out


UNSIZED_HASH_BYTES = 1 << 30


def _changed(src: Fields, file: Path) -> str | None:
    """Why a recorded data file cannot be taken for the fitted one (None: its size, sha256 and
    its sidecar's sha256 are the recorded ones). Only a regular file's bytes are hashed."""

    if not file.is_file():
        return "is not there"
    size = src.data.get("bytes")
    if size is not None and size != file.stat().st_size:
        return "changed since the fit (its size differs)"
    if size is None and file.stat().st_size > UNSIZED_HASH_BYTES:  # a 0.3 result records no size: hash no huge file on its word
        return f"has no recorded size, and at {file.stat().st_size / 2**30:.1f} GiB is not hashed to check it"
    sha = src.data.get("sha256")
    if not isinstance(sha, str):
        return "has no recorded sha256 to check it by"
    if file_sha256(file) != sha:
        return "changed since the fit (its sha256 differs)"
    side = src.data.get("sidecar_sha256")
    sidecar = file.with_suffix(".json")
    if side is not None and (not sidecar.is_file() or file_sha256(sidecar) != side):
        return "has a changed sidecar (its sha256 differs)"
    return None
