"""`dcjax design`: the next experiment's input from a saved fit (optimal input design)."""

from pathlib import Path

import numpy as np

from ...analysis.design import DEFAULT_NOISE, design_input, evaluate_input
from ...analysis.design_files import noise_from_fit, scales_from_fit, write_design
from ...errors import ConfigError
from ...io.recording import check_constants
from ...io.units import SI_UNITS
from ..common import add_output_options, add_result_options, saved_result
from ..output import announce, output_folder
from ..values import named_numbers, named_ranges, names


def add_parser(sub) -> None:
    d = sub.add_parser("design", help="design the next experiment's input from a fit (optimal input design)")
    d.add_argument("result", help="result.json of a fit")
    d.add_argument("--duration", type=float, required=True, help="length of the test (s)")
    d.add_argument("--dt", type=float, required=True, help="sample time (s)")
    d.add_argument("--umin", type=float, default=None, help="lowest level of every designed input (in its unit, e.g. V)")
    d.add_argument("--umax", type=float, default=None, help="highest level of every designed input")
    d.add_argument(
        "--range",
        type=named_ranges,
        default={},
        help="a designed input's own range, NAME=LO:HI pairs over --umin/--umax, e.g. uq=-5:5,ud=-2:2",
    )
    d.add_argument(
        "--keep",
        type=names,
        default=(),
        help="inputs not designed but kept as the fitted recording has them, e.g. ud "
        "(every other input that is not a constant is designed)",
    )
    d.add_argument(
        "--const",
        type=named_numbers,
        default={},
        help="inputs constant in the designed test, e.g. pp=4 (default: the fitted recording's constants)",
    )
    d.add_argument("--hold", type=float, default=None, help="shortest time an input level is held (s; default duration/20)")
    d.add_argument(
        "--limit",
        "--i-limit",
        dest="limit",
        type=float,
        default=None,
        help="the clamp on the model's limited state (the DC motor: the supply current limit, A; default the fitted recording's)",
    )
    d.add_argument(
        "--criterion", default="d", help="d (D-optimal, default), a (A-optimal) or parameter names, e.g. for the DC motor J,Tla,Tlb,Tlc"
    )
    d.add_argument(
        "--noise",
        type=named_numbers,
        default=None,
        help="noise std. dev. per channel, e.g. for the DC motor i_a=0.05,omega=0.5 (default: the fit's residuals, "
        "or 1%% of each channel's peak under a full step where the fit left none)",
    )
    d.add_argument(
        "--baseline",
        action="append",
        default=[],
        help="CSV of an input you would run otherwise (columns t and the input, or the input alone on the design's grid); "
        "the design must then predict smaller standard errors than every baseline in each parameter of the criterion "
        "(repeatable)",
    )
    d.add_argument("--starts", type=int, default=8, help="optimizer starts")
    d.add_argument("--steps", type=int, default=300, help="optimizer steps per start")
    d.add_argument("--seed", type=int, default=0)
    add_output_options(d, "design", "design.json and its plots")
    add_result_options(d, data=True)


def run(args) -> int:

    res = saved_result(args)
    m = res.model
    noise = args.noise or None
    source = "given (--noise)"
    if noise is None:
        noise = noise_from_fit(res)
        source = (
            "the fit's residuals (rms)"
            if noise is not None
            else f"assumed: {DEFAULT_NOISE:.0%} of each channel's peak under a full step (the fit left no residuals; --noise gives yours)"
        )
    rec = res.recording
    if args.limit is not None and not m.has_limit:
        raise ConfigError(f"--limit: model {m.name} clamps no state (it has no Model.limited_state or clamp of its own)")
    limit = args.limit if args.limit is not None else res.settings.get("i_limit") or (rec.limit if rec is not None else None)
    limit = limit if m.has_limit else None
    for name, v in (("--starts", args.starts), ("--steps", args.steps)):
        if v < 1:
            raise ConfigError(f"{name} must be a positive integer, got {v}")
    t = np.arange(int(round(args.duration / args.dt)) + 1) * args.dt
    given = _given_inputs(m, rec, t, args)
    names = tuple(c for c in m.inputs if c not in given)
    u_range = _ranges(names, args)
    files = {}
    for k, f in enumerate(args.baseline):  # one entry per file, also where two files share a name
        label = f"baseline {Path(f).stem}"
        files[label if label not in files else f"{label} ({k + 1})"] = _baseline_input(f, t, names)
    try:
        design = design_input(
            m,
            res.values(0),
            duration=args.duration,
            dt=args.dt,
            u_range=u_range,
            hold=args.hold,
            limit=limit,
            given=given,
            criterion=args.criterion,
            noise=noise,
            fixed=tuple(res.fixed),
            scale=scales_from_fit(res),
            starts=args.starts,
            steps=args.steps,
            seed=args.seed,
            baselines=list(files.values()),
        )
    except np.linalg.LinAlgError as e:
        raise ConfigError(
            f"design: the information matrix of the fitted parameters could not be decomposed ({e}): the fit's "
            "parameters give a simulation the design cannot differentiate; check the fit (dcjax report) or --noise"
        ) from None
    top = np.array([u_range[c][1] for c in names])
    baselines = {"step to " + ", ".join(f"{c}={v:g}" for c, v in zip(names, top)): evaluate_input(design, m, np.tile(top, (len(t), 1)))}
    if rec is not None:
        own = {c: np.asarray(rec[c]) for c in m.inputs if c not in design.given or np.ndim(design.given[c]) > 0}
        baselines[f"recording {rec.name}"] = evaluate_input(design, m, own, t=np.asarray(rec.t - rec.t[0]))
    baselines.update({k: evaluate_input(design, m, u) for k, u in files.items()})
    with output_folder(args, lambda f: [f / "design.json"], "an earlier design.json") as folder:
        written = write_design(design, baselines, announce(folder), m)
    ranges = ", ".join(f"{c} in [{u_range[c][0]:g}, {u_range[c][1]:g}]" for c in names)
    kept = [c for c in given if np.ndim(given[c]) > 0]
    consts = {c: v for c, v in given.items() if np.ndim(v) == 0}
    print(
        f"designed input: {design.criterion}-criterion, {args.duration:g} s at {args.dt:g} s, {ranges}, hold {design.hold:g} s"
        + (f"; kept as recording {rec.name}: {', '.join(kept)}" if kept and rec is not None else "")
        + (f"; constants {', '.join(f'{c}={v:g}' for c, v in consts.items())}" if consts else "")
    )
    print("noise (std. dev.): " + ", ".join(f"{c} {v:.3g}{_unit(m, c)}" for c, v in design.noise.items()) + f", {source}")
    for line in _other_sign(design, rec, m, names):
        print(line)
    width = max(22, *(len(k) + 1 for k in baselines))
    print(f"{'param':>6} {'design':>12}" + "".join(f" {k:>{width}}" for k in baselines) + "   (predicted relative std. errors)")
    for n in design.free:
        print(
            f"{n:>6} {_percent(design.relative_stderr()[n]):>12}"
            + "".join(f" {_percent(b.relative_stderr()[n]):>{width}}" for b in baselines.values())
        )
    if design.unidentifiable:
        print(
            f"not identifiable from any input of this form: {', '.join(design.unidentifiable)} (a null direction of the information matrix: the model structure hides them)"
        )
    for k in files:
        worse = [n for n in design.free if design.stderr[n] >= baselines[k].stderr[n] and n in _criterion_names(design)]
        if worse:
            print(f"note: the design does not beat {k} in {', '.join(worse)} (no profile of this form found that does)")
    print("wrote " + ", ".join(str(f) for f in written))
    return 0


def _unit(m, c: str) -> str:
    unit = SI_UNITS.get(m.quantities.get(c, ""), "")
    return f" {unit}" if unit else ""


def _other_sign(design, rec, m, designed) -> list[str]:
    """A warning per output that the designed input drives to the sign the fitted recording never
    reached (beyond 5 % of its peak): the model was fitted on one side only (a friction term that does
    not reverse with the direction of motion is wrong on the other)."""
    if rec is None:
        return []
    out = []
    for c in m.outputs:
        if c not in rec.channels:
            continue
        seen, y = np.asarray(rec[c]), np.asarray(design.recording[c])
        margin = 0.05 * float(np.max(np.abs(seen)))
        far = float(y.min()) if seen.min() >= 0 and y.min() < -margin else float(y.max()) if seen.max() <= 0 and y.max() > margin else None
        if far is not None:
            out.append(
                f"warning: the designed input drives {c} to {far:.3g}{_unit(m, c)}, a sign the fitted recording {rec.name} never reached "
                f"({seen.min():.3g} .. {seen.max():.3g}): the model was fitted on one side only (a friction term that does not reverse "
                f"with the direction of motion is wrong on the other); keep the input on one side (--range {designed[0]}=LO:HI) or fit "
                "a recording of both"
            )
    return out


def _percent(v: float) -> str:
    return f"{100 * v:.3g}%" if v < float("inf") else "not identifiable"


def _given_inputs(m, rec, t, args) -> dict:
    """The inputs that are not designed: the model's per-recording constants (the fitted
    recording's, over them --const), and the inputs --keep names, as the fitted recording has them
    (held from sample to sample, the last held to the end of the design)."""

    consts = {**(rec.constants if rec is not None else {}), **args.const}
    check_constants(m, consts)
    given: dict = dict(consts)
    for c in args.keep:
        if c not in m.inputs:
            raise ConfigError(f"--keep: {c} is not an input of model {m.name} (its inputs: {', '.join(m.inputs)})")
        if rec is None:
            raise ConfigError(f"--keep {c}: the fitted recording cannot be read again (its file moved?); design {c} too, or --const {c}=V")
        if c in given:
            continue
        tr = np.asarray(rec.t - rec.t[0])
        given[c] = np.asarray(rec[c])[np.clip(np.searchsorted(tr, t + 1e-9 * (t[1] - t[0]), side="right") - 1, 0, len(tr) - 1)]
    if m.inputs and all(c in given for c in m.inputs):
        raise ConfigError(f"--keep/--const: every input of model {m.name} is given ({', '.join(m.inputs)}); leave one to design")
    return given


def _ranges(names, args) -> dict[str, tuple[float, float]]:
    """Each designed input's range: --range NAME=LO:HI, else --umin/--umax."""
    given = args.range
    bad = [c for c in given if c not in names]
    if bad:
        raise ConfigError(f"--range: {', '.join(bad)} is not designed; the designed inputs are {', '.join(names)}")
    out = {}
    for c in names:
        if c in given:
            out[c] = given[c]
        elif args.umin is not None and args.umax is not None:
            out[c] = (args.umin, args.umax)
        else:
            raise ConfigError(f"no range for input {c}: give --umin and --umax, or --range {c}=LO:HI")
    return out


def _criterion_names(design) -> tuple[str, ...]:
    c = design.criterion
    return design.free if c in ("d", "a") else tuple(s.strip() for s in c.split(","))


def _baseline_input(path: str, t, names: tuple[str, ...]):
    """A baseline of the designed inputs `names` on the design's grid `t`: a CSV with a header
    naming t and each of them (held from each sample to the next), or, for one designed input,
    one column of len(t) values. (N,) for one input, (N, D) for D."""

    try:
        table = np.genfromtxt(path, delimiter=",", names=True, dtype=float)
    except (OSError, ValueError) as e:
        raise ConfigError(f"--baseline {path}: {e}") from None
    cols = table.dtype.names or ()
    if "t" in cols and all(c in cols for c in names):
        tb = np.atleast_1d(table["t"])
        ub = np.column_stack([np.atleast_1d(table[c]) for c in names])
        if not (np.all(np.isfinite(tb)) and np.all(np.isfinite(ub)) and np.all(np.diff(tb) > 0)):
            raise ConfigError(f"--baseline {path}: t must increase and t, {', '.join(names)} be finite")
        if tb[-1] - tb[0] < t[-1] - 1e-9 * (t[1] - t[0]):
            print(
                f"note: --baseline {path} lasts {tb[-1] - tb[0]:g} s, shorter than the design's {t[-1]:g} s: its last level "
                f"{', '.join(f'{v:g}' for v in ub[-1])} is held to the end"
            )
        u = ub[np.clip(np.searchsorted(tb - tb[0], t + 1e-9 * (t[1] - t[0]), side="right") - 1, 0, len(tb) - 1)]
        return u[:, 0] if len(names) == 1 else u
    if len(names) == 1 and len(cols) == 1 and np.atleast_1d(table[cols[0]]).shape == t.shape:
        return np.atleast_1d(table[cols[0]])
    one = f", or one column of {len(t)} values" if len(names) == 1 else ""
    raise ConfigError(f"--baseline {path}: needs columns t and {', '.join(names)}{one}; has {', '.join(cols) or 'none'}")
