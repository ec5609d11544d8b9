"""What a fit takes from its recordings beyond their samples: the channel weights they carry
(eq. 27, `with_weights`), each recording's share of a joint fit (`joint_weights`), and one
`Problem` per recording under the observation (`problems_of`)."""

from collections.abc import Mapping

from ..errors import ConfigError
from ..io.recording import Recording
from ..models import Model
from ..simulation.integrators import Integrator
from ..simulation.problem import Problem, make_problem
from .observation import Observation


def with_weights(recording: Recording, weights: Mapping[str, float] | None = None, joint_weight: float | None = None) -> Recording:
    """The recording with its objective weights: `weights` per measured channel (eq. 27's w1, w2;
    default all 1, eq. 24) and, in a joint fit, its `joint_weight` (default equal shares)."""
    meta = dict(recording.metadata)
    if weights is not None:
        meta["weights"] = {str(k): float(v) for k, v in weights.items()}
    if joint_weight is not None:
        meta["joint_weight"] = float(joint_weight)
    return recording.replace(metadata=meta)


def channel_weights(recordings: list[Recording], model: Model) -> tuple[float, ...] | None:
    """The channel weights the recordings carry (`with_weights`), in the model's output order."""
    given = [r.metadata.get("weights") for r in recordings]
    if all(g is None for g in given):
        return None
    if any(g != given[0] for g in given):
        raise ConfigError("the recordings of a joint fit must carry the same channel weights")
    w = dict(given[0])  # pyright: ignore[reportArgumentType]
    bad = [c for c in w if c not in model.outputs]
    if bad:
        raise ConfigError(f"weights: unknown channel(s) {bad}; model {model.name} compares {', '.join(model.outputs)}")
    return tuple(float(w.get(c, 1.0)) for c in model.outputs)


def joint_weights(recordings: list[Recording], pooled: bool = False) -> list[float]:
    """Each recording's share of a joint fit's OF: its `joint_weight`, default equal shares, or
    (`pooled`, a loss without normalisation) its share of all samples, so the recordings' means
    pool into one mean over every sample."""
    jw = [r.metadata.get("joint_weight") for r in recordings]
    if all(w is None for w in jw):
        if pooled and len(recordings) > 1:
            total = sum(len(r) for r in recordings)
            return [len(r) / total for r in recordings]
        return [1.0 / len(recordings)] * len(recordings)
    out = [1.0 if w is None else float(w) for w in jw]
    if any(not w >= 0 for w in out) or sum(out) <= 0:
        raise ConfigError("joint weights must be non-negative and not all zero")
    return out


def problems_of(recordings, model: Model, integrator: Integrator, weights, observation: Observation) -> list[Problem]:
    """Each recording's `Problem` under the observation (its loss, the initial states not fitted)."""
    return [
        make_problem(
            r,
            integrator,
            weights,
            model=model,
            loss=observation.loss,
            initial=observation.initial_values(model, r),
            hold=dict(observation.hold),
            predictor=observation.predictor(model, r),
        )
        for r in recordings
    ]
