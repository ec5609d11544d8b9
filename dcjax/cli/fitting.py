"""`dcjax fit`: one fit of one or several recordings (a joint fit), or `--each` file on its own."""

import dataclasses
import sys
from pathlib import Path

from ..io.units import parse_mapping
from .args import _floats, _named_floats, _named_ranges


def _load(data: str, args, model):
    from ..io import datasets
    from ..io.loading import load_recording

    if not Path(data).exists() and data.upper() in datasets.EMBEDDED:
        if any(getattr(args, k, None) for k in ("window", "every", "trim")):  # --columns, --units, --scale, --dt, --rate are for files
            rec = datasets.load(data)
            from ..io.loading import preprocess

            return preprocess(rec, args.window, args.every, args.trim)
        return datasets.load(data)
    return load_recording(
        data,
        columns=parse_mapping(args.columns, "--columns") or None,
        units=parse_mapping(args.units, "--units") or None,
        scale=_named_floats(args.scale, "--scale") or None,
        dt=args.dt,
        rate=args.rate,
        delimiter=args.delimiter,
        decimal=args.decimal,
        model=model,
        limit=args.limit,
        window=args.window,
        every=args.every,
        trim=args.trim,
    )


def _nd(text: str):
    if text == "auto":
        return "auto"
    try:
        return int(text)
    except ValueError:
        raise ValueError(f"--nd must be a positive integer or 'auto', got {text!r}") from None


def _bounds(args, model, rec):
    """--lower/--upper, --bounds (a preset or auto; default the sidecar's preset, else auto) and
    the --bound overrides over them. Returns (Bounds, start values of the auto estimate)."""
    from ..models.bounds import Bounds, resolve_bounds

    if (args.lower is None) != (args.upper is None):
        raise ValueError("--lower and --upper must be given together")
    start = {}
    if args.lower is not None:
        if args.bounds is not None:
            raise ValueError("give either --bounds or --lower/--upper, not both")
        bounds = Bounds(_floats(args.lower, "--lower", model.n_params), _floats(args.upper, "--upper", model.n_params), model.names)
    else:
        preset = args.bounds or (rec.metadata.get("bounds") if rec.metadata.get("bounds") in model.preset_names else "auto")
        if preset.lower() == "auto":
            from ..analysis.estimate import auto_bounds

            bounds, start, _ = auto_bounds(rec, model)
        else:
            bounds = resolve_bounds(model, preset)
    return resolve_bounds(model, bounds, _named_ranges(args.bound, "--bound")), start


def _options(args, model) -> dict:
    """The `dcjax.fit` options every file of this command shares (the parameters are per file)."""
    from ..simulation.integrators import INTEGRATORS, AutoSubsteps
    from ..strategies.memory import MEMORIES

    nd = _nd(args.nd)
    step = INTEGRATORS[args.integrator]
    integrator = AutoSubsteps(integrator=step()) if nd == "auto" else step(substeps=nd)
    memory = None if args.memory is None else MEMORIES[args.memory]
    return dict(method=args.method, integrator=integrator, runs=args.runs, budget=args.budget, generations=args.generations,
                seed=args.seed, memory=memory, polish=args.polish)  # fmt: skip


def _precision(args, model) -> dict[str, float]:
    if args.precision is None:
        return {}
    if "=" in args.precision:
        given = _named_floats(args.precision, "--precision")
        model.check_names(given)
        return given
    return dict(zip(model.names, _floats(args.precision, "--precision", model.n_params)))


def _prepared(rec, args, model):
    """The recording as the flags ask: --limit (also on an embedded data set), --weights."""
    from ..fitting.engine import with_weights

    if args.limit is not None and rec.limit != args.limit:
        rec = rec.replace(limit=args.limit)
    if args.weights is not None:
        rec = with_weights(rec, dict(zip(model.outputs, _floats(args.weights, "--weights", len(model.outputs)))))
    return rec


def _file_params(args, model, rec):
    """A file's `Parameters`: ranges from --bounds/--lower/--upper/--bound (default its sidecar's
    preset, else auto), --fix, start values from --x0 (else the auto estimate's, where inside
    the ranges) and --precision."""
    from ..models.parameters import Parameter, Parameters

    bounds, start = _bounds(args, model, rec)
    fixed = _named_floats(args.fix, "--fix")
    model.check_names(fixed, "fixed parameter")
    x0 = _named_floats(args.x0, "--x0")
    model.check_names(x0, "start value")
    lo, hi = bounds.lower, bounds.upper
    if not x0:
        x0 = {n: v for n, v in start.items() if lo[model.names.index(n)] <= v <= hi[model.names.index(n)]}
    prec = _precision(args, model)
    out = []
    for k, n in enumerate(model.names):
        value = fixed.get(n, x0.get(n))
        out.append(Parameter(n, value=value, min=float(lo[k]), max=float(hi[k]), vary=n not in fixed,
                             unit=model.units.get(n, ""), precision=prec.get(n)))  # fmt: skip
    return Parameters(out)


def _fit_one(recs, args, model, options, progress):
    from ..fitting.fit import fit

    recs = [_prepared(r, args, model) for r in recs]
    result = fit(recs, model, _file_params(args, model, recs[0]), progress=progress, **options)
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
            if lo[k] == 0:
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
    import numpy as np

    truth = recs[0].metadata.get("true_params")
    if any(r.metadata.get("true_params") != truth for r in recs) or not isinstance(truth, dict) or set(truth) != set(model.names):
        truth = None
    names = " + ".join(r.name for r in recs)
    b = result.settings["bounds"]
    print(
        f"{names}: model {model.name}, {args.method}, {args.integrator}, ND={result.settings['nd']}, {args.runs} runs x {args.budget} FEs, seed {args.seed}"
    )
    auto = result.settings.get("nd_auto")
    if auto:
        tried = ", ".join(f"ND={k}: {v:.1e}" for k, v in auto["errors_at_nd1_fit"].items())
        print(
            f"  nd auto: ND={auto['chosen']} (reference error {auto['reference_error']:.2e} <= {auto['tol']:g}: {auto['converged']}); at the ND=1 fit {tried}"
        )
    header = f"{'param':>6} {'unit':>7} {'identified':>22} {'lower':>10} {'upper':>10}" + (
        f" {'true':>14} {'rel. error':>11}" if truth else ""
    )
    print(header)
    at_bound = set(result.at_bound())
    for k, name in enumerate(model.names):
        v = result.best_values[name]
        line = f"{name:>6} {model.units.get(name, ''):>7} {v:>22.15g} {b['lower'][k]:>10.3g} {b['upper'][k]:>10.3g}"
        if truth:
            t = truth[name]
            line += f" {t:>14.6g} {abs(v - t) / abs(t) if t else abs(v):>11.2e}"
        if name in result.fixed:
            line += "  (fixed)"
        elif name in at_bound:
            line += "  [at bound]"
        print(line)
    s = result.stats
    print(f"OF best {s['best']:.4e}  worst {s['worst']:.4e}  mean {s['mean']:.4e}  std {s['std']:.4e}")
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
    print(
        f"compile {result.timing['compile_s']:.2f} s, run {result.timing['run_s']:.2f} s; wrote {out / 'result.json'} and {out / 'fit.png'}"
    )


def _save(result, out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    result.to_json(out / "result.json")
    result.plot(out / "fit.png")


def fit(args) -> int:
    from ..models import get_model

    model = get_model(args.model)
    options = _options(args, model)
    if args.each:
        return fit_each_cmd(args, model, options)
    recs = [_load(d, args, model) for d in args.data]
    result = _fit_one(recs, args, model, options, sys.stderr.isatty() if args.progress is None else args.progress)
    out = Path(args.out)
    _save(result, out)
    _print_fit(result, recs, args, model, out)
    return 0


def fit_each_cmd(args, model, options) -> int:
    """`dcjax fit --each`: one fit per file (`dcjax.fitting.fit_each`: the files of one length in
    one compiled call); a file that fails to load, validate or fit is reported and the others are
    fitted."""
    from ..fitting.each import FailedFit, fit_each, summary_rows, write_summary
    from ..simulation.problem import make_problem

    out = Path(args.out)
    results: list = [None] * len(args.data)
    ready = []  # (index, recording, parameters)
    for k, data in enumerate(args.data):
        label = Path(data).stem if Path(data).exists() else data
        try:
            rec = _prepared(_load(data, args, model), args, model)
            make_problem(rec, model=model)  # what a fit would refuse, before the first estimate of --bounds auto
            ready.append((k, rec, _file_params(args, model, rec)))
        except Exception as e:  # one broken file fails alone, whatever broke
            results[k] = FailedFit(name=label, error=(str(e).splitlines() or [type(e).__name__])[0], source=data)
    fitted = fit_each([r for _, r, _ in ready], model, [p for *_, p in ready], **options) if ready else []
    for (k, *_), res in zip(ready, fitted):
        results[k] = res if not isinstance(res, FailedFit) else dataclasses.replace(res, source=args.data[k])
    names: dict[str, int] = {}
    for result in results:
        if isinstance(result, FailedFit):
            print(f"{result.name}: failed: {result.error}")
            continue
        label = result.recording.name
        n = names.get(label, 0)
        names[label] = n + 1
        folder = out / (label if n == 0 else f"{label}_{n + 1}")
        if args.uncertainty:
            result = result.uncertainty()
        _save(result, folder)
        at = result.at_bound()
        print(f"{label}: OF {result.of:.4e}" + (f"; at bound: {', '.join(at)}" if at else "") + f"; wrote {folder}")
    rows = summary_rows(results, model)
    csv_path, png = write_summary(rows, out, model)
    ok = sum(r["status"] == "ok" for r in rows)
    flagged = [r["name"] for r in rows if r.get("outlier")]
    print(f"{ok}/{len(rows)} fitted; outliers: {', '.join(flagged) or 'none'}; wrote {csv_path} and {png}")
    return 0 if ok == len(rows) else 1 if ok else 2
