"""What a stopping rule adds to a search program's compile: XLA's seconds and the size of the
module handed to XLA for the same search with `stop=Converged()` (every default search but the
paper's) and with `stop=None` (the paper's).

`run_batch` tests the rule once an iteration and carries the result to the loop's condition, the
next iteration's mask of finished runs and the output (`dcjax.strategies.loop.run_batch`'s
`flags`) and writes an iteration's history entry once (`iterate`); before stop 79 it tested
the rule anew in each of those places (three copies of the test in the program, four with a
progress callback) and wrote the entry twice. `--against FILE`: another version of
`dcjax/strategies/loop.py` (`git show 18b2a39:dcjax/strategies/loop.py > /tmp/loop_old.py`)
compiled alternately in the same process with the rule, its runs checked to the bit.

Cases: SD1 (table4), DE/rand/1/exp and DE/best/1/bin, 2 runs of 20,000 FEs; the same with a
progress callback; `fit_each` over SD1 cut to 310, 320, ..., 500 samples (issue 53's folder of
close lengths, one program). One process (compiled loops, one device, no compilation cache),
the two ways alternating `--rounds` times; each compile starts from cleared caches.

    python -m experiments.bench_stop_compile [--rounds 5] [--against /tmp/loop_old.py]
"""

import argparse
import functools
import importlib.util
import os
import platform
import re
import statistics
import sys

import jax

import dcjax
from dcjax import datasets
from dcjax.strategies import loop

from .bench_fold_initial import measure, time_backend_compiles

dcjax.use_compiled_loops()  # before any JAX computation, as the CLI (no compilation cache)


def cases() -> dict:
    """label -> fit(stop): a fit with the given stopping rule."""
    sd1 = datasets.load("SD1")
    cut = lambda n: sd1.replace(t=sd1.t[:n], channels={c: v[:n] for c, v in sd1.channels.items()}, name=f"f{n}")
    folder = [cut(n) for n in range(310, 501, 10)]
    search = lambda m, stop: dcjax.Search(m, runs=2, budget=20_000, seed=0, stop=stop)
    out = {
        f"SD1 {m}, 2 runs x 20,000": (lambda stop, m=m: dcjax.fit(sd1, params="table4", search=search(m, stop)))
        for m in ("de-rand-1-exp", "de-best-1-bin")
    }
    out["SD1 de-rand-1-exp with progress"] = lambda stop: dcjax.fit(
        sd1, params="table4", search=search("de-rand-1-exp", stop), progress=lambda fraction: None
    )
    out["20 close lengths, fit_each, 2 runs"] = lambda stop: dcjax.fit_each(folder, params="table4", search=search("de-rand-1-exp", stop))
    return out


def other_loop(path: str):
    """`path`'s version of `dcjax.strategies.loop` as a module (its relative imports made absolute)."""
    text = re.sub(r"from \.\.", "from dcjax.", open(path).read())
    text = re.sub(r"from \.(\w)", r"from dcjax.strategies.\1", text)
    spec = importlib.util.spec_from_loader("other_loop", loader=None)
    module = importlib.util.module_from_spec(spec)  # pyright: ignore[reportArgumentType]
    sys.modules["other_loop"] = module
    exec(compile(text, path, "exec"), module.__dict__)
    return module


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--against", help="another version of dcjax/strategies/loop.py, compared with the rule")
    args = ap.parse_args()
    time_backend_compiles()
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, jax {jax.__version__}; XLA seconds of the search program: "
          f"median (min) of {args.rounds} compiles each way, alternating")  # fmt: skip
    rule = dcjax.Converged()
    ways = {"stop=None": (None, loop.run_batch), "Converged()": (rule, loop.run_batch)}
    if args.against:
        ways["Converged(), --against"] = (rule, other_loop(args.against).run_batch)
    print(f"{'case':<38} " + " ".join(f"{w:>24}" for w in ways) + " " + " ".join(f"{w + ' chars':>28}" for w in ways))
    for label, fit in cases().items():
        fit(None)  # the one-time costs of a first compile
        seconds: dict[str, list[float]] = {w: [] for w in ways}
        sizes, bits = {}, {}
        for _ in range(args.rounds):
            for way, (stop, run_batch) in ways.items():
                loop.run_batch = run_batch  # `BatchProgram.run` calls the module's `run_batch`
                s, sizes[way], bits[way] = measure(functools.partial(fit, stop))
                seconds[way].append(s)
        loop.run_batch = ways["stop=None"][1]
        cells = [f"{statistics.median(v):6.3f} ({min(v):5.3f})" for v in seconds.values()]
        line = f"{label:<38} " + " ".join(f"{c:>24}" for c in cells) + " " + " ".join(f"{sizes[w]:>28}" for w in ways)
        if args.against:
            same = bits["Converged()"] == bits["Converged(), --against"]
            ratio = statistics.median(seconds["Converged()"]) / statistics.median(seconds["Converged(), --against"])
            line += f"  this/--against {ratio:.2f}, same bits: {'yes' if same else 'NO'}"
        print(line, flush=True)


if __name__ == "__main__":
    main()
