"""How a fit observes and scores its recordings beyond the model: the `Loss`, each state's
initial value, sensor offsets on measured channels, delays of inputs (issue 28), which states
are compared (`measure`: the model's measured states unless given) and how each input acts
between its samples (`hold`: linear, eq. 29, or a zero-order hold).

An initial state is given per state as a number, `"measured"` (the first sample), `"smoothed"`
(the value at the first sample of a least-squares quadratic through the first `START_SAMPLES`
samples: less noise than the first sample where the transient is smooth over them),
`"derivative"` (the slope there of the quadratic through the state it is `Model.derivative_of`;
the default for such a state beyond `MAX_FITTED_STARTS`) or `"fit"` (a free parameter `y0_<state>`, one per recording). Any other state starts at 0 (`Observation.notes`).

The default of a compared state is decided from the data (`Observation.with_defaults`): its first
sample where the channel is clean, a fitted `y0_<state>` where it is noisy (`noise_level` above
`NOISE_SHARE` of its range in some recording). A noisy first sample is off by about one noise sd,
and a wrong start shifts every sample of the state's transient the same way: the fitted
parameters move by several of their standard errors whatever the noise level (the ratio does not
shrink with the noise). A defaulted `y0` searches the first sample +- `START_SPREAD` noise levels.
A state that is the derivative of a recorded one (a velocity of a logged position) and is not
recorded is fitted too, over +-1.5x the largest derivative: the slope of the first samples is off
where they are noisy or the motion bends over them. Beyond `MAX_FITTED_STARTS` such values in one
fit (hundreds of recordings) the first samples and slopes stay (the compared states' starts are
fitted first).
`AutoSubsteps` (nd auto) refits with them: its diffrax reference starts from the fitted state."""

import dataclasses
from collections.abc import Mapping

import numpy as np

from ..analysis.checks import noise_step
from ..errors import ConfigError, finite_number
from ..io.recording import Recording
from ..io.units import SI_UNITS
from ..models import Model
from ..models.parameters import Parameter, Parameters
from ..simulation.losses import SSE, Loss, get_loss
from ..simulation.predictors import EKF, Predictor, Simulation
from ..simulation.problem import HOLDS, held_inputs

SPECS = ("measured", "smoothed", "derivative", "fit")
FROM_SAMPLES = ("measured", "smoothed")  # a start read from the state's own channel
FOCUSES = ("simulation", "prediction")
NOISE_SHARE = 1e-4  # a channel is noisy where its noise level exceeds this share of its range
OFFSET_SHARE = 0.10  # an offset's automatic range: +- this share of its channel's peak
DELAY_SAMPLES = 10.0  # a delay's automatic range: 0 .. this many sample intervals
START_SPREAD = 8.0  # a defaulted y0's range: each recording's first sample +- this many noise levels
MAX_FITTED_STARTS = 16  # defaulted y0 values (recordings x noisy states) in one fit, at most


@dataclasses.dataclass(frozen=True)
class Observation:
    """How a fit observes and scores its recordings beyond the model (module docstring):

        dcjax.Observation(loss="huber:0.05", initial={"omega": "fit"}, offsets=("i_a",), delays=("u_a",))
        dcjax.Observation(measure=("omega",))  # the DC motor with only its speed logged

    `loss`: a `dcjax.Loss` or its spec (`"sse"`, the default, eq. 24/27; `"l1"`; `"huber:DELTA"`);
    `initial`: state -> a number, `"measured"`, `"smoothed"`, `"derivative"` or `"fit"` (a free `y0_<state>` per
    recording); `offsets`: measured channels with an additive sensor offset `offset_<channel>`;
    `delays`: inputs with a delay `delay_<input>` in seconds; `measure`: the states compared with
    the recordings (default: the model's `measured`; `Model.measuring`); `hold`: input -> "zoh"
    for an input held between samples (default "linear", eq. 29). `focus`: "simulation" (the
    default: output error, the open-loop simulation compared) or "prediction" (prediction error:
    an extended Kalman filter's innovations, `dcjax.simulation.kalman`), with `process`: state ->
    the process noise's intensity (unit^2/s) or "fit" (`q_<state>`, log scale; the default of a
    measured state; another has none) and `measurement`: output -> the sensor's sd or "fit"
    (`r_<output>`, the default). `check(model)` checks the names; `observed(model)` is the model
    with the compared states."""

    loss: Loss = dataclasses.field(default_factory=lambda: get_loss(None))
    initial: Mapping[str, "float | str"] = dataclasses.field(default_factory=dict)
    offsets: tuple[str, ...] = ()
    delays: tuple[str, ...] = ()
    measure: tuple[str, ...] | None = None
    hold: Mapping[str, str] = dataclasses.field(default_factory=dict)
    focus: str = "simulation"
    process: Mapping[str, "float | str"] = dataclasses.field(default_factory=dict)
    measurement: Mapping[str, "float | str"] = dataclasses.field(default_factory=dict)
    chosen: Mapping[str, str] = dataclasses.field(default_factory=dict, compare=False, repr=False)  # state -> why (with_defaults)
    derived: tuple[str, ...] = dataclasses.field(default=(), compare=False, repr=False)  # chosen: a recorded state's derivative

    def __post_init__(self):
        if not isinstance(self.loss, (str, Loss)):
            raise ConfigError(f"loss must be sse, l1, huber:DELTA or a dcjax Loss (dcjax.L1(), dcjax.Huber(delta=0.1)), got {self.loss!r}")
        if not isinstance(self.initial, Mapping):
            raise ConfigError(f"initial must be a state -> number|'measured'|'smoothed'|'derivative'|'fit' mapping, got {self.initial!r}")
        for what in ("offsets", "delays"):
            names = getattr(self, what)
            if isinstance(names, str) or not all(isinstance(n, str) for n in names):
                raise ConfigError(f"{what} must be a list of channel names, got {names!r}")
            object.__setattr__(self, what, tuple(names))
        if not isinstance(self.hold, Mapping) or any(str(v).lower() not in HOLDS for v in self.hold.values()):
            raise ConfigError(
                f"hold must be an input -> linear|zoh mapping, got {dict(self.hold) if isinstance(self.hold, Mapping) else self.hold!r}"
            )
        object.__setattr__(self, "hold", {str(k): "zoh" for k, v in self.hold.items() if str(v).lower() == "zoh"})
        if self.measure is not None:
            if isinstance(self.measure, str) or not all(isinstance(n, str) for n in self.measure):
                raise ConfigError(f"measure must be a list of state names, got {self.measure!r}")
            object.__setattr__(self, "measure", tuple(self.measure))
        if self.focus not in FOCUSES:
            raise ConfigError(f"focus must be simulation or prediction, got {self.focus!r}")
        for what in ("process", "measurement"):
            given = getattr(self, what)
            if not isinstance(given, Mapping):
                raise ConfigError(f"{what} must be a name -> number|'fit' mapping, got {given!r}")
            if given and self.focus != "prediction":
                raise ConfigError(f"{what} noise is a state estimator's: it needs focus='prediction' (--focus prediction)")
            object.__setattr__(self, what, {str(k): noise_spec(v, f"{what}: {k}", strict=what == "measurement") for k, v in given.items()})
        object.__setattr__(self, "loss", get_loss(self.loss))
        object.__setattr__(self, "initial", {str(k): initial_spec(v, str(k)) for k, v in dict(self.initial).items()})

    @property
    def plain(self) -> bool:
        """The paper's terms: eq. 24 from the first sample, nothing offset or delayed."""
        return (
            self.loss == get_loss(None)
            and all(v == "measured" for v in self.initial.values())
            and not self.offsets
            and not self.delays
            and self.measure is None
            and not self.hold
            and self.focus == "simulation"
        )

    def observed(self, model: Model) -> Model:
        """`model` comparing the states `measure` (itself when `measure` is None)."""
        return model if self.measure is None else model.measuring(self.measure)

    def check(self, model: Model) -> "Observation":
        """One-line errors for what `model` does not have; returns the observation."""
        model = self.observed(model)
        for state, spec in self.initial.items():
            if state not in model.states:
                raise ConfigError(f"initial: unknown state {state!r}; model {model.name} has states {', '.join(model.states)}")
            if spec == "derivative" and state not in model.derivative_of:
                raise ConfigError(
                    f"initial: {state}=derivative needs a state that is the derivative of another (Model.derivative_of); "
                    f"model {model.name} has {dict(model.derivative_of) or 'none'}"
                )
        bad = [c for c in self.offsets if c not in model.outputs]
        if bad:
            raise ConfigError(f"offset: {', '.join(bad)} is not a measured channel of model {model.name} ({', '.join(model.outputs)})")
        held_inputs(model, self.hold)  # the hold's names, checked where make_problem checks them
        bad = [c for c in self.delays if c not in model.inputs]
        if bad:
            raise ConfigError(f"delay: {', '.join(bad)} is not an input of model {model.name} ({', '.join(model.inputs) or 'none'})")
        for what, names in (("offset", self.offsets), ("delay", self.delays)):
            if len(set(names)) != len(names):
                raise ConfigError(f"{what}: a channel is named twice in {', '.join(names)}")
        for what, pool, kind in (("process", model.states, "state"), ("measurement", model.outputs, "output")):
            bad = [k for k in getattr(self, what) if k not in pool]
            if bad:
                raise ConfigError(
                    f"{what}: {', '.join(bad)} is not a{'n' if kind == 'output' else ''} {kind} of model {model.name} ({', '.join(pool)})"
                )
        if self.focus == "prediction" and type(self.loss) is not SSE:
            raise ConfigError(f"focus prediction scores the innovations' Gaussian likelihood: loss must be sse, got {self.loss.spec}")
        return self

    def spec_of(self, state: str, model: Model, recording: Recording) -> "float | str":
        """The initial spec of `state` for `recording`: the given one, else the default."""
        if state in self.initial:
            return self.initial[state]
        if state in recording.channels:
            return "measured"
        src = model.derivative_of.get(state)
        if src is not None and src in recording.channels:
            return "derivative"
        return 0.0

    def with_defaults(
        self, compared: tuple[str, ...], recordings: list[Recording], derivative_of: Mapping[str, str] | None = None
    ) -> "Observation":
        """The observation with each of the `compared` states (the observed model's `outputs`) that
        `initial` does not name decided from the data (module docstring): `"fit"` where its channel
        is noisy in some recording, else the first sample (the unnamed default); and each state
        that is the derivative of a recorded one (`derivative_of`, the model's) and is not itself
        recorded `"fit"` (`derived`): the slope of the first samples is rough where they are
        noisy and biased where the motion bends over them (a start from rest under a force that
        builds). At most `MAX_FITTED_STARTS` values in all, the compared states' first (else the
        first samples and slopes stay); `chosen` holds a note per state, for `notes`."""
        open_states = [s for s in compared if s not in self.initial and all(s in r.channels for r in recordings)]
        share = {s: max(noise_share(r[s]) for r in recordings) for s in open_states}
        noisy = [s for s in open_states if share[s] > NOISE_SHARE]
        derived = [
            d
            for d, src in (derivative_of or {}).items()
            if d not in self.initial
            and d not in compared
            and not all(d in r.channels for r in recordings)
            and all(src in r.channels for r in recordings)
        ]
        if not noisy and not derived:
            return self
        count = len(noisy) * len(recordings)
        fits = count <= MAX_FITTED_STARTS
        if (len(noisy) + len(derived)) * len(recordings) > MAX_FITTED_STARTS:
            derived = []  # the compared states' starts first; a slope stays where both would be too many
        chosen = {}
        for s in noisy:
            level = f"{s}'s noise is {share[s]:.1e} of its range"
            if fits:
                chosen[s] = (
                    f"note: {level}: its initial value is fitted (y0_{s}, the first sample +- {START_SPREAD:g} noise sd); "
                    f"initial={{{s!r}: 'measured'}} starts at the first sample"
                )
            else:
                chosen[s] = (
                    f"note: {level}, but it starts at its first sample ({count} initial values > {MAX_FITTED_STARTS}), "
                    f"which biases the fit by about its noise; initial={{{s!r}: 'fit'}} fits it"
                )
        if not fits:
            return dataclasses.replace(self, chosen=chosen)
        for d in derived:
            src = (derivative_of or {})[d]
            chosen[d] = (
                f"note: {d} is the derivative of {src}: its initial value is fitted (y0_{d}); "
                f"initial={{{d!r}: 'derivative'}} starts at the slope of {src}'s first samples, initial={{{d!r}: 0}} at rest"
            )
        initial = {**self.initial, **{s: "fit" for s in (*noisy, *derived)}}
        return dataclasses.replace(self, initial=initial, chosen=chosen, derived=tuple(derived))

    def defaulted(self, state: str) -> bool:
        """Whether `state`'s initial value is fitted by `with_defaults`' choice about its own
        channel (its range is narrow: the first sample +- `START_SPREAD` noise sd)."""
        return state in self.chosen and self.initial.get(state) == "fit" and state not in self.derived

    def fitted_states(self) -> tuple[str, ...]:
        return tuple(s for s, v in self.initial.items() if v == "fit")

    def fitted_noise(self, model: Model) -> tuple[tuple[str, ...], tuple[str, ...]]:
        """(states, outputs) whose process intensity `q_<state>` and sensor sd `r_<output>` a
        prediction-error fit searches (none for a simulation-error fit)."""
        if self.focus != "prediction":
            return (), ()
        model = self.observed(model)
        states = tuple(s for s in model.states if self.process.get(s, "fit" if s in model.outputs else 0.0) == "fit")
        return states, tuple(c for c in model.outputs if self.measurement.get(c, "fit") == "fit")

    def predictor(self, model: Model, recording: Recording) -> Predictor:
        """The predictor of `recording`'s problem: `Simulation()`, or for focus prediction an `EKF`
        with the noise given (a fitted one, `fitted_noise`, is the search's: 1 stands for it),
        P_0's sd the sensor's for a state that starts at its measured sample, else 0."""
        if self.focus != "prediction":
            return Simulation()
        model = self.observed(model)
        numbers = lambda given: {k: v for k, v in given.items() if v != "fit"}
        starts = tuple(s for s in model.states if s in model.outputs and self.spec_of(s, model, recording) in FROM_SAMPLES)
        return EKF.of(model, numbers(self.process), {c: 1.0 for c in model.outputs} | numbers(self.measurement), measured_start=starts)

    def parameter_names(self, model: Model | None = None) -> tuple[str, ...]:
        """The names of the experiment's parameters (before a joint fit's per-recording copies):
        `y0_<state>` per fitted initial state, `offset_<channel>`, `delay_<input>`, and (with
        `model`) a prediction-error fit's `q_<state>` and `r_<output>`."""
        states, outputs = self.fitted_noise(model) if model is not None else ((), ())
        return (
            *(f"y0_{s}" for s in self.fitted_states()),
            *(f"offset_{c}" for c in self.offsets),
            *(f"delay_{u}" for u in self.delays),
            *(f"q_{s}" for s in states),
            *(f"r_{c}" for c in outputs),
        )

    def parameters(self, model: Model, recordings: list[Recording], given: Parameters) -> list[Parameter]:
        """The experiment's parameters of a fit of `recordings`, in `parameter_names`' order: each
        one `given` (its range completed automatically where not finite), else automatic: an offset
        +-10 % of the channel's peak, a delay 0..10 samples (in seconds, the median sample
        interval), a fitted initial state the measured channel's range widened by 10 % of its peak
        (+-1.5x the largest filtered derivative for a derivative state; a noisy state fitted by
        default: its first samples +- 8 noise sd, `start_range`)."""
        names = self.parameter_names(model)
        bad = [n for n in given if n not in names]
        if bad:
            hint = ", ".join(sorted(names)) or "none (no initial={STATE: 'fit'}, offsets= or delays=)"
            raise ConfigError(f"unknown parameter(s) {', '.join(bad)} for model {model.name}; beyond its own the fit has {hint}")
        out = []
        for n in names:
            p = given[n] if n in given else default_parameter(n, model, recordings, self)
            if n in given and not (np.isfinite(p.min) and np.isfinite(p.max)):
                auto = default_parameter(n, model, recordings, self)
                p = dataclasses.replace(
                    p, min=auto.min if not np.isfinite(p.min) else p.min, max=auto.max if not np.isfinite(p.max) else p.max
                )
            out.append(p)
        return out

    def initial_values(self, model: Model, recording: Recording, fitted: bool = True) -> dict[str, float]:
        """The initial value of every state that is not fitted (`make_problem(initial=...)`);
        `fitted=False` (a recording the fit did not see): a fitted state as its default spec."""
        out = {}
        for s in model.states:
            spec = self.spec_of(s, model, recording)
            if spec == "fit" and not fitted:
                spec = dataclasses.replace(self, initial={k: v for k, v in self.initial.items() if k != s}).spec_of(s, model, recording)
            if spec != "fit":
                out[s] = initial_value(s, spec, model, recording)
        return out

    def notes(self, model: Model, recordings: list[Recording]) -> list[str]:
        """One line per state that starts at 0 only because nothing else was said of it, and per
        state that starts at its derivative estimate (with the values)."""
        out = list(self.chosen.values())
        for s in model.states:
            if s not in self.initial and any(self.spec_of(s, model, r) == 0.0 for r in recordings):
                out.append(
                    f"note: state {s} is neither measured nor given: it starts at 0 (initial={{{s!r}: VALUE}}, or 'derivative' or 'fit')"
                )
            elif self.spec_of(s, model, recordings[0]) == "derivative":
                src = model.derivative_of[s]
                values = ", ".join(f"{derivative_at_start(r, src, s):.4g}" for r in recordings[:4]) + (
                    ", ..." if len(recordings) > 4 else ""
                )
                out.append(
                    f"note: state {s} starts at the derivative of {src} at the first sample ({values}); from noisy samples "
                    f"that is rough: initial={{{s!r}: 'fit'}} fits it, initial={{{s!r}: 0}} if the recording starts at rest"
                )
        return out

    def to_dict(self) -> dict:
        measure = {} if self.measure is None else {"measure": list(self.measure)}
        hold = {"hold": dict(self.hold)} if self.hold else {}
        if self.focus != "simulation":
            hold |= {"focus": self.focus, "process": dict(self.process), "measurement": dict(self.measurement)}
        return {
            "loss": self.loss.spec,
            "normalize": self.loss.normalize,
            "initial": dict(self.initial),
            "offsets": list(self.offsets),
            "delays": list(self.delays),
            **measure,
            **hold,
        }

    @classmethod
    def from_settings(cls, settings: Mapping) -> "Observation":
        """The observation a result's settings record (a 0.1/0.2 result: the paper's terms)."""
        return cls(
            get_loss(settings.get("loss") or "sse", settings.get("normalize") or "peak"),
            dict(settings.get("initial") or {}),
            tuple(settings.get("offsets") or ()),
            tuple(settings.get("delays") or ()),
            None if settings.get("measure") is None else tuple(settings["measure"]),
            dict(settings.get("hold") or {}),
            settings.get("focus") or "simulation",
            dict(settings.get("process") or {}),
            dict(settings.get("measurement") or {}),
        )


def noise_level(y) -> float:
    """The white-noise sd a noisy start is judged by: `noise_step` of the fourth differences
    (a clean transient of 60 samples reads below 1e-6 of its range, where second differences read 6e-4)."""
    return noise_step(y, 4)


def noise_share(y) -> float:
    """`noise_level(y)` as a share of y's range (0 for a constant channel)."""
    span = float(np.ptp(np.asarray(y, float))) if len(y) else 0.0
    return noise_level(y) / span if span > 0 else 0.0


def start_range(state: str, recordings: list[Recording]) -> tuple[float, float]:
    """A defaulted `y0_<state>`'s range: every recording's first sample +- `START_SPREAD` noise sd."""
    lo = min(float(r[state][0]) - START_SPREAD * noise_level(r[state]) for r in recordings)
    hi = max(float(r[state][0]) + START_SPREAD * noise_level(r[state]) for r in recordings)
    return lo, hi


def initial_spec(spec, state: str = "state") -> "float | str":
    """A number, or one of `SPECS`; anything else is a one-line error."""
    if isinstance(spec, str):
        text = spec.strip().lower()
        if text in SPECS:
            return text
    return finite_number(spec, f"initial: {state}", "a number, measured, smoothed, derivative or fit")


def initial_value(state: str, spec, model: Model, recording: Recording) -> float:
    """The number a non-fitted spec gives for `recording`."""
    if spec in FROM_SAMPLES:
        if state not in recording.channels:
            raise ConfigError(f"{recording._where()}initial: {state}={spec} but the recording has no channel {state}")
        return float(recording[state][0]) if spec == "measured" else value_at_start(recording, state)
    if spec == "derivative":
        return derivative_at_start(recording, model.derivative_of[state], state)
    return float(spec)


START_SAMPLES = 11  # the local quadratic of `_start_quadratic` ("smoothed", "derivative")


def _start_quadratic(recording: Recording, channel: str) -> tuple[np.ndarray, float] | None:
    """(c2, c1, c0) of the least-squares quadratic in s = (t - t0) / T through the first
    `START_SAMPLES` samples of `channel` (T their span), and T; None below 3 samples."""
    k = min(len(recording), START_SAMPLES)
    t = np.asarray(recording.t[:k], float) - float(recording.t[0])
    if k < 3:
        return None
    return np.polyfit(t / t[-1], np.asarray(recording[channel][:k], float), 2), float(t[-1])


def value_at_start(recording: Recording, channel: str) -> float:
    """`channel` at the first sample as the local quadratic of `_start_quadratic` puts it (a
    Savitzky-Golay value at the edge: its noise sd is 0.76 sigma over 11 samples, the first
    sample's sigma; a curvature beyond quadratic over them biases it)."""
    fit = _start_quadratic(recording, channel)
    return float(recording[channel][0]) if fit is None else float(fit[0][2])


def derivative_at_start(recording: Recording, source: str, state: str = "") -> float:
    """d(source)/dt at the first sample: the slope at t0 of `_start_quadratic` (a Savitzky-Golay
    derivative at the edge; its noise is about sigma / (h K^1.5), and a filter's edge transient
    does not enter)."""
    if source not in recording.channels:
        raise ConfigError(f"{recording._where()}initial: {state}=derivative needs channel {source}, which the recording lacks")
    fit = _start_quadratic(recording, source)
    if fit is None:
        t, y = np.asarray(recording.t, float), np.asarray(recording[source], float)
        return float((y[1] - y[0]) / (t[1] - t[0])) if len(y) == 2 and t[1] > t[0] else 0.0
    coef, span = fit
    return float(coef[1] / span)


def parameter_unit(name: str, model: Model) -> str:
    """The unit of one of the experiment's parameters: a delay's s, a process intensity's
    channel unit^2/s, else its channel's SI unit."""
    if name.startswith("delay_"):
        return "s"
    if name.startswith("q_"):
        unit = SI_UNITS.get(model.quantities.get(name[2:], ""), "")
        return f"({unit})^2/s" if " " in unit or "/" in unit else f"{unit}^2/s" if unit else "1/s"
    channel = name.removeprefix("y0_").removeprefix("offset_").removeprefix("r_")
    return SI_UNITS.get(model.quantities.get(channel, ""), "")


def noise_spec(spec, field: str, strict: bool = False) -> "float | str":
    """A noise figure: `"fit"` or a number >= 0 (> 0 where `strict`)."""
    if isinstance(spec, str) and spec.strip().lower() == "fit":
        return "fit"
    v = finite_number(spec, field, "a number or fit")
    if v < 0 or (strict and v == 0):
        raise ConfigError(f"{field} must be a number {'>' if strict else '>='} 0 or fit, got {spec!r}")
    return v


NOISE_DECADES = 1.5  # a fitted sensor sd's range: the data's noise estimate x 10^(+-1.5)
PROCESS_DECADES = 8.0  # a fitted process intensity's range: this many decades below the rough top


def noise_parameter(name: str, model: Model, recordings: list[Recording], unit: str) -> Parameter:
    """A prediction-error fit's noise, on a log scale: `r_<output>` around the data's noise
    estimate (`noise_level`, x 10^(+-1.5), at least 1e-9 and 1e-3 of the peak at the ends);
    `q_<state>` from 1e-8 of up to 10 x the intensity that would explain every change of the
    state's channel between samples as noise, var(diff y) / h."""
    channel = name[2:]
    missing = [r.name for r in recordings if channel not in r.channels]
    if missing:
        raise ConfigError(f"{name}: {channel} is not measured in {missing[0]!r}: give its noise (process={{{channel!r}: VALUE}})")
    ys = [np.asarray(r[channel], float) for r in recordings]
    peak = max(float(np.max(np.abs(y))) for y in ys) or 1.0
    if name.startswith("r_"):
        sd = max(noise_level(y) for y in ys)
        lo, hi = max(sd * 10**-NOISE_DECADES, 1e-9 * peak), max(sd * 10**NOISE_DECADES, 1e-3 * peak)
        return Parameter(name, value=None, min=lo, max=hi, unit=unit, scale="log")
    top = max(float(np.var(np.diff(y)) / np.median(np.diff(r.t))) for y, r in zip(ys, recordings))
    top = 10.0 * max(top, 1e-12 * peak**2)
    return Parameter(name, value=None, min=top * 10**-PROCESS_DECADES, max=top, unit=unit, scale="log")


def default_parameter(name: str, model: Model, recordings: list[Recording], observation: Observation) -> Parameter:
    """The automatic range and start value of one of the experiment's parameters (`Observation.parameters`)."""
    unit = parameter_unit(name, model)
    if name.startswith(("q_", "r_")):
        return noise_parameter(name, model, recordings, unit)
    if name.startswith("offset_"):
        c = name.removeprefix("offset_")
        peak = max(float(np.max(np.abs(r[c]))) for r in recordings)
        return Parameter(name, value=0.0, min=-OFFSET_SHARE * peak, max=OFFSET_SHARE * peak, unit=unit)
    if name.startswith("delay_"):
        h = float(np.median(np.concatenate([np.diff(r.t) for r in recordings])))
        return Parameter(name, value=None, min=0.0, max=DELAY_SAMPLES * h, unit=unit)
    state = name.removeprefix("y0_")
    if observation.defaulted(state):
        lo, hi = start_range(state, recordings)
        return Parameter(name, value=None, min=lo, max=hi, unit=unit)
    if all(state in r.channels for r in recordings):
        lo = min(float(np.min(r[state])) for r in recordings)
        hi = max(float(np.max(r[state])) for r in recordings)
        pad = OFFSET_SHARE * max(abs(lo), abs(hi), 1e-12)
        return Parameter(name, value=None, min=lo - pad, max=hi + pad, unit=unit)
    src = model.derivative_of.get(state)
    if src is not None and all(src in r.channels for r in recordings):
        top = max(float(np.max(np.abs(np.gradient(np.asarray(r[src], float), r.t)))) for r in recordings)
        top = max(top, abs(max(derivative_at_start(r, src, state) for r in recordings)), 1e-12)
        return Parameter(name, value=None, min=-1.5 * top, max=1.5 * top, unit=unit)
    raise ConfigError(
        f"initial: {state}=fit needs a range: state {state} is not measured; give it, e.g. params[{name!r}].set(min=LO, max=HI)"
    )
