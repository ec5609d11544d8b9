"""What a `sample` call costs beyond its chains' steps: dcjax's sampler (the warm-up and the draws
one loop over one NUTS kernel, `dcjax.analysis.nuts_chain`; the chains' start one program) against
the same sampler written as blackjax's documentation shows it and as dcjax ran it before: a
compiled `blackjax.window_adaptation(...).run`, then a compiled scan of `blackjax.nuts(...).step`
with the tuned parameters (two programs, each with its NUTS kernel), the start's few operations
run eagerly. The same posterior for both (SD1 with 1 % noise, `bench_sample`'s; a fit of 2 runs x
40,000 FEs, polished; the Laplace-whitened log density with reflecting walls), 4 chains x
`--draws` after `--warmup`, seed 0. Each in a fresh process (its compilations counted): the first
call's wall, a second call's (the same seed: nothing compiled) and their difference.

    python -m experiments.bench_sample_compile [--draws 1000] [--warmup 1000]
"""

import argparse
import json
import platform
import subprocess
import sys
import time

VARIANTS = ("dcjax", "two programs")


def _warm(keys, starts, likelihood, noise, space, white, prior, steps: int, mesh):
    import blackjax
    from blackjax.adaptation.base import get_filter_adapt_info_fn

    from dcjax.analysis import posterior as P

    def one(key, start):
        adapt = blackjax.window_adaptation(
            blackjax.nuts,
            lambda e: P.log_posterior(e, likelihood, noise, space, white, prior),
            is_mass_matrix_diagonal=False,
            target_acceptance_rate=P.TARGET_ACCEPTANCE,
            integrator=P.reflecting_verlet(*white.walls()),
            adaptation_info_fn=get_filter_adapt_info_fn(),
        )
        return adapt.run(key, start, num_steps=steps)[0]  # pyright: ignore[reportCallIssue]

    return P._over_chains(lambda k, s, *_: one(k, s), mesh, 2, keys, starts)


def _draw(keys, states, params, likelihood, noise, space, white, prior, draws: int, mesh):
    import blackjax
    import jax

    from dcjax.analysis import posterior as P

    def one(key, state, p):
        logdensity = lambda e: P.log_posterior(e, likelihood, noise, space, white, prior)
        kernel = blackjax.nuts(logdensity, **p, integrator=P.reflecting_verlet(*white.walls()))
        return jax.lax.scan(lambda s, k: (kernel.step(k, s)[0],) * 2, state, jax.random.split(key, draws))[1].position

    return P._over_chains(lambda k, s, p, *_: one(k, s, p), mesh, 3, keys, states, params)


def by_hand(res, chains: int, warmup: int, draws: int, seed: int, compiled: dict):
    """The two-program sampler (dcjax's before the one loop; `compiled`: its two programs, kept
    between calls): the draws (chains, draws, F), their R-hat and ESS, as `sample` computes them."""
    import jax
    import jax.numpy as jnp
    import numpy as np

    from dcjax.analysis import posterior as P
    from dcjax.analysis import sample_size
    from dcjax.compiling import filter_jit
    from dcjax.simulation.likelihood import fit_noise, likelihood_target

    if not compiled:
        compiled |= {"warm": filter_jit(_warm), "draw": filter_jit(_draw), "laplace": filter_jit(P._laplace)}
    target, space, loss = res.target(), res.space, res.observation.loss
    x = jnp.asarray([res.best_values[n] for n in res.names], dtype=jnp.float64)
    noise = fit_noise(x, target, loss)
    likelihood, prior = likelihood_target(target, noise), P.prior_term(space, None)
    z0 = jnp.clip(space.to_unit(x), 0.0, 1.0)  # eagerly, as before: each operation its own program
    k_init, k_warm, k_draw = jax.random.split(jax.random.key(seed), 3)
    white = P.Whitening(z0, jnp.linalg.cholesky(compiled["laplace"](z0, target, noise, space, prior)))
    starts = P._inside(white, jax.random.normal(k_init, (chains, z0.shape[0]), dtype=jnp.float64))
    shared = (likelihood, noise, space, white, prior)
    mesh = P.chain_mesh(chains)
    states, params = compiled["warm"](jax.random.split(k_warm, chains), starts, *shared, warmup, mesh)
    pos = compiled["draw"](jax.random.split(k_draw, chains), states, params, *shared, draws, mesh)
    free = np.asarray(P._free_draws(pos, space, white))  # and the diagnostics, as `sample` gives them
    rhat = np.array([sample_size.rhat(free[..., k]) for k in range(free.shape[-1])])
    ess = [(sample_size.ess_bulk(free[..., k]), sample_size.ess_tail(free[..., k])) for k in range(free.shape[-1])]
    return free, rhat, ess


def child(variant: str, draws: int, warmup: int, devices: int) -> dict:
    import logging

    import jax

    import dcjax
    from experiments.bench_sample import noisy_sd1

    if devices > 1:
        dcjax.use_host_devices(devices)
    dcjax.use_compiled_loops()
    rec, _ = noisy_sd1()
    res = dcjax.fit(rec, params="table4", search=dcjax.Search(runs=2, budget=40_000, polish=True))
    compiles = []

    class Count(logging.Handler):
        def emit(self, record):
            if record.getMessage().startswith("Finished XLA compilation"):
                compiles.append(float(record.getMessage().split()[-2]))

    logger = logging.getLogger("jax")
    logger.addHandler(Count())
    walls, compiled = [], {}
    for _ in range(2):
        compiles.clear()
        t0 = time.perf_counter()
        with jax.log_compiles(True):
            if variant == "dcjax":
                res.sample(draws=draws, chains=4, warmup=warmup, seed=0)
            else:
                by_hand(res, 4, warmup, draws, 0, compiled)
        walls.append((time.perf_counter() - t0, len(compiles), sum(compiles)))
    return {"first": walls[0], "again": walls[1]}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--draws", type=int, default=1000)
    parser.add_argument("--warmup", type=int, default=1000)
    parser.add_argument("--variant", choices=VARIANTS)
    parser.add_argument(
        "--devices", type=int, nargs="+", default=[1, 2], help="host devices (the CLI: one a core); the chains split over them"
    )
    a = parser.parse_args()
    if a.variant:
        print(json.dumps(child(a.variant, a.draws, a.warmup, a.devices[0])))
        return
    print(f"{platform.processor() or platform.machine()}, CPU; SD1 with 1 % noise, 4 chains x {a.draws} after {a.warmup}")
    for d in a.devices:
        out = {}
        for v in VARIANTS:
            cmd = [
                sys.executable,
                "-m",
                "experiments.bench_sample_compile",
                "--variant",
                v,
                "--draws",
                str(a.draws),
                "--warmup",
                str(a.warmup),
            ]
            cmd += ["--devices", str(d)]
            out[v] = json.loads(subprocess.run(cmd, capture_output=True, text=True, check=True).stdout.strip().splitlines()[-1])
            (w1, n1, c1), (w2, _, _) = out[v]["first"], out[v]["again"]
            print(
                f"{d} device(s), {v:>12}: first call {w1:.2f} s ({n1} XLA compilations, {c1:.2f} s), again {w2:.2f} s, first - again {w1 - w2:.2f} s"
            )
        (d1, _, _), (d2, _, _) = out["dcjax"]["first"], out["dcjax"]["again"]
        (r1, _, _), (r2, _, _) = out["two programs"]["first"], out["two programs"]["again"]
        print(
            f"{d} device(s), dcjax / two programs: first call {d1 / r1:.2f}, beyond the steps (first - again) {(d1 - d2) / (r1 - r2):.2f}"
        )


if __name__ == "__main__":
    main()
