"""Asking JAX for one CPU device per core, and for a persistent compilation cache, explicitly.

`import dcjax` changes no environment variable and no device setting. The CLI and the
experiments call `use_host_devices()` first thing; in a notebook, do it yourself right after the
imports and before any JAX computation:

    import dcjax; dcjax.use_host_devices()

Independent runs are then sharded over the cores (on a 2-core CPU this halves the wall time of
batched runs; a single run is not faster)."""

import os
import warnings
from pathlib import Path

import jax


def use_host_devices(n: int | None = None) -> int:
    """Ask for `n` (default: one per core) XLA CPU devices; returns the count JAX then has.

    Leaves a count the user set in `XLA_FLAGS` (`--xla_force_host_platform_device_count`) alone,
    and warns instead of failing when JAX's backends already started (the count is then fixed)."""
    if "xla_force_host_platform_device_count" in os.environ.get("XLA_FLAGS", ""):
        return len(jax.devices("cpu"))
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
