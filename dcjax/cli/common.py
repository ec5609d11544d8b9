"""What several commands share: the options of reading data and of reading a saved result, the
`Loader` that reads a command's data as its flags say, and a saved result with its recordings
(`saved_result`, `load_like_fit`)."""

import argparse
import dataclasses
import warnings
from pathlib import Path

import numpy as np

from ..analysis.checks import pulse_width
from ..fitting.problems import with_weights
from ..fitting.restore import load_result
from ..fitting.result import FitResult
from ..io import datasets
from ..io.loading import Reading, load_recording, preprocess
from ..io.recording import Recording, check_constants
from ..io.units import ColumnError
from ..models import Model
from .values import mapping, named_numbers


def add_data_options(p: argparse.ArgumentParser) -> None:
    """How a command reads its data files (`Loader`)."""
    g = p.add_argument_group("reading the data")
    g.add_argument(
        "--columns",
        type=mapping,
        default=None,
        help="channel=column pairs, e.g. for the DC motor t=time_ms,u_a=U,i_a=I,omega=n (names or 0-based indices)",
    )
    g.add_argument(
        "--units", type=mapping, default=None, help="channel=unit pairs, e.g. for the DC motor t=ms,i_a=mA,omega=rpm (converted to SI)"
    )
    g.add_argument("--delimiter", default=None, help="',', ';', 'tab' or 'whitespace' (default: detected)")
    g.add_argument("--decimal", default=None, help="decimal separator, '.' or ',' (default: detected)")
    g.add_argument(
        "--drop-nan",
        action="store_true",
        help="drop the rows with a NaN/inf or an empty field in a channel read, with a one-line count (default: such a row is an error)",
    )
    g.add_argument("--window", default=None, help="keep T0:T1 (seconds)")
    g.add_argument("--every", type=int, default=None, help="keep every K-th sample")
    g.add_argument("--trim", action="store_true", help="cut the samples before the model's first input is switched on (the DC motor: u_a)")
    g.add_argument(
        "--limit",
        "--i-limit",
        dest="limit",
        type=float,
        default=None,
        help="the clamp on the model's limited state (the DC motor: the supply's current limit on i_a, in A); "
        "an error for a model that clamps no state",
    )
    g.add_argument(
        "--const",
        type=named_numbers,
        default=None,
        help='inputs constant in this recording instead of a column, e.g. kp=100,mass=0.49 (over the sidecar\'s "constants")',
    )
    g.add_argument(
        "--scale",
        type=named_numbers,
        default=None,
        help="channel=factor pairs applied after --units, e.g. for the DC motor omega=322.67 (gear ratio / wheel radius)",
    )
    g.add_argument("--dt", type=float, default=None, help="sample time (s) for a file without a time column")
    g.add_argument("--rate", type=float, default=None, help="sample rate (Hz) for a file without a time column")


def add_result_options(p: argparse.ArgumentParser, data: bool = False) -> None:
    """The options of a command that reads a saved result (and where `data`, its recordings)."""
    p.add_argument(
        "--model",
        default=None,
        help="the fit's model where it is not built in, path/to/file.py:Name or package.module:attr "
        "(a result file names it, but dcjax imports no code on a file's word)",
    )
    if data:
        p.add_argument(
            "--data",
            dest="data_files",
            nargs="+",
            default=None,
            metavar="FILE",
            help="the fitted recordings (default: the files the result names, where their bytes are the ones fitted)",
        )
    p.add_argument(
        "--allow-changed-data",
        action="store_true",
        help="read a data file the result names even where it changed since the fit (its sha256 differs), with a warning",
    )


def add_output_options(p: argparse.ArgumentParser, out: str, what: str) -> None:
    """--out (default `out`) and --overwrite."""
    p.add_argument("--out", default=out, help=f"output folder for {what}")
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace an earlier run's files in --out (default: keep them and write to OUT-2, OUT-3, ..., with a note)",
    )


@dataclasses.dataclass(frozen=True)
class Loader:
    """A command's data read as its flags say: a file (or an embedded data set's name) read with
    `reading`, then what is kept of it (`window` T0:T1, `every` K-th sample, `trim` before the
    switch-on), the clamp `limit` (also on an embedded data set) and the channel `weights`;
    `measured=False`: a file of the inputs to simulate (the outputs read where present)."""

    model: Model
    reading: Reading = Reading()
    window: str | None = None
    every: int | None = None
    trim: bool = False
    limit: float | None = None
    weights: tuple[float, ...] | None = None
    measured: bool = True

    @classmethod
    def of(cls, args: argparse.Namespace, model: Model, weights: tuple[float, ...] | None = None, measured: bool = True) -> "Loader":
        """The loader of a command with the data options (`add_data_options`)."""
        reading = Reading(
            args.columns, args.units, args.scale, args.dt, args.rate, args.delimiter, args.decimal, args.const, bool(args.drop_nan)
        )
        return cls(model, reading, args.window, args.every, bool(args.trim), args.limit, weights, measured)

    def __call__(self, data: str) -> Recording:
        if not Path(data).exists() and data.upper() in datasets.EMBEDDED:
            rec = datasets.load(data)  # --columns, --units, --scale, --dt, --rate are for files
            check_constants(self.model, self.reading.constants)
            if self.reading.constants:
                rec = rec.replace(constants={**rec.constants, **self.reading.constants})
            if self.window or self.every or self.trim:
                rec = preprocess(rec, self.window, self.every, self.trim, self.model)
        else:
            rec = load_recording(
                data,
                model=self.model,
                limit=self.limit,
                window=self.window,
                every=self.every,
                trim=self.trim,
                reading=self.reading,
                measured=self.measured,
            )
        if self.limit is not None and rec.limit != self.limit:
            rec = rec.replace(limit=self.limit)
        if self.weights is not None:
            rec = with_weights(rec, dict(zip(self.model.outputs, self.weights)))
        return rec


def saved_result(args: argparse.Namespace) -> FitResult:
    """The saved result of `args.result`: its model named by the file where built in, else by
    --model; its recordings --data where given (read in the fit's layout), else the files it
    names where their bytes are the fitted ones (--allow-changed-data: read changed ones too)."""

    model = getattr(args, "model", None)
    data = getattr(args, "data_files", None)
    if not data:
        return load_result(args.result, model=model, allow_changed_data=bool(getattr(args, "allow_changed_data", False)))
    res = load_result(args.result, [], model=model)
    return load_result(args.result, [load_like_fit(d, Loader(res.model), res) for d in data], model=model)


def load_like_fit(data: str, loader: Loader, res: FitResult) -> Recording:
    """`data` read as the fit read its file: the loader's reading options where any is given
    (they replace the fit's as a whole); none given, a file in the fit's layout (its mapped
    columns are there) is read with the fit's (`result.json`'s `load`), and one without them
    whose header names the model's channels by its own header, with a note (the fit's unit
    conversions are not applied to it). A channel whose peak differs from the fitted
    recording's by more than 10x gets a one-line warning (a unit or scale slip)."""

    src = next((d for d in res.settings.get("data") or [] if isinstance(d, dict)), {})
    fitted = Reading.from_record(src.get("load"))
    if loader.reading.given or not fitted.given or not Path(data).exists():
        rec = loader(data)
    else:
        try:
            rec = dataclasses.replace(loader, reading=fitted)(data)
        except ColumnError as e:
            try:
                rec = dataclasses.replace(loader, reading=Reading(constants=fitted.constants))(data)
            except ValueError:
                raise e from None
            print(
                f"note: {Path(data).name} is not in the fit's layout ({e.args[0].split('; ')[0].split(': ')[-1]}): read by its own "
                f"header ({', '.join(res.model.channels)}), without the fit's units and scales"
            )
    for c, peak_fit in (src.get("peaks") or {}).items():
        if c in rec.channels and peak_fit > 0:
            peak = float(np.max(np.abs(rec[c])))
            ratio = peak / peak_fit
            if not 0.1 <= ratio <= 10 and pulse_width(np.asarray(rec[c], float)) < 2:  # a short pulse, not a unit
                warnings.warn(
                    f"{rec.name}: the peak of {c} ({peak:.4g}, {ratio:.3g}x the fitted recording's) is a pulse shorter than two samples",
                    stacklevel=2,
                )
            elif not 0.1 <= ratio <= 10:
                warnings.warn(
                    f"{rec.name}: the peak of {c} is {ratio:.3g}x the fitted recording's ({peak:.4g} vs {peak_fit:.4g}): "
                    "a unit or scale slip? (--units, --scale)",
                    stacklevel=2,
                )
    return rec
