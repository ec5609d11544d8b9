"""The loss: how a residual e = y - y* of one sample and channel enters the objective.

Every loss scores the residual in the recording's units or normalised by the channel's peak
(`normalize`), averages over the samples and sums over the channels with their weights w_c:

    OF = sum_c w_c / N sum_k rho(a_c,k),    a = e / max|y*_c| ("peak") or a = e ("none").

`SSE(normalize="peak")`, rho(a) = a^2, is the paper's eq. 24/27 and the default. `L1`: rho(a) =
|a| (the mean absolute error). `Huber(delta)`: a^2 within delta, 2 delta |a| - delta^2 beyond
(quadratic near zero, linear in the tails, continuous with its slope; equal to `SSE` within
delta). With `"none"` a joint fit pools its recordings by sample count (`dcjax.fit`).

Each loss is also a noise model (`dcjax.simulation.likelihood`): the density p(a) = exp(-rho(a) /
(2 tau^2)) / Z(tau) of a residual, for SSE the Gaussian (sigma = tau), for Huber the Huber
density (Gaussian within delta, exponential tails), and for L1 the Laplace density exp(-|a| / b) /
(2 b). The total log density of n residuals of one channel depends on them only through S = sum_k
rho(a_k): `log_density(S, n, tau)`; `noise_scale(S, n)` is its maximum over tau."""

import dataclasses
import math
from abc import abstractmethod
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ConfigError

NORMALIZATIONS = ("peak", "none")


class Loss(eqx.Module):
    """Base class: `rho(a)` of a normalised residual; `least_squares` says whether sqrt(rho) is a
    smooth residual for Levenberg–Marquardt."""

    normalize: str = eqx.field(static=True, default="peak")
    least_squares: ClassVar[bool] = True
    name: ClassVar[str] = ""

    def __check_init__(self):
        if self.normalize not in NORMALIZATIONS:
            raise ConfigError(f"normalize must be one of {', '.join(NORMALIZATIONS)}, got {self.normalize!r}")

    @abstractmethod
    def rho(self, a): ...

    @abstractmethod
    def score(self, a):
        """rho'(a)."""

    @abstractmethod
    def curvature(self, a) -> float:
        """E[rho''(a)] estimated from one channel's residuals `a` (NumPy): the sandwich's bread."""

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

    likelihood: ClassVar[str] = "Gaussian"

    def log_density(self, S, n, tau):
        """log prod_k p(a_k) of n residuals with sum_k rho(a_k) = S at noise scale tau (Gaussian: -S /
        (2 tau^2) - n log(tau sqrt(2 pi)))."""
        return -S / (2.0 * tau * tau) - n * jnp.log(tau * math.sqrt(2.0 * math.pi))

    def noise_scale(self, S: float, n: int) -> float:
        """The tau that maximises `log_density(S, n, tau)` (Gaussian: sqrt(S / n))."""
        return math.sqrt(S / n)

    def fisher(self, tau: float) -> float:
        """The Fisher information of one residual about its location at scale tau (Gaussian: 1 / tau^2)."""
        return 1.0 / (tau * tau)


class SSE(Loss):
    """rho(a) = a^2: eq. 24 (unit weights) and eq. 27."""

    name: ClassVar[str] = "sse"

    def rho(self, a):
        return a * a

    def term(self, e, scale, norm):
        return scale * e**2  # as eq. 24 has always been computed here (the paper's figures, bit for bit)

    def residual(self, e, scale, norm):
        return jnp.sqrt(scale) * e

    def score(self, a):
        return 2.0 * a

    def curvature(self, a) -> float:
        return 2.0


class L1(Loss):
    """rho(a) = |a|: the mean absolute error (per channel; pooled over a joint fit's recordings
    with `normalize="none"`). Not differentiable at 0: no Levenberg–Marquardt polish."""

    name: ClassVar[str] = "l1"
    least_squares: ClassVar[bool] = False

    def rho(self, a):
        return jnp.abs(a)

    def score(self, a):
        return jnp.sign(a)

    def curvature(self, a) -> float:
        """2 f(0), f the errors' density at 0 (rho'' = 2 delta(a)), by Siddiqui's difference
        quotient f(0) = 2h / (Q(p + h) - Q(p - h)), Q the errors' quantiles, p the share below 0,
        h Hall and Sheather's bandwidth at the median for 95 % intervals, 0.9717 n^-1/3
        (Koenker, Quantile Regression, 2005, sec. 3.4.2)."""
        a = np.asarray(a, float)
        h = min(0.9717 * a.size ** (-1.0 / 3.0), 0.49)
        p = min(max(float(np.mean(a < 0)), h), 1.0 - h)
        lo, hi = np.quantile(a, [p - h, p + h])
        return 4.0 * h / (hi - lo) if hi > lo else math.inf

    likelihood: ClassVar[str] = "Laplace"

    @property
    def approximation(self) -> str:
        return (
            "l1 loss: standard errors from the l1 estimator's sandwich H^-1 V H^-1 (the errors' density at 0 by Siddiqui's "
            "difference quotient; the Laplace likelihood's under Laplace noise); `dcjax sample` uses the Laplace likelihood"
        )

    def log_density(self, S, n, tau):
        """Laplace: -S / b - n log(2 b), b = tau."""
        return -S / tau - n * jnp.log(2.0 * tau)

    def noise_scale(self, S: float, n: int) -> float:
        return S / n

    def fisher(self, tau: float) -> float:
        return 1.0 / (tau * tau)


class Huber(Loss):
    """rho(a) = a^2 for |a| <= delta, 2 delta |a| - delta^2 beyond (`delta` in the normalised units)."""

    delta: float = eqx.field(static=True, default=1.0)
    name: ClassVar[str] = "huber"

    def __check_init__(self):
        if not (isinstance(self.delta, (int, float)) and 0 < self.delta < math.inf):
            raise ConfigError(f"huber's delta must be a positive number, got {self.delta!r}")

    def rho(self, a):
        b = jnp.abs(a)
        return jnp.where(b <= self.delta, a * a, 2.0 * self.delta * b - self.delta**2)

    def score(self, a):
        return 2.0 * jnp.clip(a, -self.delta, self.delta)

    def curvature(self, a) -> float:
        return float(2.0 * np.mean(np.abs(np.asarray(a)) <= self.delta))

    @property
    def spec(self) -> str:
        return f"huber:{self.delta:g}"

    likelihood: ClassVar[str] = "Huber"

    @property
    def approximation(self) -> str:
        return (
            f"huber loss (delta {self.delta:g}): standard errors from the huber estimator's sandwich H^-1 V H^-1 "
            "(samples beyond delta weigh less, as in the fit); `dcjax sample` uses the Huber likelihood"
        )

    def _log_z(self, tau):
        """log of Z(tau) = int exp(-rho(a) / (2 tau^2)) da = tau (sqrt(2 pi) erf(k / sqrt 2) + 2 exp(-k^2 / 2) / k), k = delta / tau."""
        k = self.delta / tau
        return jnp.log(tau) + jnp.log(
            math.sqrt(2.0 * math.pi) * jax.scipy.special.erf(k / math.sqrt(2.0)) + 2.0 * jnp.exp(-0.5 * k * k) / k
        )

    def log_density(self, S, n, tau):
        return -S / (2.0 * tau * tau) - n * self._log_z(tau)

    def noise_scale(self, S: float, n: int) -> float:
        from scipy.optimize import minimize_scalar  # lazy: scipy adds 0.1-0.6 s to importing dcjax

        g = math.sqrt(S / n)  # the Gaussian scale: the answer where every residual lies within delta
        res = minimize_scalar(
            lambda lt: -float(self.log_density(S, n, math.exp(lt))),
            bounds=(math.log(g) - 5, math.log(g) + 5),
            method="bounded",
            options={"xatol": 1e-10},
        )
        return math.exp(float(res.x))

    def fisher(self, tau: float) -> float:
        """E[psi(b)^2] / tau^2 under the Huber density, b = a / tau, psi(b) = b within k = delta / tau and k sign(b)
        beyond: (int_{-k}^{k} b^2 e^{-b^2/2} db + 2 k e^{-k^2/2}) / (Z(tau) / tau) / tau^2."""
        from scipy.integrate import quad  # lazy: scipy adds 0.1-0.6 s to importing dcjax

        k = self.delta / tau
        z = math.exp(float(self._log_z(1.0 * tau))) / tau  # Z in units of tau
        inner = quad(lambda b: b * b * math.exp(-0.5 * b * b), -k, k)[0]
        tails = 2.0 * k * k * math.exp(-0.5 * k * k) / k  # 2 int_k^inf k^2 e^{k^2/2 - k b} db
        return (inner + tails) / z / (tau * tau)


LOSSES = {"sse": SSE, "l1": L1, "huber": Huber}


def get_loss(spec: "str | Loss | None", normalize: str | None = None) -> Loss:
    """A `Loss` from a spec (`"sse"`, `"l1"`, `"huber:DELTA"`) or a `Loss`; `normalize` over its own."""
    if spec is None:
        spec = SSE()
    if isinstance(spec, Loss):
        if normalize is not None and normalize != spec.normalize:
            return dataclasses.replace(spec, normalize=normalize)
        return spec
    if not isinstance(spec, str):
        raise ConfigError(f"loss must be sse, l1, huber:DELTA or a dcjax Loss, got {spec!r}")
    kind, sep, arg = spec.strip().lower().partition(":")
    norm = "peak" if normalize is None else normalize
    if normalize is not None and normalize not in NORMALIZATIONS:
        raise ConfigError(f"normalize must be one of {', '.join(NORMALIZATIONS)}, got {normalize!r}")
    if kind == "huber":
        try:
            delta = float(arg)
        except ValueError:
            raise ConfigError(f"loss huber needs its delta, e.g. huber:0.05 (in the normalised units), got {spec!r}") from None
        if not (delta > 0 and delta < float("inf")):
            raise ConfigError(f"loss huber's delta must be a positive number, got {arg!r}")
        return Huber(normalize=norm, delta=delta)
    if kind not in LOSSES or sep:
        raise ConfigError(f"loss must be sse, l1 or huber:DELTA, got {spec!r}")
    return LOSSES[kind](normalize=norm)
