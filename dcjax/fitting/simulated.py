"""A fit's simulations of a recording: its states and compared outputs as arrays (padded onto
the length grid, so recordings of many lengths share a few compiled programs), and both as a
`Recording` labelled by the model's channel names (`simulated_recording`)."""

import equinox as eqx
import numpy as np

from ..compiling import filter_jit
from ..io.recording import Recording
from ..simulation.joint import JointProblem, grid_length, padded


@filter_jit
def _simulate(x, target: JointProblem, r: int):
    """Recording r's states, one compile per problem structure and length, not one per call."""
    return target.simulate(x, r)


@filter_jit
def _simulate_outputs(x, target: JointProblem, r: int):
    return target.simulate_outputs(x, r)


def _on_grid(fn, x, target: JointProblem, r: int) -> np.ndarray:
    """`fn(x, target, r)` with recording r's problem padded to its `grid_length` and the padding
    cut off (the same values: the extra steps come after the end)."""
    p = target.problems[r]
    probs = list(target.problems)
    probs[r] = padded(p, grid_length(p.n))
    return np.array(fn(x, eqx.tree_at(lambda t: t.problems, target, tuple(probs)), r))[: p.n]


def simulate_on_grid(x, target: JointProblem, r: int) -> np.ndarray:
    """(N, S) recording r's states at the search vector `x`."""
    return _on_grid(_simulate, x, target, r)


def outputs_on_grid(x, target: JointProblem, r: int) -> np.ndarray:
    """(N, C) recording r's compared outputs at `x` (with the fitted offsets)."""
    return _on_grid(_simulate_outputs, x, target, r)


def simulated_recording(result, recording: Recording) -> Recording:
    """`result`'s simulation of `recording` as a `Recording` named `"<name> simulated"`: `t`, the
    inputs the recording holds, every state (`FitResult.simulate`: measured states with the
    fitted offsets) and every output that is not a state (`FitResult.simulate_outputs`)."""
    m = result.model
    states = result.simulate(recording)
    channels = {u: np.asarray(recording[u], float) for u in m.inputs if u in recording.channels}
    channels |= {s: states[:, k] for k, s in enumerate(m.states)}
    if m.has_output_equation:
        outs = result.simulate_outputs(recording)
        channels |= {c: outs[:, j] for j, c in enumerate(m.outputs) if c not in m.states}
    meta = {"simulated_from": recording.name, **({"constants": recording.constants} if recording.constants else {})}
    return Recording(t=recording.t, channels=channels, limit=recording.limit, name=f"{recording.name} simulated".strip(), metadata=meta)
