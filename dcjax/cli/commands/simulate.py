"""`dcjax simulate`: a saved result simulated on a recording (or on a file of its inputs alone),
as a CSV of the inputs, the measured outputs it holds and the simulated states and outputs (in
the file's own units where it was read with units), and a plot."""

import numpy as np

from ...io.files import write_text
from ...io.units import unit_factor
from ...numbers import csv_text
from ..common import Loader, add_data_options, add_output_options, add_result_options, load_like_fit, saved_result
from ..output import announce, file_names, output_folder


def add_parser(sub) -> None:
    s = sub.add_parser(
        "simulate",
        help="simulate a saved result on a recording or on its inputs alone: CSV of the inputs, measured and simulated channels, and a plot",
    )
    s.add_argument("result", help="result.json of a fit")
    s.add_argument("data", help="data file or embedded name: a recording, or t and the model's inputs alone")
    add_output_options(s, "out", "the CSV and its plot")
    add_result_options(s)
    add_data_options(s)


def file_factors(rec, model) -> dict[str, float]:
    """Channel -> the factor from SI back to the file's own unit (its `units` and `scale` as it
    was read: value_file = value_SI / factor), for the channels read with one."""
    load = (rec.metadata.get("source") or {}).get("load") or {}
    units, scale = load.get("units") or {}, load.get("scale") or {}
    out = {}
    for c in {*units, *scale}:
        quantity = "time" if c == "t" else model.quantities.get(c)
        out[c] = (unit_factor(c, units[c], quantity) if c in units else 1.0) * float(scale.get(c, 1.0))
    return {c: f for c, f in out.items() if f != 1.0}


def run(args) -> int:
    res = saved_result(args)
    m = res.model
    rec = load_like_fit(args.data, Loader.of(args, m, measured=False), res)
    stem = f"simulated_{file_names([rec.name])[0]}"
    sim = res.simulation(rec)
    measured = [c for c in m.outputs if c in rec.channels]
    outputs = [c for c in m.outputs if c not in m.states]
    named = [("t", "t", rec.t), *((u, u, rec[u]) for u in m.inputs), *((f"{c}_meas", c, rec[c]) for c in measured)]
    named += [(f"{c}_sim", c, sim[c]) for c in (*m.states, *outputs)]
    factors = file_factors(rec, m)
    cols = [name for name, _, _ in named]
    table = np.column_stack([np.asarray(v, float) / factors.get(c, 1.0) for _, c, v in named])
    with output_folder(args, lambda f: [f / f"{stem}.csv"], f"an earlier {stem}.csv") as folder:
        out = announce(folder)
        path = write_text(out / f"{stem}.csv", csv_text(cols, table))  # plain numbers: 0.0324, not 0.032399999999999998
        res.plot(out / f"{stem}.png", recordings=[rec], convergence=False)
    if factors:
        load = rec.metadata["source"]["load"]
        units = ", ".join(f"{c} {load.get('units', {}).get(c, 'SI')}" + (f" (scaled {load['scale'][c]:g})" if c in (load.get("scale") or {}) else "")
                          for c in sorted(factors))  # fmt: skip
        print(f"columns in the file's own units: {units}; the others in SI")
    if not measured:
        print(f"{rec.name} holds no output ({', '.join(m.outputs)}): the simulation alone, from the initial states the fit's specs give")
    print(f"wrote {path} and {out / f'{stem}.png'}")
    return 0
