"""`dcjax validate`: a saved result judged on other recordings (`dcjax.analysis.held_out`): per
recording and output its OF, rmse, nrmse, fit %, R², mae and the residual tests, with plots."""

from ...analysis.held_out import INITIAL_MODES, validate
from ...analysis.metrics import LAGS
from ...errors import ConfigError
from ...io.files import strict_json, write_text
from ..common import Loader, add_data_options, add_output_options, add_result_options, load_like_fit, saved_result
from ..output import announce, file_names, output_folder


def add_parser(sub) -> None:
    v = sub.add_parser(
        "validate", help="a saved result on other recordings: rmse, fit %%, R², mae and residual tests per output, with plots"
    )
    v.add_argument("result", help="result.json of a fit")
    v.add_argument("data", nargs="+", help="data file(s) or embedded names")
    v.add_argument(
        "--initial",
        default="measured",
        help="each record's initial state: measured (a recorded state's first sample, as the fit's specs say; the default) "
        "or fitted (the fit's fitted initial states: records that share their start)",
    )
    v.add_argument("--skip", default="0", help="samples left out of every figure at the start (a benchmark's initialisation window)")
    add_output_options(v, "out", "validation.json and the plots")
    add_result_options(v)
    add_data_options(v)


def _skip(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        n = -1
    if n < 0:
        raise ConfigError(f"--skip must be a whole number of samples >= 0, got {text!r}")
    return n


def run(args) -> int:
    if args.initial not in INITIAL_MODES:
        raise ConfigError(f"--initial must be one of {', '.join(INITIAL_MODES)}, got {args.initial!r}")
    skip = _skip(args.skip)
    res = saved_result(args)
    loader = Loader.of(args, res.model)
    recs = [load_like_fit(d, loader, res) for d in args.data]
    vals = validate(res, recs, initial=args.initial, skip=skip)
    width = max(12, *(len(r.name) for r in recs))
    with output_folder(args, lambda f: [f / "validation.json"], "an earlier validation.json") as folder:
        out = announce(folder)
        print(f"initial state {args.initial}; {skip} sample(s) skipped; residual tests over lags 1..{LAGS} (99 % bands)")
        print(
            f"{'recording':>{width}} {'output':>10} {'OF':>12} {'rmse':>12} {'nrmse':>9} {'fit %':>9} {'R2':>9} {'mae':>12} "
            f"{'white':>6} {'input':>6}"
        )
        rows = []
        for v, rec, name in zip(vals, recs, file_names([r.name for r in recs])):
            for c, f in v.channels.items():
                corr = max(f["input_correlation"].values(), default=float("nan"))
                print(
                    f"{v.recording:>{width}} {c:>10} {v.of:12.4e} {f['rmse']:12.4e} {f['nrmse']:9.4f} {f['fit_percent']:9.3f} "
                    f"{f['r2']:9.4f} {f['mae']:12.4e} {f['whiteness']:6.2f} {corr:6.2f}"
                )
                if not f["fit_percent"] > 0:
                    print(
                        f"warning: {v.recording}: fit % of {c} is {f['fit_percent']:.1f} <= 0: the model does not follow {c} on this recording"
                    )
            rows.append(
                {**v.to_dict(), "fit_percent": {c: f["fit_percent"] for c, f in v.channels.items()}, "plot": f"validate_{name}.png"}
            )
            res.plot(out / f"validate_{name}.png", recordings=[rec], convergence=False)
        write_text(out / "validation.json", strict_json(rows) + "\n")
    print(
        "white: the fraction of the residual's autocorrelation lags outside its band; input: the largest over the inputs of the "
        "fraction of cross-correlation lags outside theirs (an output-error model with sensor noise alone: both near 0)"
    )
    print(f"wrote {out / 'validation.json'} and {len(recs)} plot(s) in {out}")
    return 0
