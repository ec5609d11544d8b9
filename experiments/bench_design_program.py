"""The design optimizer's program (`dcjax.analysis.design._adam`) against the same optimizer with
the criterion evaluated once more after its loop (the levels of the last step, as it was before
stop 82): the lines of the lowered program, its tracing and lowering, XLA's compilation, and
whether both give the same levels, for the PMSM design of the tests (2 starts x 5 steps, 101
samples, two designed inputs). Both compiled as `design_input` compiles a design this small
(`LEAN`, no small-while-loop hoisting), alternating, in one process, cache off.

    .venv/bin/python -m experiments.bench_design_program [--rounds 3]
"""

import argparse
import os
import platform
import time

import jax
import jax.numpy as jnp
import numpy as np

import dcjax
from dcjax.analysis import design
from dcjax.compiling import LEAN, filter_jit

os.environ["DCJAX_NO_CACHE"] = "1"
dcjax.use_compiled_loops()  # as the CLI
PMSM = dict(Rs=0.5, Ld=1.0e-3, Lq=1.5e-3, psi_m=0.05, J=1e-4, B=2e-3)
OPTIONS = LEAN | {"xla_disable_hlo_passes": "small-while-loop-hoisting"}  # `design._optimize_unhoisted`'s


def adam_then_criterion(loss, z0, steps: int, rate: float):
    """The reference: `steps` Adam steps, then the criterion at the last levels (a second copy of it)."""
    import optax

    opt = optax.adam(rate)

    def run(z):
        def body(carry, _):
            z, state, best_z, best_f = carry
            (_, f), g = jax.value_and_grad(loss, has_aux=True)(z)
            g = jnp.where(jnp.isfinite(g), g, 0.0)
            better = jnp.isfinite(f) & (f < best_f)
            best_z, best_f = jnp.where(better, z, best_z), jnp.where(better, f, best_f)
            upd, state = opt.update(g, state, z)
            z = jnp.clip(jnp.asarray(optax.apply_updates(z, upd)), 0.0, 1.0)
            return (z, state, best_z, best_f), None

        (z, _, best_z, best_f), _ = jax.lax.scan(body, (z, opt.init(z), z, jnp.asarray(jnp.inf, z.dtype)), None, length=steps)
        f = loss(z)[1]
        better = jnp.isfinite(f) & (f < best_f)
        return jnp.where(better, z, best_z), jnp.where(better, f, best_f)

    return jax.vmap(run)(z0)


def the_tests_design() -> dict:
    """The criterion and starts `design_input` hands its optimizer for the tests' PMSM design."""
    seen: dict = {}
    optimize = design._optimize_unhoisted

    def capture(loss, z0, steps, rate):
        seen.update(loss=loss, z0=z0, steps=steps, rate=rate)
        return optimize(loss, z0, steps, rate)

    design._optimize_unhoisted = capture
    try:
        design.design_input(
            "pmsm", PMSM, duration=0.01, dt=1e-4, u_range={"ud": (-2.0, 2.0), "uq": (-6.0, 6.0)}, given={"pp": 4.0, "Tl": 0.02}, starts=2, steps=5
        )  # fmt: skip
    finally:
        design._optimize_unhoisted = optimize
    return seen


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=3)
    rounds = ap.parse_args().rounds
    case = the_tests_design()
    args = (case["loss"], case["z0"], case["steps"], case["rate"])
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, jax {jax.__version__}; seconds")
    levels = {}
    for r in range(rounds):
        for name, fn in (("criterion after the loop", adam_then_criterion), ("this package (one copy)", design._adam)):
            program = filter_jit(fn, options=OPTIONS)
            t0 = time.perf_counter()
            lowered = program.lower(*args)
            t1 = time.perf_counter()
            lowered.compile()
            t2 = time.perf_counter()
            levels[name] = np.asarray(program(*args)[0])
            lines = lowered.as_text().count("\n")
            print(f"round {r}  {name:26s} trace+lower {t1 - t0:5.2f}  XLA {t2 - t1:5.2f}  total {t2 - t0:5.2f}  program lines {lines}")
    a, b = levels.values()
    print("same levels:", bool(np.array_equal(a, b)))


if __name__ == "__main__":
    main()
