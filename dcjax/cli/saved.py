"""`dcjax simulate | validate | report`: what a saved result says about recordings."""

import argparse
import warnings
from pathlib import Path

import numpy as np

from .fitting import _load

# How a file is read (not what is kept of it): the command-line option -> its key in result.json's load record.
READING = {"columns": "columns", "units": "units", "scale": "scale", "dt": "dt", "rate": "rate", "delimiter": "delimiter",
           "decimal": "decimal", "const": "constants"}  # fmt: skip


def _result(path):
    from ..fitting.result import load_result

    return load_result(path)


def _load_like_fit(data: str, args, res):
    """`data` read as the command's options say, or, where none of the reading options is given,
    with the fitted file's (`result.json`: columns, units, scale, dt, rate, delimiter, decimal,
    constants);
    a channel whose peak differs from the fitted recording's by more than 10x gets a one-line
    warning (a unit or scale slip)."""
    src = next((d for d in res.settings.get("data") or [] if isinstance(d, dict)), {})
    given = any(getattr(args, k, None) not in (None, ".") for k in READING)
    load = src.get("load") or {}
    if not given and load and Path(data).exists():
        args = argparse.Namespace(**{**vars(args), **{k: _flag(k, load.get(key)) for k, key in READING.items()}})
    rec = _load(data, args, res.model)
    for c, fitted in (src.get("peaks") or {}).items():
        if c in rec.channels and fitted > 0:
            peak = float(np.max(np.abs(rec[c])))
            ratio = peak / fitted
            if not 0.1 <= ratio <= 10:
                warnings.warn(f"{rec.name}: the peak of {c} is {ratio:.3g}x the fitted recording's ({peak:.4g} vs {fitted:.4g}): "
                              "a unit or scale slip? (--units, --scale)", stacklevel=2)  # fmt: skip
    return rec


def _flag(key: str, value):
    """A saved loading option in the command line's spelling (NAME=VALUE pairs for the mappings)."""
    if isinstance(value, dict):
        return ",".join(f"{k}={v}" for k, v in value.items())
    return "." if key == "decimal" and value is None else value


def simulate_cmd(args) -> int:
    import numpy as np

    res = _result(args.result)
    rec = _load_like_fit(args.data, args, res)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    sim = res.simulate(rec)
    m = res.model
    cols = ["t", *m.inputs, *(f"{c}_meas" for c in m.outputs), *(f"{s}_sim" for s in m.states)]
    table = np.column_stack([rec.t, *(rec[c] for c in m.inputs), *(rec[c] for c in m.outputs), sim])
    path = out / f"simulated_{rec.name}.csv"
    np.savetxt(path, table, delimiter=",", header=",".join(cols), comments="", fmt="%.17g")
    res.plot(out / f"simulated_{rec.name}.png", recordings=[rec], convergence=False)
    print(f"wrote {path} and {out / f'simulated_{rec.name}.png'}")
    return 0


def validate_cmd(args) -> int:
    import jax.numpy as jnp

    from ..analysis.report import channel_fit

    res = _result(args.result)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    recs = [_load_like_fit(d, args, res) for d in args.data]
    x = jnp.asarray([res.best_values[n] for n in res.names], dtype=jnp.float64)
    width = max(12, *(len(r.name) for r in recs))
    print(f"{'recording':>{width}} {'OF':>12}  " + "  ".join(f"{'fit % ' + c:>14}" for c in res.model.outputs))
    rows = []
    for rec in recs:
        of = float(res.target([rec]).objective(x))  # a fitted recording with its own local values and initial states
        fits = channel_fit(res, rec)
        rows.append({"recording": rec.name, "of": of, "fit_percent": fits})
        print(f"{rec.name:>{width}} {of:12.4e}  " + "  ".join(f"{v:14.3f}" for v in fits.values()))
        for c, v in fits.items():
            if not v > 0:
                print(f"warning: {rec.name}: fit % of {c} is {v:.1f} <= 0: the model does not follow {c} on this recording")
        res.plot(out / f"validate_{rec.name}.png", recordings=[rec], convergence=False)
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
