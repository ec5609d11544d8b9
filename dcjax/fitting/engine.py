"""The engine under `fit` and `fit_each`: the setups' compiled runs (`dcjax.fitting.runs`) and
each setup's `FitResult` (`dcjax.fitting.outcome`), in one call (`fit_setups`); paper Section
5's automatic sub-steps over the same path (`fit_auto_substeps`)."""

import dataclasses

import jax.numpy as jnp
import numpy as np

from ..simulation.diffrax_reference import reference_simulate_jit, simulation_error
from ..simulation.integrators import AutoSubsteps
from .outcome import make_result
from .result import FitResult
from .runs import run_setups
from .setup import Plan, Setup


def fit_setups(plan: Plan, setups: list[Setup], progress=None) -> list[FitResult]:
    """Every setup's result: the runs of setups of one structure in one compiled call (single
    recordings of close lengths padded into one, `dcjax.fitting.runs.bucketed`), each polished
    (as it ran) where the search says so (`plan.integrator` an `AutoSubsteps`: `fit_auto_substeps`)."""
    if isinstance(plan.integrator, AutoSubsteps):
        return fit_auto_substeps(plan, setups, progress)
    ran = run_setups(setups, plan.search, progress)
    return [make_result(s, plan.search, *r) for s, r in zip(setups, ran)]


def fit_auto_substeps(plan: Plan, setups: list[Setup], progress=None) -> list[FitResult]:
    """Paper Section 5: fit at ND = 1; at each fit's best parameters compare the simulation at ND
    = 1, 2, 4, ... with an adaptive diffrax reference (`dcjax.simulation.diffrax_reference`) and
    take the first ND whose error (max over channels of max |y - y_ref| / max |y_measured|) is
    at most `tol`; refit there, and repeat from that fit until the ND stays (at most 3 rounds).
    The setups of one ND are fitted in one call each round. `settings["nd_auto"]` records the choice."""

    auto = plan.integrator
    assert isinstance(auto, AutoSubsteps)
    kind = type(auto.integrator)
    search = plan.search
    candidates = [2**k for k in range(int(np.log2(auto.max_substeps)) + 1)]

    def errors_at(setup: Setup, values: dict, nds) -> dict:
        """Each ND's simulation error at the search vector `values`: every recording with its own
        parameters (local ones), fitted initial state and delays, its held inputs (`Layout`)."""
        x = jnp.asarray([values[n] for n in setup.space.names])
        layout = setup.target.layout
        each = [(layout.model_x(x, r), layout.adjustments(x, r, p)) for r, p in enumerate(setup.problems)]
        refs = [reference_simulate_jit(xr, p, adj) for (xr, adj), p in zip(each, setup.problems)]
        return {
            nd: max(
                simulation_error(xr, p, ref, adj)
                for (xr, adj), p, ref in zip(each, setup.with_integrator(kind(substeps=nd)).problems, refs)
            )
            for nd in nds
        }

    current = [s.with_integrator(kind(substeps=1)) for s in setups]
    runs: list = [None] * len(setups)
    nd = [1] * len(setups)
    rounds: list[list] = [[] for _ in setups]
    pending = list(range(len(setups)))
    for fitted in range(4):  # the fit at ND = 1, then up to 3 refits: a refit can move the parameters to where another ND is needed
        for k, res in zip(pending, run_setups([current[k] for k in pending], search, progress)):
            runs[k] = res
        refit = []
        for k in pending if fitted < 3 else []:  # at most 3 rounds of choosing
            values = dict(
                zip(
                    current[k].space.names,
                    map(float, np.asarray(current[k].space.to_physical(runs[k][0].best_x))[int(np.argmin(np.asarray(runs[k][0].best_f)))]),
                )
            )
            errors = errors_at(current[k], values, candidates)
            rounds[k].append({"fit_nd": nd[k], "errors": {str(c): v for c, v in errors.items()}})
            chosen = next((c for c in candidates if errors[c] <= auto.tol), None)
            if chosen is None:  # no ND meets tol: stop where doubling no longer halves the error
                stalled = [b for a, b in zip(candidates, candidates[1:]) if errors[b] > 0.5 * errors[a]]
                chosen = stalled[0] // 2 if stalled else candidates[-1]
            if chosen != nd[k]:
                nd[k] = chosen
                current[k] = current[k].with_integrator(kind(substeps=chosen))
                refit.append(k)
        if not refit:
            break
        pending = refit
    out = []
    for k, setup in enumerate(current):
        result = make_result(setup, search, *runs[k])
        final = errors_at(setup, result.best_values, [nd[k]])[nd[k]]
        info = {
            "tol": auto.tol,
            "max": auto.max_substeps,
            "chosen": nd[k],
            "converged": bool(final <= auto.tol),
            "reference_error": final,
            "errors_at_nd1_fit": rounds[k][0]["errors"],
            "rounds": rounds[k],
            "reference": "diffrax Dopri8, PID rtol 1e-10 atol 1e-12, jump_ts at the samples",
        }
        out.append(dataclasses.replace(result, nd_auto=info))  # a new result with the choice recorded
    return out
