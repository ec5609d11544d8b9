"""`dcjax simulate | validate | report`: what a saved result says about recordings."""

from pathlib import Path

from .fitting import _load


def _result(path):
    from ..fitting.result import load_result

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
    from ..analysis.report import channel_fit
    from ..simulation.objectives import objective

    res = _result(args.result)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    recs = [_load(d, args, res.model) for d in args.data]
    x = [res.best_values[n] for n in res.names]
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
        res = res.uncertainty()
    print(res.report())
    return 0
