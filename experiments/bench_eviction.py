"""What an executable evicted from dcjax's `ExecutableCache` costs: a sweep of distinct fits (the
paper's five methods in turn, SD1, one run of 140 FEs each; the cache holds `--size`) with
Python's automatic garbage collection off, so that only the eviction frees anything. Prints the
process's memory mappings after each fit (they stay flat where evicted executables are freed),
how many evicted executables were still referenced (each would cost a full collection), and
what one full collection (`gc.collect()`, what every eviction paid before) costs in this process
afterwards. Linux only (`/proc/self/maps`).

    python -m experiments.bench_eviction [--fits 10] [--size 1]
"""

import argparse
import gc
import platform
import time
import weakref


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fits", type=int, default=10)
    parser.add_argument("--size", type=int, default=1, help="executables the cache holds")
    args = parser.parse_args(argv)

    import dcjax

    dcjax.use_host_devices()
    dcjax.use_compiled_loops()
    from dcjax import datasets, fit
    from dcjax.fitting import runs
    from dcjax.strategies import make_strategy

    cache = runs.EXECUTABLES
    cache.clear()
    cache.size = args.size
    evicted = []
    popitem = cache._items.popitem

    def watched_popitem(last=True):
        item = popitem(last)
        evicted.append(weakref.ref(item[1]))
        return item

    cache._items.popitem = watched_popitem  # pyright: ignore[reportAttributeAccessIssue]
    sd1 = datasets.load("SD1")
    methods = ["de-rand-1-exp", "tlbo", "abc", "ga", "de-best-1-bin"]
    maps = []
    gc.disable()
    try:
        for k in range(args.fits):
            search = dcjax.Search(make_strategy(methods[k % 5], pop_size=70 - k // 5), runs=1, budget=140, seed=k)
            fit(sd1, search=search)
            with open("/proc/self/maps") as f:
                maps.append(sum(1 for _ in f))
    finally:
        gc.enable()
    alive = sum(ref() is not None for ref in evicted)
    t0 = time.perf_counter()
    gc.collect()
    collect_s = time.perf_counter() - t0
    print(f"{platform.processor() or platform.machine()}, {args.fits} distinct fits, cache of {args.size}")
    print(f"memory mappings after each fit: {maps}")
    print(f"evicted: {len(evicted)}, still referenced after eviction: {alive}")
    print(f"one full collection in this process: {collect_s:.3f} s (paid on every eviction before)")


if __name__ == "__main__":
    main()
