"""The Fisher information an input gives about a model's parameters (the basis of
`dcjax.analysis.design`): the recording a candidate input makes (`template_problem`,
`with_input`), F = J^T diag(1/sigma^2) J of the simulated outputs' sensitivities
(`information`), the D-/A-criterion of it, the predicted standard errors sqrt(diag F^-1) and the
parameters in its null directions."""

import dataclasses
from collections.abc import Mapping, Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..compiling import filter_jit
from ..errors import ConfigError
from ..io.recording import Recording
from ..models import DiscreteModel, Model
from ..simulation.integrators import RK4
from ..simulation.objectives import outputs_of, simulate, simulate_outputs
from ..simulation.problem import Problem, make_problem

simulate_jit = filter_jit(simulate)  # the eager calls: one compiled program per shape, not a new scan each call
NULL_TOL = 1e-12  # an eigenvalue of the scaled information below this fraction of the largest: numerically zero, not identifiable


def input_channels(model: Model, t: np.ndarray, u, given: Mapping | None = None, inputs: Sequence[str] | None = None) -> dict:
    """Every input of `model` on the grid `t`: the designed `inputs` (default the model's inputs
    not in `given`) from `u` ((N,) for one, (N, D) for D), the others from `given` (a constant or
    (N,) samples; an input in neither: 0)."""
    given = dict(given or {})
    names = tuple(inputs) if inputs is not None else tuple(c for c in model.inputs if c not in given)
    u = np.asarray(u, float).reshape(len(t), -1)
    if u.shape[1] != len(names):
        raise ConfigError(f"inputs: {len(names)} designed input(s) ({', '.join(names)}), got {u.shape[1]} column(s)")
    chans = {c: np.broadcast_to(np.asarray(given.get(c, 0.0), float), t.shape).copy() for c in model.inputs}
    chans.update({c: u[:, k] for k, c in enumerate(names)})
    return chans


def template_problem(
    model: Model,
    params: dict[str, float],
    t: np.ndarray,
    u,
    limit: float | None,
    given: Mapping | None = None,
    inputs: Sequence[str] | None = None,
) -> Problem:
    """A `Problem` on the grid `t` with the inputs of `input_channels` (default: `u` the model's
    first input, the others 0) and the states starting at 0; the measured channels are those
    simulated at `params`."""
    chans = input_channels(model, t, u, given, inputs if inputs is not None or given else model.inputs[:1])
    for s in model.outputs:  # placeholders (replaced below): zero initial state, a non-zero peak for make_problem
        chans[s] = np.zeros_like(t)
        chans[s][-1] = 1.0
    rec = Recording(t=t, channels=chans, limit=limit)
    prob = make_problem(rec, None if isinstance(model, DiscreteModel) else RK4(substeps=2), model=model)
    x = jnp.asarray([params[n] for n in model.names])
    sim = simulate_jit(x, prob)
    return eqx.tree_at(lambda p: p.y_meas, prob, outputs_of(x, prob, sim))


def with_input(prob: Problem, u: jax.Array, columns: Sequence[int] = (0,)) -> Problem:
    """The problem with its inputs `columns` replaced by `u` ((N,) for one, (N, D) for D)."""
    u = u.reshape(u.shape[0], -1)
    cols = np.asarray(columns)
    u_start = prob.u_start.at[:, cols].set(u[:-1])
    u_end = prob.u_end.at[:, cols].set(u[1:])
    prob = dataclasses.replace(prob, steady=tuple(j for j in prob.steady if j not in cols))  # designed: read every step
    return eqx.tree_at(lambda p: (p.u_start, p.u_end), prob, (u_start, u_end))


def information(prob: Problem, x: jax.Array, free: jax.Array, sigma: jax.Array, scale: jax.Array | None = None) -> jax.Array:
    """F (F x F) of the scaled free parameters theta_j = x_j + scale_j delta_j (default scale
    |x_j|: relative parameters): sum over samples and channels of s s^T / sigma^2, s = dy/d delta."""
    scale = jnp.abs(x[free]) if scale is None else scale

    def y_of(delta):
        xx = x.at[free].add(scale * delta)
        return simulate_outputs(xx, prob) / sigma  # (N, C)

    s = jax.jacfwd(y_of)(jnp.zeros(free.shape[0], x.dtype))  # (N, C, F)
    s = s.reshape(-1, s.shape[-1])
    return s.T @ s


def criterion_value(F: jax.Array, criterion: str, weights: jax.Array) -> jax.Array:
    """What the design minimizes: -log det F ("d"), sum_j (F^-1)_jj ("a"), or for named
    parameters sum_j w_j log (F^-1)_jj ("names": every named parameter's relative variance
    counts by its factor of improvement, so a small one is not sacrificed to a large one)."""
    reg = 1e-12 * jnp.trace(F) / F.shape[0] * jnp.eye(F.shape[0])
    if criterion == "d":
        return -jnp.linalg.slogdet(F + reg)[1]
    var = jnp.diag(jnp.linalg.inv(F + reg))
    if criterion == "a":
        return jnp.sum(var)
    return jnp.sum(weights * jnp.log(jnp.maximum(var, 1e-300)))


def predicted_stderr(F: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Physical standard errors from the information of the scaled parameters; a parameter in a
    direction the information does not see (eigenvalue <= NULL_TOL x the largest) gets inf."""
    w, v = np.linalg.eigh(np.asarray(F, float))
    seen = w > NULL_TOL * max(float(w.max()), 1e-300)
    var = np.einsum("jk,k,jk->j", v, np.where(seen, 1.0 / np.where(seen, w, 1.0), 0.0), v)
    hidden = np.any((np.abs(v) > 1e-6) & ~seen[None, :], axis=1)
    return np.where(hidden, np.inf, np.sqrt(np.maximum(var, 0.0)) * np.abs(scale))


def null_parameters(F: np.ndarray, names: tuple[str, ...]) -> list[str]:
    """Parameters that dominate a null direction of F (the structure hides them, whatever the input)."""
    w, v = np.linalg.eigh(np.asarray(F, float))
    out = []
    for k in np.flatnonzero(w <= NULL_TOL * max(w.max(), 1e-300)):
        out += [names[j] for j in np.flatnonzero(np.abs(v[:, k]) > 0.3) if names[j] not in out]
    return out
