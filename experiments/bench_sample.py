"""Posterior sampling (`dcjax sample`) on SD1 with 1 % noise (issue: honest uncertainty): the noisy
recording from dcjax's plain-NumPy RK4 (`dcjax.io.numpy_simulator`, 64 sub-steps, the truth of
Table 2), Gaussian noise of 1 % of each channel's peak (seed 1); a fit (default DE, 2 runs of
40,000 FEs, polished; the default initial state: both noisy starts fitted), then NUTS (4 chains x 1000 draws after 1000 warmup steps, seed 0) under the
sse fit's Gaussian likelihood and an l1 fit's Laplace one. Prints per fit: R-hat and bulk/tail ESS
per parameter, leapfrog steps a draw, divergences, warmup and sampling seconds, bulk ESS per
second of sampling (the least over the parameters), and the truth's distance from the posterior
mean in posterior standard deviations.

    python -m experiments.bench_sample
"""

import platform
import time

import jax
import numpy as np

import dcjax
from dcjax import datasets
from dcjax.io.numpy_simulator import simulate_numpy

dcjax.use_compiled_loops()


def noisy_sd1() -> tuple[dcjax.Recording, dict]:
    rec, truth = datasets.load("SD1"), datasets.true_params("SD1")
    y = simulate_numpy([truth[n] for n in dcjax.DC().names], rec.t, np.asarray(rec["u_a"]), nd=64)
    y = y + 0.01 * np.abs(y).max(axis=0) * np.random.default_rng(1).standard_normal(y.shape)
    return dcjax.Recording(t=rec.t, u_a=rec["u_a"], i_a=y[:, 0], omega=y[:, 1], name="SD1-noisy"), truth


def main():
    rec, truth = noisy_sd1()
    print(f"{platform.processor() or platform.machine()}, {jax.devices()[0].platform}, {len(jax.devices())} device(s); SD1 with 1 % noise")
    for loss in ("sse", "l1"):
        t0 = time.perf_counter()
        res = dcjax.fit(
            rec, params="table4", observation=dcjax.Observation(loss=loss), search=dcjax.Search(runs=2, budget=40_000, polish=loss == "sse")
        )
        fit_s = time.perf_counter() - t0
        post = res.sample(draws=1000, chains=4, warmup=1000, seed=0)
        print(f"\n--- {loss} fit ({fit_s:.1f} s), {post.likelihood} likelihood")
        print(post.table())
        true = {**truth, "y0_i_a": 0.0, "y0_omega": 0.0}  # the motor starts at rest; the default fits both noisy starts
        dist = {n: (true[n] - post.mean[n]) / post.sd[n] for n in post.names}
        print("truth - posterior mean, in posterior sd: " + ", ".join(f"{n} {v:+.2f}" for n, v in dist.items()))
        print(f"least bulk ESS {min(post.ess_bulk.values()):.0f}, largest R-hat {max(post.rhat.values()):.4f}, "
              f"{post.ess_per_second:.1f} bulk ESS/s of sampling")  # fmt: skip


if __name__ == "__main__":
    main()
