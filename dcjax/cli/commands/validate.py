"""`dcjax validate`: a saved result judged on other recordings (`dcjax.analysis.held_out`): per
recording and output its OF, rmse, nrmse, fit %, R², mae and the residual tests, with plots."""

from ...analysis.held_out import DEFAULT_INITIAL
from ...errors import ConfigError
from ..common import Loader, add_data_options, add_output_options, add_result_options, load_like_fit, saved_result
from ..output import announce, output_folder
from ..validation_lines import INITIAL_HELP, PREDICT_HELP, SKIP_HELP, skip_samples, validation_report


def add_parser(sub) -> None:
    v = sub.add_parser(
        "validate", help="a saved result on other recordings: rmse, fit %%, R², mae and residual tests per output, with plots"
    )
    v.add_argument("result", help="result.json of a fit")
    v.add_argument("data", nargs="+", help="data file(s) or embedded names")
    v.add_argument("--initial", default=DEFAULT_INITIAL, help=INITIAL_HELP)
    v.add_argument("--skip", default="0", help=SKIP_HELP)
    v.add_argument("--predict", type=int, default=None, metavar="K", help=PREDICT_HELP)
    add_output_options(v, "out", "validation.json and the plots")
    add_result_options(v)
    add_data_options(v)


def run(args) -> int:
    skip = skip_samples(args.skip, "--skip")
    res = saved_result(args)
    loader = Loader.of(args, res.model)
    recs = [load_like_fit(d, loader, res) for d in args.data]
    with output_folder(args, lambda f: [f / "validation.json"], "an earlier validation.json") as folder:
        out = announce(folder)
        if args.predict is not None and args.predict < 1:
            raise ConfigError(f"--predict must be a whole number of samples >= 1, got {args.predict}")
        lines = validation_report(res, recs, args.initial, skip, out, args.predict)
    print("\n".join(lines))
    return 0
