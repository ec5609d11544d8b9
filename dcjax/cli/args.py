"""The command line's parser and the parsing of its NAME=VALUE options."""

import argparse

from ..errors import ConfigError
from ..fitting.search import MANY_STEPS, Search
from ..io.units import parse_mapping
from ..models import MODELS
from ..models.priors import prior_from_spec
from ..simulation.integrators import INTEGRATORS
from ..strategies import METHODS
from ..strategies.memory import MEMORIES
from ..version import __version__


def _floats(text: str, what: str, n: int | None = None) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise ConfigError(f"{what} must be comma-separated numbers, got {text!r}") from None
    if n is not None and len(values) != n:
        raise ConfigError(f"{what} must be {n} comma-separated numbers, got {len(values)}")
    return values


def _named_floats(text: str | None, what: str) -> dict[str, float]:
    out = {}
    for k, v in parse_mapping(text, what).items():
        try:
            out[k] = float(v)
        except ValueError:
            raise ConfigError(f"{what}: value of {k} must be a number, got {v!r}") from None
    return out


def _names(text: str | None, what: str) -> tuple[str, ...]:
    """A comma-separated list of names (None: none)."""
    if text is None:
        return ()
    names = tuple(n.strip() for n in text.split(","))
    if not all(names):
        raise ConfigError(f"{what} must be comma-separated names, got {text!r}")
    return names


def _named_ranges(text: str | None, what: str) -> dict[str, tuple[float, float]]:
    out = {}
    for k, v in parse_mapping(text, what).items():
        lo, sep, hi = v.partition(":")
        try:
            out[k] = (float(lo), float(hi))
        except ValueError:
            raise ConfigError(f"{what}: {k} needs LOWER:UPPER, got {v!r}") from None
        if not sep:
            raise ConfigError(f"{what}: {k} needs LOWER:UPPER, got {v!r}")
    return out


def _named_priors(items: list[str] | None) -> dict[str, str]:
    """`--prior NAME=SPEC` (repeatable; `;` also separates): name -> prior spec, checked."""

    out = {}
    for item in [part for text in items or [] for part in text.split(";") if part.strip()]:
        name, sep, spec = item.partition("=")
        if not sep or not name.strip():
            raise ConfigError(f"--prior must be NAME=SPEC, e.g. J=lognormal(1e-4,0.5), got {item!r}")
        out[name.strip()] = prior_from_spec(spec).spec
    return out


def _add_data_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("reading the data")
    g.add_argument(
        "--columns",
        default=None,
        help="channel=column pairs, e.g. for the DC motor t=time_ms,u_a=U,i_a=I,omega=n (names or 0-based indices)",
    )
    g.add_argument("--units", default=None, help="channel=unit pairs, e.g. for the DC motor t=ms,i_a=mA,omega=rpm (converted to SI)")
    g.add_argument("--delimiter", default=None, help="',', ';', 'tab' or 'whitespace' (default: detected)")
    g.add_argument("--decimal", default=".", help="decimal separator, '.' or ','")
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
        default=None,
        help='inputs constant in this recording instead of a column, e.g. kp=100,mass=0.49 (over the sidecar\'s "constants")',
    )
    g.add_argument(
        "--scale",
        default=None,
        help="channel=factor pairs applied after --units, e.g. for the DC motor omega=322.67 (gear ratio / wheel radius)",
    )
    g.add_argument("--dt", type=float, default=None, help="sample time (s) for a file without a time column")
    g.add_argument("--rate", type=float, default=None, help="sample rate (Hz) for a file without a time column")


def _add_experiment_options(f: argparse.ArgumentParser) -> None:
    g = f.add_argument_group("the experiment: loss, initial state, per-recording parameters, sensors")
    g.add_argument("--loss", default=None, help="sse (default: the paper's eq. 24/27), l1 (mean absolute error) or huber:DELTA")
    g.add_argument(
        "--normalize",
        default=None,
        choices=["peak", "none"],
        help="peak (default): residuals over each channel's peak; none: raw units, a joint fit pooled by sample count",
    )
    g.add_argument(
        "--initial",
        default=None,
        help="initial states, STATE=SPEC pairs: a number, measured (default where measured), derivative (default for a "
        "derivative state) or fit (a free y0_STATE per recording), e.g. for the DC motor omega=fit",
    )
    g.add_argument(
        "--local",
        default=None,
        help="parameters with one value per recording of a joint fit, e.g. for the DC motor Tla or Tla,offset_i_a (listed as Tla[0], Tla[1], ...)",
    )
    g.add_argument(
        "--hold",
        default=None,
        help="how an input acts between its samples, INPUT=linear|zoh pairs (default linear, "
        "eq. 29; zoh: held until the next sample, as a drive's PWM updated once per sample), e.g. for the DC motor u_a=zoh",
    )
    g.add_argument(
        "--measure",
        default=None,
        help="the states compared with the recording (default: the model's measured states), "
        "e.g. for the DC motor with only its speed logged omega; a column named after another state still gives its initial state",
    )
    g.add_argument(
        "--offset",
        default=None,
        help="measured channels with a free additive sensor offset offset_CH (range +-10%% of "
        "the peak; --bound offset_CH=LO:HI), e.g. for the DC motor i_a",
    )
    g.add_argument(
        "--delay",
        default=None,
        help="inputs with a free delay delay_IN in seconds (range 0..10 samples; --bound delay_IN=LO:HI), e.g. for the DC motor u_a",
    )


def _add_result_options(p: argparse.ArgumentParser, data: bool = False) -> None:
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


def _add_overwrite(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace an earlier run's files in --out (default: keep them and write to OUT-2, OUT-3, ..., with a note)",
    )


def _add_design_parser(sub) -> None:
    """`dcjax design`: its options."""
    d = sub.add_parser("design", help="design the next experiment's input from a fit (optimal input design)")
    d.add_argument("result", help="result.json of a fit")
    d.add_argument("--duration", type=float, required=True, help="length of the test (s)")
    d.add_argument("--dt", type=float, required=True, help="sample time (s)")
    d.add_argument("--umin", type=float, default=None, help="lowest level of every designed input (in its unit, e.g. V)")
    d.add_argument("--umax", type=float, default=None, help="highest level of every designed input")
    d.add_argument("--range", default=None, help="a designed input's own range, NAME=LO:HI pairs over --umin/--umax, e.g. uq=-5:5,ud=-2:2")
    d.add_argument(
        "--keep",
        default=None,
        help="inputs not designed but kept as the fitted recording has them, e.g. ud "
        "(every other input that is not a constant is designed)",
    )
    d.add_argument(
        "--const", default=None, help="inputs constant in the designed test, e.g. pp=4 (default: the fitted recording's constants)"
    )
    d.add_argument("--hold", type=float, default=None, help="shortest time an input level is held (s; default duration/20)")
    d.add_argument(
        "--limit",
        "--i-limit",
        dest="limit",
        type=float,
        default=None,
        help="the clamp on the model's limited state (the DC motor: the supply current limit, A; default the fitted recording's)",
    )
    d.add_argument(
        "--criterion", default="d", help="d (D-optimal, default), a (A-optimal) or parameter names, e.g. for the DC motor J,Tla,Tlb,Tlc"
    )
    d.add_argument(
        "--noise",
        default=None,
        help="noise std. dev. per channel, e.g. for the DC motor i_a=0.05,omega=0.5 (default: the fit's residuals, "
        "or 1%% of each channel's peak under a full step where the fit left none)",
    )
    d.add_argument(
        "--baseline",
        action="append",
        default=[],
        help="CSV of an input you would run otherwise (columns t and the input, or the input alone on the design's grid); "
        "the design must then predict smaller standard errors than every baseline in each parameter of the criterion "
        "(repeatable)",
    )
    d.add_argument("--starts", type=int, default=8, help="optimizer starts")
    d.add_argument("--steps", type=int, default=300, help="optimizer steps per start")
    d.add_argument("--seed", type=int, default=0)
    d.add_argument("--out", default="design", help="output folder")
    _add_overwrite(d)
    _add_result_options(d, data=True)


def _add_saved_parsers(sub) -> None:
    """`dcjax simulate | validate | design | sample | report`: the commands on a saved result."""
    s = sub.add_parser("simulate", help="simulate a saved result on a recording: CSV of measured and simulated channels, and a plot")
    s.add_argument("result", help="result.json of a fit")
    s.add_argument("data", help="data file or embedded name")
    s.add_argument("--out", default="out", help="output folder")
    _add_overwrite(s)
    _add_result_options(s)
    _add_data_options(s)
    v = sub.add_parser("validate", help="OF and fit %% per channel of a saved result on other recordings, with plots")
    v.add_argument("result", help="result.json of a fit")
    v.add_argument("data", nargs="+", help="data file(s) or embedded names")
    v.add_argument("--out", default="out", help="output folder")
    _add_overwrite(v)
    _add_result_options(v)
    _add_data_options(v)
    _add_design_parser(sub)
    m = sub.add_parser("sample", help="posterior draws of a saved result's parameters (NUTS through the simulator), with R-hat and ESS")
    m.add_argument("result", help="result.json of a fit (its data files are read again)")
    m.add_argument("--draws", type=int, default=1000, help="draws per chain after warmup (default 1000)")
    m.add_argument("--chains", type=int, default=4, help="chains, run side by side (default 4)")
    m.add_argument("--warmup", type=int, default=1000, help="warmup steps per chain: step size and dense mass matrix (default 1000)")
    m.add_argument("--seed", type=int, default=0, help="random seed (same seed, same draws)")
    m.add_argument("--out", default="out", help="output folder for posterior.npz and corner.png")
    _add_overwrite(m)
    _add_result_options(m, data=True)
    m.add_argument(
        "--prior",
        action="append",
        default=None,
        metavar="NAME=SPEC",
        help="a parameter's own prior within its range instead of the uniform one: normal(MEAN,SD), lognormal(MEDIAN,SIGMA) "
        "or halfnormal(SD), e.g. for the DC motor --prior 'J=lognormal(1e-4,0.5)' (repeatable)",
    )
    r = sub.add_parser("report", help="print the fit report of a saved result")
    r.add_argument("result", help="result.json of a fit")
    r.add_argument("--uncertainty", action="store_true", help="compute standard errors (needs the fitted data file)")
    r.add_argument(
        "--posterior",
        default=None,
        help="posterior.npz of `dcjax sample` to report beside (default: the one beside RESULT.json sampled from it, if any)",
    )
    _add_result_options(r, data=True)


def _parser() -> argparse.ArgumentParser:

    p = argparse.ArgumentParser(prog="dcjax", description="Motor and drive parameter identification (Jesenik et al. 2020).")
    p.add_argument("--version", action="version", version=f"dcjax {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    f = sub.add_parser("fit", help="identify a model's parameters from recordings")
    f.add_argument("data", nargs="+", help="data file(s) or embedded names (SD1..SD4, MD1..MD4); several = joint fit (see --each)")
    f.add_argument(
        "--each",
        action="store_true",
        help="fit every file on its own: DIR/<name>/ per file, DIR/summary.csv and DIR/summary.png; "
        "exit 0 all fitted, 1 some failed, 2 none fitted",
    )
    f.add_argument(
        "--model", default="dc", help=f"{', '.join(MODELS)} (built in; dc the default), package.module:attr or path/to/file.py:Name"
    )
    PAPER_SEARCH, MANY_SEARCH = Search.paper(), Search.many()
    f.add_argument(
        "--method",
        default=None,
        help=f"{', '.join(METHODS)}, cma-es or an evosax algorithm (CMA_ES, PSO, ...); default "
        f"{PAPER_SEARCH.method}, and {MANY_SEARCH.method} for a joint fit of >= {MANY_STEPS:,} samples (many recordings)",
    )
    f.add_argument(
        "--integrator",
        default=None,
        choices=list(INTEGRATORS),
        help="default rk4; diffrax: adaptive, for a stiff model (a discrete-time model takes none)",
    )
    f.add_argument("--nd", default="1", help="sub-steps per sample interval (eq. 28), or 'auto'")
    f.add_argument(
        "--runs", type=int, default=None, help=f"default {PAPER_SEARCH.runs}; {MANY_SEARCH.runs} for a joint fit of many recordings"
    )
    f.add_argument(
        "--budget",
        type=int,
        default=None,
        help=f"fitness evaluations per run; default {PAPER_SEARCH.budget:,}, {MANY_SEARCH.budget:,} for a joint fit of many recordings",
    )
    f.add_argument("--seed", type=int, default=0)
    f.add_argument("--weights", default=None, help="one weight per measured channel, e.g. 1,1 (eq. 27; default all 1 = eq. 24)")
    f.add_argument(
        "--bounds",
        default=None,
        help="auto (ranges from an equation-error first estimate) or a preset of the model, e.g. table4, table8 "
        "(default: the sidecar's 'bounds', else auto)",
    )
    f.add_argument("--bound", default=None, help="per-parameter bounds over the preset, e.g. for the DC motor Ra=0:10,J=0:0.1")
    f.add_argument(
        "--log",
        default=None,
        help="parameters searched on a log scale (uniform in decades; each needs a range above 0, "
        "e.g. --bound Tlc=1e-10:1e-5), e.g. for the DC motor Tlb,Tlc",
    )
    f.add_argument("--lower", default=None, help="all lower bounds, comma-separated in the model's order")
    f.add_argument("--upper", default=None, help="all upper bounds, comma-separated in the model's order")
    f.add_argument("--fix", default=None, help="known parameters, not searched, e.g. for the DC motor Ra=42.5,Tlc=0")
    f.add_argument("--x0", default=None, help="start values seeding the initial population, e.g. for the DC motor Ra=40,J=2e-5")
    f.add_argument("--polish", action="store_true", help="Levenberg-Marquardt polish of every run (sse and huber losses)")
    _add_experiment_options(f)
    f.add_argument("--uncertainty", action="store_true", help="standard errors, 95%% intervals and identifiability")
    f.add_argument(
        "--memory",
        default=None,
        choices=list(MEMORIES),
        help="memory assistance (Section 4.4; ltma-hash: indexed)",
    )
    f.add_argument("--precision", default=None, help="duplicate precisions, NAME=VALUE pairs or one value per parameter (default Table 29)")
    f.add_argument("--generations", type=int, default=None, help="stop each run after this many iterations")
    f.add_argument(
        "--plots",
        default=None,
        choices=["each", "summary", "none"],
        help="with --each: a fit.png per file (each), only summary.png (summary, the default: a file's plot costs more than its "
        "search at --runs 2), or none; a single or joint fit: none (no fit.png)",
    )
    f.add_argument("--out", default="out", help="output folder for result.json and fit.png")
    _add_overwrite(f)
    f.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar on stderr (default: when stderr is a terminal)",
    )
    _add_data_options(f)
    _add_saved_parsers(sub)
    return p
