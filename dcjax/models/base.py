"""The model protocol: everything that is specific to one motor or drive model.

A model is a small `eqx.Module` (diffrax/optimistix style). The built-in `DC` (paper eq. 6–9) and
`DCCoulomb` show the protocol; a model from outside the package subclasses `Model` and sets:

- `names`, `units`: the parameters, in the order of a parameter vector `x[..., k]`;
- `states`, `inputs`: the integrated states and the recorded inputs (channel names of a
  `Recording`); `measured`: the states the objective compares with the recording (default all);
- `presets()`: named `Parameters` presets (search ranges, memory-assistance precisions, units;
  paper Tables 4, 8 and 29 for `DC`), the first the default, new objects each call. A 0.1 model
  that sets the class dicts `bounds` (`{preset: {name: (lower, upper)}}`), `precision` and
  `units` instead still works: the base class builds its presets from them;
- `units`, `precision`: name -> unit and name -> memory precision (views of the presets for `DC`);
- optionally `positive`: the parameters never below 0 (automatic ranges and first estimates keep
  the sign; a preset's `Parameter(positive=True, scale="log")` says it per preset);
- `quantities`: channel -> physical quantity (`dcjax.io.units.UNITS`), so a loader can convert units;
- `limited_state`: the state the supply's limit clamps after every sub-step (`"i_a"` for a drive
  with a current limit), or None; or a `clamp(y, limit)` of its own (the PMSM's current vector);
- `coefficients(p)`: hoisted per-simulation quantities (1/La, Ra/La, ...) from the parameter dict;
- `vector_field(c, u, y)`: dy/dt as a tuple, from the coefficients, the inputs and the states;
- optionally an output equation: `outputs` (the output channels, which need not be states) and
  `output(c, u, y)` returning one value per output (a sensor that reads |b x1|, saturates, or
  reads a torque kt i); without it the outputs are the `measured` states. A recording's column
  named after a state still gives that state's initial value (others start at 0 or are fitted);
- optionally `steady_state(p, channels)`: the model's stationary relations (dy/dt = 0) as
  predicted channel values, used by `dcjax.analysis.validation.stationary_check` (paper eq. 25–26);
- optionally `regression(y, dy, u)`: the state equations written linear in the parameters, for
  the equation-error first estimate (`dcjax.initial_estimate`); without it that estimate runs
  Levenberg–Marquardt on the derivative residual;
- `derivative_of`: states that are the time derivative of another state (`{"v": "q"}`: v = dq/dt),
  so a first estimate can differentiate a measured position when the velocity is not measured;
- optionally `follows`: measured channel -> the input it follows in sign (`{"omega": "u_a"}`: a
  positive voltage drives a positive speed), so the data checks can flag reversed polarity;
- optionally `required`: the parameters the model's physics needs (not zero), so a fit that puts
  one on its zero bound is named a failed fit, not an unneeded term;
- optionally `time_constants(p)`: name -> seconds (DC: La/Ra), so a sample interval longer than
  a time constant can be flagged after the fit;
- optionally `derived(p)`: name -> (value, unit) that `report` prints (DC: the static speed gain,
  the electrical and mechanical time constants).
"""

import dataclasses
import functools
from collections.abc import Mapping
from typing import Any, ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..errors import ModelError
from .parameters import Parameter, Parameters


class Model(eqx.Module):
    """Base class of motor and drive models; see the module docstring for the protocol."""

    names: ClassVar[tuple[str, ...]] = ()
    units: ClassVar[dict[str, str]] = {}
    states: ClassVar[tuple[str, ...]] = ()
    inputs: ClassVar[tuple[str, ...]] = ()
    measured: ClassVar[tuple[str, ...] | None] = None
    bounds: ClassVar[dict[str, dict[str, tuple[float, float]]]] = {}  # 0.1 protocol, read by `presets`
    precision: ClassVar[dict[str, float] | None] = None
    limited_state: ClassVar[str | None] = None
    quantities: ClassVar[dict[str, str]] = {}  # channel -> quantity ("voltage", ...) for unit conversion
    derivative_of: ClassVar[dict[str, str]] = {}  # state -> the state it is the time derivative of
    follows: ClassVar[dict[str, str]] = {}  # measured channel -> the input it follows in sign
    required: ClassVar[tuple[str, ...]] = ()  # parameters the physics needs (a zero is a failed fit)
    measuring_base: ClassVar["type[Model] | None"] = None  # the class a `measuring` variant was made from
    positive: ClassVar[tuple[str, ...]] = ()  # parameters never below 0 (a model without presets: `Parameter(positive=True)`)

    # -- what a model defines -------------------------------------------------------------
    def coefficients(self, p: dict[str, Array]) -> Any:
        """Quantities computed once per simulation from the parameters (default: the dict)."""
        return p

    def vector_field(self, c: Any, u: tuple[Array, ...], y: tuple[Array, ...]) -> tuple[Array, ...]:
        raise NotImplementedError

    def regression(self, y: dict[str, np.ndarray], dy: dict[str, np.ndarray], u: dict[str, np.ndarray]) -> list | None:
        """The state equations linear in the parameters, one entry per equation:
        `(columns, rhs, mass)` with sum_k theta_k columns[k] = rhs, and `mass` the parameter that
        multiplies the state's derivative (it scales the equation's error). None: not linear."""
        return None

    def time_constants(self, p: dict[str, float]) -> dict[str, float]:
        """Name -> a time constant (s) of the model at `p` that the sampling must resolve."""
        return {}

    def derived(self, p: dict[str, float]) -> dict[str, tuple[float, str]]:
        """Name -> (value, unit) of quantities derived from the parameters that a report shows
        (DC: the static speed gain and the time constants); default none."""
        return {}

    def steady_state(self, p: dict[str, float], channels: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Channel values the model predicts in stationary operation from the other channels."""
        raise NotImplementedError(f"model {self.name!r} defines no steady-state relations")

    # -- derived ------------------------------------------------------------------------------
    @property
    def name(self) -> str:
        return type(self).__name__

    @property
    def n_params(self) -> int:
        return len(self.names)

    @property
    def outputs(self) -> tuple[str, ...]:
        """The channels the objective compares: the measured states by default; a model with an
        output equation declares its outputs instead (`outputs: ClassVar = ("v",)`, with
        `output`), and `measuring` chooses among them."""
        return tuple(self.states if self.measured is None else self.measured)

    def output(self, c: Any, u: tuple[Array, ...], y: tuple[Array, ...]) -> tuple[Array, ...]:
        """The output equation y_out = g(c, u, x), one entry per channel of `output_channels`
        (the argument order of `vector_field`; `u`: the inputs at the sample). Default: the
        states named by the outputs (no equation)."""
        return tuple(y[self.states.index(s)] for s in self.output_channels)

    @property
    def output_channels(self) -> tuple[str, ...]:
        """Every channel `output` returns: the model class's declared outputs (a `measuring`
        variant compares a subset of them)."""
        return declared_outputs(type(self).measuring_base or type(self))

    @property
    def has_output_equation(self) -> bool:
        """Whether the model defines `output` (its outputs need not be states)."""
        return type(self).output is not Model.output

    def compared(self, c: Any, u: tuple[Array, ...], y: tuple[Array, ...]) -> tuple[Array, ...]:
        """The outputs the objective compares (`outputs`, in order) at one sample: the states
        themselves where the model has no output equation, else its `output`'s entries."""
        if not self.has_output_equation:
            return tuple(y[k] for k in self.output_index)
        out, names = self.output(c, u, y), self.output_channels
        if len(out) != len(names):
            raise ModelError(f"model {self.name}: output() returned {len(out)} value(s) for the {len(names)} outputs {', '.join(names)}")
        return tuple(out[names.index(c_)] for c_ in self.outputs)

    @property
    def output_index(self) -> tuple[int, ...]:
        """The states the outputs are (a model without an output equation)."""
        if self.has_output_equation:
            raise ModelError(f"model {self.name} has an output equation: its outputs {', '.join(self.outputs)} are not states")
        bad = [s for s in self.outputs if s not in self.states]
        if bad:
            raise ModelError(f"model {self.name}: output(s) {', '.join(bad)} are not states; define output(c, u, y) for them")
        return tuple(self.states.index(s) for s in self.outputs)

    @property
    def channels(self) -> tuple[str, ...]:
        """Every channel a recording must hold for this model: inputs, then measured states."""
        return tuple(self.inputs) + self.outputs

    def measuring(self, channels) -> "Model":
        """This model comparing only the states `channels` with a recording (`Observation(measure=("omega",))`:
        the DC motor with its speed logged alone), as a subclass with `measured = channels` would
        (`class DCSpeed(dcjax.DC): measured = ("omega",)`); one class per model class and channels."""
        channels = (channels,) if isinstance(channels, str) else tuple(channels)
        pool, kind = (self.output_channels, "output") if self.has_output_equation else (self.states, "state")
        bad = [c for c in channels if c not in pool]
        if not channels or bad or len(set(channels)) != len(channels):
            why = (
                f"{', '.join(map(repr, bad))} is not a{'n' if kind == 'output' else ''} {kind}"
                if bad
                else f"name each {kind} once"
                if channels
                else f"name at least one {kind}"
            )
            raise ModelError(f"measure: {why}; model {self.name} has {kind}s {', '.join(pool)}")
        cls = measuring_class(type(self).measuring_base or type(self), channels)
        if type(self) is cls:
            return self
        new = object.__new__(cls)
        for f in dataclasses.fields(self):
            object.__setattr__(new, f.name, getattr(self, f.name))
        return new

    def unknown(self, names) -> list[str]:
        return [n for n in names if n not in self.names]

    def check_names(self, names, what: str = "parameter") -> None:
        bad = self.unknown(names)
        if bad:
            raise ModelError(
                f"unknown {what} {', '.join(map(repr, bad))} for model {self.name}; its parameters are {', '.join(self.names)}"
            )

    def as_array(self, params) -> Float[Array, "*batch P"]:
        """A parameter vector (…, P) from an array, a name -> value mapping or a params module
        with one attribute per name."""
        if isinstance(params, Mapping):
            missing = [n for n in self.names if n not in params]
            if missing:
                raise ModelError(f"missing parameters {missing} for model {self.name}; need all of {self.names}")
            return jnp.stack([jnp.asarray(params[n], dtype=jnp.float64) for n in self.names], axis=-1)
        if all(hasattr(params, n) for n in self.names) and not hasattr(params, "shape"):
            return jnp.stack([jnp.asarray(getattr(params, n), dtype=jnp.float64) for n in self.names], axis=-1)
        x = jnp.asarray(params, dtype=jnp.float64)
        if x.ndim == 0 or x.shape[-1] != self.n_params:
            raise ModelError(f"parameter vector must have {self.n_params} entries {self.names}, got shape {x.shape}")
        return x

    def as_dict(self, x: Float[Array, "*batch P"]) -> dict[str, Array]:
        """Name -> x[..., k]."""
        return {n: x[..., k] for k, n in enumerate(self.names)}

    def to_floats(self, x) -> dict[str, float]:
        """Python floats by name (unbatched parameters only)."""
        x = np.asarray(self.as_array(x))
        return {n: float(x[k]) for k, n in enumerate(self.names)}

    def presets(self) -> dict[str, Parameters]:
        """Named `Parameters` presets, the first the default (override this; the base class builds
        them from the 0.1 class dicts `bounds`, `units` and `precision`)."""
        prec = self.precision or {}
        return {
            key: Parameters([Parameter(n, min=b[n][0], max=b[n][1], unit=self.units.get(n, ""), precision=prec.get(n)) for n in self.names])
            for key, b in self.bounds.items()
        }

    @property
    def preset_names(self) -> tuple[str, ...]:
        return tuple(self.presets())

    def parameters(self, preset: str | None = None) -> Parameters:
        """A preset's `Parameters` (default the model's first; a model without presets: unbounded,
        with its units and precisions), a new object to change freely."""
        presets = self.presets()
        if preset is None and not presets:
            prec = self.memory_precision or {}
            return Parameters(
                [Parameter(n, unit=self.units.get(n, ""), precision=prec.get(n), positive=n in self.positive) for n in self.names]
            )
        if not presets:
            raise ModelError(f"model {self.name} has no parameter presets; give bounds explicitly")
        key = next(iter(presets)) if preset is None else str(preset).lower()
        if key not in presets:
            raise ModelError(f"unknown bounds preset {preset!r} for model {self.name}; choose one of {sorted(presets)}")
        params = presets[key]
        if params.names != tuple(self.names):
            raise ModelError(
                f"preset {key!r} of model {self.name} must name {', '.join(self.names)} in order, got {', '.join(params.names)}"
            )
        for n, p in params.items():  # a preset may leave the units to the model's `units`
            p.unit = p.unit or self.units.get(n, "")
        return params

    def bound_arrays(self, preset: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) of a preset (default: the model's first)."""
        if not self.preset_names:
            raise ModelError(f"model {self.name} has no bounds presets; give bounds explicitly")
        params = self.parameters(preset)
        return params.lower, params.upper

    @property
    def memory_precision(self) -> dict[str, float] | None:
        """Name -> the memory-assistance precision: the default preset's, else the class dict."""
        presets = self.presets()
        first = next(iter(presets.values())).precision if presets else None
        return first if first is not None else self.precision

    def precision_array(self) -> np.ndarray:
        prec = self.memory_precision
        if prec is None:
            raise ModelError(f"model {self.name} defines no memory precision; pass precision= explicitly")
        return np.array([prec[n] for n in self.names], float)

    @property
    def has_limit(self) -> bool:
        """Whether a recording's `limit` acts on this model: a `limited_state`, or a `clamp` of its own."""
        return self.limited_state is not None or type(self).clamp is not Model.clamp

    def clamp(self, y: tuple[Array, ...], limit) -> tuple[Array, ...]:
        """The model's limit after every (sub-)step, `limit` the recording's (None: none). Default
        |y[limited_state]| <= limit (the supply's current limit, Section 4, Fig. 4); a model may
        override it (the PMSM: the current vector's magnitude)."""
        if limit is None or self.limited_state is None:
            return y
        k = self.states.index(self.limited_state)
        return y[:k] + (jnp.clip(y[k], -limit, limit),) + y[k + 1 :]


def declared_outputs(cls: type[Model]) -> tuple[str, ...]:
    """The outputs a model class declares (`outputs = (...)`), else its measured states."""
    declared: Any = cls.outputs  # the base class's property, or a subclass's tuple
    if isinstance(declared, property):
        return tuple(cls.states if cls.measured is None else cls.measured)
    return tuple(declared)


@functools.cache
def measuring_class(base: type[Model], channels: tuple[str, ...]) -> type[Model]:
    """`base` with `measured = channels` (`Model.measuring`), made once per pair so that a fit's
    compiled programs, keyed by the model's class, are reused; named and placed as `base`
    (`measuring_base` says where a saved result finds it)."""
    if declared_outputs(base) == channels:
        return base
    attrs = {"measured": channels, "measuring_base": base, "__module__": base.__module__, "__qualname__": base.__qualname__}
    if not isinstance(base.outputs, property):  # declared outputs (an output equation): the variant's own
        attrs["outputs"] = channels
    meta: Any = type(base)  # equinox's metaclass: the subclass is a module (a pytree) like its base
    return meta(base.__name__, (base,), attrs)


class DiscreteModel(Model):
    """A model given as its own map from one sample to the next instead of a vector field:

        update(self, c, u, y, dt) -> y_next

    with the coefficients `c`, the inputs `u` at the sample (a tuple), the states `y` (a tuple) and
    the sample interval `dt` (a model whose behaviour depends on the step, such as a firmware's
    friction per step, is written once, correct at any rate). No integrator applies: the
    simulation applies `update` once per sample interval (and the limit after it)."""

    def update(self, c: Any, u: tuple[Array, ...], y: tuple[Array, ...], dt) -> tuple[Array, ...]:
        raise NotImplementedError

    def vector_field(self, c, u, y):
        raise ModelError(f"model {self.name} is a discrete-time model: it defines update(c, u, y, dt), not a vector field")
