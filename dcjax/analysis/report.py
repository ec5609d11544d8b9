"""A fit report to paste into lab notes, in the manner of lmfit's `fit_report`, and the
goodness-of-fit figures it uses (fit % as MATLAB's `compare`: 100 (1 - NRMSE))."""

import numpy as np

from ..html_table import html_table
from ..numbers import to_uncertainty

AGREEING_RUNS = 2.0  # runs whose OF is within this factor of the best one found the same optimum
FLOAT_PRECISION = 1e-12  # relative: no fit pins a parameter closer than this in float64
ONE_RUN_PRECISION = 1e-4  # relative, nothing else known: six significant digits
LOOSE_SPREAD = 0.05  # relative spread of a parameter over runs that fit as well from which the fit says the data may not pin it
RANGE_SHARE = 0.01  # ... and by this share of its search range


def fit_percent(measured: np.ndarray, simulated: np.ndarray) -> float:
    """100 (1 - ||y - y_sim|| / ||y - mean(y)||): 100 is a perfect fit, 0 no better than the mean."""
    y = np.asarray(measured, float)
    d = np.linalg.norm(y - y.mean())
    return float(100 * (1 - np.linalg.norm(y - np.asarray(simulated, float)) / d)) if d > 0 else float("nan")


def channel_fit(result, recording, sim: np.ndarray | None = None) -> dict[str, float]:
    """Fit % of every measured channel of `recording` under the result's best parameters (`sim`:
    their simulated outputs, where the caller has them)."""
    sim = result.simulate_outputs(recording) if sim is None else sim
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


def value_uncertainties(result) -> dict[str, tuple[float, str]]:
    """Per free parameter, the uncertainty its printed digits keep two significant digits of, and
    where it comes from: its standard error ("std. error", where `result.uncertainty()` gave a
    finite one), else the standard deviation of the runs that agree with the best ("runs"; OF
    within 2x of the best), else six significant digits ("best run": the best run alone); never below 1e-12 relative."""
    u = getattr(result, "uncertainties", None)
    of = np.asarray(result.run_of, dtype=float)
    agree = np.isfinite(of) & (of <= AGREEING_RUNS * np.nanmin(of) + 1e-300) if np.isfinite(of).any() else of > 0
    spread = np.std(np.asarray(result.run_params)[agree], axis=0, ddof=1) if agree.sum() >= 2 else None
    out = {}
    for k, n in enumerate(result.names):
        v = abs(result.best_values[n])
        if n in result.fixed:
            continue
        if u is not None and n in u.se and np.isfinite(u.se[n]) and u.se[n] > 0:
            out[n] = (max(float(u.se[n]), FLOAT_PRECISION * v), "std. error")
        elif spread is not None:
            out[n] = (max(float(spread[k]), FLOAT_PRECISION * v), "runs")
        else:
            out[n] = (ONE_RUN_PRECISION * v, "best run")
    return out


def loose_parameters(result) -> tuple[int, dict[str, float]]:
    """(how many runs ended at an optimum that fits as well as the best, the free parameters whose
    values spread across them by more than `LOOSE_SPREAD` (standard deviation over |mean|) and by
    more than `RANGE_SHARE` of the search range (a value near 0 spreads widely by the first)). Such
    runs: OF within `AGREEING_RUNS` of the best, each converged by the search's stopping rule or
    polished (a run stopped short by its budget says nothing here), at least 2. Runs that fit the
    data as well with other values are what a direction the data do not determine leaves (a
    heated block's k/C and Rth*C, not C, k, Rth)."""
    of = np.asarray(result.run_of, dtype=float)
    if not np.isfinite(of).any():
        return 0, {}
    ended = np.full(of.shape, result.polish is not None) | (
        np.zeros(of.shape, bool) if result.converged is None else np.asarray(result.converged, bool)
    )
    agree = ended & np.isfinite(of) & (of <= AGREEING_RUNS * np.nanmin(of) + 1e-300)
    if agree.sum() < 2:
        return int(agree.sum()), {}
    x = np.asarray(result.run_params, dtype=float)[agree]
    sd = np.std(x, axis=0, ddof=1)
    rel = sd / np.maximum(np.abs(np.mean(x, axis=0)), 1e-300)
    width = np.asarray(result.bounds.upper, float) - np.asarray(result.bounds.lower, float)
    seen = ~np.isfinite(width) | (sd > RANGE_SHARE * np.where(np.isfinite(width), width, 0.0))  # a value near 0: a share of its range
    loose = {n: float(rel[k]) for k, n in enumerate(result.names) if n not in result.fixed and rel[k] > LOOSE_SPREAD and seen[k]}
    return int(agree.sum()), loose


def loose_text(result) -> str | None:
    """`loose_parameters` in words (without what to run next), or None where there is nothing to say."""
    equal, loose = loose_parameters(result)
    if not loose:
        return None
    spread = ", ".join(f"{n} by {100 * v:.2g} %" for n, v in loose.items())
    return (
        f"{equal} converged runs fit as well as the best (OF within {AGREEING_RUNS:g}x) with values that spread: {spread}; "
        f"the data may not determine {'it' if len(loose) == 1 else 'them each'} alone"
    )


def shown_values(result) -> dict[str, str]:
    """Every parameter's value as printed: to the digits `value_uncertainties` justifies; a fixed
    one as given (its shortest text)."""
    errors = value_uncertainties(result)
    return {n: to_uncertainty(v, errors[n][0]) if n in errors else repr(float(v)) for n, v in result.best_values.items()}


def digits_note(result) -> str:
    """One line saying where the printed digits come from."""
    sources = {s for _, s in value_uncertainties(result).values()}
    agree = int(np.sum(np.asarray(result.run_of) <= AGREEING_RUNS * np.nanmin(result.run_of) + 1e-300))
    runs = len(result.run_of)
    alone = (
        "one run, no standard error: --uncertainty or --runs 2 tell more"
        if runs == 1
        else f"no other of the {runs} runs came within 2x of the best's OF, no standard error: --uncertainty tells more"
    )
    said = {
        "std. error": "their standard error",
        "runs": f"the spread of the {agree} runs that agree with the best, OF within 2x",
        "best run": f"six significant digits ({alone})",
    }
    first, *rest = (said[s] for s in said if s in sources)
    head = first if first.startswith("six") else "two significant digits of " + first
    return "values to " + head + "".join(f"; else {r if r.startswith('six') else 'of ' + r}" for r in rest) + "; all 17 in result.json"


def _observation_lines(result) -> list[str]:
    """The report's lines of the observation beyond the paper's terms."""
    m, lines = result.model, []
    obs = getattr(result, "observation", None)
    if obs is not None and not obs.plain:
        norm = (
            "over each channel's peak"
            if obs.loss.normalize == "peak"
            else "raw units" + (", pooled by samples" if len(result.recordings) > 1 else "")
        )
        if obs.focus == "prediction":
            lines.append(f"    focus              = prediction: {predictor_summary(obs, m)}")
        else:
            lines.append(f"    loss               = {obs.loss.spec} ({norm})")
        if obs.initial:
            lines.append(f"    initial state      = {', '.join(f'{k}={v}' for k, v in obs.initial.items())}")
        if obs.offsets or obs.delays:
            lines.append(
                "    sensors            = " + ", ".join([*(f"offset on {c}" for c in obs.offsets), *(f"delay of {c}" for c in obs.delays)])
            )
    return lines


def predictor_summary(observation, model) -> str:
    """`EKF (innovations' -log L / N); process noise q_omega fitted, i_a 0; sensor noise fitted`."""
    states, outputs = observation.fitted_noise(model)
    q = [f"{k} {v:g}" for k, v in observation.process.items() if v != "fit"]
    r = [f"{k} {v:g}" for k, v in observation.measurement.items() if v != "fit"]
    fitted = lambda names, prefix: ", ".join(f"{prefix}_{n}" for n in names)
    return (
        "EKF (the innovations' -log L / N)"
        + (f"; process noise {fitted(states, 'q')} fitted" if states else "")
        + (f"; process noise {', '.join(q)}" if q else "")
        + (f"; sensor noise {fitted(outputs, 'r')} fitted" if outputs else "")
        + (f"; sensor noise {', '.join(r)}" if r else "")
    )


def fit_html(result) -> str:
    """A notebook's view of a fit: model, method, best OF and status in the caption; per parameter
    its value (`shown_values`' digits), the uncertainty they keep and where it comes from, unit,
    range and flags."""
    errors, shown = value_uncertainties(result), shown_values(result)
    at_bound = set(result.at_bound())
    units = {n: p.unit for n, p in result.params.items()}
    rows = []
    for k, n in enumerate(result.names):
        e, source = errors.get(n, (None, "fixed"))
        flag = "fixed" if n in result.fixed else "at bound" if n in at_bound else ""
        rows.append((n, shown[n], "" if e is None or source == "best run" else f"{e:.2g}", source, units.get(n, ""),
                     f"{result.bounds.lower[k]:.3g}", f"{result.bounds.upper[k]:.3g}", flag))  # fmt: skip
    s = result.settings
    caption = (
        f"{result.model.name} fit: {s['method']}, {s['runs']} runs x {s['budget']} FEs; OF {result.of:.4e}; "
        f"{'success' if result.success else 'failed'} ({result.message})"
    )
    return html_table(caption, ("param", "value", "+/-", "from", "unit", "lower", "upper", ""), rows)


def relative_error(value: float, error: float) -> str:
    """' (0.31 %)': the error over the value's size to two digits; ' (> 1000 %)' past ten times it."""
    if not value:
        return ""
    rel = 100 * error / abs(value)
    return " (> 1000 %)" if rel > 1000 else f" ({rel:.2g} %)"


def fit_report(result, correl_threshold: float = 0.9, posterior=None, findings=None) -> str:
    """Model, settings, OF statistics, fit % per channel, the data checks' `findings` (default:
    those the result carries), every parameter with its standard error (where
    `result.uncertainty()` was computed), fixed and at-bound flags, the strongly correlated pairs
    and, given a `Posterior` of the result, its 90 % intervals beside the linearised ones."""
    s = result.settings
    m = result.model
    st = result.stats
    lines = ["[[Model]]", f"    {m.name}: {', '.join(m.names)}"]
    lines += [
        "[[Fit Statistics]]",
        f"    method             = {s['method']}, {s['integrator']}, ND = {s['nd']}",
        f"    runs x FEs         = {s['runs']} x {s['budget']}, seed {s['seed']}"
        + ((", BFGS polish" if getattr(result, "prediction", False) else ", LM polish") if s.get("polish") else ""),
    ]
    if s.get("stop"):
        lines.append(f"    converged          = {stop_summary(result)}")
    lines += _observation_lines(result)
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
    if not getattr(result, "prediction", False):
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
    findings = result.checks if findings is None else findings
    if findings:
        lines += ["[[Checks]]", *(f"    {f}" for f in findings)]
    u = result.uncertainties
    lines.append("[[Variables]]")
    at_bound = set(result.at_bound())
    names = result.names
    params = result.params
    width = max(len(n) for n in names)
    recs = [r.name for r in result.recordings] or (s.get("recording") if isinstance(s.get("recording"), list) else [])
    shown = shown_values(result)
    for n in names:
        v = result.best_values[n]
        unit = params[n].unit
        text = f"    {n + ':':<{width + 1}} {shown[n]:>{0 if shown[n].startswith('-') else 1}}"
        if n in result.fixed:
            text += " (fixed)"
        elif u is not None:
            se = u.se[n]
            text += f" +/- {se:.2g}{relative_error(v, se)}" if np.isfinite(se) else " +/- -"
        text += f" {unit}" if unit else ""
        flagged = u is not None and n not in result.fixed and u.verdict[n] != "well determined"
        if n in at_bound and not (flagged and u.reason[n] == "at a bound"):  # pyright: ignore[reportOptionalMemberAccess]
            text += "  [at bound]"
        if flagged:
            text += f"  [{u.verdict[n]}: {u.reason[n]}]"  # pyright: ignore[reportOptionalMemberAccess]
        if n.endswith("]") and "[" in n:
            k = int(n[n.rindex("[") + 1 : -1])
            text += f"  ({recs[k]})" if k < len(recs) else ""
        lines.append(text)
    lines.append(f"    ({digits_note(result)})")
    if u is None:
        lines.append("    (standard errors: result.uncertainty())")
        loose = loose_text(result)
        if loose:
            lines.append(f"    ({loose}: result.uncertainty() names what they do determine)")
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
