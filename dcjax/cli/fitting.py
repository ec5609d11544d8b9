"""`dcjax fit`: one fit of one or several recordings (a joint fit), or `--each` file on its own."""

import dataclasses
import sys
from pathlib import Path

import numpy as np

from ..analysis.checks import fit_findings
from ..errors import ConfigError
from ..fitting.fit import fit
from ..fitting.observation import Observation
from ..fitting.parameter_spec import ParameterSpec
from ..fitting.search import Search
from ..fitting.setup import with_weights
from ..fitting.vector import base_name, unit_of
from ..io import datasets
from ..io.loading import Reading, load_recording, preprocess
from ..io.units import parse_mapping
from ..models import DiscreteModel
from ..simulation.integrators import INTEGRATORS, AutoSubsteps
from ..simulation.losses import get_loss
from ..strategies.memory import MEMORIES
from .args import _floats, _named_floats, _named_ranges, _names
from .flags import as_flags
from .output import announce, fit_products, output_folder, remove_earlier, save_fit


def reading_of(args):
    """The command's reading options as one `dcjax.io.loading.Reading` (none given: the defaults)."""

    return Reading(
        columns=parse_mapping(args.columns, "--columns") or None,
        units=parse_mapping(args.units, "--units") or None,
        scale=_named_floats(args.scale, "--scale") or None,
        dt=args.dt,
        rate=args.rate,
        delimiter=args.delimiter,
        decimal=args.decimal,
        constants=_named_floats(getattr(args, "const", None), "--const") or None,
        drop_nan=bool(getattr(args, "drop_nan", False)),
    )


def _load(data: str, args, model, reading=None):
    """`data` (a file, or an embedded data set's name) read with `reading` (default the command's
    own options), then what the command keeps of it (--window, --every, --trim) and its --limit."""

    reading = reading_of(args) if reading is None else reading
    if not Path(data).exists() and data.upper() in datasets.EMBEDDED:
        rec = datasets.load(data)
        if reading.constants:
            rec = rec.replace(constants={**rec.constants, **reading.constants})
        if any(getattr(args, k, None) for k in ("window", "every", "trim")):  # --columns, --units, --scale, --dt, --rate are for files
            rec = preprocess(rec, args.window, args.every, args.trim, model)
        return rec
    return load_recording(data, model=model, limit=args.limit, window=args.window, every=args.every, trim=args.trim, reading=reading)


def _nd(text: str):
    if text == "auto":
        return "auto"
    try:
        return int(text)
    except ValueError:
        raise ConfigError(f"--nd must be a positive integer or 'auto', got {text!r}") from None


def _spec(args, model):
    """The fit's parameters as the flags give them, one `ParameterSpec`: --bounds (a preset or
    auto; default the sidecar's preset, else auto) or --lower/--upper, --bound, --fix, --x0, --log,
    --local, --precision."""
    if (args.lower is None) != (args.upper is None):
        raise ConfigError("--lower and --upper must be given together")
    if args.lower is not None and args.bounds is not None:
        raise ConfigError("give either --bounds or --lower/--upper, not both")
    lower = None if args.lower is None else _floats(args.lower, "--lower", model.n_params)
    upper = None if args.upper is None else _floats(args.upper, "--upper", model.n_params)
    precision = None
    if args.precision is not None:
        precision = (
            _named_floats(args.precision, "--precision")
            if "=" in args.precision
            else _floats(args.precision, "--precision", model.n_params)
        )
    return ParameterSpec(
        args.bounds,
        lower,
        upper,
        _named_ranges(args.bound, "--bound"),
        _named_floats(args.fix, "--fix"),
        _named_floats(args.x0, "--x0"),
        _names(args.log, "--log"),
        _names(args.local, "--local"),
        precision,
    )


def _options(args, model) -> dict:
    """The `dcjax.fit` options every file of this command shares (the parameters are per file; the
    search, `_search`, once the recordings are read): the integrator, the memory and the
    `Observation`, built once."""

    nd = _nd(args.nd)
    if isinstance(model, DiscreteModel):
        if args.integrator is not None or nd != 1:
            raise ConfigError(
                f"model {model.name} is a discrete-time model (update(c, u, y, dt) per sample): --integrator and --nd do not apply"
            )
        integrator = None
    else:
        step = INTEGRATORS[args.integrator or "rk4"]
        integrator = AutoSubsteps(integrator=step()) if nd == "auto" else step(substeps=nd)
    if args.limit is not None and not model.has_limit:
        raise ConfigError(
            f"--limit: model {model.name} clamps no state (it has no Model.limited_state or clamp of its own); its states are "
            f"{', '.join(model.states)}"
        )
    if args.local is not None and (args.each or len(args.data) < 2):
        raise ConfigError("--local needs a joint fit of several recordings (each gets its own value), not --each or one file")
    observation = Observation(
        get_loss(args.loss or "sse", args.normalize),
        parse_mapping(args.initial, "--initial"),
        _names(args.offset, "--offset"),
        _names(args.delay, "--delay"),
        None if args.measure is None else _names(args.measure, "--measure"),
        parse_mapping(args.hold, "--hold"),
    )
    return dict(integrator=integrator, observation=observation)


def _search(args, recs=()):
    """The `Search` of the command: --method (with --generations), --runs, --budget, --seed,
    --memory, --polish as given, else the default for a fit of `recs` (`Search.for_steps`: a joint
    fit of many recordings searches shorter; `--each` and one recording: the paper's). The
    namespace gets the values, so the command's report shows them."""

    nd = _nd(args.nd)
    chosen = Search.for_steps(sum(len(r.t) for r in recs) * (nd if isinstance(nd, int) else 1) if len(recs) > 1 else 0)
    args.method = chosen.name if args.method is None else args.method
    args.runs = chosen.runs if args.runs is None else args.runs
    args.budget = chosen.budget if args.budget is None else args.budget
    search = Search(args.method, args.runs, args.budget, args.seed, None if args.memory is None else MEMORIES[args.memory], args.polish)
    return search if args.generations is None else search.with_generations(args.generations)


def _prepared(rec, args, model):
    """The recording as the flags ask: --limit (also on an embedded data set), --weights."""

    if args.limit is not None and rec.limit != args.limit:
        rec = rec.replace(limit=args.limit)
    if args.weights is not None:
        rec = with_weights(rec, dict(zip(model.outputs, _floats(args.weights, "--weights", len(model.outputs)))))
    return rec


def _fit_one(recs, args, model, options, progress):

    recs = [_prepared(r, args, model) for r in recs]
    result = fit(recs, model, _spec(args, model), progress=progress, **options)
    if args.uncertainty:
        result = result.uncertainty()
    return result


def bound_hints(result) -> list[str]:
    """One line per free parameter that ended on a search bound: what it means, what to do."""
    b = result.bounds
    lo, hi = b.lower, b.upper
    out = []
    for n in result.at_bound():
        k = result.names.index(n)
        v = result.best_values[n]
        if abs(v - lo[k]) <= abs(v - hi[k]):
            if lo[k] == 0 and n in result.model.required:
                out.append(
                    f"hint: {n} ended at 0, its lower bound, but the model's physics needs it (not zero): the fit failed to explain "
                    f"the data; check the data checks, units and scales (--scale), or the model"
                )
            elif lo[k] == 0:
                out.append(
                    f"hint: {n} ended at 0, its lower bound: this recording does not need the term, or {n} is not identifiable from it"
                )
            else:
                out.append(f"hint: {n} ended at its lower bound {lo[k]:g}: widen it, e.g. --bound {n}={lo[k] / 10:g}:{hi[k]:g}")
        else:
            out.append(
                f"hint: {n} ended at its upper bound {hi[k]:g}: widen it, e.g. --bound {n}={lo[k]:g}:{hi[k] * 10:g} (or --bounds auto)"
            )
    return out


def _print_fit(result, recs, args, model, out):

    truth = recs[0].metadata.get("true_params")
    if any(r.metadata.get("true_params") != truth for r in recs) or not isinstance(truth, dict) or set(truth) != set(model.names):
        truth = None
    names = (
        " + ".join(r.name for r in recs)
        if len(recs) <= 4
        else f"{recs[0].name} + {recs[1].name} + ... + {recs[-1].name} ({len(recs)} recordings)"
    )
    b = result.settings["bounds"]
    print(
        f"{names}: model {model.name}, {args.method}, {result.settings['integrator']}, ND={result.settings['nd']}, {args.runs} runs x {args.budget} FEs, seed {args.seed}"
    )
    auto = result.settings.get("nd_auto")
    if auto:
        tried = ", ".join(f"ND={k}: {v:.1e}" for k, v in auto["errors_at_nd1_fit"].items())
        print(
            f"  nd auto: ND={auto['chosen']} (reference error {auto['reference_error']:.2e} <= {auto['tol']:g}: {auto['converged']}); at the ND=1 fit {tried}"
        )

    for note in result.observation.notes(model, recs):
        print(as_flags(note))
    if not result.observation.plain:
        o = result.observation
        print(
            f"  loss {o.loss.spec} ({'normalised by each channel' + chr(39) + 's peak' if o.loss.normalize == 'peak' else 'raw units'})"
            + (f"; initial {', '.join(f'{k}={v}' for k, v in o.initial.items())}" if o.initial else "")
            + (f"; compared: {', '.join(o.measure)}" if o.measure is not None else "")
        )
    w = max(6, *(len(n) for n in result.names))
    header = f"{'param':>{w}} {'unit':>7} {'identified':>22} {'lower':>10} {'upper':>10}" + (
        f" {'true':>14} {'rel. error':>11}" if truth else ""
    )
    print(header)
    at_bound = set(result.at_bound())
    for k, name in enumerate(result.names):
        v = result.best_values[name]
        line = f"{name:>{w}} {unit_of(name, model):>7} {v:>22.15g} {b['lower'][k]:>10.3g} {b['upper'][k]:>10.3g}"
        if truth and base_name(name) in truth:
            t = truth[base_name(name)]
            line += f" {t:>14.6g} {abs(v - t) / abs(t) if t else abs(v):>11.2e}"
        if name in result.fixed:
            line += "  (fixed)"
        elif name in at_bound:
            line += "  [at bound]"
        print(line)
    s = result.stats
    print(f"OF best {s['best']:.4e}  worst {s['worst']:.4e}  mean {s['mean']:.4e}  std {s['std']:.4e}")
    if truth:  # simulated, noise-free data: an exact fit means something
        print(f"runs with OF <= 1e-15: {int(np.sum(result.run_of <= 1e-15))}/{args.runs}")
    if result.duplicates is not None:
        d = result.duplicates
        print(
            f"memory {args.memory}: {d['percent']:.1f} % of candidates answered from memory; mean FEs {result.fes.mean():.0f}, iterations {result.iterations.mean():.0f}"
        )
    if args.uncertainty:
        print(result.uncertainties.table())
    for line in bound_hints(result):
        print(line)

    named = lambda r, g: g if len(recs) == 1 else dataclasses.replace(g, message=f"{r.name}: {g.message}")  # a joint fit: whose
    for f in [*result.checks, *(named(r, g) for r in recs for g in fit_findings(result, r))]:
        print(f"check {f}")
    print(
        f"compile {result.timing['compile_s']:.2f} s, run {result.timing['run_s']:.2f} s; wrote {out / 'result.json'}"
        + (f" and {out / 'fit.png'}" if args.plots is None else "")
    )


def _no_finite_candidate(result) -> str | None:
    """The one-line error of a fit none of whose runs found a finite objective, else None."""

    if np.any(np.isfinite(result.run_of)):
        return None
    return (
        f"no run found parameters whose simulation is finite (every OF is inf, {result.nfev:,} evaluations): the model "
        "blows up over the whole search range; check the bounds, the units and scales (--units, --scale) and the model"
    )


def fit_one(args, model, options) -> int:
    """`dcjax fit` of one recording or a joint fit of several: result.json and fit.png in --out."""

    if args.plots not in (None, "none"):
        raise ConfigError(f"--plots {args.plots} goes with --each; a single or joint fit writes fit.png unless --plots none")
    with output_folder(args, fit_products, "an earlier fit's result.json") as folder:
        out = folder.path
        recs = [_load(d, args, model) for d in args.data]
        options["search"] = _search(args, recs)
        result = _fit_one(recs, args, model, options, sys.stderr.isatty() if args.progress is None else args.progress)
        failed = _no_finite_candidate(result)
        if failed:
            raise ConfigError(failed)
        announce(folder)  # where it writes, once there is something to write
        remove_earlier(folder.replaced)
        save_fit(result, out, plot=args.plots is None)
    _print_fit(result, recs, args, model, out)
    return 0
