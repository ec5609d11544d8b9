"""A search program with its initial population evaluated by the run loop's first pass (a
`pending` state, `dcjax.strategies.loop.folds_initial_evaluation`) against evaluated before the
loop (the strategy's `init`, as every search did before): XLA's seconds for the search program
(traced and lowered alike; `jax.monitoring` cannot tell programs apart, so XLA's compile call is
timed), the size of the module handed to XLA, and whether both give the same runs to the bit.

Cases: SD1 (table4) with each strategy that folds, 2 runs of 20,000 FEs; `fit_each` over SD1 cut
to 310, 320, ..., 500 samples (issue 53's folder of close lengths, one program); the default
search of one recording. One process (compiled loops, one device, no compilation cache), the two
ways alternating `--rounds` times; each compile starts from cleared caches.

    python -m experiments.bench_fold_initial [--rounds 5]
"""

import argparse
import hashlib
import os
import platform
import statistics
import time

import jax
import numpy as np
from jax._src import compiler

import dcjax
from dcjax import datasets
from dcjax.fitting import runs
from dcjax.strategies import ABC, GA, TLBO, DEBest1Bin, DERand1Exp

dcjax.use_compiled_loops()  # before any JAX computation, as the CLI (no compilation cache)
FOLDING = (DERand1Exp, DEBest1Bin, GA, TLBO, ABC)
SEARCH_PROGRAMS = ("device_runs", "one_after_another", "side_by_side")
_compiled: list[tuple[str, float, int]] = []


def time_backend_compiles():
    """XLA's compile call, timed per program (name, seconds, characters of its module)."""
    backend_compile = compiler.backend_compile_and_load

    def timed(backend, module, *args, **kwargs):
        name = str(module.operation.attributes["sym_name"]).strip('"')
        size = len(module.operation.get_asm(enable_debug_info=False))
        t0 = time.perf_counter()
        out = backend_compile(backend, module, *args, **kwargs)
        _compiled.append((name, time.perf_counter() - t0, size))
        return out

    compiler.backend_compile_and_load = timed


def cases() -> dict:
    sd1 = datasets.load("SD1")
    cut = lambda n: sd1.replace(t=sd1.t[:n], channels={c: v[:n] for c, v in sd1.channels.items()}, name=f"f{n}")
    folder = [cut(n) for n in range(310, 501, 10)]
    out = {
        f"SD1 {m}, 2 runs x 20,000": (lambda m=m: dcjax.fit(sd1, params="table4", search=dcjax.Search(m, runs=2, budget=20_000, seed=0)))
        for m in ("de-rand-1-exp", "de-best-1-bin", "ga", "tlbo", "abc")
    }
    out["20 close lengths, fit_each, 2 runs"] = lambda: dcjax.fit_each(
        folder, params="table4", search=dcjax.Search.many(runs=2, budget=20_000)
    )
    out["SD1, the default search"] = lambda: dcjax.fit(sd1, params="table4")
    return out


def measure(fit) -> tuple[float, int, str]:
    runs.EXECUTABLES.clear()
    jax.clear_caches()
    _compiled.clear()
    res = fit()
    found = [(s, z) for name, s, z in _compiled if any(p in name for p in SEARCH_PROGRAMS)]
    results = res if isinstance(res, list) else [res]
    bits = hashlib.sha256(
        b"".join(np.asarray(r.run_params).tobytes() + np.asarray(r.run_of).tobytes() + np.asarray(r.history).tobytes() for r in results)
    )
    return sum(s for s, _ in found), sum(z for _, z in found), bits.hexdigest()[:12]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    time_backend_compiles()
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, jax {jax.__version__}; XLA seconds of the search program: "
          f"median (min) of {args.rounds} compiles each way, alternating")  # fmt: skip
    print(f"{'case':<38} {'before the loop':>16} {'in the loop':>16} {'ratio':>6} {'module chars':>18} {'same bits':>9}")
    for label, fit in cases().items():
        fit()  # the one-time costs of a first compile
        seconds: dict[bool, list[float]] = {True: [], False: []}
        sizes, bits = {}, {}
        for _ in range(args.rounds):
            for fold in (False, True):
                for cls in FOLDING:
                    cls.evaluates_pending = fold  # False: the strategy's `init` evaluates before the loop
                s, sizes[fold], bits[fold] = measure(fit)
                seconds[fold].append(s)
        for cls in FOLDING:
            cls.evaluates_pending = True
        before, inside = statistics.median(seconds[False]), statistics.median(seconds[True])
        print(f"{label:<38} {before:6.3f} ({min(seconds[False]):5.3f}) {inside:6.3f} ({min(seconds[True]):5.3f}) {inside / before:6.2f} "
              f"{sizes[False]:>8} -> {sizes[True]:>7} {'yes' if bits[False] == bits[True] else 'NO':>9}", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
