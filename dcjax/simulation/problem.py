"""A recording prepared for simulation with a model: the sample grid, the inputs, the scaled
targets of the objective (paper eq. 24, 27) and the integration settings (eq. 28–29)."""

import equinox as eqx
import numpy as np
from jaxtyping import Array, Float

from ..errors import ConfigError, DataError
from ..io.recording import Recording
from ..models import DiscreteModel, Model, get_model
from .integrators import RK4, Integrator, integrator_for
from .losses import SSE, Loss, get_loss
from .predictors import EKF, Predictor, Simulation


class Problem(eqx.Module):
    """Everything `simulate` and `objective` need, as arrays.

    Sample k = 0 is the initial state; interval k (k = 1..N-1) integrates from t[k-1] to
    t[k] with step h[k-1] = t[k] - t[k-1], split into `integrator.substeps` equal sub-steps
    (eq. 28) with the inputs interpolated linearly between u[k-1] and u[k] (eq. 29), or held at
    u[k-1] for an input in `held` (u_end = u_start there). A `steady` input (given as a
    recording's constant) is read once, not at every step (`varying`, `steady_inputs`)."""

    model: Model
    h: Float[Array, " n-1"]
    u_start: Float[Array, "n-1 m"]
    u_end: Float[Array, "n-1 m"]
    y_meas: Float[Array, "n c"]  # the model's measured states (`model.outputs`)
    y0: Float[Array, " s"]  # initial state
    limit: Float[Array, ""] | None  # the model's clamp (`Model.clamp`: on `model.limited_state` by default)
    scale: Float[Array, " c"]  # w_c / (N * max|y_c|^2) (w_c / N without normalisation)
    integrator: Integrator = RK4()
    norm: Float[Array, " c"] | None = None  # 1 / max|y_c| (1 without normalisation); None: the default SSE
    loss: Loss = SSE()
    predictor: Predictor = Simulation()  # how the outputs are predicted: open loop, or a state estimator (`EKF`)
    mask: Float[Array, " n"] | None = None  # 1 for a recorded sample, 0 for padding (`dcjax.simulation.joint.padded`)
    unroll: int = eqx.field(static=True, default=1)
    knots: int = eqx.field(static=True, default=1)  # most knots of a delayed input inside one interval (`knots_per_interval`)
    held: tuple[int, ...] = eqx.field(static=True, default=())  # inputs held between samples (zero-order hold) instead of eq. 29
    steady: tuple[int, ...] = eqx.field(static=True, default=())  # inputs constant over the recording (its constants)

    @property
    def n(self) -> int:
        return self.y_meas.shape[0]

    def measured(self, channel: str) -> Float[Array, " n"]:
        return self.y_meas[:, self.model.outputs.index(channel)]

    @property
    def varying(self) -> tuple[int, ...]:
        """The inputs a step reads from the samples: all but the `steady` ones."""
        return tuple(j for j in range(self.u_start.shape[-1]) if j not in self.steady)

    @property
    def reads_ends(self) -> bool:
        """Whether a step reads its interval's end input (eq. 29); a discrete-time map reads its start only."""
        return not isinstance(self.model, DiscreteModel)

    def steady_inputs(self) -> tuple:
        """Per input its value where `steady` (one for the whole recording), else None: read once,
        outside the time loop, so that the loop carries only the inputs that change (476 servo
        logs' five constants were 5/6 of the inputs every step of every evaluation copied)."""
        return tuple(self.u_start[..., 0, j] if j in self.steady else None for j in range(self.u_start.shape[-1]))


def _host(x) -> Array:
    """A float64 host (NumPy) array: a call or a stack of problems moves it to the device (476
    recordings' device puts, one per array, took 0.34 s of a joint fit's setup)."""
    return np.asarray(x, dtype=np.float64)  # pyright: ignore[reportReturnType]


def knots_per_interval(t: np.ndarray) -> int:
    """The most sample instants in an open window as long as the longest sample interval: the
    most knots of a delayed input that can fall inside one interval (1 on a uniform grid;
    `dcjax.simulation.adjustments.input_pieces`)."""
    t = np.asarray(t, float)
    span = float(np.max(np.diff(t))) * (1.0 - 1e-9)
    return int(np.max(np.searchsorted(t, t + span, side="left") - np.arange(len(t))))


def check_positive_int(name: str, v) -> None:
    if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < 1:
        raise ConfigError(f"{name} must be a positive integer, got {v!r}")


def make_problem(
    recording: Recording,
    integrator: Integrator | None = None,
    weights: tuple[float, ...] | None = None,
    *,
    model: Model | str | None = None,
    initial: dict[str, float] | None = None,
    voltage: float | None = None,
    unroll: int = 1,
    loss: Loss | str | None = None,
    hold: "dict[str, str] | None" = None,
    measured: bool = True,
    predictor: Predictor | None = None,
) -> Problem:
    """Prepare `recording` for `simulate`/`objective` with `model` (default: the paper's DC drive).

    - `integrator`: a `dcjax.Integrator` (`Euler(substeps=N)`, eq. 11–12; `RK4(substeps=N)`,
      eq. 14–23, the default with N = 1; or a user's own), N sub-steps per sample interval
      (eq. 28) with the inputs interpolated (eq. 29).
    - `weights`: one weight per measured channel (w1, w2 of eq. 27). The paper's eq. 24 is all
      ones, the default, so OF values compare directly with Tables 5, 9–16; eq. 27 uses
      w1 + w2 = 1 (e.g. (0.5, 0.5) is half of eq. 24).
    - `initial`: initial state by state name; default the recording's first sample (a state the
      recording lacks starts at 0).
    - `voltage`: a constant first input (step response) instead of the recorded one.
    - `hold`: input -> "linear" (eq. 29, the default) or "zoh" (held at its sample until the
      next, as a drive's PWM updated once per sample applies it).
    - `loss`: a `dcjax.Loss` (`SSE()`, the default: eq. 24/27; `L1()`, `Huber(delta)`; each
      normalised by the channel's peak or not), or its spec (`"l1"`, `"huber:0.1"`).
    - `measured=False`: a problem to simulate the recording's inputs alone; it may lack the
      model's outputs (their targets are NaN, and so is the objective).
    - `predictor`: `Simulation()` (the default: open loop, output error) or `EKF.of(model, ...)`
      (prediction error: the objective is the innovations' negative log-likelihood over N,
      `dcjax.simulation.kalman`; its loss is the Gaussian one, so `loss` must be the default).
    - The supply's limit (`model.clamp`: on `model.limited_state`, or the model's own) is the recording's `limit` (None: no limit;
      `recording.replace(limit=...)` for another).
    """
    model = get_model(model)
    if integrator is not None and not isinstance(integrator, Integrator):
        raise ConfigError(
            f"integrator must be a dcjax.Integrator (dcjax.Euler(substeps=N), dcjax.RK4(substeps=N), ...), got {integrator!r}"
        )
    integrator = integrator_for(model, integrator)
    loss = get_loss(loss)
    predictor = checked_predictor(predictor, model, loss)
    check_positive_int("unroll", unroll)
    outs = model.outputs
    w = channel_weights(weights, outs)
    _check_channels(recording, model, measured)
    t = recording.t
    u = np.stack([recording[c] for c in model.inputs], axis=1) if model.inputs else np.zeros((len(t), 0))
    if voltage is not None:
        if not model.inputs:
            raise ConfigError(f"model {model.name} has no input to set a constant voltage on")
        u = u.copy()
        u[:, 0] = float(voltage)
    if not np.all(np.isfinite(u)):
        raise ConfigError("voltage must be finite")
    held = held_inputs(model, hold)
    u_end = u[1:].copy()
    u_end[:, list(held)] = u[:-1, list(held)]
    limit = recording.limit
    if limit is not None and not limit > 0:
        raise ConfigError(f"current limit must be positive, got {limit}")
    y = np.stack([recording[c] if c in recording.channels else np.full(len(t), np.nan) for c in outs], axis=1)
    peak = np.max(np.abs(y), axis=0)
    for c, m in zip(outs, peak):
        if not m > 0 and not (np.isnan(m) and not measured):
            raise DataError("dead", f"{recording._where()}column {c!r} is all zero (the objective divides by its maximum)")
    init = dict(initial or {})
    bad = [s for s in init if s not in model.states]
    if bad:
        raise ConfigError(f"unknown state(s) {bad} for model {model.name}; its states are {model.states}")
    y0 = [float(init[s]) if s in init else float(recording[s][0]) if s in recording.channels else 0.0 for s in model.states]
    n = t.shape[0]

    f64 = _host
    return Problem(
        model=model,
        h=f64(np.diff(t)),
        u_start=f64(u[:-1]),
        u_end=f64(u_end),
        y_meas=f64(y),
        y0=f64(y0),
        limit=None if limit is None or not model.has_limit else f64(limit),
        scale=f64(w / (n * peak**2) if loss.normalize == "peak" else w / n),
        integrator=integrator,
        unroll=int(unroll),
        norm=None if type(loss) is SSE else f64(1.0 / peak if loss.normalize == "peak" else np.ones_like(peak)),
        loss=loss,
        predictor=predictor,
        knots=knots_per_interval(t),
        held=held,
        steady=tuple(j for j, c in enumerate(model.inputs) if (j == 0 and voltage is not None) or c not in recording.channels),
    )


def _check_channels(recording: Recording, model: Model, measured: bool) -> None:
    """A one-line error where `recording` lacks a channel the problem needs (the inputs alone
    where not `measured`; an input may be a recording's constant)."""
    needed = model.channels if measured else model.inputs
    missing = [c for c in needed if not (c in recording.channels or (c in model.inputs and c in recording.constants))]
    if missing:
        consts = f" and constants {', '.join(recording.constants)}" if recording.constants else ""
        raise ConfigError(
            f"{recording._where()}model {model.name} needs channel(s) {', '.join(missing)}; the recording has "
            f"{', '.join(recording.channels)}{consts} (the model's inputs {', '.join(model.inputs) or 'none'} may also be "
            'constants: constants={NAME: V}, or the sidecar\'s "constants")'
        )


def checked_predictor(predictor, model: Model, loss: Loss) -> Predictor:
    """`predictor` (None: `Simulation()`), one-line errors where it cannot serve `model` or `loss`."""
    if predictor is None:
        return Simulation()
    if not isinstance(predictor, Predictor):
        raise ConfigError(f"predictor must be dcjax.Simulation() or dcjax.EKF.of(model, ...), got {predictor!r}")
    if isinstance(predictor, EKF):
        if predictor.process.shape != (len(model.states),) or predictor.measurement.shape != (len(model.outputs),):
            raise ConfigError(f"predictor: an EKF sized for another model; build it with EKF.of(model, ...) for model {model.name}")
        if type(loss) is not SSE:
            raise ConfigError(
                f"predictor: an EKF scores the innovations' Gaussian likelihood; loss must be the default sse, got {loss.spec}"
            )
    return predictor


def channel_weights(weights, outs: tuple[str, ...]) -> np.ndarray:
    """eq. 27's weights, one per compared channel `outs` (None: all 1, eq. 24), checked."""
    if weights is None:
        return np.ones(len(outs))
    try:
        w = np.array([float(x) for x in weights])
    except (TypeError, ValueError):
        raise ConfigError(f"weights must be {len(outs)} numbers (one per channel {outs}), got {weights!r}") from None
    if w.shape != (len(outs),):
        raise ConfigError(f"weights must be {len(outs)} numbers (one per channel {outs}), got {weights!r}")
    if not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() == 0:
        raise ConfigError(f"weights must be non-negative, finite and not all zero, got {weights!r}")
    return w


HOLDS = ("linear", "zoh")


def held_inputs(model: Model, hold) -> tuple[int, ...]:
    """The indices of the inputs `hold` (input -> "linear" | "zoh") holds; one-line errors."""
    hold = dict(hold or {})
    bad = [k for k in hold if k not in model.inputs]
    if bad:
        raise ConfigError(f"hold: {', '.join(bad)} is not an input of model {model.name} ({', '.join(model.inputs) or 'none'})")
    for k, v in hold.items():
        if v not in HOLDS:
            raise ConfigError(f"hold: {k} must be linear or zoh, got {v!r}")
    return tuple(j for j, c in enumerate(model.inputs) if hold.get(c) == "zoh")
