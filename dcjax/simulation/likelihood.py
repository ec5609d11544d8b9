"""The likelihood of a fit's recordings under its loss's noise model (`Loss.log_density`).

Every measured channel c of every recording r has its own noise scale tau_rc (in the loss's units
a = e / max|y*_c| with peak normalisation, the recording's units otherwise), estimated from the
residuals at the optimum by maximum likelihood (`Loss.noise_scale`) and then held:

    log L(x) = sum_rc log p(a_rc(x) | tau_rc),    log p = `Loss.log_density`(sum_k rho(a_rck), n_rc, tau_rc)

(Gaussian for SSE, Laplace for L1, the Huber density for Huber). A channel of weight 0, or a
recording of share 0, is not in the likelihood, as it is not in the fit. The residuals are the
objective's: the same offsets, delays, initial states and padding (`JointProblem`)."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..compiling import filter_jit
from ..errors import ConfigError
from .joint import JointProblem
from .losses import Loss
from .objectives import simulate_outputs
from .problem import Problem


class NoiseModel(eqx.Module):
    """A loss's noise density with a scale per recording and channel (`active` 0: not counted)."""

    loss: Loss
    scale: Float[Array, "R C"]  # tau_rc, in the loss's units (`a`)
    count: Float[Array, "R C"]  # samples n_rc
    active: Float[Array, "R C"]  # 1 where the channel counts
    information: Float[Array, "R C"]  # `Loss.fisher`: one residual's Fisher information about its location (0: not active)

    def log_likelihood(self, sums: Float[Array, "R C"]) -> Float[Array, ""]:
        """sum_rc log p of the channels whose rho-sums are `sums`."""
        tau = jnp.where(self.active > 0, self.scale, 1.0)
        return jnp.sum(self.active * self.loss.log_density(sums, self.count, tau))


def channel_errors(params, problem: Problem, adj) -> Float[Array, "C n"]:
    """a = e * norm of every measured channel and sample (e for the default SSE), offsets added."""
    sim = simulate_outputs(params, problem, adj)
    norm = problem.norm if problem.norm is not None else jnp.ones_like(problem.scale)
    return jnp.stack([(sim[..., j] - problem.y_meas[:, j]) * norm[j] for j in range(sim.shape[-1])])


def _channel_rho(params, problem: Problem, adj) -> Float[Array, " C"]:
    """sum_k rho(a_k) per measured channel (padding masked)."""
    rho = jnp.asarray(problem.loss.rho(channel_errors(params, problem, adj)))
    return jnp.sum(rho if problem.mask is None else problem.mask * rho, axis=-1)


def channel_sums(x: Float[Array, " D"], target: JointProblem) -> Float[Array, "R C"]:
    """sum_k rho(a_rck) for every recording r and measured channel c at search vector `x`
    (`JointProblem.each`: recordings of one group evaluated by one vmapped call)."""
    return jnp.stack(target.each(x, _channel_rho))


_sums = filter_jit(channel_sums)


def likelihood_target(target: JointProblem, noise: NoiseModel) -> JointProblem:
    """`target` with each channel's scale set so that its objective is -log L + log L(S = 0):
    every density here is linear in the channel's rho-sum S (Gaussian and Huber -S / (2 tau^2),
    Laplace -S / tau, plus a term of n and tau), so scale_rc = -d log p / dS norm_c^2 and the
    recordings' weights 1. The search's fused objective (the sum inside the scan, no trajectory
    kept) takes a gradient in 0.84 of `channel_sums`' time (SD1: 29.6 against 35.4 us)."""
    norms = [np.ones(np.shape(p.scale)) if p.norm is None else p.norm for p in target.problems]
    scales = _likelihood_scales(noise, norms)
    problems = [eqx.tree_at(lambda q: q.scale, p, s) for p, s in zip(target.problems, scales)]
    return JointProblem(tuple(problems), (1.0,) * len(problems), target.layout)


@filter_jit
def _likelihood_scales(noise: NoiseModel, norms: list) -> list:
    """`likelihood_target`'s scale of each recording's channels, in one program (eager, its few
    operations would each compile)."""
    tau = jnp.where(noise.active > 0, noise.scale, 1.0)
    slope = jax.grad(lambda s: jnp.sum(noise.loss.log_density(s, noise.count, tau)))(jnp.zeros_like(tau))
    return [-noise.active[r] * slope[r] * norm * norm for r, norm in enumerate(norms)]


def fit_noise(x, target: JointProblem, loss: Loss) -> NoiseModel:
    """The noise model at `x` (the fit's optimum): each channel's maximum-likelihood scale."""
    sums = np.asarray(_sums(jnp.asarray(x, dtype=jnp.float64), target))
    count = np.array([[float(p.n)] * sums.shape[1] for p in target.problems])
    active = np.array([[float(w > 0 and s > 0) for s in np.asarray(p.scale)] for p, w in zip(target.problems, target.weights)])
    active = active * (sums > 0)  # a channel fitted exactly has no noise to model (tau 0)
    scale = np.array([[loss.noise_scale(float(S), int(n)) if on else 1.0 for S, n, on in zip(*row)] for row in zip(sums, count, active)])
    info = np.where(active > 0, [[loss.fisher(float(t)) for t in row] for row in scale], 0.0)
    f64 = lambda a: jnp.asarray(a, dtype=jnp.float64)
    return NoiseModel(loss, f64(scale), f64(count), f64(active), f64(info))


def whitened_residuals(x, target: JointProblem, noise: NoiseModel) -> Float[Array, " m"]:
    """a_rck sqrt(I_rc) for every channel's samples (I the noise model's Fisher information, 0
    for a channel not in the likelihood): J^T J of their Jacobian is the Fisher information
    matrix of x. Evaluated by groups, as the objective (`JointProblem.each`)."""
    root = jnp.sqrt(noise.information)
    rows = target.each(x, channel_errors)
    return jnp.concatenate([(root[r][:, None] * a[:, : p.n]).reshape(-1) for r, (a, p) in enumerate(zip(rows, target.problems))])


def filter_likelihood(target: JointProblem) -> tuple[JointProblem, NoiseModel]:
    """A prediction-error fit's likelihood: `target` with each recording weighted by its recorded
    samples, so that its objective (each the innovations' -log L / N) is the whole -log L, and a
    noise model with nothing active (the filter's noise is in the search vector)."""
    counts = tuple(float(p.n if p.mask is None else np.sum(np.asarray(p.mask))) for p in target.problems)
    shape = (len(target.problems), len(target.problems[0].model.outputs))
    zeros = jnp.zeros(shape, dtype=jnp.float64)
    return JointProblem(target.problems, counts, target.layout), NoiseModel(target.problems[0].loss, jnp.ones(shape), zeros, zeros, zeros)


NOISE_FREE = 1e-9  # a noise scale below this share of its channel's peak: rounding, not noise


def noise_free(target: JointProblem, noise: NoiseModel) -> None:
    """A one-line `ConfigError` where a channel's fitted noise scale is below `NOISE_FREE` of its
    peak: the data are noise-free (or fitted to rounding), the likelihood is degenerate and its
    posterior a point the sampler cannot explore."""
    scale, active = np.asarray(noise.scale), np.asarray(noise.active)
    for r, p in enumerate(target.problems):
        peak = np.max(np.abs(np.asarray(p.y_meas)), axis=0)
        share = scale[r] if p.loss.normalize == "peak" else scale[r] / peak  # the residuals are over the peak, or in units
        for j, c in enumerate(p.model.outputs):
            if active[r, j] > 0 and share[j] < NOISE_FREE:
                raise ConfigError(
                    f"the data look noise-free: the fitted noise of {c} is {share[j]:.2g} of its peak (rounding), so the likelihood's "
                    "posterior is a point the sampler cannot explore; sample a fit of noisy recordings (dcjax.analysis.uncertainty "
                    "gives the linearised errors)"
                )


def noise_names(target: JointProblem, noise: NoiseModel) -> dict[str, float]:
    """'recording:channel' -> tau in the channel's units (tau / norm)."""
    out = {}
    scale, active = np.asarray(noise.scale), np.asarray(noise.active)
    for r, p in enumerate(target.problems):
        norm = np.ones(scale.shape[1]) if p.norm is None else np.asarray(p.norm)
        for j, c in enumerate(p.model.outputs):
            if active[r, j]:
                out[f"{r}:{c}" if len(target.problems) > 1 else c] = float(scale[r, j] / norm[j])
    return out
