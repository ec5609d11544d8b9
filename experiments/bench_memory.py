"""Does skipping duplicates save time? Evaluation of a population with only a fraction of its
members live: `compacted(fn)(z, active)` (bucketed, `dcjax/strategies/compact.py`) against the
full population `fn(z)` (what a masked lane costs), on MD1 with RK and RK10, for one run (P = 70)
and for a batch of 25 runs (one device's share of 50), where compaction spans the runs.
Also the memory look-up itself: STMA (70 records) and LTMA (10,000 and 30,000 records, full scan).

    .venv/bin/python -m experiments.bench_memory
"""

import time

import jax
import jax.numpy as jnp

import dcjax
from dcjax import DC, INTEGRATORS, load_csv, make_problem, objective
from dcjax.io.datasets import DATA_DIR
from dcjax.strategies.compact import compacted
from dcjax.strategies.memory import MEMORIES

dcjax.use_host_devices()  # one XLA CPU device per core, before any JAX computation
dcjax.use_compiled_loops()
BOX = DC().parameters("table8")


def best_of(f, *args, reps=30):
    jax.block_until_ready(f(*args))
    t = []
    for _ in range(3):
        t0 = time.perf_counter()
        for _ in range(reps):
            out = f(*args)
        jax.block_until_ready(out)
        t.append((time.perf_counter() - t0) / reps)
    return min(t)


def main():
    rec = load_csv(DATA_DIR / "MD1.csv")
    print(f"MD1: {len(rec)} samples; devices: {jax.device_count()} (timings on one)")
    for integ, nd in (("rk4", 1), ("rk4", 10)):
        prob = make_problem(rec, INTEGRATORS[integ](substeps=nd))
        fn = lambda z, prob=prob: objective(BOX.lower + z * (BOX.upper - BOX.lower), prob)
        for batch in (1, 25):
            z = jax.random.uniform(jax.random.PRNGKey(0), (batch, 70, 7))
            full = jax.jit(jax.vmap(fn))
            t_full = best_of(full, z)
            line = f"RK{'' if nd == 1 else str(nd):<3s} runs {batch:2d}: full {1e3 * t_full:7.3f} ms |"
            comp = jax.jit(jax.vmap(compacted(fn)))
            for frac in (1.0, 0.5, 0.2, 0.05, 0.0):
                active = jax.random.uniform(jax.random.PRNGKey(1), (batch, 70)) < frac
                t = best_of(comp, z, active)
                line += f" live {int(100 * frac):3d} %: {100 * t / t_full:5.1f} %"
            print(line, flush=True)
    z = jax.random.uniform(jax.random.PRNGKey(2), (70, 7))
    prec = jnp.full(7, 1e-5)
    for kind, n in (("stma", 70), ("ltma-s1", 10_000), ("ltma-s1", 30_000)):
        recs = jax.random.uniform(jax.random.PRNGKey(3), (n, 7))
        m = MEMORIES[kind].create(prec, recs[:70], jnp.zeros(70), jnp.ones(70, bool), 140_070)
        if kind != "stma":
            m = m.add(recs[70:], jnp.zeros(n - 70), jnp.ones(n - 70, bool))
        t = best_of(jax.jit(lambda m, z: m.lookup(z)[0]), m, z)
        print(f"look-up of 70 new candidates, {kind} with {n} records: {1e3 * t:.3f} ms ({1e9 * t / (70 * n):.2f} ns per comparison)")


if __name__ == "__main__":
    main()
