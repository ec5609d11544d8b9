"""`dcjax simulate`: a saved result simulated on a recording, as a CSV of the measured and
simulated channels and a plot."""

import numpy as np

from ...io.files import write_atomic
from ..common import Loader, add_data_options, add_output_options, add_result_options, load_like_fit, saved_result
from ..output import announce, file_names, output_folder


def add_parser(sub) -> None:
    s = sub.add_parser("simulate", help="simulate a saved result on a recording: CSV of measured and simulated channels, and a plot")
    s.add_argument("result", help="result.json of a fit")
    s.add_argument("data", help="data file or embedded name")
    add_output_options(s, "out", "the CSV and its plot")
    add_result_options(s)
    add_data_options(s)


def run(args) -> int:
    res = saved_result(args)
    rec = load_like_fit(args.data, Loader.of(args, res.model), res)
    stem = f"simulated_{file_names([rec.name])[0]}"
    sim = res.simulate(rec)
    m = res.model
    cols = ["t", *m.inputs, *(f"{c}_meas" for c in m.outputs), *(f"{s}_sim" for s in m.states)]
    table = np.column_stack([rec.t, *(rec[c] for c in m.inputs), *(rec[c] for c in m.outputs), sim])
    if m.has_output_equation:  # the outputs as the sensors read them, beside the states
        outs = [j for j, c in enumerate(m.outputs) if c not in m.states]
        cols += [f"{m.outputs[j]}_sim" for j in outs]
        table = np.column_stack([table, res.simulate_outputs(rec)[:, outs]])
    with output_folder(args, lambda f: [f / f"{stem}.csv"], f"an earlier {stem}.csv") as folder:
        out = announce(folder)
        path = write_atomic(
            out / f"{stem}.csv", lambda tmp: np.savetxt(tmp, table, delimiter=",", header=",".join(cols), comments="", fmt="%.17g")
        )
        res.plot(out / f"{stem}.png", recordings=[rec], convergence=False)
    print(f"wrote {path} and {out / f'{stem}.png'}")
    return 0
