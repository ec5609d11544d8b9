"""Fixed-step integrators as small objects that carry their own step (diffrax style).

An integrator advances the model's states over one sub-step:

    step(self, field, y, u0, u1, h) -> y_next

where `field(u, y)` returns dy/dt as a tuple, `u0`/`u1` are the inputs (tuples) at the start and
the end of the sub-step and `h` its length. `substeps` equal sub-steps make one sample interval
(paper eq. 28), the inputs interpolated linearly between the samples (eq. 29). A user's own
method subclasses `Integrator` and defines `step`; it works in `fit`, `simulate`, `validate` and
the uncertainty analysis without touching the package:

    class Heun(dcjax.Integrator):
        def step(self, field, y, u0, u1, h):
            k1 = field(u0, y)
            k2 = field(u1, tuple(a + h * b for a, b in zip(y, k1)))
            return tuple(a + 0.5 * h * (b + c) for a, b, c in zip(y, k1, k2))
"""

import abc
import importlib
from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import Any, ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array

from ..errors import ConfigError
from ..models.base import DiscreteModel

State = tuple[Array, ...]
Field = Callable[[State, State], State]


def _axpy(y: State, h, k: State) -> State:
    return tuple(a + h * b for a, b in zip(y, k))


class Integrator(eqx.Module):
    """A fixed-step method: `step(field, y, u0, u1, h) -> y_next` (module docstring), with
    `substeps` equal sub-steps per sample interval (eq. 28)."""

    substeps: int = eqx.field(static=True, default=1)
    per_member: ClassVar[bool] = False  # True: a population is simulated member by member (vmap), as an adaptive step needs

    def __check_init__(self):
        if not isinstance(self.substeps, (int, np.integer)) or isinstance(self.substeps, bool) or self.substeps < 1:
            raise ConfigError(f"substeps must be a positive integer, got {self.substeps!r}")

    @abc.abstractmethod
    def step(self, field: Field, y: State, u0: State, u1: State, h) -> State:
        """The state after one sub-step of length `h` from `y`."""


class Euler(Integrator):
    """Forward Euler, eq. 11–12: y1 = y0 + h f(u0, y0)."""

    def step(self, field, y, u0, u1, h):
        return _axpy(y, h, field(u0, y))


class RK4(Integrator):
    """Classic Runge–Kutta, eq. 14–23, with the input at t, t + h/2 (interpolated) and t + h."""

    def step(self, field, y, u0, u1, h):
        um = tuple(0.5 * (a + b) for a, b in zip(u0, u1))
        hh = 0.5 * h
        k1 = field(u0, y)
        k2 = field(um, _axpy(y, hh, k1))
        k3 = field(um, _axpy(y, hh, k2))
        k4 = field(u1, _axpy(y, h, k3))
        h6 = h / 6.0
        return tuple(a + h6 * (q1 + 2.0 * (q2 + q3) + q4) for a, q1, q2, q3, q4 in zip(y, k1, k2, k3, k4))


class Diffrax(Integrator):
    """An adaptive diffrax solver over each sub-step (default `diffrax.Tsit5()` with a PID
    controller at `rtol`, `atol`): the input linear within the sub-step (eq. 29), the step size
    chosen per member of a population (`per_member`: the population is vmapped, so one stiff or
    failing member does not fail the others; a failed solve, or one that needs more than
    `max_steps` per sub-step, is +inf: the vmapped population waits for its slowest member, so
    the cap bounds what one stiff candidate costs; raise it, or `substeps`, for a stiff model). For a stiff or fast model that a fixed step cannot resolve; its cost
    against RK4 is in BENCHMARKS.md. Usable in `fit`, `simulate`, `validate`; the LM polish differentiates
    through it forward-mode (`diffrax.ForwardMode`)."""

    solver: Any = None
    rtol: float = eqx.field(static=True, default=1e-8)
    atol: float = eqx.field(static=True, default=1e-10)
    max_steps: int = eqx.field(static=True, default=256)  # per sub-step; a member that needs more is +inf
    per_member: ClassVar[bool] = True

    def __check_init__(self):
        super().__check_init__()
        if not (self.rtol > 0 and self.atol > 0):
            raise ConfigError(f"Diffrax rtol and atol must be positive, got rtol={self.rtol!r}, atol={self.atol!r}")

    def step(self, field, y, u0, u1, h):
        import diffrax  # lazy: importing it is a third of dcjax's own import time, and most fits never step with it

        shape = jnp.broadcast_shapes(*(jnp.shape(a) for a in y))
        y0 = jnp.stack([jnp.broadcast_to(a, shape) for a in y])

        def rhs(s, z, _):
            w = s / h
            return jnp.stack([jnp.broadcast_to(d, shape) for d in field(tuple(a + w * (b - a) for a, b in zip(u0, u1)), tuple(z))])

        sol = diffrax.diffeqsolve(
            diffrax.ODETerm(rhs),
            diffrax.Tsit5() if self.solver is None else self.solver,
            t0=0.0,
            t1=h,
            dt0=h,
            y0=y0,
            saveat=diffrax.SaveAt(t1=True),
            stepsize_controller=diffrax.PIDController(rtol=self.rtol, atol=self.atol),
            max_steps=self.max_steps,
            adjoint=diffrax.ForwardMode(),
            throw=False,
        )
        out = sol.ys[-1]  # pyright: ignore[reportOptionalSubscript]
        ok = sol.result == diffrax.RESULTS.successful
        return tuple(jnp.where(ok, out[k], jnp.nan) for k in range(len(y)))


class SampleMap(Integrator):
    """A discrete-time model's own map from one sample to the next (`DiscreteModel.update`): no
    integration, one application per sample interval (`substeps` must stay 1)."""

    def __check_init__(self):
        if self.substeps != 1:
            raise ConfigError("a discrete-time model's update has no sub-steps")

    def step(self, field, y, u0, u1, h):
        raise ConfigError("SampleMap belongs to a dcjax.DiscreteModel; an ODE model needs Euler, RK4 or an Integrator of its own")


# The defaults `integrator_for` gives, built once (an equinox module's construction costs ~0.07 ms:
# 476 recordings' problems spent 35 ms building the same `SampleMap`).
DEFAULT_RK4 = RK4()
SAMPLE_MAP = SampleMap()


def integrator_for(model, integrator: "Integrator | None") -> Integrator:
    """The integrator of a simulation of `model`: the given one (default `RK4()`), or for a
    `DiscreteModel` its `SampleMap` (any other is a one-line error)."""

    if isinstance(model, DiscreteModel):
        if integrator is not None and not isinstance(integrator, SampleMap):
            raise ConfigError(
                f"model {model.name} is a discrete-time model (update(c, u, y, dt) per sample): it takes no integrator, got {integrator!r}"
            )
        return integrator if integrator is not None else SAMPLE_MAP
    if isinstance(integrator, SampleMap):
        raise ConfigError(f"model {model.name} is not a discrete-time model: it needs an integrator (Euler, RK4, ...), not SampleMap")
    return DEFAULT_RK4 if integrator is None else integrator


class AutoSubsteps(eqx.Module):
    """The sub-steps chosen against an adaptive diffrax reference (paper Section 5): fit at 1, take
    the first of 1, 2, 4, ... `max_substeps` within `tol` of the reference (relative to each
    channel's peak), refit there."""

    integrator: Integrator = RK4()
    tol: float = 1e-4
    max_substeps: int = 64

    def __check_init__(self):
        if not isinstance(self.integrator, Integrator):
            raise ConfigError(f"AutoSubsteps.integrator must be a dcjax.Integrator, got {self.integrator!r}")
        if not self.tol > 0:
            raise ConfigError(f"AutoSubsteps.tol must be positive, got {self.tol!r}")
        if not isinstance(self.max_substeps, int) or self.max_substeps < 1:
            raise ConfigError(f"AutoSubsteps.max_substeps must be a positive integer, got {self.max_substeps!r}")


# The built-in integrators by the names the CLI, the sidecars and result.json spell them.
INTEGRATORS: Mapping[str, type[Integrator]] = MappingProxyType({"euler": Euler, "rk4": RK4, "diffrax": Diffrax})


def integrator_spec(integrator: Integrator) -> str:
    """The name `get_integrator` resolves back: a built-in name, else `module:Class`."""
    for name, cls in INTEGRATORS.items():
        if type(integrator) is cls:
            return name
    if type(integrator) is SampleMap:
        return "discrete"
    return f"{type(integrator).__module__}:{type(integrator).__qualname__}"


def get_integrator(spec: "str | Integrator | type[Integrator]", substeps: int = 1) -> Integrator:
    """An integrator from a built-in name (`INTEGRATORS`), `module:Class`, a class or an instance."""
    if isinstance(spec, Integrator):
        return spec
    if isinstance(spec, type) and issubclass(spec, Integrator):
        return spec(substeps=substeps)
    if not isinstance(spec, str):
        raise ConfigError(f"integrator must be a dcjax.Integrator or one of {sorted(INTEGRATORS)}, got {spec!r}")
    if spec.lower() in INTEGRATORS:
        return INTEGRATORS[spec.lower()](substeps=substeps)
    if spec.lower() == "discrete":
        return SampleMap()
    mod, _, attr = spec.rpartition(":")
    try:
        cls = getattr(importlib.import_module(mod), attr) if mod else None
    except (ImportError, AttributeError):
        cls = None
    if not (isinstance(cls, type) and issubclass(cls, Integrator)):
        raise ConfigError(f"unknown integrator {spec!r}; choose one of {sorted(INTEGRATORS)} or give 'module:Class' of a dcjax.Integrator")
    return cls(substeps=substeps)
