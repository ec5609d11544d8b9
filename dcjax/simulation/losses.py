"""The loss: how a residual e = y - y* of one sample and channel enters the objective.

Every loss scores the residual in the recording's units or normalised by the channel's peak
(`normalize`), averages over the samples and sums over the channels with their weights w_c:

    OF = sum_c w_c / N sum_k rho(a_c,k),    a = e / max|y*_c| ("peak") or a = e ("none").

`SSE(normalize="peak")`, rho(a) = a^2, is the paper's eq. 24/27 and the default. `L1`: rho(a) =
|a| (the mean absolute error). `Huber(delta)`: a^2 within delta, 2 delta |a| - delta^2 beyond
(quadratic near zero, linear in the tails, continuous with its slope; equal to `SSE` within
delta). With `"none"` a joint fit pools its recordings by sample count (`dcjax.fit`)."""

import math
from abc import abstractmethod
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp

NORMALIZATIONS = ("peak", "none")


class Loss(eqx.Module):
    """Base class: `rho(a)` of a normalised residual; `least_squares` says whether sqrt(rho) is a
    smooth residual for Levenberg–Marquardt."""

    normalize: str = eqx.field(static=True, default="peak")
    least_squares: ClassVar[bool] = True
    name: ClassVar[str] = ""

    def __check_init__(self):
        if self.normalize not in NORMALIZATIONS:
            raise ValueError(f"normalize must be one of {', '.join(NORMALIZATIONS)}, got {self.normalize!r}")

    @abstractmethod
    def rho(self, a): ...

    def term(self, e, scale, norm):
        """w_c/N rho(e norm), with `scale` = w_c/N norm^2 (the `Problem`'s) and `norm` = 1/peak or 1."""
        return (scale / (norm * norm)) * self.rho(e * norm)

    def residual(self, e, scale, norm):
        """r with r^2 = `term` (the least-squares form the polish and the uncertainty use)."""
        a = e * norm
        return jnp.sign(a) * jnp.sqrt(scale / (norm * norm) * self.rho(a))

    @property
    def spec(self) -> str:
        """The loss as the command line writes it (`sse`, `l1`, `huber:0.1`)."""
        return self.name

    @property
    def approximation(self) -> str:
        """What the uncertainty analysis assumes under this loss ("" for the Gaussian one, SSE)."""
        return ""


class SSE(Loss):
    """rho(a) = a^2: eq. 24 (unit weights) and eq. 27."""

    name: ClassVar[str] = "sse"

    def rho(self, a):
        return a * a

    def term(self, e, scale, norm):
        return scale * e**2  # as eq. 24 has always been computed here (the paper's figures, bit for bit)

    def residual(self, e, scale, norm):
        return jnp.sqrt(scale) * e


class L1(Loss):
    """rho(a) = |a|: the mean absolute error (per channel; pooled over a joint fit's recordings
    with `normalize="none"`). Not differentiable at 0: no Levenberg–Marquardt polish."""

    name: ClassVar[str] = "l1"
    least_squares: ClassVar[bool] = False

    def rho(self, a):
        return jnp.abs(a)

    @property
    def approximation(self) -> str:
        return ("l1 loss: the standard errors are those of the squared-error objective linearized at the l1 optimum "
                "(Gauss-Newton; exact for Gaussian noise, a rough guide for heavy-tailed noise)")  # fmt: skip


class Huber(Loss):
    """rho(a) = a^2 for |a| <= delta, 2 delta |a| - delta^2 beyond (`delta` in the normalised units)."""

    delta: float = eqx.field(static=True, default=1.0)
    name: ClassVar[str] = "huber"

    def __check_init__(self):
        if not (isinstance(self.delta, (int, float)) and 0 < self.delta < math.inf):
            raise ValueError(f"huber's delta must be a positive number, got {self.delta!r}")

    def rho(self, a):
        b = jnp.abs(a)
        return jnp.where(b <= self.delta, a * a, 2.0 * self.delta * b - self.delta**2)

    @property
    def spec(self) -> str:
        return f"huber:{self.delta:g}"

    @property
    def approximation(self) -> str:
        return (f"huber loss (delta {self.delta:g}): Gauss-Newton on its least-squares form sign(a) sqrt(rho(a)); "
                "samples beyond delta weigh less, as in the fit (no sandwich correction)")  # fmt: skip


LOSSES = {"sse": SSE, "l1": L1, "huber": Huber}


def get_loss(spec: "str | Loss | None", normalize: str | None = None) -> Loss:
    """A `Loss` from a spec (`"sse"`, `"l1"`, `"huber:DELTA"`) or a `Loss`; `normalize` over its own."""
    if spec is None:
        spec = SSE()
    if isinstance(spec, Loss):
        if normalize is not None and normalize != spec.normalize:
            import dataclasses

            return dataclasses.replace(spec, normalize=normalize)
        return spec
    if not isinstance(spec, str):
        raise ValueError(f"loss must be sse, l1, huber:DELTA or a dcjax Loss, got {spec!r}")
    kind, sep, arg = spec.strip().lower().partition(":")
    norm = "peak" if normalize is None else normalize
    if normalize is not None and normalize not in NORMALIZATIONS:
        raise ValueError(f"normalize must be one of {', '.join(NORMALIZATIONS)}, got {normalize!r}")
    if kind == "huber":
        try:
            delta = float(arg)
        except ValueError:
            raise ValueError(f"loss huber needs its delta, e.g. huber:0.05 (in the normalised units), got {spec!r}") from None
        if not (delta > 0 and delta < float("inf")):
            raise ValueError(f"loss huber's delta must be a positive number, got {arg!r}")
        return Huber(normalize=norm, delta=delta)
    if kind not in LOSSES or sep:
        raise ValueError(f"loss must be sse, l1 or huber:DELTA, got {spec!r}")
    return LOSSES[kind](normalize=norm)
