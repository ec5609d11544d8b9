"""`dcjax fit | simulate | validate | report`: identification and its checks from a shell."""

import argparse
import sys
import warnings
from pathlib import Path

from .units import parse_mapping


def _floats(text: str, what: str, n: int | None = None) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise ValueError(f"{what} must be comma-separated numbers, got {text!r}") from None
    if n is not None and len(values) != n:
        raise ValueError(f"{what} must be {n} comma-separated numbers, got {len(values)}")
    return values


def _named_floats(text: str | None, what: str) -> dict[str, float]:
    out = {}
    for k, v in parse_mapping(text, what).items():
        try:
            out[k] = float(v)
        except ValueError:
            raise ValueError(f"{what}: value of {k} must be a number, got {v!r}") from None
    return out


def _named_ranges(text: str | None, what: str) -> dict[str, tuple[float, float]]:
    out = {}
    for k, v in parse_mapping(text, what).items():
        lo, sep, hi = v.partition(":")
        try:
            out[k] = (float(lo), float(hi))
        except ValueError:
            raise ValueError(f"{what}: {k} needs LOWER:UPPER, got {v!r}") from None
        if not sep:
            raise ValueError(f"{what}: {k} needs LOWER:UPPER, got {v!r}")
    return out


def _add_data_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("reading the data")
    g.add_argument("--columns", default=None, help="channel=column pairs, e.g. t=time_ms,u_a=U,i_a=I,omega=n (names or 0-based indices)")
    g.add_argument("--units", default=None, help="channel=unit pairs, e.g. t=ms,i_a=mA,omega=rpm (converted to SI)")
    g.add_argument("--delimiter", default=None, help="',', ';', 'tab' or 'whitespace' (default: detected)")
    g.add_argument("--decimal", default=".", help="decimal separator, '.' or ','")
    g.add_argument("--window", default=None, help="keep T0:T1 (seconds)")
    g.add_argument("--every", type=int, default=None, help="keep every K-th sample")
    g.add_argument("--trim", action="store_true", help="cut the samples before the armature is switched on")
    g.add_argument("--i-limit", type=float, default=None, help="supply current limit (A)")
    g.add_argument(
        "--scale", default=None, help="channel=factor pairs applied after --units, e.g. omega=322.67 (gear ratio / wheel radius)"
    )
    g.add_argument("--dt", type=float, default=None, help="sample time (s) for a file without a time column")
    g.add_argument("--rate", type=float, default=None, help="sample rate (Hz) for a file without a time column")


def _parser() -> argparse.ArgumentParser:
    from .strategies import METHODS
    from .version import __version__

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
    f.add_argument("--model", default="dc", help="dc (default), dc-coulomb, package.module:attr or path/to/file.py:Name")
    f.add_argument("--method", default="de-rand-1-exp", help=f"{', '.join(METHODS)} or an evosax algorithm (CMA_ES, PSO, ...)")
    f.add_argument("--integrator", default="rk4", choices=["euler", "rk4"])
    f.add_argument("--nd", default="1", help="sub-steps per sample interval (eq. 28), or 'auto'")
    f.add_argument("--runs", type=int, default=50)
    f.add_argument("--budget", type=int, default=140_000, help="fitness evaluations per run")
    f.add_argument("--seed", type=int, default=0)
    f.add_argument("--weights", default=None, help="one weight per measured channel, e.g. 1,1 (eq. 27; default all 1 = eq. 24)")
    f.add_argument(
        "--bounds",
        default=None,
        help="auto (ranges from an equation-error first estimate) or a preset of the model, e.g. table4, table8 "
        "(default: the sidecar's 'bounds', else auto)",
    )
    f.add_argument("--bound", default=None, help="per-parameter bounds over the preset, e.g. Ra=0:10,J=0:0.1")
    f.add_argument("--lower", default=None, help="all lower bounds, comma-separated in the model's order")
    f.add_argument("--upper", default=None, help="all upper bounds, comma-separated in the model's order")
    f.add_argument("--fix", default=None, help="known parameters, not searched, e.g. Ra=42.5,Tlc=0")
    f.add_argument("--x0", default=None, help="start values seeding the initial population, e.g. Ra=40,J=2e-5")
    f.add_argument("--polish", action="store_true", help="Levenberg-Marquardt polish of every run")
    f.add_argument("--uncertainty", action="store_true", help="standard errors, 95%% intervals and identifiability")
    f.add_argument(
        "--memory",
        default=None,
        choices=["stma", "ltma-s1", "ltma-s2", "ltma-hash"],
        help="memory assistance (Section 4.4; ltma-hash: indexed)",
    )
    f.add_argument("--precision", default=None, help="duplicate precisions, NAME=VALUE pairs or one value per parameter (default Table 29)")
    f.add_argument("--generations", type=int, default=None, help="stop each run after this many iterations")
    f.add_argument("--out", default="out", help="output folder for result.json and fit.png")
    f.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar on stderr (default: when stderr is a terminal)",
    )
    _add_data_options(f)
    s = sub.add_parser("simulate", help="simulate a saved result on a recording: CSV of measured and simulated channels, and a plot")
    s.add_argument("result", help="result.json of a fit")
    s.add_argument("data", help="data file or embedded name")
    s.add_argument("--out", default="out", help="output folder")
    _add_data_options(s)
    v = sub.add_parser("validate", help="OF and fit %% per channel of a saved result on other recordings, with plots")
    v.add_argument("result", help="result.json of a fit")
    v.add_argument("data", nargs="+", help="data file(s) or embedded names")
    v.add_argument("--out", default="out", help="output folder")
    _add_data_options(v)
    d = sub.add_parser("design", help="design the next experiment's input from a fit (optimal input design)")
    d.add_argument("result", help="result.json of a fit")
    d.add_argument("--duration", type=float, required=True, help="length of the test (s)")
    d.add_argument("--dt", type=float, required=True, help="sample time (s)")
    d.add_argument("--umin", type=float, required=True, help="lowest input level (V)")
    d.add_argument("--umax", type=float, required=True, help="highest input level (V)")
    d.add_argument("--hold", type=float, default=None, help="shortest time an input level is held (s; default duration/20)")
    d.add_argument("--i-limit", type=float, default=None, help="supply current limit (A; default the fitted recording's)")
    d.add_argument("--criterion", default="d", help="d (D-optimal, default), a (A-optimal) or parameter names, e.g. J,Tla,Tlb,Tlc")
    d.add_argument("--noise", default=None, help="noise std. dev. per channel, e.g. i_a=0.05,omega=0.5 (default: the fit's residuals, "
                   "or 1%% of each channel's peak under a full step where the fit left none)")  # fmt: skip
    d.add_argument("--starts", type=int, default=8, help="optimizer starts")
    d.add_argument("--steps", type=int, default=300, help="optimizer steps per start")
    d.add_argument("--seed", type=int, default=0)
    d.add_argument("--out", default="design", help="output folder")
    r = sub.add_parser("report", help="print the fit report of a saved result")
    r.add_argument("result", help="result.json of a fit")
    r.add_argument("--uncertainty", action="store_true", help="compute standard errors (needs the fitted data file)")
    return p


def _load(data: str, args, model):
    from . import datasets
    from .loading import load_recording

    if not Path(data).exists() and data.upper() in datasets.EMBEDDED:
        if any(getattr(args, k, None) for k in ("window", "every", "trim")):  # --columns, --units, --scale, --dt, --rate are for files
            rec = datasets.load(data)
            from .loading import preprocess

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
        i_limit=args.i_limit,
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
    from .bounds import Bounds, resolve_bounds

    if (args.lower is None) != (args.upper is None):
        raise ValueError("--lower and --upper must be given together")
    start = {}
    if args.lower is not None:
        if args.bounds is not None:
            raise ValueError("give either --bounds or --lower/--upper, not both")
        bounds = Bounds(_floats(args.lower, "--lower", model.n_params), _floats(args.upper, "--upper", model.n_params), model.names)
    else:
        preset = args.bounds or (rec.metadata.get("bounds") if rec.metadata.get("bounds") in model.bounds else "auto")
        if preset.lower() == "auto":
            from .estimate import auto_bounds

            bounds, start, _ = auto_bounds(rec, model)
        else:
            bounds = resolve_bounds(model, preset)
    return resolve_bounds(model, bounds, _named_ranges(args.bound, "--bound")), start


def _options(args, model) -> dict:
    """The identify options every file of this command shares (bounds are per file)."""
    precision = None
    if args.precision is not None:
        precision = (
            _named_floats(args.precision, "--precision")
            if "=" in args.precision
            else _floats(args.precision, "--precision", model.n_params)
        )
    return dict(
        method=args.method,
        integrator=args.integrator,
        nd=_nd(args.nd),
        weights=None if args.weights is None else tuple(_floats(args.weights, "--weights", len(model.outputs))),
        runs=args.runs,
        budget=args.budget,
        seed=args.seed,
        polish=args.polish,
        i_limit=args.i_limit,
        memory=args.memory,
        precision=precision,
        generations=args.generations,
        model=model,
        fixed=_named_floats(args.fix, "--fix") or None,
    )


def _fit_one(recs, args, model, options, progress):
    from .identify import identify

    bounds, x0 = _file_search(args, model, options, recs[0])
    result = identify(recs, bounds=bounds, x0=x0, progress=progress, **options)
    if args.uncertainty:
        result.uncertainty()
    return result


def bound_hints(result) -> list[str]:
    """One line per free parameter that ended on a search bound: what it means, what to do."""
    b = result.bounds
    lo, hi = b.lower, b.upper
    out = []
    for n in result.at_bound():
        k = result.names.index(n)
        v = result.params[n]
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
        v = result.params[name]
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
        print(result._uncertainty.table())
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
    from .models import get_model

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
    """`dcjax fit --each`: one fit per file, the files of one length in one compiled call; a file
    that fails to load, validate or fit is reported and the others are fitted."""
    from .each import FailedFit, _check, summary_rows, write_summary

    out = Path(args.out)
    results: list = [None] * len(args.data)
    ready = []  # (index, recording, bounds, start values)
    for k, data in enumerate(args.data):
        label = Path(data).stem if Path(data).exists() else data
        try:
            rec = _load(data, args, model)
            _check(rec, model, options)
            bounds, x0 = _file_search(args, model, options, rec)
            ready.append((k, rec, bounds, x0))
        except Exception as e:  # one broken file fails alone, whatever broke
            results[k] = FailedFit(name=label, error=(str(e).splitlines() or [type(e).__name__])[0], source=data)
    recs = {k: rec for k, rec, _, _ in ready}
    for k, res in _fit_ready(ready, model, options).items():
        if isinstance(res, Exception):
            res = FailedFit(name=recs[k].name, error=(str(res).splitlines() or [type(res).__name__])[0], source=args.data[k])
        results[k] = res
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
            result.uncertainty()
        _save(result, folder)
        at = result.at_bound()
        print(f"{label}: OF {result.of:.4e}" + (f"; at bound: {', '.join(at)}" if at else "") + f"; wrote {folder}")
    rows = summary_rows(results, model)
    csv_path, png = write_summary(rows, out, model)
    ok = sum(r["status"] == "ok" for r in rows)
    flagged = [r["name"] for r in rows if r.get("outlier")]
    print(f"{ok}/{len(rows)} fitted; outliers: {', '.join(flagged) or 'none'}; wrote {csv_path} and {png}")
    return 0 if ok == len(rows) else 1 if ok else 2


def _file_search(args, model, options, rec):
    """A file's bounds (--bounds/--lower/--upper/--bound, default its sidecar's preset or auto) and
    start values (--x0, else the auto estimate's)."""
    bounds, start = _bounds(args, model, rec)
    x0 = _named_floats(args.x0, "--x0") or None
    if x0 is None and start:
        lo, hi = bounds.lower, bounds.upper
        free = {n: v for n, v in start.items() if n not in (options["fixed"] or {})}
        x0 = {n: v for n, v in free.items() if lo[model.names.index(n)] <= v <= hi[model.names.index(n)]} or None
    return bounds, x0


def _fit_ready(ready, model, options) -> dict:
    """Index -> result (or the exception) of each validated file: in one `identify_each` call
    where the settings allow, else (and where that call fails) one `identify` each."""
    from .batch import identify_each
    from .identify import identify

    if not ready:
        return {}
    if options["nd"] != "auto":
        try:
            res = identify_each([r for _, r, _, _ in ready], bounds=[b for *_, b, _ in ready], x0=[x for *_, x in ready], **options)
            return {k: r for (k, *_), r in zip(ready, res)}
        except Exception:  # a file that breaks the batch: fit them one by one, so it fails alone
            pass
    out = {}
    for k, rec, bounds, x0 in ready:
        try:
            out[k] = identify([rec], bounds=bounds, x0=x0, **options)
        except Exception as e:
            out[k] = e
    return out


def _result(path):
    from .result import load_result

    return load_result(path)


def simulate_cmd(args) -> int:
    import numpy as np

    res = _result(args.result)
    rec = _load(args.data, args, res.model)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    sim = res.simulate(rec)
    m = res.model
    cols = ["t", *m.inputs, *(f"{c}_meas" for c in m.outputs), *(f"{s}_sim" for s in m.states)]
    table = np.column_stack([rec.t, *(rec[c] for c in m.inputs), *(rec[c] for c in m.outputs), sim])
    path = out / f"simulated_{rec.name}.csv"
    np.savetxt(path, table, delimiter=",", header=",".join(cols), comments="", fmt="%.17g")
    res.plot(out / f"simulated_{rec.name}.png", recordings=[rec])
    print(f"wrote {path} and {out / f'simulated_{rec.name}.png'}")
    return 0


def validate_cmd(args) -> int:
    from .objectives import objective
    from .report import channel_fit

    res = _result(args.result)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    recs = [_load(d, args, res.model) for d in args.data]
    x = [res.params[n] for n in res.names]
    print(f"{'recording':>12} {'OF':>12}  " + "  ".join(f"{'fit % ' + c:>14}" for c in res.model.outputs))
    rows = []
    for rec in recs:
        of = float(objective(x, res.problems([rec])[0]))
        fits = channel_fit(res, rec)
        rows.append({"recording": rec.name, "of": of, "fit_percent": fits})
        print(f"{rec.name:>12} {of:12.4e}  " + "  ".join(f"{v:14.3f}" for v in fits.values()))
        res.plot(out / f"validate_{rec.name}.png", recordings=[rec])
    import json

    (out / "validation.json").write_text(json.dumps(rows, indent=2) + "\n")
    print(f"wrote {out / 'validation.json'} and {len(recs)} plot(s) in {out}")
    return 0


def report_cmd(args) -> int:
    res = _result(args.result)
    if args.uncertainty:
        res.uncertainty()
    print(res.report())
    return 0


def design_cmd(args) -> int:
    import numpy as np

    from .design import design_input, evaluate_input, noise_from_fit, scales_from_fit, write_design

    res = _result(args.result)
    m = res.model
    noise = _named_floats(args.noise, "--noise") or None
    if noise is None:
        noise = noise_from_fit(res)
    rec = res.recording
    limit = args.i_limit if args.i_limit is not None else res.settings.get("i_limit") or (rec.i_a_limit if rec is not None else None)
    for name, v in (("--starts", args.starts), ("--steps", args.steps)):
        if v < 1:
            raise ValueError(f"{name} must be a positive integer, got {v}")
    design = design_input(
        m, res.params, duration=args.duration, dt=args.dt, u_range=(args.umin, args.umax), hold=args.hold, i_limit=limit,
        criterion=args.criterion, noise=noise, fixed=tuple(res.fixed), scale=scales_from_fit(res), starts=args.starts,
        steps=args.steps, seed=args.seed,
    )  # fmt: skip
    t = design.recording.t
    baselines = {f"step to {args.umax:g}": evaluate_input(design, m, np.full_like(t, args.umax))}
    if rec is not None:
        baselines[f"recording {rec.name}"] = evaluate_input(design, m, np.asarray(rec[m.inputs[0]]), t=np.asarray(rec.t - rec.t[0]))
    files = write_design(design, baselines, Path(args.out), m)
    print(
        f"designed input: {design.criterion}-criterion, {args.duration:g} s at {args.dt:g} s, levels in [{args.umin:g}, {args.umax:g}], hold {design.hold:g} s"
    )
    print("noise: " + ", ".join(f"{c} {v:.3g}" for c, v in design.noise.items()))
    print(f"{'param':>6} {'design':>12}" + "".join(f" {k:>22}" for k in baselines) + "   (predicted relative std. errors)")
    for n in design.free:
        print(
            f"{n:>6} {100 * design.relative_stderr()[n]:>11.3g}%"
            + "".join(f" {100 * b.relative_stderr()[n]:>21.3g}%" for b in baselines.values())
        )
    if design.unidentifiable:
        print(
            f"not identifiable from any input of this form: {', '.join(design.unidentifiable)} (a null direction of the information matrix: the model structure hides them)"
        )
    print("wrote " + ", ".join(str(f) for f in files))
    return 0


COMMANDS = {"fit": fit, "simulate": simulate_cmd, "validate": validate_cmd, "report": report_cmd, "design": design_cmd}


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    from .devices import use_compilation_cache, use_compiled_loops, use_host_devices

    use_host_devices()
    with warnings.catch_warnings():  # main() called in a process where JAX already runs: skip quietly
        warnings.simplefilter("ignore")
        use_compiled_loops()  # a population's time loop as one CPU function (XLA_FLAGS set by the user: kept)
    use_compilation_cache()  # a repeated fit loads its executables (DCJAX_NO_CACHE=1: off)
    with warnings.catch_warnings():
        warnings.showwarning = _one_line_warning  # inside this block only (catch_warnings restores it)
        try:
            return COMMANDS[args.command](args)
        except (ValueError, OSError) as e:
            print(f"dcjax: error: {e}", file=sys.stderr)
            return 2
        except Exception as e:  # never a traceback from the command line
            print(f"dcjax: error: {type(e).__name__}: {(str(e).splitlines() or [''])[0]}", file=sys.stderr)
            return 2


def _one_line_warning(message, category, filename, lineno, file=None, line=None):
    print(f"dcjax: warning: {message}", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
