"""Where the test suite's time goes: a pytest plugin that records, per test, JAX's compile events
(tracing, lowering, XLA), every program handed to XLA (its name, a hash of its module and the
seconds XLA took) and the seconds of Python's full garbage collections (generation 2, automatic
or asked for), one JSON file per xdist worker; and a summary of those files.

    DCJAX_SUITE_PROFILE=/tmp/prof python -m pytest -q -m "not slow" -p experiments.suite_profile
    python -m experiments.suite_profile /tmp/prof

The summary prints the tests' wall time summed over the workers and the part of it spent
compiling, the compilations against the distinct programs (a program compiled twice is time the
shared persistent cache did not save), the XLA seconds by program name, and the tests that
compile most. Compilations in a test's subprocesses are not seen (only their wall time)."""

import collections
import gc
import glob
import hashlib
import json
import os
import sys
import time

FOLDER = os.environ.get("DCJAX_SUITE_PROFILE")
FULL_GC = "full garbage collections"
NOT_COMPILING = ("wall", FULL_GC)  # a test's entries that are not compile events
_current: list = [None]
_events: dict = collections.defaultdict(collections.Counter)  # test -> compile event -> seconds
_programs: list = []  # (hash, name, seconds, test)


def _install() -> None:
    import jax.monitoring
    from jax._src import compiler  # the one call every XLA compilation goes through (cache misses only)

    def on_duration(event, duration, **kwargs):
        if event.startswith("/jax/core/compile/") and _current[0] is not None:
            _events[_current[0]][event.rsplit("/", 1)[-1]] += duration

    jax.monitoring.register_event_duration_secs_listener(on_duration)
    started: list = [0.0]

    def on_collection(phase, info):
        if info["generation"] != 2:
            return
        if phase == "start":
            started[0] = time.perf_counter()
        elif _current[0] is not None:
            _events[_current[0]][FULL_GC] += time.perf_counter() - started[0]

    gc.callbacks.append(on_collection)
    backend_compile = compiler.backend_compile_and_load

    def timed(backend, module, *args, **kwargs):
        text = module.operation.get_asm(enable_debug_info=False)
        name = str(module.operation.attributes["sym_name"]).strip('"')
        t0 = time.perf_counter()
        out = backend_compile(backend, module, *args, **kwargs)
        _programs.append((hashlib.sha1(text.encode()).hexdigest()[:16], name, time.perf_counter() - t0, _current[0]))
        return out

    compiler.backend_compile_and_load = timed


if FOLDER:
    import pytest

    _install()

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_protocol(item, nextitem):
        _current[0] = item.nodeid
        t0 = time.perf_counter()
        yield
        _events[item.nodeid]["wall"] += time.perf_counter() - t0
        _current[0] = None

    def pytest_unconfigure(config):
        if not _events and not _programs:  # xdist's controller runs no test
            return
        os.makedirs(FOLDER, exist_ok=True)
        worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
        with open(os.path.join(FOLDER, f"{worker}.json"), "w") as f:
            json.dump({"tests": _events, "programs": _programs}, f)


def summary(folder: str) -> None:
    files = sorted(glob.glob(os.path.join(folder, "*.json")))
    if not files:
        raise SystemExit(f"no profile in {folder}: run pytest with DCJAX_SUITE_PROFILE={folder} -p experiments.suite_profile")
    tests: dict = {}
    programs: list = []
    for path in files:
        data = json.load(open(path))
        tests |= data["tests"]
        programs += data["programs"]
    wall = sum(c.get("wall", 0.0) for c in tests.values())
    kinds = collections.Counter()
    for c in tests.values():
        kinds.update({k: v for k, v in c.items() if k not in NOT_COMPILING})
    compiling = sum(kinds.values())
    collecting = sum(c.get(FULL_GC, 0.0) for c in tests.values())
    print(
        f"{len(tests)} tests, {len(files)} workers: wall summed {wall:.1f} s, compiling {compiling:.1f} s ({compiling / max(wall, 1e-9):.0%}),"
        f" {FULL_GC} {collecting:.1f} s"
    )
    for k, v in kinds.most_common():
        print(f"  {k:40s} {v:8.1f} s")
    by_hash = collections.defaultdict(list)
    for h, _name, seconds, _test in programs:
        by_hash[h].append(seconds)
    again = sum(sum(s) - s[0] for s in by_hash.values())
    print(f"{len(programs)} XLA compilations of {len(by_hash)} distinct programs; compiling one again: {again:.1f} s")
    seconds, count = collections.Counter(), collections.Counter()
    for _, name, s, _ in programs:
        seconds[name] += s
        count[name] += 1
    print("XLA seconds by program:")
    for name, s in seconds.most_common(15):
        print(f"  {name:40s} {s:8.1f} s  {count[name]:5d} x {s / count[name]:.2f} s")
    print("tests that compile most (compile / wall, seconds):")
    rows = sorted(((sum(v for k, v in c.items() if k not in NOT_COMPILING), c.get("wall", 0.0), t) for t, c in tests.items()), reverse=True)
    for comp, w, t in rows[:20]:
        print(f"  {comp:6.1f} / {w:6.1f}  {t}")


if __name__ == "__main__":
    summary(sys.argv[1] if len(sys.argv) > 1 else FOLDER or "")
