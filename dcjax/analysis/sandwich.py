"""The sandwich covariance of an M-estimator (Huber 1967): the standard errors of an l1 or huber
fit under its own loss, not under the squared error's.

A fit minimises OF(x) = sum_b k_b sum_{i in b} rho(a_i), b a channel of a recording, k_b its
weight (the recording's share times w_c / N, the normalisation taken out) and a_i = e_i norm_c
the normalised errors. With g_i = da_i/dx, asymptotically

    Cov(x) = H^-1 V H^-1,   H = sum_b k_b E_b[rho''] G_b,   V = sum_b k_b^2 E_b[rho'^2] G_b,

G_b = sum_{i in b} g_i g_i^T (the score's variance V, the expected Hessian H). For l1,
E[rho''] = 2 f(0), the errors' density at 0 (`L1.curvature`: Siddiqui's quotient), and
rho'^2 = 1: under Laplace noise of scale s this is s^2 (sum g g^T)^-1, the Laplace likelihood's
inverse Fisher information; under Gaussian noise pi/2 times the least-squares covariance (the
median's efficiency). For the squared error it is White's heteroscedastic form."""

import jax
import jax.numpy as jnp
import numpy as np

from ..compiling import filter_jit
from ..simulation.joint import JointProblem
from ..simulation.likelihood import channel_errors


@filter_jit
def _errors_and_jacobian(x: jax.Array, free: jax.Array, target: JointProblem):
    """Every recording's normalised errors (C, n) and their Jacobian (C, n, F) in the free entries."""

    def rows(xf):
        return target.each(x.at[free].set(xf), channel_errors)

    return rows(x[free]), jax.jacfwd(rows)(x[free])


def sandwich(x, target: JointProblem, free) -> tuple[np.ndarray, np.ndarray]:
    """(H, V) over the entries `free` of search vector `x` under `target`'s loss (its problems'
    `loss`): Cov(x_free) = H^-1 V H^-1. Padding and samples that no parameter moves and that
    the model meets exactly (a state started at its measured sample) are left out."""
    xj = jnp.asarray(x, dtype=jnp.float64)
    a_all, g_all = _errors_and_jacobian(xj, jnp.asarray(free, dtype=int), target)
    dim = len(free)
    hess, var = np.zeros((dim, dim)), np.zeros((dim, dim))
    for a_r, g_r, p, w in zip(a_all, g_all, target.problems, target.weights):
        a_r, g_r = np.asarray(a_r)[:, : p.n], np.asarray(g_r)[:, : p.n]
        norm = np.ones(len(p.scale)) if p.norm is None else np.asarray(p.norm)
        mask = np.ones(p.n, bool) if p.mask is None else np.asarray(p.mask)[: p.n] > 0
        for c, (scale, nc) in enumerate(zip(np.asarray(p.scale), norm)):
            k = w * scale / (nc * nc)
            a, g = a_r[c], g_r[c]
            keep = mask & ~((a == 0) & np.all(g == 0, axis=-1))
            if k <= 0 or not np.any(keep):
                continue
            a, g = a[keep], g[keep]
            gram = g.T @ g
            hess += k * p.loss.curvature(a) * gram
            var += k * k * float(np.mean(np.asarray(p.loss.score(a)) ** 2)) * gram
    return hess, var
