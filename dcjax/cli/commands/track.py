"""`dcjax track`: a saved result's parameters followed through a recording (`dcjax.analysis.tracking`):
track.csv (t, each parameter and its sd) and track.png with the bands."""

from ...analysis.tracking import plot_tracked, track
from ...io.files import write_text
from ...numbers import csv_text
from ..common import Loader, add_data_options, add_output_options, add_result_options, load_like_fit, saved_result
from ..output import announce, output_folder
from ..values import named_numbers, names


def add_parser(sub) -> None:
    t = sub.add_parser(
        "track",
        help="follow a saved result's parameters through a recording (a Kalman filter on the state augmented with them, "
        "and a smoother): track.csv and track.png",
    )
    t.add_argument("result", help="result.json of a fit")
    t.add_argument("data", help="data file or embedded name")
    t.add_argument("--vary", type=names, required=True, help="the parameters that may drift, e.g. for the DC motor Ra or Ra,cm")
    t.add_argument(
        "--drift",
        type=named_numbers,
        default={},
        metavar="NAME=Q",
        help="a parameter's random-walk intensity (unit^2/s), NAME=Q pairs (default: (0.1 x its value)^2 over the record's duration)",
    )
    add_output_options(t, "out", "track.csv and track.png")
    add_result_options(t)
    add_data_options(t)


def run(args) -> int:
    res = saved_result(args)
    rec = load_like_fit(args.data, Loader.of(args, res.model), res)
    tracked = track(res, rec, args.vary, args.drift)
    cols, rows = tracked.table()
    with output_folder(args, lambda f: [f / "track.csv"], "an earlier track.csv") as folder:
        out = announce(folder)
        write_text(out / "track.csv", csv_text(cols, rows))
        plot_tracked(tracked, out / "track.png")
    for k, n in enumerate(tracked.names):
        v, s = tracked.values[:, k], tracked.sd[:, k]
        print(
            f"{n}: {v[0]:.5g} +- {s[0]:.2g} at t = {tracked.t[0]:g} s, {v[-1]:.5g} +- {s[-1]:.2g} at t = {tracked.t[-1]:g} s "
            f"({100 * (v[-1] - v[0]) / abs(v[0]) if v[0] else float('nan'):+.1f} %); drift intensity {tracked.drift[n]:.3g}"
        )
    print(f"wrote {out / 'track.csv'} and {out / 'track.png'}")
    return 0
