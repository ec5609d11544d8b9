"""`dcjax design`: the next experiment's input from a saved fit (optimal input design)."""

from pathlib import Path

from .args import _named_floats
from .saved import _result


def design_cmd(args) -> int:
    import numpy as np

    from ..analysis.design import design_input, evaluate_input, noise_from_fit, scales_from_fit, write_design

    res = _result(args.result)
    m = res.model
    noise = _named_floats(args.noise, "--noise") or None
    if noise is None:
        noise = noise_from_fit(res)
    rec = res.recording
    limit = args.limit if args.limit is not None else res.settings.get("i_limit") or (rec.limit if rec is not None else None)
    for name, v in (("--starts", args.starts), ("--steps", args.steps)):
        if v < 1:
            raise ValueError(f"{name} must be a positive integer, got {v}")
    t = np.arange(int(round(args.duration / args.dt)) + 1) * args.dt
    given = {}
    for k, f in enumerate(args.baseline):  # one entry per file, also where two files share a name
        label = f"baseline {Path(f).stem}"
        given[label if label not in given else f"{label} ({k + 1})"] = _baseline_input(f, t, m.inputs[0] if m.inputs else "u")
    design = design_input(
        m, res.values(0), duration=args.duration, dt=args.dt, u_range=(args.umin, args.umax), hold=args.hold, limit=limit,
        criterion=args.criterion, noise=noise, fixed=tuple(res.fixed), scale=scales_from_fit(res), starts=args.starts,
        steps=args.steps, seed=args.seed, baselines=list(given.values()),
    )  # fmt: skip
    baselines = {f"step to {args.umax:g}": evaluate_input(design, m, np.full_like(t, args.umax))}
    if rec is not None:
        baselines[f"recording {rec.name}"] = evaluate_input(design, m, np.asarray(rec[m.inputs[0]]), t=np.asarray(rec.t - rec.t[0]))
    baselines.update({k: evaluate_input(design, m, u) for k, u in given.items()})
    files = write_design(design, baselines, Path(args.out), m)
    print(
        f"designed input: {design.criterion}-criterion, {args.duration:g} s at {args.dt:g} s, levels in [{args.umin:g}, {args.umax:g}], hold {design.hold:g} s"
    )
    print("noise: " + ", ".join(f"{c} {v:.3g}" for c, v in design.noise.items()))
    print(f"{'param':>6} {'design':>12}" + "".join(f" {k:>22}" for k in baselines) + "   (predicted relative std. errors)")
    for n in design.free:
        print(
            f"{n:>6} {100 * design.relative_stderr()[n]:>11.3g}%"
            + "".join(f" {100 * b.relative_stderr()[n]:>21.3g}%" for b in baselines.values())
        )
    if design.unidentifiable:
        print(
            f"not identifiable from any input of this form: {', '.join(design.unidentifiable)} (a null direction of the information matrix: the model structure hides them)"
        )
    for k in given:
        worse = [n for n in design.free if design.stderr[n] >= baselines[k].stderr[n] and n in _criterion_names(design)]
        if worse:
            print(f"note: the design does not beat {k} in {', '.join(worse)} (no profile of this form found that does)")
    print("wrote " + ", ".join(str(f) for f in files))
    return 0


def _criterion_names(design) -> tuple[str, ...]:
    c = design.criterion
    return design.free if c in ("d", "a") else tuple(s.strip() for s in c.split(","))


def _baseline_input(path: str, t, name: str):
    """A baseline input on the design's grid `t`: a CSV with a header naming t and `name` (held
    from each sample to the next), or one column of len(t) values."""
    import numpy as np

    try:
        table = np.genfromtxt(path, delimiter=",", names=True, dtype=float)
    except (OSError, ValueError) as e:
        raise ValueError(f"--baseline {path}: {e}") from None
    cols = table.dtype.names or ()
    if "t" in cols and name in cols:
        tb, ub = np.atleast_1d(table["t"]), np.atleast_1d(table[name])
        if not (np.all(np.isfinite(tb)) and np.all(np.isfinite(ub)) and np.all(np.diff(tb) > 0)):
            raise ValueError(f"--baseline {path}: t must increase and t, {name} be finite")
        if tb[-1] - tb[0] < t[-1] - 1e-9 * (t[1] - t[0]):
            print(f"note: --baseline {path} lasts {tb[-1] - tb[0]:g} s, shorter than the design's {t[-1]:g} s: its last level "
                  f"{ub[-1]:g} is held to the end")  # fmt: skip
        return ub[np.clip(np.searchsorted(tb - tb[0], t + 1e-9 * (t[1] - t[0]), side="right") - 1, 0, len(tb) - 1)]
    if len(cols) == 1 and np.atleast_1d(table[cols[0]]).shape == t.shape:
        return np.atleast_1d(table[cols[0]])
    raise ValueError(f"--baseline {path}: needs columns t and {name}, or one column of {len(t)} values; has {', '.join(cols) or 'none'}")
