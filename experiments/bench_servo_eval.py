"""One evaluation of the 476 servo logs of `bench_servo_fleet` against the machine's float64 peak
(issue: speed at scale, item 1): the population objective of CMA-ES's 12 members on one device,
with the built-in `Servo` (its sine `dcjax.models.trig.sin`, arithmetic only) and with the same
map calling `jnp.sin` (XLA:CPU: a call of the C library's `sin` per element), each compiled with
XLA's defaults and with `QUICK | LEAN` (a short search's), in ns a member's sample step; the peak from a measured FMA loop (one device, 32 independent FMAs an element and
iteration over 4,096 elements in cache) and the flops of one step (the arithmetic equations of
the map's jaxpr plus the loss's; the sine as one, and as the arithmetic of `dcjax.models.sin`).

With `--fit`, the same two sines in the search (CMA-ES, one run of 1,200 FEs, as the CLI starts:
2 host devices) and the ordered sum of a joint fit's OFs written out against its loop
(`dcjax.simulation.joint.UNROLLED_SUM`; DE, 2 runs of 3,000 FEs), alternated twice in this process.

    python -m experiments.bench_servo_eval [--logs 476] [--repeat 20] [--fit]
"""

import argparse
import itertools
import os
import platform
import time

import jax
import jax.numpy as jnp
import numpy as np

import dcjax
import dcjax.models.servo as servo_module
from dcjax.compiling import filter_jit
from dcjax.fitting.planning import plan
from dcjax.fitting.runs import QUICK_COMPILE
from dcjax.simulation.joint import stacked_target

from .bench_servo_fleet import BOX, DT, SAMPLES, dcjax_case, logs

ARITHMETIC = {"add", "sub", "mul", "div", "neg", "abs", "sign", "min", "max", "round", "floor", "select_n", "eq", "sin", "integer_pow"}


def median_seconds(fn, x, repeat: int) -> float:
    jax.block_until_ready(fn(x))
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        jax.block_until_ready(fn(x))
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def fma_peak(repeat: int) -> float:
    """FP64 flop/s of one device on 32 chained FMAs an element (4,096 elements, 2,000 iterations)."""

    def body(_, a):
        for _ in range(32):
            a = a * 0.999999 + 1e-7
        return a

    f = jax.jit(lambda a: jax.lax.fori_loop(0, 2000, body, a))
    return 2 * 32 * 4096 * 2000 / median_seconds(f, jnp.ones(4096), repeat)


def step_flops(model) -> int:
    """Arithmetic equations of one step of `model`'s map on scalars (its sine as `jnp.sin`: one)."""
    c = dict.fromkeys(model.names, 1.0)
    jaxpr = jax.make_jaxpr(lambda y, u: model.update(c, u, y, DT))((0.1, 0.0), (0.2, 32.0, 15.0, 0.5, 0.1, 0.05))

    def count(jx) -> int:
        n = 0
        for eqn in jx.eqns:
            n += eqn.primitive.name in ARITHMETIC
            for v in eqn.params.values():
                n += count(getattr(v, "jaxpr", v)) if hasattr(v, "eqns") or hasattr(v, "jaxpr") else 0
        return n

    return count(jaxpr.jaxpr) + 3  # the l1 misfit: a subtraction, a scale and an accumulation


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", type=int, default=476)
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--fit", action="store_true", help="also the sines and the ordered sum inside fits (2 host devices)")
    args = ap.parse_args()
    if args.fit:
        dcjax.use_host_devices()
    dcjax.use_compiled_loops()
    recs, box, obs = dcjax_case(*logs(args.logs))
    lo, hi = np.array([v[0] for v in BOX.values()]), np.array([v[1] for v in BOX.values()])
    x = jnp.asarray(lo + (hi - lo) * np.random.default_rng(0).uniform(0.2, 0.8, (12, len(BOX))))
    peak = fma_peak(args.repeat)
    ours = servo_module.sin
    executed = step_flops(dcjax.Servo())  # with the sine's own arithmetic, as the step executes it
    servo_module.sin = jnp.sin
    flops = step_flops(dcjax.Servo())
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, one XLA device; {args.logs} logs x {SAMPLES} samples, "
          f"12 members: {args.logs * SAMPLES * 12:,} member-steps an evaluation")  # fmt: skip
    print(f"FP64 peak (FMA loop, one device): {peak / 1e9:.1f} GFLOP/s; a step of the map and loss: {flops} flops = "
          f"{1e9 * flops / peak:.2f} ns at the peak; {executed} with dcjax's sine's own arithmetic = {1e9 * executed / peak:.2f} ns")  # fmt: skip
    try:
        for (label, sine), (level, options) in itertools.product(
            (("dcjax.models.trig.sin", ours), ("jnp.sin (libm)", jnp.sin)), (("XLA's defaults", {}), ("QUICK | LEAN", QUICK_COMPILE))
        ):
            servo_module.sin = sine
            setup = plan("servo", "cma-es", observation=obs).setup(recs, box)
            target = jax.tree.map(jnp.asarray, stacked_target(setup.target))
            f = filter_jit(lambda tg, x: tg.objective(x), options=options)
            s = median_seconds(lambda x, f=f, tg=target: f(tg, x), x, args.repeat)
            ns = 1e9 * s / (12 * args.logs * SAMPLES)
            print(f"{label:<22} {level:<15} {1e3 * s:7.2f} ms an evaluation of 12 members, {ns:5.2f} ns a member-step = "
                  f"{ns / (1e9 * flops / peak):4.1f}x the peak's" + (f" ({ns / (1e9 * executed / peak):.1f}x counting the sine's arithmetic)"
                                                                    if sine is ours else ""), flush=True)  # fmt: skip
    finally:
        servo_module.sin = ours
    if args.fit:
        in_fits(recs, box, obs)


def in_fits(recs, box, obs) -> None:
    """The sines in a CMA-ES fit and the ordered sum written out or looped in a DE fit, alternated."""
    import dcjax.simulation.joint as joint

    ours, unrolled = servo_module.sin, joint.UNROLLED_SUM
    try:
        for k in range(4):
            servo_module.sin = (ours, jnp.sin)[k % 2]
            res = dcjax.fit(
                recs, "servo", box, search=dcjax.Search("cma-es", runs=1, budget=1200 + k), observation=obs
            )  # a new budget each: compiled again, not reused
            print(f"fit, {('dcjax.models.trig.sin', 'jnp.sin (libm)')[k % 2]:<22}: CMA-ES 1 run x 1,200 FEs, compile "
                  f"{res.timing['compile_s']:.2f} s, search {res.timing['run_s']:.2f} s, OF {res.of:.7g}", flush=True)  # fmt: skip
        servo_module.sin = ours
        for k in range(4):
            joint.UNROLLED_SUM = (unrolled, 1 << 30)[k % 2]
            res = dcjax.fit(recs, "servo", box, search=dcjax.Search("de-rand-1-exp", runs=2, budget=3000 + k), observation=obs)
            print(f"fit, the ordered sum {('in a loop', 'written out')[k % 2]:<12}: DE 2 runs x 3,000 FEs, compile "
                  f"{res.timing['compile_s']:.2f} s, search {res.timing['run_s']:.2f} s, OFs {', '.join(f'{v:.7g}' for v in res.run_of)}",
                  flush=True)  # fmt: skip
    finally:
        servo_module.sin, joint.UNROLLED_SUM = ours, unrolled


if __name__ == "__main__":
    main()
