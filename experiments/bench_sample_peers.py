"""Posterior sampling against the peers (issue: honest uncertainty, item 7): bulk ESS per second of
`dcjax sample` (NUTS) against pyPESTO's adaptive Metropolis (its defaults, and
`decay_constant=1.0`) and emcee through lmfit's `Minimizer.emcee`, on one posterior measured in one
run on the same cores.

The posterior: SD1 with 1 % noise (`experiments.bench_sample.noisy_sd1`, the truth of Table 2
through the plain-NumPy RK4), the motor starting at rest, the seven parameters on a log scale with a
uniform prior on log(x) in [truth / 10, truth x 10] (`--space log`, the issue's problem) or uniform
in Table 4's ranges (`--space table4`, dcjax's own bench), a Gaussian likelihood with each
channel's noise sd fixed at dcjax's estimate at the optimum (so all three sample the same density). The peers'
likelihood is a numba RK4 of eq. 8-9 (ND 1, eq. 29's input, the plain-NumPy simulator's arithmetic).
Bulk ESS: `blackjax.diagnostics.ess_bulk` for every sampler (emcee's walkers as chains), the least
over the parameters. Figures: ESS/s of the kept draws' wall, and of the whole wall (warm-up,
burn-in and, for dcjax, its compilation). The posterior means agree when every sampler samples the
same density: the table prints them in the posterior sd of dcjax.

Needs pyPESTO, lmfit, emcee and numba beside dcjax (not dcjax's dependencies: a venv of its own,
`pip install -e . pypesto lmfit emcee numba`).

    python -m experiments.bench_sample_peers [--space log|table4] [--emcee-steps 20000] [--am-samples 100000]
    XLA_FLAGS=--xla_force_host_platform_device_count=2 python -m experiments.bench_sample_peers   # dcjax's chains on 2 devices
"""

import argparse
import os
import platform
import time

import dcjax

dcjax.use_compiled_loops()  # before anything starts JAX (importing blackjax's diagnostics does)

import blackjax.diagnostics as diag  # noqa: E402
import jax  # noqa: E402
import numpy as np  # noqa: E402

from experiments.bench_sample import noisy_sd1  # noqa: E402

NAMES = dcjax.DC().names


def log_posterior_numba(rec, sigma, log: bool = True):
    """theta (log x, or x where not `log`; 7) -> minus the log likelihood up to a constant, numba-compiled."""
    import numba

    t, u = np.asarray(rec.t, float), np.asarray(rec["u_a"], float)
    im, wm = np.asarray(rec["i_a"], float), np.asarray(rec["omega"], float)
    si, sw = float(sigma["i_a"]), float(sigma["omega"])

    @numba.njit(cache=False, fastmath=False)
    def half_chi2(theta):
        ra, la, cm, j, tla, tlb, tlc = np.exp(theta) if log else theta
        i, w, s = 0.0, 0.0, 0.0
        for k in range(1, t.size):
            h = t[k] - t[k - 1]
            ua, ub = u[k - 1], u[k]
            um = 0.5 * (ua + ub)
            k1 = (ua - i * ra - cm * w) / la
            l1 = (cm * i - (tla + tlb * w + tlc * w * w)) / j
            i2, w2 = i + 0.5 * h * k1, w + 0.5 * h * l1
            k2 = (um - i2 * ra - cm * w2) / la
            l2 = (cm * i2 - (tla + tlb * w2 + tlc * w2 * w2)) / j
            i3, w3 = i + 0.5 * h * k2, w + 0.5 * h * l2
            k3 = (um - i3 * ra - cm * w3) / la
            l3 = (cm * i3 - (tla + tlb * w3 + tlc * w3 * w3)) / j
            i4, w4 = i + h * k3, w + h * l3
            k4 = (ub - i4 * ra - cm * w4) / la
            l4 = (cm * i4 - (tla + tlb * w4 + tlc * w4 * w4)) / j
            i = i + h * (k1 / 6 + k2 / 3 + k3 / 3 + k4 / 6)
            w = w + h * (l1 / 6 + l2 / 3 + l3 / 3 + l4 / 6)
            s += ((i - im[k]) / si) ** 2 + ((w - wm[k]) / sw) ** 2
        return 0.5 * s if np.isfinite(s) else np.inf

    return half_chi2


def summary(tag: str, draws: np.ndarray, kept_s: float, total_s: float, extra: str = "") -> dict:
    """draws (chains, n, 7) of the sampled coordinates."""
    ess = np.nan_to_num(np.asarray(diag.ess_bulk(draws)), nan=0.0)  # a chain that never moved: NaN
    rhat = np.asarray(diag.rhat(draws)) if draws.shape[0] > 1 else np.full(len(NAMES), np.nan)
    row = {"tag": tag, "ess": ess, "rhat": rhat, "mean": draws.reshape(-1, len(NAMES)).mean(0), "kept_s": kept_s, "total_s": total_s}
    print(f"{tag:<32} least bulk ESS {ess.min():7.0f}  max R-hat {np.nanmax(rhat) if draws.shape[0] > 1 else float('nan'):6.3f}  "
          f"kept {kept_s:7.1f} s  whole {total_s:7.1f} s  {ess.min() / kept_s:8.2f} ESS/s kept  {ess.min() / total_s:8.2f} ESS/s whole"
          + (f"  ({extra})" if extra else ""), flush=True)  # fmt: skip
    return row


def run_dcjax(rec, truth, draws, warmup, log: bool):
    params = dcjax.DC().parameters("table4")
    for n in NAMES:
        if log:
            params[n].set(min=truth[n] / 10, max=truth[n] * 10, scale="log", value=None)
    obs = dcjax.Observation(initial={"i_a": 0.0, "omega": 0.0})
    res = dcjax.fit(rec, params=params, observation=obs, search=dcjax.Search(runs=2, budget=40_000, polish=True))
    t0 = time.perf_counter()
    post = res.sample(draws=draws, chains=4, warmup=warmup, seed=0)
    total = time.perf_counter() - t0
    row = summary("dcjax NUTS (4 chains)", np.log(post.draws) if log else post.draws, post.wall["sampling"], total, f"{post.steps:.1f} leapfrog steps a draw, "
                  f"{post.divergences} divergent")  # fmt: skip
    return row, post, res


def run_am(problem_fun, lo, hi, x0, samples, decay, seed):
    import pypesto
    import pypesto.sample as ps

    problem = pypesto.Problem(objective=pypesto.Objective(fun=problem_fun), lb=lo, ub=hi, x_names=list(NAMES))
    chains, kept = [], 0.0
    t0 = time.perf_counter()
    for c in range(4):
        np.random.seed(seed + c)
        opts = {} if decay is None else {"decay_constant": decay}
        result = ps.sample(problem, n_samples=samples, sampler=ps.AdaptiveMetropolisSampler(options=opts), x0=x0)
        trace = np.asarray(result.sample_result.trace_x)[0]
        chains.append(trace[samples // 2 :])  # the second half: after the adaptation's burn-in
    total = time.perf_counter() - t0
    kept = total / 2  # the kept half of every chain's steps
    tag = "pyPESTO AM (default)" if decay is None else f"pyPESTO AM (decay_constant={decay:g})"
    return summary(tag, np.stack(chains), kept, total, f"4 chains x {samples} steps, the second half kept")


def run_emcee(half_chi2, lo, hi, x0, steps, seed):
    import lmfit

    params = lmfit.Parameters()
    for n, a, b, v in zip(NAMES, lo, hi, x0):
        params.add(f"p_{n}", value=float(v), min=float(a), max=float(b))

    def lnprob(p):
        return -half_chi2(np.array([p[f"p_{n}"].value for n in NAMES]))

    walkers, burn = 32, steps // 3
    rng = np.random.default_rng(seed)
    start = np.clip(x0 + 1e-4 * np.maximum(np.abs(x0), 1e-3 * (hi - lo)) * rng.standard_normal((walkers, len(NAMES))), lo, hi)
    t0 = time.perf_counter()
    out = lmfit.Minimizer(lnprob, params, nan_policy="omit").emcee(
        steps=steps, nwalkers=walkers, burn=burn, pos=start, float_behavior="posterior", is_weighted=True, seed=seed, progress=False
    )
    total = time.perf_counter() - t0
    chain = np.asarray(out.chain)  # (steps - burn, walkers, 7)
    return summary("emcee via lmfit (32 walkers)", np.moveaxis(chain, 1, 0), total * (steps - burn) / steps, total,
                   f"{steps} steps, {burn} burn-in, acceptance {np.mean(out.acceptance_fraction):.2f}")  # fmt: skip


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--draws", type=int, default=1000)
    ap.add_argument("--warmup", type=int, default=1000)
    ap.add_argument("--emcee-steps", type=int, default=20_000)
    ap.add_argument("--am-samples", type=int, default=100_000)
    ap.add_argument("--space", default="log", choices=("log", "table4"), help="log: log x in [truth/10, truth*10]; table4: x in Table 4")
    args = ap.parse_args(argv)
    log = args.space == "log"
    what = "7 log-parameters in [truth/10, truth*10]" if log else "7 parameters in Table 4's ranges (Tlb, Tlc from 0)"
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, {jax.devices()[0].platform}; SD1 with 1 % noise, "
          f"{what}, the noise sd fixed at dcjax's estimate")  # fmt: skip
    rec, truth = noisy_sd1()
    rows = []
    row, post, res = run_dcjax(rec, truth, args.draws, args.warmup, log)
    rows.append(row)
    sigma = {c.split(":")[-1]: v for c, v in post.noise.items()}
    half_chi2 = log_posterior_numba(rec, sigma, log)
    if log:
        lo, hi = np.log([truth[n] / 10 for n in NAMES]), np.log([truth[n] * 10 for n in NAMES])
        x0 = np.log([res.params[n].value for n in NAMES])
    else:
        box = dcjax.DC().parameters("table4")
        lo, hi = np.array([box[n].min for n in NAMES]), np.array([box[n].max for n in NAMES])
        x0 = np.array([res.params[n].value for n in NAMES])
    t0 = time.perf_counter()
    half_chi2(x0)
    print(f"numba likelihood: compiled in {time.perf_counter() - t0:.1f} s; its value at dcjax's optimum {half_chi2(x0):.6g}", flush=True)
    rows.append(run_am(half_chi2, lo, hi, x0, args.am_samples, None, 1))
    rows.append(run_am(half_chi2, lo, hi, x0, args.am_samples, 1.0, 1))
    rows.append(run_emcee(half_chi2, lo, hi, x0, args.emcee_steps, 1))
    ref = rows[0]
    sd = (np.log(post.draws) if log else post.draws).reshape(-1, len(NAMES)).std(0)
    print(f"\nposterior mean of {'log x' if log else 'x'}, each sampler's minus dcjax's, in dcjax's posterior sd:")
    print(f"{'sampler':<36}" + "".join(f"{n:>8}" for n in NAMES))
    for r in rows[1:]:
        print(f"{r['tag']:<36}" + "".join(f"{v:8.2f}" for v in (r["mean"] - ref["mean"]) / sd))
    print("\ndcjax's ESS/s (kept draws) over each peer's:")
    for r in rows[1:]:
        a, b = ref["ess"].min() / ref["kept_s"], r["ess"].min() / r["kept_s"]
        a2, b2 = ref["ess"].min() / ref["total_s"], r["ess"].min() / r["total_s"]
        ratio = lambda x, y: f"{x / y:8.1f}x" if y > 0 else "  (no ESS)"
        print(f"  {r['tag']:<34} {ratio(a, b)} kept   {ratio(a2, b2)} whole")


if __name__ == "__main__":
    main()
