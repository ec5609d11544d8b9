"""A fit report to paste into lab notes, in the manner of lmfit's `fit_report`, and the
goodness-of-fit figures it uses (fit % as MATLAB's `compare`: 100 (1 - NRMSE))."""

import numpy as np


def fit_percent(measured: np.ndarray, simulated: np.ndarray) -> float:
    """100 (1 - ||y - y_sim|| / ||y - mean(y)||): 100 is a perfect fit, 0 no better than the mean."""
    y = np.asarray(measured, float)
    d = np.linalg.norm(y - y.mean())
    return float(100 * (1 - np.linalg.norm(y - np.asarray(simulated, float)) / d)) if d > 0 else float("nan")


def channel_fit(result, recording) -> dict[str, float]:
    """Fit % of every measured channel of `recording` under the result's best parameters."""
    sim = result.simulate_outputs(recording)
    return {c: fit_percent(recording[c], sim[:, j]) for j, c in enumerate(result.model.outputs)}


def stop_summary(result) -> str:
    """How the search's stopping rule (`Search.stop`) ended the runs: `2/2 runs after 9,310 of
    20,000 FEs (mean; rtol 1e-08, atol 0, patience 50)`."""
    spec = result.search.stop or {}
    rule = f"rtol {spec.get('rtol', 0):g}, atol {spec.get('atol', 0):g}, patience {spec.get('patience', 0)}"
    conv = np.zeros(len(result.run_of), bool) if result.converged is None else np.asarray(result.converged, bool)
    if not conv.any():
        return f"0/{len(conv)} runs ({rule}): every run spent its budget"
    return (
        f"{int(conv.sum())}/{len(conv)} runs after {float(np.mean(result.fes[conv])):,.0f} of {result.search.budget:,} FEs (mean; {rule})"
    )


def fit_report(result, correl_threshold: float = 0.9, posterior=None) -> str:
    """Model, settings, OF statistics, fit % per channel, every parameter with its standard
    error (where `result.uncertainty()` was computed), fixed and at-bound flags, the strongly
    correlated pairs and, given a `Posterior` of the result, its 90 % intervals beside the
    linearised ones."""
    s = result.settings
    m = result.model
    st = result.stats
    lines = ["[[Model]]", f"    {m.name}: {', '.join(m.names)}"]
    lines += [
        "[[Fit Statistics]]",
        f"    method             = {s['method']}, {s['integrator']}, ND = {s['nd']}",
        f"    runs x FEs         = {s['runs']} x {s['budget']}, seed {s['seed']}" + (", LM polish" if s.get("polish") else ""),
    ]
    if s.get("stop"):
        lines.append(f"    converged          = {stop_summary(result)}")
    obs = getattr(result, "observation", None)
    if obs is not None and not obs.plain:
        norm = (
            "over each channel's peak"
            if obs.loss.normalize == "peak"
            else "raw units" + (", pooled by samples" if len(result.recordings) > 1 else "")
        )
        lines.append(f"    loss               = {obs.loss.spec} ({norm})")
        if obs.initial:
            lines.append(f"    initial state      = {', '.join(f'{k}={v}' for k, v in obs.initial.items())}")
        if obs.offsets or obs.delays:
            lines.append(
                "    sensors            = " + ", ".join([*(f"offset on {c}" for c in obs.offsets), *(f"delay of {c}" for c in obs.delays)])
            )
    for rec in result.recordings:
        consts = ", constants " + ", ".join(f"{k}={v:g}" for k, v in rec.constants.items()) if rec.constants else ""
        lines.append(f"    data               = {rec.name} ({len(rec)} samples, t {rec.t[0]:g}..{rec.t[-1]:g} s{consts})")
    if not result.recordings:
        lines.append(f"    data               = {s.get('recording')} (not loaded)")
    lines.append(f"    objective (best)   = {st['best']:.6e}")
    lines.append(f"    objective W/M/SD   = {st['worst']:.4e} / {st['mean']:.4e} / {st['std']:.4e}")
    lines.append(f"    # fitness evals    = {result.nfev}")
    lines.append(f"    # data points      = {result.ndata}")
    lines.append(f"    # variables        = {result.nvarys}")
    lines.append(f"    chi-square         = {result.chisqr:.6e}")
    lines.append(f"    reduced chi-square = {result.redchi:.6e}")
    lines.append(f"    Akaike info crit   = {result.aic:.4f}")
    lines.append(f"    Bayesian info crit = {result.bic:.4f}")
    lines.append(f"    success            = {result.success} ({result.message})")
    for rec in result.recordings:
        fits = channel_fit(result, rec)
        lines.append(
            f"    fit % ({rec.name})" + " " * max(1, 11 - len(rec.name)) + "= " + ", ".join(f"{c} {v:.3f}" for c, v in fits.items())
        )
    u = result.uncertainties
    lines.append("[[Variables]]")
    at_bound = set(result.at_bound())
    names = result.names
    params = result.params
    width = max(len(n) for n in names)
    recs = [r.name for r in result.recordings] or (s.get("recording") if isinstance(s.get("recording"), list) else [])
    for n in names:
        v = result.best_values[n]
        unit = params[n].unit
        text = f"    {n + ':':<{width + 1}} {v: .10g}"
        if n in result.fixed:
            text += " (fixed)"
        elif u is not None:
            se = u.se[n]
            rel = f" ({100 * se / abs(v):.2f}%)" if v else ""
            text += f" +/- {se:.3g}{rel}" if np.isfinite(se) else " +/- -"
        text += f" {unit}" if unit else ""
        if n in at_bound:
            text += "  [at bound]"
        if u is not None and n not in result.fixed and u.verdict[n] != "well determined":
            text += f"  [{u.verdict[n]}: {u.reason[n]}]"
        if n.endswith("]") and "[" in n:
            k = int(n[n.rindex("[") + 1 : -1])
            text += f"  ({recs[k]})" if k < len(recs) else ""
        lines.append(text)
    if u is None:
        lines.append("    (standard errors: result.uncertainty())")
    else:
        lines += [f"    {line}" for line in u.combination_lines()]
        if getattr(u, "approximation", ""):
            lines.append(f"    ({u.approximation})")
        pairs = u.strong_correlations(correl_threshold)
        lines.append(f"[[Correlations]] (unreported correlations are < {correl_threshold:.3f})")
        lines += [f"    C({a}, {b}) = {c:+.4f}" for a, b, c in pairs] or ["    none"]
    if posterior is not None:
        lin = None if u is None else u.intervals(posterior.names)  # pyright: ignore[reportAttributeAccessIssue]
        lines.append("[[Posterior]]" + ("" if u is not None else " (linearised intervals: result.uncertainty())"))
        lines += [f"    {line}" for line in posterior.table(lin).splitlines()]
    derived = m.derived(result.values(0) if hasattr(result, "values") else result.best_values)  # a local one: the first recording's
    if derived:
        lines.append("[[Derived]] (" + f"{m.name}.derived)")
        lines += [f"    {k} = {v:.6g} {unit}" for k, (v, unit) in derived.items()]
    return "\n".join(lines)
