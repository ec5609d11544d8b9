"""`dcjax validate`: a saved result's OF and fit % per channel on other recordings, with plots."""

import jax.numpy as jnp

from ...analysis.report import channel_fit
from ...io.files import strict_json, write_text
from ..common import Loader, add_data_options, add_output_options, add_result_options, load_like_fit, saved_result
from ..output import announce, file_names, output_folder


def add_parser(sub) -> None:
    v = sub.add_parser("validate", help="OF and fit %% per channel of a saved result on other recordings, with plots")
    v.add_argument("result", help="result.json of a fit")
    v.add_argument("data", nargs="+", help="data file(s) or embedded names")
    add_output_options(v, "out", "validation.json and the plots")
    add_result_options(v)
    add_data_options(v)


def run(args) -> int:
    res = saved_result(args)
    loader = Loader.of(args, res.model)
    recs = [load_like_fit(d, loader, res) for d in args.data]
    x = jnp.asarray([res.best_values[n] for n in res.names], dtype=jnp.float64)
    width = max(12, *(len(r.name) for r in recs))
    with output_folder(args, lambda f: [f / "validation.json"], "an earlier validation.json") as folder:
        out = announce(folder)
        print(f"{'recording':>{width}} {'OF':>12}  " + "  ".join(f"{'fit % ' + c:>14}" for c in res.model.outputs))
        rows = []
        for rec, name in zip(recs, file_names([r.name for r in recs])):
            of = float(res.target([rec]).objective(x))  # a fitted recording with its own local values and initial states
            fits = channel_fit(res, rec)
            rows.append({"recording": rec.name, "of": of, "fit_percent": fits, "plot": f"validate_{name}.png"})
            print(f"{rec.name:>{width}} {of:12.4e}  " + "  ".join(f"{v:14.3f}" for v in fits.values()))
            for c, v in fits.items():
                if not v > 0:
                    print(f"warning: {rec.name}: fit % of {c} is {v:.1f} <= 0: the model does not follow {c} on this recording")
            res.plot(out / f"validate_{name}.png", recordings=[rec], convergence=False)
        write_text(out / "validation.json", strict_json(rows) + "\n")
    print(f"wrote {out / 'validation.json'} and {len(recs)} plot(s) in {out}")
    return 0
