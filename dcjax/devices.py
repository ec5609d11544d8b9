"""Asking JAX for one CPU device per core, for compiled time loops and for a persistent
compilation cache, explicitly.

`import dcjax` changes no environment variable and no device setting. The CLI and the
experiments call `use_host_devices()` and `use_compiled_loops()` first thing; in a notebook, do
it yourself right after the imports and before any JAX computation:

    import dcjax; dcjax.use_host_devices(); dcjax.use_compiled_loops()

Independent runs are then sharded over the cores (on a 2-core CPU this halves the wall time of
batched runs; a single run is not faster)."""

import contextlib
import os
import re
import warnings
from collections.abc import Iterator
from pathlib import Path

import jax

from .errors import ConfigError


def use_host_devices(n: int | None = None) -> int:
    """Ask for `n` (default: one per core) XLA CPU devices; returns the count JAX then has.

    Leaves a count the user set in `XLA_FLAGS` (`--xla_force_host_platform_device_count`) alone,
    and warns instead of failing when JAX's backends already started (the count is then fixed)."""
    user = re.search(r"xla_force_host_platform_device_count=(\d+)", os.environ.get("XLA_FLAGS", ""))
    if user:  # read, not asked of JAX: asking would start its backends before use_compiled_loops()
        return int(user.group(1))
    n = int(n or os.cpu_count() or 1)
    try:
        jax.config.update("jax_num_cpu_devices", n)
    except RuntimeError:
        have = len(jax.devices("cpu"))
        if have != n:
            warnings.warn(
                f"JAX already started with {have} CPU device(s); call dcjax.use_host_devices() before any JAX computation", stacklevel=2
            )
        return have
    return n


LOOP_OPTION = "xla_cpu_small_while_loop_byte_threshold"
EXTRA_OPTIONS = "xla_backend_extra_options"  # the XLA flag that carries backend options


def _backends_started() -> bool:
    try:
        from jax._src import xla_bridge  # private: whether a backend has started (no public call tells)

        return bool(xla_bridge.backends_are_initialized())
    except (ImportError, AttributeError):  # pragma: no cover - a JAX without the helper
        return False


COMPILED_LOOP_BYTES = 1 << 24  # `use_compiled_loops`' default: a stacked joint fit's time loop


def use_compiled_loops(max_bytes: int = COMPILED_LOOP_BYTES) -> bool:
    """Let XLA's CPU compiler build each while loop whose state is at most `max_bytes` as one
    function, instead of dispatching its body's kernels one at a time (XLA's default limit is 1
    KiB). A `lax.scan`'s state holds the whole arrays it reads, so a stacked joint fit's time
    loop (every recording's samples) needs a high limit where one recording's does not: at 16 MiB
    against 128 KiB one SD1 DE run searches in 0.19 s instead of 0.24 s, an evaluation of 16
    stacked recordings x 70 members takes 1.4 ms instead of 5.1, a generation of CMA-ES on 476
    servo logs 16.1 ms instead of 19.9 (`python -m experiments.bench_loop_bytes`), a folder of
    20 files of 20 lengths (`--each`) searches in 8.4 s instead of 11.0 (`python -m
    experiments.bench_each --lengths 400 1600`); at XLA's 1 KiB one SD1 run took 0.33 s.

    Adds `--xla_backend_extra_options=xla_cpu_small_while_loop_byte_threshold=<max_bytes>` to
    `XLA_FLAGS`, which XLA reads when JAX starts its backends, so call it before any JAX
    computation (the CLI and the experiments do). Leaves `XLA_FLAGS` alone where the user already
    set `xla_backend_extra_options`. Returns whether a threshold is in force."""
    if not isinstance(max_bytes, int) or isinstance(max_bytes, bool) or max_bytes < 1:
        raise ConfigError(f"max_bytes must be a positive integer, got {max_bytes!r}")
    flags = os.environ.get("XLA_FLAGS", "")
    if EXTRA_OPTIONS in flags:
        return LOOP_OPTION in flags
    if _backends_started():
        warnings.warn("JAX already started; call dcjax.use_compiled_loops() before any JAX computation", stacklevel=2)
        return False
    os.environ["XLA_FLAGS"] = f"{flags} --{EXTRA_OPTIONS}={LOOP_OPTION}={max_bytes}".strip()
    return True


def compiled_loop_bytes() -> int:
    """The largest while-loop state (bytes) XLA:CPU builds as one function in this process: what
    `use_compiled_loops` (or the user's `XLA_FLAGS`) set, else XLA's default, 1 KiB. Read from
    `XLA_FLAGS`, which XLA reads once as JAX starts: a change after that is not in force."""
    found = re.search(rf"{LOOP_OPTION}=(\d+)", os.environ.get("XLA_FLAGS", ""))
    return int(found.group(1)) if found else 1024


def cache_dir() -> Path:
    """`$DCJAX_CACHE_DIR`, else `$XDG_CACHE_HOME/dcjax/xla` (default `~/.cache/dcjax/xla`)."""
    if os.environ.get("DCJAX_CACHE_DIR"):
        return Path(os.environ["DCJAX_CACHE_DIR"])
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "dcjax" / "xla"


def use_compilation_cache(path: str | Path | None = None, min_compile_seconds: float = 0.5) -> Path | None:
    """Turn on JAX's persistent compilation cache in `path` (default `cache_dir()`), so a second
    identical fit in a new process loads its executables instead of compiling them. The `dcjax`
    command and the experiments call this; set `DCJAX_NO_CACHE=1` to opt out (returns None).
    Importing dcjax does not: in your own code, call it yourself."""
    if os.environ.get("DCJAX_NO_CACHE", "").strip() not in ("", "0"):
        return None
    where = Path(path) if path is not None else cache_dir()
    where.mkdir(parents=True, exist_ok=True)
    jax.config.update("jax_compilation_cache_dir", str(where))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", float(min_compile_seconds))
    return where


_CACHE_SETTINGS = ("jax_compilation_cache_dir", "jax_persistent_cache_min_compile_time_secs")


def _reopen_cache() -> None:
    """JAX opens its persistent cache once per process, from the folder set at its first
    compilation; forget it, so the next compilation opens the folder set now."""
    from jax._src import compilation_cache  # private: JAX's own tests reset it so; no public call does

    compilation_cache.reset_cache()


@contextlib.contextmanager
def compilation_cache(path: str | Path | None = None, min_compile_seconds: float = 0.5) -> Iterator[Path | None]:
    """`use_compilation_cache` for the `with` block only (the `dcjax` command called in a process:
    a notebook, a test): JAX's cache folder and threshold are as they were before it afterwards,
    and a folder of the caller's own is opened again."""
    before = {name: getattr(jax.config, name) for name in _CACHE_SETTINGS}
    where = use_compilation_cache(path, min_compile_seconds)
    moved = where is not None and before["jax_compilation_cache_dir"] != str(where)
    if moved:
        _reopen_cache()
    try:
        yield where
    finally:
        if where is not None:
            for name, value in before.items():
                jax.config.update(name, value)
            if moved:
                _reopen_cache()
