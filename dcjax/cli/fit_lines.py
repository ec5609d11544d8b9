"""What `dcjax fit` prints of a result: the parameter table, the objective's statistics, the
analyses, hints for a parameter at its bound and the data checks."""

import shlex
from pathlib import Path

import numpy as np

from ..analysis.checks import result_findings
from ..analysis.report import (
    digits_note,
    loose_text,
    predictor_summary,
    shown_values,
    stop_summary,
    value_uncertainties,
)
from ..fitting.result import FitResult
from ..fitting.vector import base_name, unit_of
from ..io.recording import Recording
from ..models import MODELS, model_spec
from .flags import as_flags


def bound_hints(result: FitResult) -> list[str]:
    """One line per free parameter that ended on a search bound: what it means, what to do."""
    b = result.bounds
    lo, hi = b.lower, b.upper
    out = []
    for n in result.at_bound():
        k = result.names.index(n)
        v = result.best_values[n]
        if abs(v - lo[k]) <= abs(v - hi[k]):
            if lo[k] == 0 and n in result.model.required:
                out.append(
                    f"hint: {n} ended at 0, its lower bound, but the model's physics needs it (not zero): the fit failed to explain "
                    f"the data; check the data checks, units and scales (--scale), or the model"
                )
            elif lo[k] == 0:
                out.append(
                    f"hint: {n} ended at 0, its lower bound: this recording does not need the term, or {n} is not identifiable from it"
                )
            else:
                out.append(f"hint: {n} ended at its lower bound {lo[k]:g}: widen it, e.g. --bound {n}={lo[k] / 10:g}:{hi[k]:g}")
        else:
            out.append(
                f"hint: {n} ended at its upper bound {hi[k]:g}: widen it, e.g. --bound {n}={lo[k]:g}:{hi[k] * 10:g} (or --bounds auto)"
            )
    return out


def uncertainty_command(result: FitResult, out: Path) -> str:
    """The `dcjax report ... --uncertainty` command for the result written to `out` (its model named where it is a file's)."""
    spec = model_spec(result.model)
    return shlex.join(["dcjax", "report", str(out / "result.json"), "--uncertainty", *(["--model", spec] if spec not in MODELS else [])])


def loose_lines(result: FitResult, out: Path) -> list[str]:
    """A note where the runs that fit as well as the best spread in some parameters (`loose_text`)."""
    loose = loose_text(result)
    if loose is None:
        return []
    return [f"note: {loose} (`{uncertainty_command(result, out)}` names what they do determine)"]


def _truth(recs: list[Recording], names: tuple[str, ...]) -> dict | None:
    """The true parameters of simulated recordings (their metadata), where they all name the same."""
    truth = recs[0].metadata.get("true_params")
    if any(r.metadata.get("true_params") != truth for r in recs) or not isinstance(truth, dict) or set(truth) != set(names):
        return None
    return truth


def print_fit(result: FitResult, recs: list[Recording], out: Path, plotted: bool) -> None:
    """The report of a single or joint fit of `recs` written to `out` (fit.png too where `plotted`)."""

    model, s = result.model, result.search
    truth = _truth(recs, model.names)
    names = (
        " + ".join(r.name for r in recs)
        if len(recs) <= 4
        else f"{recs[0].name} + {recs[1].name} + ... + {recs[-1].name} ({len(recs)} recordings)"
    )
    b = result.bounds
    settings = result.settings
    print(
        f"{names}: model {model.name}, {s.method}, {settings['integrator']}, ND={settings['nd']}, {s.runs} runs x {s.budget} FEs, seed {s.seed}"
    )
    auto = result.nd_auto
    if auto:
        tried = ", ".join(f"ND={k}: {v:.1e}" for k, v in auto["errors_at_nd1_fit"].items())
        print(
            f"  nd auto: ND={auto['chosen']} (reference error {auto['reference_error']:.2e} <= {auto['tol']:g}: {auto['converged']}); at the ND=1 fit {tried}"
        )
    for note in result.observation.notes(model, recs):
        print(as_flags(note))
    o = result.observation
    if not o.plain:
        print(
            (
                f"  focus prediction: {predictor_summary(o, model)}"
                if o.focus == "prediction"
                else f"  loss {o.loss.spec} ({'normalised by each channel' + chr(39) + 's peak' if o.loss.normalize == 'peak' else 'raw units'})"
            )
            + (f"; initial {', '.join(f'{k}={v}' for k, v in o.initial.items())}" if o.initial else "")
            + (f"; compared: {', '.join(o.measure)}" if o.measure is not None else "")
        )
    w = max(6, *(len(n) for n in result.names))
    shown, errors = shown_values(result), value_uncertainties(result)
    pm = any(source != "best run" for _, source in errors.values())
    wv = max(10, *(len(t) for t in shown.values()))
    print(
        f"{'param':>{w}} {'unit':>7} {'identified':>{wv}}"
        + (f" {'+/-':>8}" if pm else "")
        + f" {'lower':>10} {'upper':>10}"
        + (f" {'true':>14} {'rel. error':>11}" if truth else "")
    )
    at_bound = set(result.at_bound())
    for k, name in enumerate(result.names):
        v = result.best_values[name]
        e, source = errors.get(name, (0.0, "fixed"))
        error = f" {e:>8.2g}" if source not in ("best run", "fixed") else f" {'':>8}"
        line = f"{name:>{w}} {unit_of(name, model):>7} {shown[name]:>{wv}}{error if pm else ''} {b.lower[k]:>10.3g} {b.upper[k]:>10.3g}"
        if truth and base_name(name) in truth:
            t = truth[base_name(name)]
            line += f" {t:>14.6g} {abs(v - t) / abs(t) if t else abs(v):>11.2e}"
        if name in result.fixed:
            line += "  (fixed)"
        elif name in at_bound:
            line += "  [at bound]"
        print(line)
    print(digits_note(result))
    st = result.stats
    print(f"OF best {st['best']:.4e}  worst {st['worst']:.4e}  mean {st['mean']:.4e}  std {st['std']:.4e}")
    if truth:  # simulated, noise-free data: an exact fit means something
        print(f"runs with OF <= 1e-15: {int(np.sum(result.run_of <= 1e-15))}/{s.runs}")
    if s.stop is not None:
        print(f"converged: {stop_summary(result)}")
    if result.duplicates is not None:
        d = result.duplicates
        print(
            f"memory {s.memory}: {d['percent']:.1f} % of candidates answered from memory; mean FEs {result.fes.mean():.0f}, iterations {result.iterations.mean():.0f}"
        )
    if result.uncertainties is not None:
        print(result.uncertainties.table())
    else:
        for line in loose_lines(result, out):
            print(line)
    for line in bound_hints(result):
        print(line)
    for f in result_findings(result):
        print(as_flags(f"check {f}"))
    print(
        f"compile {result.timing['compile_s']:.2f} s, run {result.timing['run_s']:.2f} s; wrote {out / 'result.json'}"
        + (f" and {out / 'fit.png'}" if plotted else "")
    )
