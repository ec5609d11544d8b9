"""XLA compiler options per executable (never `XLA_FLAGS`, never global state), and `filter_jit`,
equinox's `filter_jit` with them.

XLA:CPU's fusion emitters (its newer code generator for fused loops) cost compile time that most
of dcjax's programs do not win back: without them (`LEAN`) a short search compiles in 0.6-0.8 of
the time to the same bits and runs as fast (`python -m experiments.bench_compile_level`), the
sampler's programs in 0.75 (8.1 -> 6.2 s on SD1) and run within 8 %. Not free everywhere: a batch
of recordings (`fit_each`) and a memory-assisted search run 25-27 % slower without them (the
short searches take that for one rule for every run's program), and the polish's last bits
change where the time loops are not compiled (`use_compiled_loops`), so there it keeps them
(`dcjax.fitting.polish`)."""

import functools
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.core import Tracer

LEAN = {"xla_cpu_use_fusion_emitters": False}
QUICK = {"xla_backend_optimization_level": 2}  # a short search: LLVM level 2 (XLA:CPU's default is 3)


def _split(args: tuple) -> tuple:
    """(the array leaves, the structure, the other leaves) of `args`: what `filter_jit` traces,
    and the static part it hashes (lists become structure)."""
    dynamic, static = eqx.partition(args, eqx.is_array)
    leaves, treedef = jax.tree.flatten(static)
    return dynamic, treedef, tuple(leaves)


def filter_jit(fn: Callable | None = None, *, options: dict | None = None) -> Callable:
    """`eqx.filter_jit(fn)` compiled with XLA compiler `options` (default `LEAN`; `{}`: XLA's own): the array
    leaves of the positional arguments are traced, everything else is static (hashed), as
    equinox does."""
    if fn is None:
        return functools.partial(filter_jit, options=options)
    opts = LEAN if options is None else options

    def program(dynamic, treedef, leaves):
        args = eqx.combine(dynamic, jax.tree.unflatten(treedef, leaves))
        return fn(*args)

    program.__name__ = program.__qualname__ = getattr(fn, "__name__", "program")  # the logs and profiles name `fn`
    compiled = jax.jit(program, static_argnums=(1, 2), compiler_options=opts)

    @functools.wraps(fn)
    def call(*args):
        return compiled(*_split(args))

    def ahead(*args):
        """The executable for `args` compiled now (ahead of a timed call): a function of the same arguments."""
        executable = compiled.lower(*_split(args)).compile()
        return lambda *a: executable(_split(a)[0])

    call.lower = lambda *args: compiled.lower(*_split(args))  # pyright: ignore[reportFunctionMemberAccess]
    call.ahead = ahead  # pyright: ignore[reportFunctionMemberAccess]
    call.clear_cache = compiled.clear_cache  # pyright: ignore[reportFunctionMemberAccess]
    return call


def on_device(value, dtype=None) -> jax.Array:
    """A host value (a NumPy array, a list, a number) as a JAX array, copied without compiling:
    `jnp.asarray` of one stages an identity program compiled once per shape and dtype (jax 0.10,
    ~30 ms each here; `dcjax fit data/SD1.csv --bounds auto` compiled 12 of them, 0.33-0.36 s),
    `jax.device_put` of the NumPy array copies it. A JAX array of that dtype is returned as it
    is, a traced value goes through `jnp.asarray` (inside its program)."""
    if isinstance(value, Tracer):
        return jnp.asarray(value, dtype)
    if isinstance(value, jax.Array) and (dtype is None or value.dtype == np.dtype(dtype)):
        return value
    return jax.device_put(np.asarray(value, dtype))


def compiled_when_eager(fn: Callable) -> Callable:
    """`fn` as it is where an argument is traced (inside the caller's `jit`, `vmap` or `grad`: part
    of the caller's program), and compiled (`filter_jit`, `LEAN`: one executable per structure
    of the arguments) where none is: an eager call of a simulation or an objective from a
    notebook, a test or a report is then one program, not its few dozen operations each
    compiled and dispatched on its own (`experiments/bench_eager.py`). Arguments whose static
    part cannot be hashed (a user's object) run as they are."""
    compiled = filter_jit(fn)

    @functools.wraps(fn)
    def call(*args):
        if any(isinstance(leaf, Tracer) for leaf in jax.tree.leaves(args)):
            return fn(*args)
        try:
            hash(_split(args)[1:])
        except TypeError:
            return fn(*args)
        return compiled(*args)

    return call


__all__ = ["LEAN", "QUICK", "compiled_when_eager", "filter_jit"]
