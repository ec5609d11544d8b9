"""`dcjax fit DATA.csv`: identify the seven parameters of a recording from the command line."""

import argparse
import sys
from pathlib import Path

from .params import PARAM_NAMES, PARAM_UNITS


def _floats(text: str, n: int, what: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise ValueError(f"{what} must be {n} comma-separated numbers, got {text!r}") from None
    if len(values) != n:
        raise ValueError(f"{what} must be {n} comma-separated numbers, got {len(values)}")
    return values


def _parser() -> argparse.ArgumentParser:
    from .strategies import METHODS

    p = argparse.ArgumentParser(prog="dcjax", description="DC motor and drive parameter identification.")
    sub = p.add_subparsers(dest="command", required=True)
    f = sub.add_parser("fit", help="identify Ra, La, cm, J, Tla, Tlb, Tlc from a t,u_a,i_a,omega CSV")
    f.add_argument("data", nargs="+", help="CSV file(s) (t,u_a,i_a,omega) or embedded names (SD1..SD4); several = joint fit")
    f.add_argument("--method", default="de-rand-1-exp", help=f"{', '.join(METHODS)} or an evosax algorithm (CMA_ES, PSO, ...)")
    f.add_argument("--integrator", default="rk4", choices=["euler", "rk4"])
    f.add_argument("--nd", default="1", help="sub-steps per sample interval (eq. 28), or 'auto'")
    f.add_argument("--runs", type=int, default=50)
    f.add_argument("--budget", type=int, default=140_000, help="fitness evaluations per run")
    f.add_argument("--seed", type=int, default=0)
    f.add_argument("--weights", default="1,1", help="w1,w2 of eq. 27 (default 1,1 = eq. 24)")
    f.add_argument("--bounds", default=None, help="table4 or table8 (default: table4, or the sidecar's 'bounds')")
    f.add_argument("--lower", default=None, help="7 comma-separated lower bounds")
    f.add_argument("--upper", default=None, help="7 comma-separated upper bounds")
    f.add_argument("--i-limit", type=float, default=None, help="supply current limit (A)")
    f.add_argument("--polish", action="store_true", help="Levenberg-Marquardt polish of every run")
    f.add_argument("--uncertainty", action="store_true", help="print standard errors, 95%% intervals and identifiability")
    f.add_argument("--memory", default=None, choices=["stma", "ltma-s1", "ltma-s2"], help="memory assistance (Section 4.4)")
    f.add_argument("--precision", default=None, help="7 comma-separated duplicate precisions (default Table 29)")
    f.add_argument("--generations", type=int, default=None, help="stop each run after this many iterations")
    f.add_argument("--out", default="out", help="output folder for result.json and fit.png")
    return p


def _load(data: str):
    from . import datasets
    from .recording import load_csv

    if not Path(data).exists() and data.upper() in datasets.SD_PARAMS:
        return datasets.load(data)
    return load_csv(data)


def fit(args) -> int:
    import numpy as np

    from .bounds import Bounds, bounds_preset
    from .identify import identify

    recs = [_load(d) for d in args.data]
    rec = recs[0]
    if args.nd == "auto":
        nd = "auto"
    else:
        try:
            nd = int(args.nd)
        except ValueError:
            raise ValueError(f"--nd must be a positive integer or 'auto', got {args.nd!r}") from None
    weights = tuple(_floats(args.weights, 2, "--weights"))
    if (args.lower is None) != (args.upper is None):
        raise ValueError("--lower and --upper must be given together")
    if args.lower is not None:
        if args.bounds is not None:
            raise ValueError("give either --bounds or --lower/--upper, not both")
        bounds = Bounds(_floats(args.lower, 7, "--lower"), _floats(args.upper, 7, "--upper"))
    else:
        bounds = bounds_preset(args.bounds or rec.metadata.get("bounds", "table4"))
    result = identify(
        recs,
        method=args.method,
        integrator=args.integrator,
        nd=nd,
        weights=weights,
        bounds=bounds,
        runs=args.runs,
        budget=args.budget,
        seed=args.seed,
        polish=args.polish,
        i_limit=args.i_limit,
        memory=args.memory,
        precision=None if args.precision is None else _floats(args.precision, 7, "--precision"),
        generations=args.generations,
    )
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    result.to_json(out / "result.json")
    result.plot(out / "fit.png")
    truth = rec.metadata.get("true_params")
    if any(r.metadata.get("true_params") != truth for r in recs):
        truth = None
    names = " + ".join(r.name for r in recs)
    print(f"{names}: {args.method}, {args.integrator}, ND={result.settings['nd']}, {args.runs} runs x {args.budget} FEs, seed {args.seed}")
    for step in result.settings.get("nd_sequence", []):
        change = "" if step["max_rel_change"] is None else f", max rel. change {step['max_rel_change']:.2e}"
        print(f"  ND={step['nd']}: OF {step['of']:.4e}{change}")
    header = f"{'param':>6} {'unit':>7} {'identified':>22}" + (f" {'true':>14} {'rel. error':>11}" if truth else "")
    print(header)
    for name in PARAM_NAMES:
        v = result.params[name]
        line = f"{name:>6} {PARAM_UNITS[name]:>7} {v:>22.15g}"
        if truth:
            t = truth[name]
            line += f" {t:>14.6g} {abs(v - t) / abs(t) if t else abs(v):>11.2e}"
        print(line)
    s = result.stats
    print(f"OF best {s['best']:.4e}  worst {s['worst']:.4e}  mean {s['mean']:.4e}  std {s['std']:.4e}")
    print(f"runs with OF <= 1e-15: {int(np.sum(result.run_of <= 1e-15))}/{args.runs}")
    if result.duplicates is not None:
        d = result.duplicates
        print(f"memory {args.memory}: {d['percent']:.1f} % of candidates answered from memory; mean FEs {result.fes.mean():.0f}, iterations {result.iterations.mean():.0f}")
    if args.uncertainty:
        print(result.uncertainty().table())
    print(f"compile {result.timing['compile_s']:.2f} s, run {result.timing['run_s']:.2f} s; wrote {out / 'result.json'} and {out / 'fit.png'}")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        return fit(args)
    except ValueError as e:
        print(f"dcjax: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
