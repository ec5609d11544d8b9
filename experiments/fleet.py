"""Fleet example (issue 6): identify many simulated motors in one sharded call and report the
throughput. Motors: parameters drawn uniformly within +-40 % of SD1 (inside Table 4), 220 V step
responses of 501 samples (0.05 s, as SD1). DE/rand/1/exp, RK4, NP = 70, one run per motor.

    .venv/bin/python -m experiments.fleet [--motors 1000] [--budget 140000]
"""

import argparse

import numpy as np

import dcjax
from dcjax import DC, Recording, datasets
from dcjax.io.numpy_simulator import simulate_numpy

dcjax.use_host_devices()  # one XLA CPU device per core, before any JAX computation
dcjax.use_compiled_loops()
dcjax.use_compilation_cache()  # executables persist across runs (DCJAX_NO_CACHE=1: off)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--motors", type=int, default=1000)
    ap.add_argument("--budget", type=int, default=140_000)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    truth = np.array([datasets.true_params("SD1")[p] for p in DC.names])
    x = truth * np.random.default_rng(args.seed).uniform(0.6, 1.4, (args.motors, 7))
    t = np.arange(501) * 1e-4
    u = np.full_like(t, 220.0)
    traj = simulate_numpy(x, t, u)
    recs = [Recording(t=t, u_a=u, i_a=traj[k, :, 0], omega=traj[k, :, 1]) for k in range(args.motors)]
    results = dcjax.fit_each(recs, params="table4", search=dcjax.Search(runs=1, budget=args.budget, seed=args.seed))
    params = np.array([[r.best_values[n] for n in DC.names] for r in results])  # type: ignore[union-attr]
    of = np.array([r.of for r in results])  # type: ignore[union-attr]
    timing = results[0].timing  # type: ignore[union-attr]
    rel = np.max(np.abs(params - x) / x, axis=1)
    print(f"{args.motors} motors, {args.budget} FEs each, {timing['devices']} devices")
    print(f"compile {timing['compile_s']:.1f} s, run {timing['batch_run_s']:.1f} s: {args.motors / timing['batch_run_s']:.2f} motors/s")
    print(f"OF <= 1e-15: {int(np.sum(of <= 1e-15))}/{args.motors}; all parameters within 1e-6: {int(np.sum(rel <= 1e-6))}/{args.motors}")
    print(f"worst OF {of.max():.2e}, worst max relative parameter error {rel.max():.2e}")


if __name__ == "__main__":
    main()
