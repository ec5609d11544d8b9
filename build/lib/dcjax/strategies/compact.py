"""Evaluate only the candidates that need it, so that skipping really saves work.

`fn` evaluates a whole population in one vectorized time scan; a masked lane would cost as much
as a live one. `compacted(fn)(z, active)` moves the active rows to the front and evaluates the
smallest bucket that holds them (N, N/2, N/4, ... rows, chosen by `lax.switch`), giving +inf to
the inactive rows. Under `vmap` a data-dependent switch would turn into a select of every
branch, so a custom batching rule flattens the batch first: the active candidates of *all* runs
of a batch are compacted together and the bucket is chosen once for the batch."""

import jax
import jax.numpy as jnp
from jaxtyping import Array, Bool, Float

MIN_BUCKET = 8


def bucket_sizes(n: int, min_bucket: int = MIN_BUCKET) -> tuple[int, ...]:
    """Descending bucket sizes n, ceil(n/2), ... down to about `min_bucket`, then 0."""
    sizes = [n]
    while sizes[-1] > min_bucket:
        sizes.append(-(-sizes[-1] // 2))
    return tuple(sizes) + (0,)


def _bucketed(fn, z: Float[Array, "N D"], active: Bool[Array, " N"]) -> Float[Array, " N"]:
    n = z.shape[0]
    sizes = bucket_sizes(n)
    count = jnp.sum(active)
    order = jnp.argsort(~active, stable=True)  # active rows first, in their original order
    # Smallest bucket holding `count`: sizes are descending, so the last one >= count.
    branch = jnp.sum(jnp.asarray(sizes) >= count) - 1

    def evaluate_first(size):
        def go(z, order, active):
            if size == 0:
                return jnp.full((n,), jnp.inf, z.dtype)
            rows = order[:size]
            f = fn(z[rows])
            out = jnp.full((n,), jnp.inf, f.dtype).at[rows].set(f)
            return jnp.where(active, out, jnp.inf)

        return go

    return jax.lax.switch(branch, [evaluate_first(s) for s in sizes], z, order, active)


def compacted(fn):
    """`g(z, active)`: `fn(z)` on the rows where `active`, +inf elsewhere, with the work done only
    for (a bucket just larger than) the active rows; batched calls compact across the batch.

    Values `fn` closes over (recording data traced by an outer `jit`) are passed explicitly
    (`jax.closure_convert`); if they are themselves batched (one recording per batch member, as
    in `identify_fleet`), members cannot share a simulation and the batch is evaluated whole."""

    def call(z, active):
        # Convert for one row, then vmap it over however many rows a bucket holds.
        one, consts = jax.closure_convert(fn, z[:1])
        rows = jax.vmap(lambda x, *c: one(x[None], *c)[0], in_axes=(0,) + (None,) * len(consts))
        return _compacted(rows)(z, active, *consts)

    return call


def _compacted(fn):
    @jax.custom_batching.custom_vmap
    def g(z, active, *consts):
        return _bucketed(lambda x: fn(x, *consts), z, active)

    @g.def_vmap
    def _rule(axis_size, in_batched, z, active, *consts):
        z_b, a_b, *c_b = in_batched
        if any(c_b):
            axes = (0 if z_b else None, 0 if a_b else None, *(0 if b else None for b in c_b))
            whole = jax.vmap(lambda z, a, *c: jnp.where(a, fn(z, *c), jnp.inf), in_axes=axes, axis_size=axis_size)
            return whole(z, active, *consts), True
        if not z_b:
            z = jnp.broadcast_to(z, (axis_size,) + z.shape)
        if not a_b:
            active = jnp.broadcast_to(active, (axis_size,) + active.shape)
        b, n = active.shape
        f = g(z.reshape((b * n,) + z.shape[2:]), active.reshape(b * n), *consts)  # nested vmaps flatten again
        return f.reshape(b, n), True

    return g
