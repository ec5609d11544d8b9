"""Asking JAX for one CPU device per core, explicitly.

`import dcjax` changes no environment variable and no device setting. The CLI and the
experiments call `use_host_devices()` first thing; in a notebook, do it yourself right after the
imports and before any JAX computation:

    import dcjax; dcjax.use_host_devices()

Independent runs are then sharded over the cores (on a 2-core CPU this halves the wall time of
batched runs; a single run is not faster)."""

import os
import warnings

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
