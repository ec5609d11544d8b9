"""Running many independent searches in one compiled call: per-run keys, sharding over the
devices JAX sees, and a small cache of dcjax's own compiled executables (shared by `identify`
and the fleet).

Run r's key is `fold_in(PRNGKey(seed), r)` (for every recording of a batch alike), so a run
does not depend on how many others are made or on the device count. The leading axis is padded
to a multiple of the device count and sharded (`NamedSharding`); padding is dropped afterwards."""

import gc
import weakref
from collections import OrderedDict
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jax.experimental import multihost_utils
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from ..compiling import on_device


def fold_keys(seed: int, *shape: int) -> jax.Array:
    """Keys of shape `shape`: key[a, b, ...] = fold_in(...fold_in(PRNGKey(seed), a)..., b)."""

    def make(prefix, dims):
        if not dims:
            return prefix
        return jax.vmap(lambda r: make(jax.random.fold_in(prefix, r), dims[1:]))(jnp.arange(dims[0]))

    return make(jax.random.PRNGKey(seed), list(shape))


def padded_size(n: int, devices) -> int:
    return -(-n // len(devices)) * len(devices)


def mesh_of(devices, axis: str) -> Mesh | None:
    return Mesh(np.array(devices), (axis,)) if len(devices) > 1 else None


def to_host(a: jax.Array) -> np.ndarray:
    """The whole array on this host: gathered from every process after `jax.distributed`."""
    if jax.process_count() > 1 and not a.is_fully_addressable:
        return np.asarray(multihost_utils.process_allgather(a, tiled=True))
    return np.asarray(jax.device_get(a))


def replicate(host, mesh: Mesh | None):
    """`host` whole on every device of the mesh (across processes too)."""
    if mesh is None:
        return on_device(host)
    host = np.asarray(host)
    return jax.make_array_from_callback(host.shape, NamedSharding(mesh, PartitionSpec()), lambda idx: host[idx])


def shard(host: np.ndarray | jax.Array, mesh: Mesh | None, axis: str):
    """Put `host` on the mesh, split along its leading axis (works across processes too: every
    process passes the same host data to `jax.make_array_from_callback`)."""
    if mesh is None:
        return on_device(host)
    host = np.asarray(host)
    sharding = NamedSharding(mesh, PartitionSpec(axis))
    return jax.make_array_from_callback(host.shape, sharding, lambda idx: host[idx])


class ExecutableCache:
    """The last `size` compiled executables, by a key the caller builds (settings and argument
    shapes), so cells of a sweep reuse them. Bounded on purpose: every XLA CPU executable holds
    memory mappings, and a process that kept ~180 hit the kernel's limit (vm.max_map_count).
    Only dcjax's own executables are dropped: the user's compiled functions are untouched."""

    def __init__(self, size: int = 4):
        self.size = size
        self._items: OrderedDict = OrderedDict()

    def get(self, key, build: Callable[[], Callable], args, options: dict | None = None) -> tuple[Callable, bool]:
        """(compiled executable, reused?) for `key`; on a miss `build()` returns a jitted function
        that is lowered and compiled for `args` with XLA's compiler `options` (None: its
        defaults), and its tracing caches are released. `key` must include the options."""
        hit = self._items.get(key)
        reused = hit is not None
        if not reused:
            fn = build()
            hit = fn.lower(*args).compile(compiler_options=options)
            clear = getattr(fn, "clear_cache", None)
            if clear is not None:
                clear()
            del fn
            self._items[key] = hit
            while len(self._items) > self.size:
                _, evicted = self._items.popitem(last=False)
                alive = weakref.ref(evicted)
                del evicted
                # Freed here, with its memory mappings, unless a reference cycle still holds it
                # (an older JAX's tracing and lowering caches did): collect only then, as a full
                # collection costs ~0.5 s in a large process (a test worker: 35 s of a fast run).
                if alive() is not None:
                    gc.collect()
        self._items.move_to_end(key)
        return hit, reused

    def clear(self) -> None:
        self._items.clear()

    def __len__(self) -> int:
        return len(self._items)
