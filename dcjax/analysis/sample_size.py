"""Convergence diagnostics of MCMC draws, in NumPy on the host: the bulk ESS of the
rank-normalised split chains and the tail ESS of the 5 % and 95 % quantile indicators (Vehtari et
al. 2021, sections 3.2 and 4.3), each with Stan's autocorrelation estimate truncated by Geyer's
initial positive and monotone sequences (Geyer 1992), and the rank-normalised split R-hat (section
4.2). These are the estimators Stan and ArviZ print, so `dcjax sample`, `arviz.ess` and
`arviz.rhat` give one number (blackjax's ESS truncation differs by up to ~1 %; its R-hat is the
same formula, compiled: ~1 s of XLA for every new shape of draws)."""

import numpy as np
from jaxtyping import Float
from scipy import special, stats


def _split(x: Float[np.ndarray, "C N"]) -> Float[np.ndarray, "2C H"]:
    """Each chain's first and last halves as chains of their own (a middle draw of an odd N dropped)."""
    half = x.shape[1] // 2
    return np.concatenate([x[:, :half], x[:, x.shape[1] - half :]])


def _rank_normalised(x: Float[np.ndarray, "C N"]) -> Float[np.ndarray, "C N"]:
    """z = Phi^-1((r - 3/8) / (S + 1/4)) of the pooled draws' average ranks r (Vehtari et al. eq. 14)."""
    r = stats.rankdata(x, method="average", axis=None).reshape(x.shape)
    return special.ndtri((r - 0.375) / (x.size + 0.25))


def _autocovariance(x: Float[np.ndarray, "C N"]) -> Float[np.ndarray, "C N"]:
    """Each chain's biased autocovariance at lags 0..N-1 (by FFT, zero-padded past 2N)."""
    n = x.shape[1]
    f = np.fft.rfft(x - x.mean(axis=1, keepdims=True), n=2 * n, axis=1)
    return np.fft.irfft(f * np.conj(f), n=2 * n, axis=1)[:, :n] / n


def effective_size(x: Float[np.ndarray, "C N"]) -> float:
    """ESS = C N / tau with tau = -1 + 2 sum rho_t over Geyer's initial positive sequence, made
    monotone (Vehtari et al. eqs. 10-11; Stan's estimator); the draws of every chain, unsplit."""
    x = np.asarray(x, dtype=float)
    c, n = x.shape
    if not np.all(np.isfinite(x)):
        return float("nan")
    if np.ptp(x) < np.finfo(float).resolution:
        return float(x.size)
    acov = _autocovariance(x)
    within = acov[:, 0].mean() * n / (n - 1)
    var_plus = within * (n - 1) / n + (np.var(x.mean(axis=1), ddof=1) if c > 1 else 0.0)
    rho = np.zeros(n)

    def rho_at(t: int) -> float:
        return 1.0 - (within - acov[:, t].mean()) / var_plus

    rho[0], rho[1] = 1.0, rho_at(1)
    even, odd, t = 1.0, rho[1], 1
    while t < n - 3 and even + odd > 0:  # the initial positive sequence of pair sums
        even, odd = rho_at(t + 1), rho_at(t + 2)
        if even + odd >= 0:
            rho[t + 1], rho[t + 2] = even, odd
        t += 2
    last = t - 2
    if even > 0:
        rho[last + 1] = even
    for t in range(1, last - 1, 2):  # the initial monotone sequence
        if rho[t + 1] + rho[t + 2] > rho[t - 1] + rho[t]:
            rho[t + 1] = rho[t + 2] = (rho[t - 1] + rho[t]) / 2
    tau = -1.0 + 2.0 * rho[: last + 1].sum() + rho[last + 1 : last + 2].sum()
    return float(c * n / max(tau, 1.0 / np.log10(c * n)))


MIN_DRAWS = 4  # fewer draws a chain: no ESS (NaN), as ArviZ (its minimum shape, draws=4)


def ess_bulk(x: Float[np.ndarray, "C N"]) -> float:
    """The bulk ESS: of the rank-normalised split chains (NaN under `MIN_DRAWS` draws a chain)."""
    x = np.asarray(x, dtype=float)
    if x.shape[1] < MIN_DRAWS:
        return float("nan")
    return effective_size(_rank_normalised(_split(x)))


def ess_tail(x: Float[np.ndarray, "C N"]) -> float:
    """The tail ESS: the smaller of the split chains' ESS of the indicators x <= q05 and x <= q95
    (the quantiles of all draws, R's type 7; NaN under `MIN_DRAWS` draws a chain)."""
    x = np.asarray(x, dtype=float)
    if not np.all(np.isfinite(x)) or x.shape[1] < MIN_DRAWS:
        return float("nan")
    q = stats.mstats.mquantiles(x.ravel(), (0.05, 0.95), alphap=1, betap=1)  # type 7 as R and ArviZ compute it (a tie at q counts)
    return min(effective_size(_split((x <= qk).astype(float))) for qk in np.asarray(q))


def _scale_reduction(x: Float[np.ndarray, "C N"]) -> float:
    """Gelman and Rubin's R = sqrt((N - 1) / N + B / (N W)) of chains `x` (B / N: the variance of
    the chain means, W: the mean within-chain variance; Vehtari et al. eqs. 3-4)."""
    n = x.shape[1]
    within = x.var(axis=1, ddof=1).mean()
    between = n * x.mean(axis=1).var(ddof=1)
    with np.errstate(divide="ignore", invalid="ignore"):  # constant draws: 0 / 0, NaN
        return float(np.sqrt((between / within + n - 1) / n))


def rhat(x: Float[np.ndarray, "C N"]) -> float:
    """The rank-normalised split R-hat: the larger of R of the rank-normalised split chains (bulk)
    and of their absolute deviations from the pooled median, rank-normalised (tail) (Vehtari et
    al. 2021, section 4.2; ArviZ's `rhat`). NaN for one chain, under `MIN_DRAWS` draws a chain,
    for constant or non-finite draws."""
    x = np.asarray(x, dtype=float)
    if x.shape[0] < 2 or x.shape[1] < MIN_DRAWS or not np.all(np.isfinite(x)):
        return float("nan")
    split = _split(x)
    folded = np.abs(split - np.median(split))
    return float(np.maximum(_scale_reduction(_rank_normalised(split)), _scale_reduction(_rank_normalised(folded))))


__all__ = ["MIN_DRAWS", "effective_size", "ess_bulk", "ess_tail", "rhat"]
