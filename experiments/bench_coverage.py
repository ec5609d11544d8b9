"""Coverage of the 90 % intervals over noise seeds (issue: honest uncertainty, item 6): SD1-like
data (the truth of Table 2 through dcjax's plain-NumPy RK4 at 64 sub-steps, Gaussian noise of 1 %
of each channel's peak, seed s), fitted with the motor known to start at rest (`initial={"i_a": 0,
"omega": 0}`: the default first noisy sample biases the friction terms, see the guide's "Posterior
sampling"), Table 4's ranges, DE 2 runs x 40,000 FEs, polished. Per seed: does the linearised 90 %
interval (x +- 1.645 se) and the posterior's central 90 % interval (NUTS, 4 chains x 500 draws
after 500 warmup, seed s) hold the truth, per parameter. Each finished seed is appended to
`--store` (JSON lines) at once; a second call resumes where the first stopped.

`--case joint-offset`: a two-recording joint fit with a current-sensor offset: SD1's 220 V step
and a 110 V -> 220 V step at 25 ms, the same motor, the offset 3 % of the current's peak added to
both measured currents, fitted with `offsets=("i_a",)` (one shared `offset_i_a`), the motor
known to start at rest; coverage of the seven parameters and the offset. `--case sd1-default`:
the sd1 data under the default initial state (both channels noisy: `y0_i_a`, `y0_omega` fitted,
their coverage of the true 0 counted too).

    python -m experiments.bench_coverage [--case sd1|sd1-default|joint-offset] [--seeds 50] [--store PATH]
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


CASES = ("sd1", "sd1-default", "joint-offset")
OFFSET_SHARE = 0.03  # the joint case's current-sensor offset, of the current's peak


def noisy(u, t, seed: int, name: str, offset: float = 0.0) -> dcjax.Recording:
    """The Table 2 motor (SD1's truth) driven by `u`, the NumPy RK4 at 64 sub-steps, `offset` (A)
    added to the current, then 1 % noise of each channel's peak (seed)."""
    truth = datasets.true_params("SD1")
    y = simulate_numpy([truth[n] for n in dcjax.DC().names], t, u, nd=64)
    y[:, 0] += offset
    y = y + 0.01 * np.abs(y).max(axis=0) * np.random.default_rng(seed).standard_normal(y.shape)
    return dcjax.Recording(t=t, u_a=u, i_a=y[:, 0], omega=y[:, 1], name=name)


def case_data(case: str, seed: int) -> tuple[list[dcjax.Recording], dict, dcjax.Observation]:
    """The recordings, the truth (every searched entry) and the observation of one seed."""
    rec, truth = datasets.load("SD1"), datasets.true_params("SD1")
    t, u = np.asarray(rec.t), np.asarray(rec["u_a"])
    at_rest = {"i_a": 0.0, "omega": 0.0}
    if case == "sd1":
        return [noisy(u, t, seed, f"SD1-noise{seed}")], truth, dcjax.Observation(initial=at_rest)
    if case == "sd1-default":  # the default initial state: both channels are noisy, so y0 is fitted
        return [noisy(u, t, seed, f"SD1-noise{seed}")], {**truth, "y0_i_a": 0.0, "y0_omega": 0.0}, dcjax.Observation()
    if case == "joint-offset":
        stepped = np.where(t < 0.025, 110.0, 220.0)
        clean = simulate_numpy([truth[n] for n in dcjax.DC().names], t, u, nd=64)
        offset = OFFSET_SHARE * float(np.abs(clean[:, 0]).max())  # one sensor: the same amperes in both recordings
        recs = [noisy(u, t, seed, f"SD1-offset-noise{seed}", offset), noisy(stepped, t, 10_000 + seed, f"step-offset-noise{seed}", offset)]
        return recs, {**truth, "offset_i_a": offset}, dcjax.Observation(initial=at_rest, offsets=("i_a",))
    raise ValueError(f"case must be one of {', '.join(CASES)}, got {case!r}")


def one_seed(seed: int, case: str = "sd1", runs: int = 2, budget: int = 40_000, draws: int = 500) -> dict:
    """Does each 90 % interval of seed `seed`'s fit (DE `runs` x `budget` FEs, polished; NUTS
    `draws` after as many warmup steps, 4 chains) hold the truth."""
    recs, truth, obs = case_data(case, seed)
    t0 = time.perf_counter()
    res = dcjax.fit(
        recs if len(recs) > 1 else recs[0],
        params="table4",
        observation=obs,
        search=dcjax.Search(runs=runs, budget=budget, seed=seed, polish=True),
    )
    u = res.uncertainty().uncertainties
    assert u is not None
    post = res.sample(draws=draws, chains=4, warmup=draws, seed=seed)
    out = {"seed": seed, "seconds": time.perf_counter() - t0, "linearised": {}, "posterior": {}, "rhat": max(post.rhat.values())}
    for n, true in truth.items():
        v, se = u.params[n], u.se[n]
        out["linearised"][n] = bool(np.isfinite(se) and v - Z90 * se <= true <= v + Z90 * se)
        lo, hi = post.interval(n, 0.9)
        out["posterior"][n] = bool(lo <= true <= hi)
    return out


def main(argv=None):
    dcjax.use_compiled_loops()  # here, not at import: the slow test imports one_seed into a running JAX
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="sd1", choices=CASES)
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--store", default=None, help="default experiments/results/coverage[-CASE].jsonl")
    args = ap.parse_args(argv)
    store = Path(args.store or f"experiments/results/coverage{'' if args.case == 'sd1' else '-' + args.case}.jsonl")
    store.parent.mkdir(parents=True, exist_ok=True)
    done = [json.loads(line) for line in store.read_text().splitlines()] if store.exists() else []
    have = {d["seed"] for d in done}
    print(f"{platform.processor() or platform.machine()}, {jax.devices()[0].platform}; {len(have)} of {args.seeds} seeds stored in {store}")
    for seed in range(args.seeds):
        if seed in have:
            continue
        d = one_seed(seed, args.case)
        with store.open("a") as f:
            f.write(json.dumps(d) + "\n")
        done.append(d)
        print(f"seed {seed}: {d['seconds']:.1f} s, largest R-hat {d['rhat']:.4f}", flush=True)
    rows = [d for d in done if d["seed"] < args.seeds]
    print(f"\ncoverage of the truth by the 90 % intervals over {len(rows)} seeds (target 0.90; band 0.80-0.97):")
    print(f"{'param':>6} {'linearised':>11} {'posterior':>10}")
    for n in rows[0]["linearised"] if rows else ():
        lin = np.mean([d["linearised"][n] for d in rows])
        post = np.mean([d["posterior"][n] for d in rows])
        print(f"{n:>6} {lin:11.2f} {post:10.2f}")


if __name__ == "__main__":
    main()
