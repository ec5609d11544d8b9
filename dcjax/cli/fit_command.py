"""`dcjax fit`'s flags (`add_arguments`) and the library's typed objects they make, once
(`FitCommand.of`): the model, the `Loader` of the data, the `ParameterSpec`, the `Observation`,
the integrator, the search's changes to the default `Search`, the output folder."""

import argparse
import dataclasses
import sys
from collections.abc import Mapping

from ..analysis.held_out import DEFAULT_INITIAL
from ..errors import ConfigError
from ..fitting.observation import Observation
from ..fitting.parameter_spec import ParameterSpec
from ..fitting.search import MANY, MANY_STEPS, Search
from ..models import MODELS, DiscreteModel, Model, get_model
from ..simulation.integrators import INTEGRATORS, AutoSubsteps, Integrator
from ..simulation.losses import get_loss
from ..strategies import METHODS
from ..strategies.memory import MEMORIES
from ..strategies.stopping import Converged
from .common import Loader, add_data_options, add_output_options
from .output import OutputFolder, drop_sidecars, each_products, fit_products
from .validation_lines import INITIAL_HELP, SKIP_HELP, skip_samples
from .values import mapping, named_numbers, named_numbers_or_numbers, named_ranges, names, numbers, stop_rule, substeps

NOT_GIVEN = object()  # --stop absent: the default's rule


def add_arguments(f: argparse.ArgumentParser) -> None:
    """`dcjax fit`'s flags, each made its type as it is parsed (`dcjax.cli.values`)."""
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
    paper = Search.paper()
    f.add_argument(
        "--method",
        default=None,
        help=f"{', '.join(METHODS)}, cma-es or an evosax algorithm (CMA_ES, PSO, ...); default "
        f"{paper.method}, and {MANY['method']} with {MANY['pop_size']} members for a joint fit of >= {MANY_STEPS:,} samples (many recordings)",
    )
    f.add_argument(
        "--integrator",
        default=None,
        choices=list(INTEGRATORS),
        help="default rk4; diffrax: adaptive, for a stiff model (a discrete-time model takes none)",
    )
    f.add_argument("--nd", type=substeps, default=None, help="sub-steps per sample interval (eq. 28), or 'auto' (default 1)")
    f.add_argument("--runs", type=int, default=None, help=f"default {paper.runs}; {MANY['runs']} for a joint fit of many recordings")
    f.add_argument(
        "--budget",
        type=int,
        default=None,
        help=f"fitness evaluations per run (at most, where a run stops on convergence: --stop); default {paper.budget:,}, "
        f"{MANY['budget']:,} for a joint fit of many recordings",
    )
    f.add_argument("--seed", type=int, default=None)
    f.add_argument(
        "--weights", type=numbers, default=None, help="one weight per measured channel, e.g. 1,1 (eq. 27; default all 1 = eq. 24)"
    )
    f.add_argument(
        "--bounds",
        default=None,
        help="auto (ranges from an equation-error first estimate) or a preset of the model, e.g. table4, table8 "
        "(default: the sidecar's 'bounds', else auto)",
    )
    f.add_argument(
        "--bound", type=named_ranges, default={}, help="per-parameter bounds over the preset, e.g. for the DC motor Ra=0:10,J=0:0.1"
    )
    f.add_argument(
        "--log",
        type=names,
        default=(),
        help="parameters searched on a log scale (uniform in decades; each needs a range above 0, "
        "e.g. --bound Tlc=1e-10:1e-5), e.g. for the DC motor Tlb,Tlc",
    )
    f.add_argument("--lower", type=numbers, default=None, help="all lower bounds, comma-separated in the model's order")
    f.add_argument("--upper", type=numbers, default=None, help="all upper bounds, comma-separated in the model's order")
    f.add_argument("--fix", type=named_numbers, default={}, help="known parameters, not searched, e.g. for the DC motor Ra=42.5,Tlc=0")
    f.add_argument(
        "--x0", type=named_numbers, default={}, help="start values seeding the initial population, e.g. for the DC motor Ra=40,J=2e-5"
    )
    f.add_argument("--polish", action="store_true", default=None, help="Levenberg-Marquardt polish of every run (sse and huber losses)")
    _add_experiment_arguments(f)
    f.add_argument("--uncertainty", action="store_true", help="standard errors, 95%% intervals and identifiability")
    f.add_argument("--memory", default=None, choices=list(MEMORIES), help="memory assistance (Section 4.4; ltma-hash: indexed)")
    f.add_argument(
        "--precision",
        type=named_numbers_or_numbers,
        default=None,
        help="duplicate precisions, NAME=VALUE pairs or one value per parameter (default Table 29)",
    )
    f.add_argument("--generations", type=int, default=None, help="stop each run after this many iterations")
    f.add_argument(
        "--stop",
        type=stop_rule,
        nargs="?",
        const={},
        default=NOT_GIVEN,
        metavar="rtol=R,atol=A,patience=G|never",
        help="end a run once it has converged (its best OF improved by at most R|best| + A over G iterations, and for the DEs, "
        "TLBO and CMA-ES more than half its population's OFs within that of the best); the budget stays the upper bound "
        f"(R={Converged().rtol:g}, A={Converged().atol:g}, G={Converged().patience} where not given); never: every run spends its "
        "budget. Default: the rule with those values, and never for the paper's data (a sidecar naming table4 or table8)",
    )
    f.add_argument(
        "--plots",
        default=None,
        choices=["each", "summary", "none"],
        help="with --each: a fit.png per file (each), only summary.png (summary, the default: a file's plot costs more than its "
        "search at --runs 2), or none; a single or joint fit: none (no fit.png)",
    )
    add_output_options(f, "out", "result.json and fit.png")
    _add_held_out_arguments(f)
    f.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar on stderr (default: when stderr is a terminal)",
    )
    add_data_options(f)


def _add_held_out_arguments(f: argparse.ArgumentParser) -> None:
    g = f.add_argument_group("judged on other recordings (as dcjax validate)")
    g.add_argument(
        "--validate", nargs="+", default=None, metavar="FILE", help="held-out recordings to validate the fit on, read as the fitted ones"
    )
    g.add_argument("--validate-initial", default=DEFAULT_INITIAL, help=INITIAL_HELP)
    g.add_argument("--validate-skip", default="0", help=SKIP_HELP)


def _add_experiment_arguments(f: argparse.ArgumentParser) -> None:
    g = f.add_argument_group("the experiment: loss, initial state, per-recording parameters, sensors")
    g.add_argument("--loss", default="sse", help="sse (default: the paper's eq. 24/27), l1 (mean absolute error) or huber:DELTA")
    g.add_argument(
        "--normalize",
        default=None,
        choices=["peak", "none"],
        help="peak (default): residuals over each channel's peak; none: raw units, a joint fit pooled by sample count",
    )
    g.add_argument(
        "--initial",
        type=mapping,
        default={},
        help="initial states, STATE=SPEC pairs: a number, measured (default where measured), smoothed (the first samples' "
        "local quadratic at t0), derivative (default for a "
        "derivative state) or fit (a free y0_STATE per recording), e.g. for the DC motor omega=fit",
    )
    g.add_argument(
        "--local",
        type=names,
        default=(),
        help="parameters with one value per recording of a joint fit, e.g. for the DC motor Tla or Tla,offset_i_a (listed as Tla[0], Tla[1], ...)",
    )
    g.add_argument(
        "--hold",
        type=mapping,
        default={},
        help="how an input acts between its samples, INPUT=linear|zoh pairs (default linear, "
        "eq. 29; zoh: held until the next sample, as a drive's PWM updated once per sample), e.g. for the DC motor u_a=zoh",
    )
    g.add_argument(
        "--measure",
        type=names,
        default=None,
        help="the states compared with the recording (default: the model's measured states), "
        "e.g. for the DC motor with only its speed logged omega; a column named after another state still gives its initial state",
    )
    g.add_argument(
        "--offset",
        type=names,
        default=(),
        help="measured channels with a free additive sensor offset offset_CH (range +-10%% of "
        "the peak; --bound offset_CH=LO:HI), e.g. for the DC motor i_a",
    )
    g.add_argument(
        "--delay",
        type=names,
        default=(),
        help="inputs with a free delay delay_IN in seconds (range 0..10 samples; --bound delay_IN=LO:HI), e.g. for the DC motor u_a",
    )
    g.add_argument(
        "--focus",
        default="simulation",
        choices=["simulation", "prediction"],
        help="simulation (default: output error, the open-loop simulation compared, the paper's) or prediction (prediction "
        "error: an extended Kalman filter's innovations' likelihood, for disturbances inside the loop; its noise is "
        "fitted: q_STATE, r_OUTPUT on log scales)",
    )
    g.add_argument(
        "--process-noise",
        type=mapping,
        default={},
        help="with --focus prediction: a state's process noise intensity (unit^2/s) or fit, STATE=VALUE|fit pairs (default fit "
        "for a measured state, else 0), e.g. for the DC motor i_a=0,omega=fit",
    )
    g.add_argument(
        "--measurement-noise",
        type=mapping,
        default={},
        help="with --focus prediction: a sensor's noise std. dev. or fit, OUTPUT=VALUE|fit pairs (default fit), e.g. i_a=0.01",
    )


@dataclasses.dataclass(frozen=True)
class HeldOut:
    """`--validate`'s recordings, each record's `initial` state mode and the samples to `skip`."""

    data: tuple[str, ...]
    initial: str = DEFAULT_INITIAL
    skip: int = 0


@dataclasses.dataclass(frozen=True)
class FitCommand:
    """`dcjax fit` as the library's typed objects: the `model` (its compared states those of
    --measure), the `data` and their `loader`, the `params`, the `observation`, the `integrator`
    (None: a discrete-time model's own), `search` the flags' changes to the default `Search` of
    the fit (as `dcjax.fit` takes them), `each` (one fit per file), the analyses, the outputs and
    the `held_out` recordings to validate the fit on."""

    data: tuple[str, ...]
    model: Model
    loader: Loader
    params: ParameterSpec
    observation: Observation
    integrator: Integrator | AutoSubsteps | None
    search: Mapping
    out: OutputFolder
    each: bool = False
    uncertainty: bool = False
    plots: str | None = None
    progress: bool = False
    held_out: HeldOut | None = None

    @classmethod
    def of(cls, args: argparse.Namespace) -> "FitCommand":
        """The command of `dcjax fit`'s parsed flags (`add_arguments`); a flag that does not fit
        another, or the model, is a one-line `ConfigError` naming it."""
        if (args.lower is None) != (args.upper is None):
            raise ConfigError("--lower and --upper must be given together")
        if args.lower is not None and args.bounds is not None:
            raise ConfigError("give either --bounds or --lower/--upper, not both")
        if args.bounds is not None and "=" in args.bounds:
            raise ConfigError(f"--bounds takes auto or a preset, got {args.bounds!r}: a parameter's range goes in --bound NAME=LO:HI")
        if args.local and (args.each or len(args.data) < 2):
            raise ConfigError("--local needs a joint fit of several recordings (each gets its own value), not --each or one file")
        if args.plots not in (None, "none") and not args.each:
            raise ConfigError(f"--plots {args.plots} goes with --each; a single or joint fit writes fit.png unless --plots none")
        if args.validate and args.each:
            raise ConfigError("--validate goes with a single or joint fit, not --each (dcjax validate RESULT FILE for one of its results)")
        if not args.validate and (args.validate_initial != DEFAULT_INITIAL or args.validate_skip != "0"):
            raise ConfigError("--validate-initial and --validate-skip go with --validate FILE")
        held_out = (
            HeldOut(tuple(args.validate), args.validate_initial, skip_samples(args.validate_skip, "--validate-skip"))
            if args.validate
            else None
        )
        observation = Observation(
            get_loss(args.loss, args.normalize),
            args.initial,
            args.offset,
            args.delay,
            args.measure,
            args.hold,
            args.focus,
            args.process_noise,
            args.measurement_noise,
        )
        model = get_model(args.model)
        model = observation.check(model).observed(model)  # --measure: the compared states
        if args.weights is not None and len(args.weights) != len(model.outputs):
            raise ConfigError(
                f"--weights must be {len(model.outputs)} comma-separated numbers ({', '.join(model.outputs)}), got {len(args.weights)}"
            )
        if args.limit is not None and not model.has_limit:
            raise ConfigError(
                f"--limit: model {model.name} clamps no state (it has no Model.limited_state or clamp of its own); its states are "
                f"{', '.join(model.states)}"
            )
        search = {
            k: getattr(args, k) for k in ("method", "runs", "budget", "seed", "polish", "generations") if getattr(args, k) is not None
        }
        if args.memory is not None:
            search["memory"] = MEMORIES[args.memory]
        if args.stop is None:
            search["stop"] = None
        elif args.stop is not NOT_GIVEN:
            unknown = sorted(set(args.stop) - {"rtol", "atol", "patience"})
            if unknown:
                raise ConfigError(f"--stop takes rtol, atol and patience, got {', '.join(unknown)}")
            given = {k: (int(v) if k == "patience" and float(v).is_integer() else v) for k, v in args.stop.items()}
            search["stop"] = Converged(**given)
        return cls(
            tuple(drop_sidecars(args.data)),
            model,
            Loader.of(args, model, args.weights),
            ParameterSpec(args.bounds, args.lower, args.upper, args.bound, args.fix, args.x0, args.log, args.local, args.precision),
            observation,
            _integrator(model, args.integrator, args.nd),
            search,
            OutputFolder(
                args.out,
                each_products if args.each else fit_products,
                bool(args.overwrite),
                "an earlier --each run's summary and results" if args.each else "an earlier fit's result.json",
                args.cleanup,
            ),
            bool(args.each),
            bool(args.uncertainty),
            args.plots,
            sys.stderr.isatty() if args.progress is None else bool(args.progress),
            held_out,
        )


def _integrator(model: Model, name: str | None, nd: int | str | None) -> Integrator | AutoSubsteps | None:
    """--integrator with --nd (default rk4 at 1 sub-step); none for a discrete-time model."""
    if isinstance(model, DiscreteModel):
        if name is not None or nd not in (None, 1):
            raise ConfigError(
                f"model {model.name} is a discrete-time model (update(c, u, y, dt) per sample): --integrator and --nd do not apply"
            )
        return None
    step = INTEGRATORS[name or "rk4"]
    if nd == "auto":
        return AutoSubsteps(integrator=step())
    return step(substeps=1 if nd is None else int(nd))
