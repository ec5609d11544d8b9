"""A record's initial state estimated with a fit's parameters fixed (MATLAB's `findstates`): the
states `estimated` minimise the record's objective (eq. 24/27 with the fit's loss, weights,
offsets and delays) over the whole record or its first `samples`, by Levenberg–Marquardt from
the start the fit's specs give."""

import dataclasses

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..compiling import filter_jit
from ..simulation.joint import JointProblem

MAX_STEPS = 200


def with_start(target: JointProblem, z, idx) -> JointProblem:
    """`target` with its first recording's states `idx` starting at `z`."""
    p = target.problems[0]
    q = eqx.tree_at(lambda q: q.y0, p, jnp.asarray(p.y0).at[idx].set(z))
    return eqx.tree_at(lambda t: t.problems, target, (q, *target.problems[1:]))


def _residuals(z, args):
    target, x, idx = args
    return with_start(target, z, idx).residuals(x)


@filter_jit
def _estimate(z0, target: JointProblem, x, idx):
    import optimistix as optx  # lazy: with lineax a tenth of a second of every dcjax import

    solver = optx.LevenbergMarquardt(rtol=1e-10, atol=1e-12)
    sol = optx.least_squares(_residuals, solver, z0, args=(target, x, idx), max_steps=MAX_STEPS, throw=False)
    r = _residuals(sol.value, (target, x, idx))
    return sol.value, jnp.sum(r * r), sol.result == optx.RESULTS.successful


def released(target: JointProblem, estimated: tuple[int, ...]) -> JointProblem:
    """`target` whose states `estimated` start at their `y0` as it stands (not at a measured
    sample less a fitted offset: `Layout.measured_start`)."""
    layout, model = target.layout, target.problems[0].model
    start = tuple(j for j in layout.measured_start if model.states.index(model.outputs[layout.offset_channels[j]]) not in estimated)
    return dataclasses.replace(target, layout=dataclasses.replace(layout, measured_start=start))


def estimate_states(target: JointProblem, x, estimated: tuple[int, ...], samples: int | None = None) -> tuple[np.ndarray, float, bool]:
    """(values, OF over the samples used, converged) of the states `estimated` (indices into the
    model's states) of `released(target)`'s first recording at the search vector `x`, from its
    `y0`; `samples`: the first ones only (None: all)."""
    target = released(target, estimated)
    p = target.problems[0]
    if samples is not None:
        keep = (np.arange(p.n) < samples).astype(np.float64)
        mask = keep if p.mask is None else keep * np.asarray(p.mask)
        p = eqx.tree_at(lambda q: q.mask, p, mask, is_leaf=lambda v: v is None)
        target = eqx.tree_at(lambda t: t.problems, target, (p, *target.problems[1:]))
    idx = np.asarray(estimated, dtype=np.int32)
    z, of, ok = _estimate(jnp.asarray(np.asarray(p.y0, float)[idx]), target, jnp.asarray(x, jnp.float64), idx)
    return np.asarray(z), float(of), bool(ok)
