"""How a model's outputs are predicted from a recording: open loop from the initial state (the
paper's output error, `Simulation`, the default) or by an extended Kalman filter that corrects
the state with each measured sample (`EKF`: prediction error, for drives with disturbances inside
the loop). A `Problem` holds one beside its `Integrator` and its `Loss`; a new estimator is one
small module here and its filter in `dcjax.simulation.kalman`.

The EKF's noise is stated in the units of the model's channels:

- `process`: state name -> continuous-time intensity q (the variance a state's random walk gains
  per second, unit^2/s), so that records of different sample rates share it: over a sample
  interval h the state gains covariance Q_k = diag(q) h (the Euler–Maruyama discretisation);
- `measurement`: output name -> the sensor's standard deviation r (R = diag(r^2));
- `initial`: state name -> the standard deviation of the initial state (P_0 = diag(s^2); a state
  not named starts known, s = 0); a state that starts at its measured first sample
  (`measured_start`) has its sensor's standard deviation there.

The noise a fit searches (`q_<state>`, `r_<output>`: `dcjax.simulation.adjustments.Adjustments`)
replaces the EKF's own values candidate by candidate."""

from collections.abc import Mapping

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..errors import ConfigError
from ..models.base import Model


class Predictor(eqx.Module):
    """How the outputs are predicted: `Simulation()` (open loop) or a state estimator (`EKF`)."""

    @property
    def filters(self) -> bool:
        """Whether the measured samples correct the state (a state estimator)."""
        return False


class Simulation(Predictor):
    """The open-loop simulation from the initial state (output error; the paper's eq. 24)."""


class EKF(Predictor):
    """An extended Kalman filter (`dcjax.simulation.kalman.kalman_filter`): the model's own
    integrator step as the transition, its Jacobian by forward differentiation through the step,
    the output equation as the measurement model, Joseph-form updates. Noise per the module
    docstring: `process` (continuous intensities per state), `measurement` (std. dev. per output),
    `initial` (std. dev. of the initial state per state). `EKF.of(model, ...)` builds one from
    name -> value mappings."""

    process: Float[Array, " s"]
    measurement: Float[Array, " c"]
    initial: Float[Array, " s"]
    measured_start: tuple[tuple[int, int], ...] = eqx.field(static=True, default=())  # (state, output): P_0's sd is the sensor's

    def initial_sd(self, measurement: Float[Array, "*batch c"]) -> Float[Array, "*batch s"]:
        """The initial state's sd: `initial`, a `measured_start` state's its sensor's sd."""
        s0 = jnp.broadcast_to(self.initial, (*measurement.shape[:-1], self.initial.shape[0]))
        for state, out in self.measured_start:
            s0 = s0.at[..., state].set(measurement[..., out])
        return s0

    @property
    def filters(self) -> bool:
        return True

    @classmethod
    def of(
        cls,
        model: Model,
        process: Mapping[str, float] | None = None,
        measurement: Mapping[str, float] | None = None,
        initial: Mapping[str, float] | None = None,
        measured_start: tuple[str, ...] = (),
    ) -> "EKF":
        """An EKF for `model` from name -> value mappings (a state or output not named: 0 process
        noise, known start; every output needs its measurement noise, > 0); `measured_start`: the
        states that start at their measured first sample (P_0's sd there is the sensor's)."""
        q = _named("process", process or {}, model.states, "state", lower=0.0)
        s0 = _named("initial", initial or {}, model.states, "state", lower=0.0)
        missing = [c for c in model.outputs if c not in (measurement or {})]
        if missing:
            raise ConfigError(f"measurement: give every output's noise std. dev. (> 0); missing {', '.join(missing)}")
        r = _named("measurement", measurement or {}, model.outputs, "output", lower=0.0, strict=True)
        starts = tuple((model.states.index(s), model.outputs.index(s)) for s in measured_start if s in model.outputs and s in model.states)
        return cls(process=jnp.asarray(q), measurement=jnp.asarray(r), initial=jnp.asarray(s0), measured_start=starts)


def _named(field: str, values: Mapping[str, float], names: tuple[str, ...], kind: str, lower: float, strict: bool = False) -> np.ndarray:
    unknown = [k for k in values if k not in names]
    if unknown:
        raise ConfigError(f"{field}: {', '.join(unknown)} is not a {kind} of the model (its {kind}s: {', '.join(names)})")
    out = np.zeros(len(names))
    for k, n in enumerate(names):
        v = values.get(n, 0.0)
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise ConfigError(f"{field}: {n} must be a number, got {v!r}") from None
        if not np.isfinite(v) or v < lower or (strict and v <= lower):
            raise ConfigError(f"{field}: {n} must be a finite number {'>' if strict else '>='} {lower:g}, got {v!r}")
        out[k] = v
    return out


__all__ = ["EKF", "Predictor", "Simulation"]
