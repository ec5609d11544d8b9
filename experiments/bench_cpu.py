"""Benchmark (issue 14, CPU): where one DE/rand/1/exp run on SD1 spends its time, with and
without `dcjax.use_compiled_loops()`, each in a fresh process with one XLA CPU device.

    .venv/bin/python -m experiments.bench_cpu
    # an older dcjax: copy this file into its checkout's experiments/ and run it from there

Per process: the population objective (70 members, 501 samples, RK4; best of 7 x 200 calls),
a whole run (140,000 FEs, 1999 generations) with a trivial objective (sum of squares: what is left
is the strategy's own work per generation) and the whole run on SD1 (best of 5 seeds). Then, with
one device per core, `identify` on SD1 (1 run and 50 runs, 3 seeds each) with the population
padding on (`objectives.LANES = 8`) and off (`LANES = 1`), alternating twice, a process each."""

import json
import os
import subprocess
import sys
import time

LOOPS_OFF = "--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=1024"  # XLA's default


def _child() -> dict:
    import dcjax

    if hasattr(dcjax, "use_compiled_loops"):
        dcjax.use_compiled_loops()
    import jax
    import jax.numpy as jnp

    from dcjax import DC, datasets, make_problem, objective
    from dcjax.strategies import make_strategy, run

    prob = make_problem(datasets.load("SD1"))
    box = DC().parameters("table4")
    x = jnp.asarray(box.lower + jax.random.uniform(jax.random.PRNGKey(0), (70, 7)) * (box.upper - box.lower))
    of = jax.jit(lambda x: objective(x, prob)).lower(x).compile()
    jax.block_until_ready(of(x))
    per_call = []
    for _ in range(7):
        t0 = time.perf_counter()
        for _ in range(200):
            out = of(x)
        jax.block_until_ready(out)
        per_call.append((time.perf_counter() - t0) / 200)

    def whole_run(fn) -> tuple[float, int]:
        s = make_strategy("de-rand-1-exp")
        c = jax.jit(lambda k: run(s, k, fn, 140_000, 7)).lower(jax.random.PRNGKey(0)).compile()
        times = []
        for r in range(5):
            t0 = time.perf_counter()
            o = jax.block_until_ready(c(jax.random.PRNGKey(r)))
            times.append(time.perf_counter() - t0)
        return min(times), int(o.iterations)

    trivial_s, gens = whole_run(lambda z: jnp.sum((z - 0.3) ** 2, axis=1))
    sd1_s, _ = whole_run(lambda z: objective(jnp.asarray(box.lower + z * (box.upper - box.lower)), prob))
    return {"objective_us": min(per_call) * 1e6, "bookkeeping_us": trivial_s / gens * 1e6, "run_s": sd1_s, "generations": gens}


def _padding(lanes: int) -> dict:
    """`identify` timings with `objectives.LANES = lanes` (a process of its own: `identify` keeps
    its compiled executables, which would otherwise outlive a change of LANES)."""
    import dcjax

    dcjax.use_host_devices()
    dcjax.use_compiled_loops()
    import dcjax.simulation.objectives as objectives
    from dcjax import datasets, fit

    objectives.LANES = lanes
    rec = datasets.load("SD1")
    one = [fit(rec, params="table4", search=dcjax.Search("de-rand-1-exp", runs=1, seed=s)).timing["run_s"] for s in range(3)]
    fifty = [fit(rec, params="table4", search=dcjax.Search("de-rand-1-exp", runs=50, seed=s)).timing["run_s"] for s in range(3)]
    return {"lanes": lanes, "one": one, "fifty": fifty}


def _spawn(loops: bool, *what: str) -> dict:
    flags = "--xla_force_host_platform_device_count=1" + ("" if loops else f" {LOOPS_OFF}")
    env = dict(os.environ, XLA_FLAGS=flags) if not what else dict(os.environ)
    p = subprocess.run([sys.executable, "-m", "experiments.bench_cpu", *(what or ("--child",))], capture_output=True, text=True, env=env)
    if p.returncode != 0:
        raise RuntimeError(p.stderr)
    return json.loads(p.stdout.strip().splitlines()[-1])


def main():
    if sys.argv[1:] == ["--child"]:
        print(json.dumps(_child()))
        return
    if sys.argv[1:2] == ["--padding"]:
        print(json.dumps(_padding(int(sys.argv[2]))))
        return
    import dcjax

    print(f"dcjax from {os.path.dirname(dcjax.__file__)}; SD1, DE/rand/1/exp, NP 70, 140,000 FEs, 1 XLA CPU device")
    print(f"{'':28s} {'objective / population':>24s} {'strategy / generation':>22s} {'one SD1 run':>12s}")
    rows = [("XLA default loops", False)] + ([("dcjax.use_compiled_loops()", True)] if hasattr(dcjax, "use_compiled_loops") else [])
    for name, loops in rows:
        r = _spawn(loops)
        print(f"{name:28s} {r['objective_us']:21.1f} µs {r['bookkeeping_us']:19.1f} µs {r['run_s']:10.3f} s")
    if hasattr(dcjax, "use_compiled_loops"):
        print(f"\nidentify on SD1, DE/rand/1/exp, {os.cpu_count()} XLA devices, run_s of 3 seeds; population padding on/off:")
        for lanes in (8, 1, 8, 1):  # one process each, alternating
            r = _spawn(True, "--padding", str(lanes))
            fmt = lambda ts, d: " ".join(f"{t:.{d}f}" for t in ts)
            print(f"  LANES = {r['lanes']}:  1 run {fmt(r['one'], 3)} s   50 runs {fmt(r['fifty'], 2)} s")


if __name__ == "__main__":
    main()
