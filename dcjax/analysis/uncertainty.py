"""Uncertainty and identifiability at a fitted optimum.

Linearization (Gauss–Newton): with the residual vector r(x) of eq. 24/27 (sum r^2 = OF) and its
Jacobian J = dr/dx by `jax.jacfwd` through the integrator,

    s^2 = sum r^2 / (m - p),      Cov(x) = s^2 (J^T J)^+,      se_k = sqrt(Cov_kk),

computed in bound-scaled coordinates (x = lower + (upper - lower) z) with an SVD pseudo-inverse,
so that parameters of very different size and near-singular directions are handled. 95 %
intervals are x_k +- t_{0.975, m-p} se_k. A profile likelihood re-fits all other parameters with
one held fixed (Levenberg–Marquardt) over a grid."""

import dataclasses
import statistics

import jax
import jax.numpy as jnp
import numpy as np

from ..compiling import filter_jit
from ..errors import ConfigError
from ..models.bounds import Bounds
from ..models.space import Space, make_space
from ..numbers import to_uncertainty
from ..simulation.joint import JointProblem, joint_problem
from ..simulation.objectives import objective
from ..simulation.problem import Problem
from .sandwich import sandwich

WELL, WEAK, NOT, FIXED = "well determined", "weakly determined", "not identifiable from this recording", "fixed (known)"


@dataclasses.dataclass
class Uncertainty:
    params: dict[str, float]
    se: dict[str, float]
    ci95: dict[str, tuple[float, float]]
    correlation: np.ndarray  # (P, P); 0 for fixed parameters
    verdict: dict[str, str]
    reason: dict[str, str]
    singular_values: np.ndarray  # of the bound-scaled Jacobian, descending
    dof: int
    s2: float
    profile: tuple | None = None  # (values, OFs) of a profile likelihood, where computed
    approximation: str = ""  # what a non-Gaussian loss's errors assume ("" for the squared error)
    null_names: tuple[str, ...] = ()  # parameters that move along a null direction (no interval)
    combinations: dict[str, tuple[float, float]] = dataclasses.field(default_factory=dict)  # name -> (value, rel. std. error)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.params)

    def intervals(self, names, prob: float = 0.9) -> dict[str, tuple[float, float]]:
        """The linearised central `prob` interval value +- z se of each of `names` (NaN where a
        null direction leaves no standard error)."""
        z = statistics.NormalDist().inv_cdf((1 + prob) / 2)
        return {n: (self.params[n] - z * self.se[n], self.params[n] + z * self.se[n]) for n in names}

    def strong_correlations(self, threshold: float = 0.9) -> list[tuple[str, str, float]]:
        """Pairs of parameters correlated above `threshold` in absolute value, strongest first."""
        names, c = self.names, self.correlation
        pairs = [
            (names[a], names[b], float(c[a, b])) for a in range(len(names)) for b in range(a + 1, len(names)) if abs(c[a, b]) > threshold
        ]
        return sorted(pairs, key=lambda p: -abs(p[2]))

    def table(self) -> str:
        """One row per parameter; a dash where no finite standard error exists (a null direction)."""
        w = max(6, *(len(n) for n in self.params))
        lines = [f"{'param':>{w}} {'value':>13} {'std. error':>11} {'rel.':>8} {'95 % interval':>29}  verdict"]
        for n in self.params:
            v, s = self.params[n], self.se[n]
            lo, hi = self.ci95[n]
            if np.isfinite(s) and s > 0:  # the value and the interval to two significant digits of the error
                rel = s / abs(v) if v else np.inf
                cols = f"{s:11.2g} {rel:8.1e} [{to_uncertainty(lo, s):>13}, {to_uncertainty(hi, s):>13}]"
                value = to_uncertainty(v, s)
            else:
                cols = f"{'-':>11} {'-':>8} {'-':>29}"
                value = f"{v:.6g}"
            lines.append(f"{n:>{w}} {value:>13} {cols}  {self.verdict[n]} ({self.reason[n]})")
        lines += self.combination_lines()
        if self.approximation:
            lines.append(f"note: {self.approximation}")
        return "\n".join(lines)

    def combination_lines(self) -> list[str]:
        """What a null direction leaves determined: the parameters each alone are not, the
        combinations (products of powers) along which the data cannot move are."""
        if not self.null_names:
            return []
        verb = "is" if len(self.null_names) == 1 else "are"
        out = [f"null direction: {', '.join(self.null_names)} {verb} not determined, each alone (no interval)"]
        if self.combinations:
            out.append("determined combinations:")
            out += [f"  {k} = {v:.9g} (relative std. error {r:.1e})" for k, (v, r) in self.combinations.items()]
        else:
            out.append("(more than one null direction, or a parameter at 0 in it: no combination named)")
        return out


def _target(problems, weights) -> JointProblem:
    if isinstance(problems, JointProblem):
        return problems
    problems = problems if isinstance(problems, list) else [problems]
    return joint_problem(problems, weights)


def residual_jacobian(
    x: np.ndarray, problems: "list[Problem] | JointProblem", weights: list[float] | None = None, free=None
) -> tuple[np.ndarray, np.ndarray]:
    """Stacked residuals r (m,) and J = dr/dx (m, F) over one or several recordings (or a fit's
    `JointProblem`: its search vector), with respect to the entries `free` (indices; default all);
    each recording's residuals are scaled by sqrt(its weight), so sum r^2 is the (joint) OF."""
    xj = jnp.asarray(x, dtype=jnp.float64)
    free = jnp.arange(xj.shape[0]) if free is None else jnp.asarray(free, dtype=int)
    r, jac = _residuals_and_jacobian(xj, free, _target(problems, weights))
    return np.asarray(r), np.asarray(jac)


@filter_jit
def _residuals_and_jacobian(x: jax.Array, free: jax.Array, target: JointProblem):
    """One compiled residual and forward-mode Jacobian per problem structure (reused across calls)."""

    def r_of(xf):
        return target.residuals(x.at[free].set(xf))

    return r_of(x[free]), jax.jacfwd(r_of)(x[free])


def _t_quantile(dof: int) -> float:
    try:
        from scipy.stats import t  # lazy: scipy adds 0.1-0.6 s to importing dcjax

        return float(t.ppf(0.975, dof))
    except ImportError:  # normal approximation
        return 1.959963984540054


def uncertainty(
    x,
    problems: "Problem | list[Problem] | JointProblem",
    bounds: Bounds | Space,
    weights: list[float] | None = None,
    weak_rel_se: float = 0.1,
    not_rel_se: float = 1.0,
    rcond: float = 1e-10,
    robust: JointProblem | None = None,
) -> Uncertainty:
    """Standard errors, 95 % intervals, correlations and a verdict per parameter at `x`.

    `robust`: the fit's own target where its loss is not the squared error (l1, huber): the
    covariance is then that loss's sandwich (`dcjax.analysis.sandwich`), in the subspace that J
    determines; `problems` stays the squared-error form whose J finds the null directions.

    Verdicts: *not identifiable from this recording* when the parameter sits on a bound, loads on a
    null direction of J (singular value below `rcond` x the largest), or its relative standard error
    exceeds `not_rel_se`; *weakly determined* when the relative error exceeds `weak_rel_se` or it
    is correlated above 0.99 with another parameter; else *well determined*. A value near 0 is
    judged in absolute terms: where it lies within one standard error of 0 and that error is at most
    `ABSOLUTE_SHARE` of its range (a load torque of 0 fitted to +-6e-4 Nm in a range of 1 Nm), it is
    *well determined* (near 0), not "not identifiable" for a relative error that only 0 makes large. Parameters fixed in
    `bounds` (a `Space`, or equal lower and upper bounds) are known: *fixed (known)*, error 0,
    and the others' errors are computed with them held."""
    target = _target(problems, weights)
    model = target.problems[0].model
    space = bounds if isinstance(bounds, Space) else make_space(model, bounds)
    names = space.names
    x = np.asarray(x, dtype=np.float64)
    fidx = np.array(space.free)
    width = np.asarray(space.upper - space.lower)
    jac, dof, s2 = _curvature(x, target, fidx, width)
    p = jac.shape[1]
    xf = x[fidx]
    jz = jac * width  # d r / d z
    u, sv, vt = np.linalg.svd(jz, full_matrices=False)
    keep = sv > rcond * sv[0]
    inv = np.where(keep, 1.0 / np.where(keep, sv, 1.0) ** 2, 0.0)
    cov_z = (vt.T * inv) @ vt * s2
    if robust is not None:
        cov_z = _sandwich_z(x, robust, fidx, width, vt[keep], cov_z)
    cov = cov_z * np.outer(width, width)
    se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    d = np.where(se > 0, se, 1.0)
    corr = cov / np.outer(d, d)
    null_load = np.abs(vt[~keep]).max(axis=0) if np.any(~keep) else np.zeros(p)
    null_idx, combos = _null_combinations(xf, jac, space.free_names, s2, rcond)
    tq = _t_quantile(dof)
    lo_b, hi_b = np.asarray(space.lower), np.asarray(space.upper)
    free_names = space.free_names
    verdict, reason = {}, {}
    for k, n in enumerate(free_names):
        rel = se[k] / abs(xf[k]) if xf[k] != 0 else np.inf
        at_bound = min(abs(xf[k] - lo_b[k]), abs(hi_b[k] - xf[k])) <= 1e-9 * width[k] + 1e-300
        others = np.abs(np.where((np.arange(p) == k) | np.isin(np.arange(p), null_idx), 0.0, corr[k]))  # not with a null direction's
        if at_bound:
            verdict[n], reason[n] = NOT, "at a bound"
        elif k in null_idx:
            verdict[n], reason[n] = NOT, "in a null direction: only combinations are determined"
        elif null_load[k] > 0.3:
            verdict[n], reason[n] = NOT, "in a null direction of the Jacobian"
        elif rel > not_rel_se and se[k] <= ABSOLUTE_SHARE * width[k]:
            verdict[n], reason[n] = WELL, f"near 0: std. error {se[k]:.2g}, {se[k] / width[k]:.1e} of its range"
        elif rel > not_rel_se:
            verdict[n], reason[n] = NOT, f"relative std. error {rel:.1e}"
        elif rel > weak_rel_se:
            verdict[n], reason[n] = WEAK, f"relative std. error {rel:.1e}"
        elif others.max() > 0.99:
            j = int(np.argmax(others))
            verdict[n], reason[n] = WEAK, f"correlation {corr[k, j]:+.3f} with {free_names[j]}"
        else:
            verdict[n], reason[n] = WELL, f"relative std. error {rel:.1e}"
    # A parameter in a null direction has no finite standard error (the pseudo-inverse's 1e-20
    # would be a number without meaning): NaN, printed as a dash, and no interval.
    se = np.where([reason[n].startswith("in a null direction") for n in free_names], np.nan, se)
    se_all = np.zeros(len(names))
    se_all[fidx] = se
    corr_all = np.zeros((len(names), len(names)))
    corr_all[np.ix_(fidx, fidx)] = corr
    for n in space.fixed:
        verdict[n], reason[n] = FIXED, "given"
    return Uncertainty(
        params=dict(zip(names, map(float, x))),
        se=dict(zip(names, map(float, se_all))),
        ci95={n: (float(x[k] - tq * se_all[k]), float(x[k] + tq * se_all[k])) for k, n in enumerate(names)},
        correlation=corr_all,
        verdict={n: verdict[n] for n in names},
        reason={n: reason[n] for n in names},
        singular_values=sv,
        dof=dof,
        s2=s2,
        null_names=tuple(free_names[k] for k in null_idx),
        combinations=combos,
    )


def _curvature(x, target: JointProblem, fidx, width) -> tuple[np.ndarray, int, float]:
    """(J, dof, s2): s2 (J'J)^-1 is the covariance. The residuals' Jacobian and their variance; a
    prediction-error fit's likelihood Hessian as J'J (`likelihood_root`) with s2 = 1."""
    if any(p.predictor.filters for p in target.problems):
        jac, samples = likelihood_root(x, target, fidx, width)
        return jac, max(samples - jac.shape[1], 1), 1.0
    r, jac = residual_jacobian(x, target, None, fidx)
    dof = max(jac.shape[0] - jac.shape[1], 1)
    return jac, dof, float(r @ r) / dof


def likelihood_root(x: np.ndarray, target: JointProblem, free: np.ndarray, width: np.ndarray) -> tuple[np.ndarray, int]:
    """(A, M) with A'A the Hessian of the negative log-likelihood (sum over the recordings of N_r
    OF_r, a prediction-error fit's innovations' likelihood) in the free parameters (A = Lambda^1/2
    V' / width from the Hessian's eigenvectors in bound-scaled coordinates, negative curvature
    clipped), so that the Jacobian analysis above gives its inverse as the covariance; M the
    measured values (samples x outputs)."""
    hz = np.asarray(_nll_hessian(jnp.asarray(x), jnp.asarray(free), jnp.asarray(width), target))
    lam, vecs = np.linalg.eigh(0.5 * (hz + hz.T))
    order = np.argsort(lam)[::-1]
    root = np.sqrt(np.clip(lam[order], 0.0, None))[:, None] * vecs[:, order].T
    samples = sum(int(p.n if p.mask is None else np.sum(np.asarray(p.mask))) * len(p.model.outputs) for p in target.problems)
    return root / width, samples


@filter_jit
def _nll_hessian(x: jax.Array, free: jax.Array, width: jax.Array, target: JointProblem):
    def nll(z):
        xz = x.at[free].set(x[free] + width * z)
        total = 0.0
        for r, p in enumerate(target.problems):
            n = p.n if p.mask is None else jnp.sum(p.mask)
            total = total + n * objective(target.model_x(xz, r), p, target.adjustments(xz, r))
        return total

    # forward over forward: a Kalman filter's Hessian compiles in about half the time of
    # `jax.hessian` (reverse inside): 2.9 against 5.0 s on a 250-sample record, 11 parameters
    # (`python -m experiments.bench_polish_compile`)
    return jax.jacfwd(jax.jacfwd(nll))(jnp.zeros(free.shape[0], x.dtype))


def _sandwich_z(x, robust: JointProblem, fidx, width, basis, fallback):
    """H^-1 V H^-1 in bound-scaled coordinates, within the span of `basis` (J's determined
    directions); `fallback` where the loss leaves no density to estimate (all errors 0)."""
    hess, var = sandwich(x, robust, fidx)
    hz, vz = hess * np.outer(width, width), var * np.outer(width, width)
    h_r, v_r = basis @ hz @ basis.T, basis @ vz @ basis.T
    if not (np.all(np.isfinite(h_r)) and np.all(np.isfinite(v_r))):
        return fallback
    h_inv = np.linalg.pinv(h_r)
    return basis.T @ (h_inv @ v_r @ h_inv) @ basis


ABSOLUTE_SHARE = 1e-3  # a standard error this share of the parameter's range determines it, whatever its value

NULL_LOAD = 1e-4  # a parameter whose share of a unit null vector exceeds this moves along it


def _power_name(a: str, b: str, e: float) -> str:
    if abs(e - 1) < 1e-6:
        return f"{a}*{b}"
    if abs(e + 1) < 1e-6:
        return f"{a}/{b}"
    return f"{a}*{b}^{e:.4g}"


def _null_combinations(x: np.ndarray, jac: np.ndarray, names, s2: float, rcond: float) -> tuple[list[int], dict[str, tuple[float, float]]]:
    """The null directions of J in relative coordinates (d x_k = |x_k| d log x_k, absolute where
    x_k = 0), where a scaling symmetry (Ra/s, La/s, J s, ...) is one direction with equal shares:
    (indices of the parameters in a null direction, {combination: (value, rel. std. error)}). With
    one null direction v and every parameter in it positive, x_k * x_p^(-v_k / v_p) (p the first
    of the largest shares) is constant along it: determined, with the log-space covariance s^2 (J_s^T J_s)^+."""
    js = jac * np.where(x != 0, np.abs(x), 1.0)
    _, sv, vt = np.linalg.svd(js, full_matrices=False)
    if sv.size == 0 or not sv[0] > 0:
        return [], {}
    null = sv <= rcond * sv[0]
    if not null.any():
        return [], {}
    V = vt[null]
    inside = [int(k) for k in np.flatnonzero(np.abs(V).max(axis=0) > NULL_LOAD)]
    if len(V) != 1 or not all(x[k] > 0 for k in inside) or len(inside) < 2:
        return inside, {}
    v = V[0]
    top = max(abs(v[k]) for k in inside)
    piv = next(k for k in inside if abs(v[k]) >= (1 - 1e-6) * top)  # the first of the largest shares
    inv = np.where(~null, 1.0 / np.where(~null, sv, 1.0) ** 2, 0.0)
    cov_log = (vt.T * inv) @ vt * s2
    combos = {}
    for k in inside:
        if k == piv:
            continue
        e = -v[k] / v[piv]
        e = round(e * 2) / 2 if abs(e * 2 - round(e * 2)) < 1e-6 else e
        a = np.zeros(len(x))
        a[k], a[piv] = 1.0, e
        combos[_power_name(names[k], names[piv], e)] = (float(x[k] * x[piv] ** e), float(np.sqrt(max(a @ cov_log @ a, 0.0))))
    return inside, combos


def profile(
    x,
    name: str,
    values,
    problems: "Problem | list[Problem] | JointProblem",
    bounds: Bounds | Space,
    weights: list[float] | None = None,
    max_steps: int = 200,
) -> np.ndarray:
    """Profile likelihood of one parameter: for each value, the least OF over the other free
    parameters (Levenberg–Marquardt from `x`, bounds kept by the sine reparametrization; fixed
    parameters stay fixed). Returns OFs."""
    target = _target(problems, weights)
    model = target.problems[0].model
    space = bounds if isinstance(bounds, Space) else make_space(model, bounds)
    if name not in space.names:
        raise ConfigError(f"unknown parameter {name!r}; the fit's parameters are {', '.join(space.names)}")
    if name in space.fixed:
        raise ConfigError(f"{name} is fixed; a profile needs a free parameter")
    k = space.names.index(name)
    free = np.array([j for j in space.free if j != k])
    lo, hi = np.asarray(space.bounds.lower)[free], np.asarray(space.bounds.upper)[free]
    z0 = np.clip((np.asarray(x)[free] - lo) / np.where(hi > lo, hi - lo, 1.0), 1e-12, 1 - 1e-12)
    y0 = jnp.arcsin(2 * jnp.asarray(z0) - 1)
    base = jnp.asarray(x, dtype=jnp.float64)

    def full(y, v):
        xf = jnp.asarray(lo) + (jnp.asarray(hi) - jnp.asarray(lo)) * 0.5 * (jnp.sin(y) + 1)
        return base.at[free].set(xf).at[k].set(v)

    def fn(y, v):
        return target.residuals(full(y, v))

    import optimistix as optx  # lazy: with lineax a tenth of a second of every dcjax import

    @jax.jit
    def solve(v):
        sol = optx.least_squares(fn, optx.LevenbergMarquardt(rtol=1e-10, atol=1e-14), y0, args=v, max_steps=max_steps, throw=False)
        r = fn(sol.value, v)
        return jnp.sum(r * r)

    return np.array([float(solve(jnp.asarray(v, dtype=jnp.float64))) for v in values])


INCONSISTENT, CONSISTENT = "inconsistent between recordings", "consistent between recordings"


def consistency(uncertainties: dict[str, Uncertainty], threshold: float = 3.0) -> dict[str, dict]:
    """Do separate fits of one drive agree within their standard errors (Section 4.2.5)?

    For each parameter, the inverse-variance weighted mean of the fits and the largest
    z = |x_r - mean| / se_r. z > `threshold` means the recordings disagree by far more than the
    linearized errors explain (systematic model/measurement error), e.g. the paper's La between
    MD1–MD3. Parameters not identifiable in every fit are reported as such."""
    names = list(uncertainties)
    out = {}
    for n in uncertainties[names[0]].params:
        x = np.array([uncertainties[r].params[n] for r in names])
        se = np.array([uncertainties[r].se[n] for r in names])
        if all(uncertainties[r].verdict[n] == FIXED for r in names):
            out[n] = {"values": x.tolist(), "se": se.tolist(), "spread": 0.0, "max_z": None, "verdict": FIXED}
            continue
        identifiable = [uncertainties[r].verdict[n] not in (NOT, FIXED) for r in names]
        spread = float((x.max() - x.min()) / abs(x.mean())) if x.mean() else np.inf
        if not all(identifiable):
            out[n] = {
                "values": x.tolist(),
                "se": se.tolist(),
                "spread": spread,
                "max_z": None,
                "verdict": f"not identifiable in {', '.join(r for r, ok in zip(names, identifiable) if not ok)}",
            }
            continue
        w = 1.0 / np.maximum(se, 1e-300) ** 2
        mean = float(np.sum(w * x) / np.sum(w))
        z = float(np.max(np.abs(x - mean) / np.maximum(se, 1e-300)))
        out[n] = {
            "values": x.tolist(),
            "se": se.tolist(),
            "spread": spread,
            "max_z": z,
            "verdict": INCONSISTENT if z > threshold else CONSISTENT,
        }
    return out
