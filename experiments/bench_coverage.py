"""Coverage of the 90 % intervals over noise seeds (issue: honest uncertainty, item 6): SD1-like
data (the truth of Table 2 through dcjax's plain-NumPy RK4 at 64 sub-steps, Gaussian noise of 1 %
of each channel's peak, seed s), fitted with the motor known to start at rest (`initial={"i_a": 0,
"omega": 0}`: the default first noisy sample biases the friction terms, see the guide's "Posterior
sampling"), Table 4's ranges, DE 2 runs x 40,000 FEs, polished. Per seed: does the linearised 90 %
interval (x +- 1.645 se) and the posterior's central 90 % interval (NUTS, 4 chains x 500 draws
after 500 warmup, seed s) hold the truth, per parameter. Each finished seed is appended to
`--store` (JSON lines) at once; a second call resumes where the first stopped.

    python -m experiments.bench_coverage [--seeds 50] [--store experiments/results/coverage.jsonl]
"""

import argparse
import json
import platform
import time
from pathlib import Path

import jax
import numpy as np

import dcjax
from dcjax import datasets
from dcjax.io.numpy_simulator import simulate_numpy

Z90 = 1.6448536269514722


def one_seed(seed: int) -> dict:
    rec, truth = datasets.load("SD1"), datasets.true_params("SD1")
    names = dcjax.DC().names
    y = simulate_numpy([truth[n] for n in names], rec.t, np.asarray(rec["u_a"]), nd=64)
    y = y + 0.01 * np.abs(y).max(axis=0) * np.random.default_rng(seed).standard_normal(y.shape)
    noisy = dcjax.Recording(t=rec.t, u_a=rec["u_a"], i_a=y[:, 0], omega=y[:, 1], name=f"SD1-noise{seed}")
    t0 = time.perf_counter()
    res = dcjax.fit(noisy, params="table4", runs=2, budget=40_000, polish=True, seed=seed,
                    observation=dcjax.Observation(initial={"i_a": 0.0, "omega": 0.0}))  # fmt: skip
    u = res.uncertainty().uncertainties
    assert u is not None
    post = res.sample(draws=500, chains=4, warmup=500, seed=seed)
    out = {"seed": seed, "seconds": time.perf_counter() - t0, "linearised": {}, "posterior": {}, "rhat": max(post.rhat.values())}
    for n in names:
        v, se = u.params[n], u.se[n]
        out["linearised"][n] = bool(np.isfinite(se) and v - Z90 * se <= truth[n] <= v + Z90 * se)
        lo, hi = post.interval(n, 0.9)
        out["posterior"][n] = bool(lo <= truth[n] <= hi)
    return out


def main(argv=None):
    dcjax.use_compiled_loops()  # here, not at import: the slow test imports one_seed into a running JAX
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--store", default="experiments/results/coverage.jsonl")
    args = ap.parse_args(argv)
    store = Path(args.store)
    store.parent.mkdir(parents=True, exist_ok=True)
    done = [json.loads(line) for line in store.read_text().splitlines()] if store.exists() else []
    have = {d["seed"] for d in done}
    print(f"{platform.processor() or platform.machine()}, {jax.devices()[0].platform}; {len(have)} of {args.seeds} seeds stored in {store}")
    for seed in range(args.seeds):
        if seed in have:
            continue
        d = one_seed(seed)
        with store.open("a") as f:
            f.write(json.dumps(d) + "\n")
        done.append(d)
        print(f"seed {seed}: {d['seconds']:.1f} s, largest R-hat {d['rhat']:.4f}", flush=True)
    rows = [d for d in done if d["seed"] < args.seeds]
    print(f"\ncoverage of the truth by the 90 % intervals over {len(rows)} seeds (target 0.90; band 0.80-0.97):")
    print(f"{'param':>6} {'linearised':>11} {'posterior':>10}")
    for n in dcjax.DC().names:
        lin = np.mean([d["linearised"][n] for d in rows])
        post = np.mean([d["posterior"][n] for d in rows])
        print(f"{n:>6} {lin:11.2f} {post:10.2f}")


if __name__ == "__main__":
    main()
