"""`dcjax report`: the fit report of a saved result (with its uncertainty, and a posterior)."""

import sys
from pathlib import Path

from ...errors import ConfigError
from ...io.files import file_sha256
from ..common import add_result_options, saved_result
from ..flags import as_flags


def add_parser(sub) -> None:
    r = sub.add_parser("report", help="print the fit report of a saved result")
    r.add_argument("result", help="result.json of a fit")
    r.add_argument("--uncertainty", action="store_true", help="compute standard errors (needs the fitted data file)")
    r.add_argument(
        "--posterior",
        default=None,
        help="posterior.npz of `dcjax sample` to report beside (default: the one beside RESULT.json sampled from it, if any)",
    )
    add_result_options(r, data=True)


def run(args) -> int:
    from ...analysis.posterior import Posterior  # lazy: blackjax adds ~0.3 s to importing dcjax

    res = saved_result(args)
    if args.uncertainty:
        res = res.uncertainty()
    path = Path(args.posterior) if args.posterior else Path(args.result).parent / "posterior.npz"
    if args.posterior and not path.is_file():
        raise ConfigError(f"--posterior: no such file: {path}")
    post = Posterior.load(path) if path.is_file() else None
    if post is not None and post.result_sha256 != file_sha256(args.result):
        if not args.posterior:  # the file beside it belongs to another result (or a result changed since): not this one's
            print(
                f"note: {path} was not sampled from this result.json (another fit's, or the result changed): not reported; "
                "--posterior names a posterior to report anyway",
                file=sys.stderr,
            )
            post = None
        else:
            print(f"note: --posterior {path} was not sampled from this result.json", file=sys.stderr)
    if post is not None and not set(post.names) <= set(res.names):
        raise ConfigError(f"--posterior: {path} holds draws of {', '.join(post.names)}, not of this result's parameters")
    print(as_flags(res.report(posterior=post)))
    return 0
