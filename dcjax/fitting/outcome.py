"""A setup's runs made its `FitResult`, once: the optional Levenberg–Marquardt polish of every
run (`polish_runs`), the best run, what the result keeps of the setup (`recorded`), the `few-data`
finding, and a warning per fitted initial state left on its range's bound (`start_warnings`)."""

import dataclasses
import time
import warnings

import jax
import jax.numpy as jnp
import numpy as np

from ..analysis.checks import count_findings
from ..io.recording import Recording
from ..simulation.joint import stacked_target
from .observation import START_SPREAD
from .polish import polish_batch
from .result import FitResult
from .search import Search, SearchRecord
from .setup import Setup
from .vector import base_name


def polish_runs(run_x, setup: Setup):
    """Levenberg–Marquardt from every run's best: (parameters, OFs, what the polish did)."""

    t0 = time.perf_counter()
    pol = jax.block_until_ready(polish_batch(jnp.asarray(run_x), stacked_target(setup.target), setup.space))
    info = {
        "of_before": np.asarray(pol.of_before).tolist(),
        "of_after": np.asarray(pol.of_after).tolist(),
        "steps": np.asarray(pol.steps).tolist(),
        "converged": np.asarray(pol.converged).tolist(),
        "time_s": time.perf_counter() - t0,
    }
    return np.asarray(pol.x), np.asarray(pol.of_after), info


def make_result(setup: Setup, search: Search, out, timing: dict, ran: Setup | None = None) -> FitResult:
    """The result of the runs `out` of one setup, after the optional polish (of the setup the runs
    ran, `ran`: the setup itself or its padded form, `dcjax.fitting.runs.bucketed`), its data
    checks' findings and `few-data` where its residuals do not outnumber its free parameters
    (`count_findings`); a warning per fitted start that ended on its range's bound (`start_warnings`)."""
    run_x = np.asarray(setup.space.to_physical(out.best_x))
    run_of = np.asarray(out.best_f)
    polish_info = None
    if search.polish:
        run_x, run_of, polish_info = polish_runs(run_x, ran or setup)
    best = int(np.argmin(run_of))
    memory = search.memory is not None
    result = FitResult(
        best_values=dict(zip(setup.space.names, map(float, run_x[best]))),
        of=float(run_of[best]),
        run_of=run_of,
        run_params=run_x,
        fes=np.asarray(out.fes),
        iterations=np.asarray(out.iterations),
        history=np.asarray(out.history),
        search=SearchRecord.of(search),
        integrator=setup.integrator,
        bounds=setup.space.bounds,
        timing=timing,
        polish=polish_info,
        dups=np.asarray(out.dups) if memory else None,
        converged=np.asarray(out.converged) if search.stop is not None else None,
        memory_chunks=np.asarray(out.chunks) if memory else None,
        recordings=list(setup.recordings),
        model=setup.model,
        fixed=setup.space.fixed,
        checks=tuple(setup.findings),
        observation=setup.observation,
        layout=setup.layout,
        **recorded(setup, search),
    )
    result = dataclasses.replace(result, checks=result.checks + tuple(count_findings(result.ndata, result.nvarys)))
    for line in start_warnings(result):  # a fitted start on its range's bound: said, not left silent
        warnings.warn(line, stacklevel=5)  # make_result, fit_setups, fit_sets, fit / fit_each: their caller
    return result


def recorded(setup: Setup, search: Search) -> dict:
    """What a result keeps of a fit's setup beyond its objects: the channel and joint weights (the
    latter where not equal shares: given, or pooled by sample count), each recording's source, the
    start values, the parameters' own priors, the local and log-scale names, the memory's
    precisions and the number of residuals."""
    recs, space = setup.recordings, setup.space
    weighted = any(r.metadata.get("joint_weight") is not None for r in recs) or len(set(setup.joint_weights)) > 1
    return dict(
        weights=tuple(float(w) for w in setup.weights) if setup.weights is not None else (),
        joint_weights=tuple(float(w) for w in setup.joint_weights) if weighted else None,
        sources=tuple(_source(r) for r in recs),
        recording_names=tuple(r.name for r in recs),
        start=setup.params.start or None,
        priors={n: p.prior.spec for n, p in setup.params.items() if p.prior is not None and p.vary},  # for the sampler
        local=tuple(sorted({base_name(n) for n, p in setup.params.items() if p.local})),
        log=tuple(space.names[k] for k in space.log),
        precision=None if search.memory is None else tuple(setup.physical_precision()),
        data_points=int(sum(len(r) * len(setup.model.outputs) for r in recs)),
    )


def _source(r: Recording):
    """Where a recording came from (its loader's record, else its name), with the limit fitted and
    each channel's peak (so a validation can tell a unit or scale slip)."""
    src = r.metadata.get("source", {"name": r.name})
    peaks = {c: float(np.max(np.abs(v))) for c, v in r.channels.items()}
    return {**src, "limit": r.limit, "peaks": peaks} if isinstance(src, dict) else src


START_AT_BOUND = 1e-3  # a fitted start within this share of its range from a bound ended on it (a search nears a bound)


def start_warnings(result: FitResult) -> list[str]:
    """A line per fitted initial state (`y0_<state>`, `y0_<state>[k]`) that ended on its range's
    bound (within `START_AT_BOUND` of its width): the start the data want lies outside the range,
    so the other parameters took up the rest."""
    if result.bounds is None or result.failure:
        return []
    out = []
    for name in result.at_bound(rtol=START_AT_BOUND):
        if not name.startswith("y0_"):
            continue
        state = name[3:].split("[")[0]
        k = result.names.index(name)
        lo, hi = float(result.bounds.lower[k]), float(result.bounds.upper[k])
        where = (
            f"the first sample +- {START_SPREAD:g} noise sd, {lo:.4g}..{hi:.4g}"
            if result.observation.defaulted(state)
            else f"{lo:.4g}..{hi:.4g}"
        )
        start = "'derivative'" if state in result.observation.derived else "'measured'"
        out.append(
            f"{name} ended on its range's bound ({where}): the fit wants another start, which the other parameters now "
            f"absorb; give initial={{{state!r}: {start}}} or a wider range for {name.split('[')[0]}"
        )
    return out
