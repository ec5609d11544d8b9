"""A parameter's prior for posterior sampling (`Parameter(prior=...)`, `dcjax sample`'s priors).

Without one, a parameter's prior is uniform over its search range (log-uniform on a log scale).
A `Prior` replaces that density inside the same range: the posterior's box stays the range, so
the prior is truncated to it. The fit itself does not use priors (it minimises the loss); the
sampler adds log p(x) (+ log x for a log-scale parameter, the Jacobian against the log-uniform base
measure) to the log likelihood.

    params["J"].set(prior=dcjax.LogNormalPrior(median=1e-4, sigma=0.5))
    params["Tlc"].set(prior=dcjax.HalfNormalPrior(sd=1e-6))

Each prior is also a string the command line writes, `normal(MEAN,SD)`, `lognormal(MEDIAN,SIGMA)`,
`halfnormal(SD)` (`prior_from_spec`, `Prior.spec`); result.json keeps it so."""

import dataclasses
import math
import re
from abc import abstractmethod
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array

from ..errors import ConfigError


class Prior(eqx.Module):
    """Base class: `log_density(x)`, the log of an (unnormalised) density of the physical value x."""

    kind: ClassVar[str] = ""

    @abstractmethod
    def log_density(self, x) -> Array: ...

    @property
    @abstractmethod
    def arguments(self) -> tuple[float, ...]: ...

    @property
    def spec(self) -> str:
        """The prior as the command line writes it (`normal(0.0001,2e-05)`)."""
        return f"{self.kind}({','.join(repr(float(a)) for a in self.arguments)})"


def _positive(what: str, v) -> None:
    if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v > 0):
        raise ConfigError(f"{what} must be a finite number > 0, got {v!r}")


class NormalPrior(Prior):
    """N(mean, sd^2): log p(x) = -(x - mean)^2 / (2 sd^2)."""

    mean: float
    sd: float
    kind: ClassVar[str] = "normal"

    def __check_init__(self):
        if not (isinstance(self.mean, (int, float)) and math.isfinite(self.mean)):
            raise ConfigError(f"normal prior: mean must be a finite number, got {self.mean!r}")
        _positive("normal prior: sd", self.sd)

    def log_density(self, x) -> Array:
        return -0.5 * ((x - self.mean) / self.sd) ** 2

    @property
    def arguments(self) -> tuple[float, ...]:
        return (self.mean, self.sd)


class LogNormalPrior(Prior):
    """ln x ~ N(ln median, sigma^2): log p(x) = -(ln x - ln median)^2 / (2 sigma^2) - ln x (x > 0)."""

    median: float
    sigma: float
    kind: ClassVar[str] = "lognormal"

    def __check_init__(self):
        _positive("lognormal prior: median", self.median)
        _positive("lognormal prior: sigma", self.sigma)

    def log_density(self, x) -> Array:
        lx = jnp.log(jnp.where(x > 0, x, 1.0))
        return jnp.where(x > 0, -0.5 * ((lx - math.log(self.median)) / self.sigma) ** 2 - lx, -jnp.inf)

    @property
    def arguments(self) -> tuple[float, ...]:
        return (self.median, self.sigma)


class HalfNormalPrior(Prior):
    """|N(0, sd^2)| on x >= 0: log p(x) = -x^2 / (2 sd^2) (a friction or load term near 0)."""

    sd: float
    kind: ClassVar[str] = "halfnormal"

    def __check_init__(self):
        _positive("halfnormal prior: sd", self.sd)

    def log_density(self, x) -> Array:
        return jnp.where(x >= 0, -0.5 * (x / self.sd) ** 2, -jnp.inf)

    @property
    def arguments(self) -> tuple[float, ...]:
        return (self.sd,)


PRIORS: dict[str, type[Prior]] = {p.kind: p for p in (NormalPrior, LogNormalPrior, HalfNormalPrior)}
_SPEC = re.compile(r"^\s*([a-z]+)\s*\(([^()]*)\)\s*$")


def prior_from_spec(text: "str | Prior") -> Prior:
    """`normal(MEAN,SD)`, `lognormal(MEDIAN,SIGMA)` or `halfnormal(SD)` (a `Prior` as is)."""
    if isinstance(text, Prior):
        return text
    accepted = "normal(MEAN,SD), lognormal(MEDIAN,SIGMA) or halfnormal(SD)"
    m = _SPEC.match(str(text).lower())
    if m is None or m.group(1) not in PRIORS:
        raise ConfigError(f"prior must be {accepted}, got {text!r}")
    cls = PRIORS[m.group(1)]
    try:
        args = [float(a) for a in m.group(2).split(",")]
    except ValueError:
        raise ConfigError(f"prior {text!r}: the arguments must be numbers ({accepted})") from None
    fields = [f.name for f in dataclasses.fields(cls)]
    if len(args) != len(fields):
        raise ConfigError(f"prior {text!r}: {cls.kind} takes {len(fields)} number(s) ({', '.join(fields)})")
    return cls(*args)


__all__ = ["Prior", "NormalPrior", "LogNormalPrior", "HalfNormalPrior", "PRIORS", "prior_from_spec"]
