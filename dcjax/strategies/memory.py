"""Memory assistance (paper Section 4.4, Figs. 23–24, Table 29): a candidate within `precision`
of a stored record (every parameter closer than its precision) is a duplicate; it takes the
record's parameters and OF and is not simulated.

A memory is chosen with a small object that creates its own records (`create`) for a run:

- `STMA()` ("stma"): the records are the previous iteration's population (refreshed after every step).
- `LTMA(order="oldest" | "newest")` ("ltma-s1" / "ltma-s2"): the records are the whole search
  history; every evaluated non-duplicate is appended. The history is searched in chunks, oldest
  first (S1) or newest first (S2), and the search stops as soon as every candidate is resolved.
- `IndexedLTMA()` ("ltma-hash"): the history indexed by precision-grid cells (`HashRecords`).

The records answer `lookup(z)`, `add(z, f, new)` and `refresh(pop, fit)`.

A duplicate takes the record's *parameters* as well as its OF, so every (x, OF) pair a run holds
was really evaluated. When a candidate matches several records, S1 returns the oldest and S2 the
newest (the order of Fig. 24), so whole-run paths of S1 and S2 can differ, as the paper's Tables
30–33 (different duplication counts for S1 and S2) show.

Shapes are static: the LTMA history holds `capacity` records, by default the FE budget plus one
population. Only evaluated non-duplicates are stored and a run never evaluates more than its
budget, so the history cannot overflow; were it full, further records would be dropped (not
stored) and the search would go on over the records kept.

Candidates of one batch are compared with the memory as it was before the batch (a vectorized
evaluation must); the paper's one-by-one loop would also catch a near-copy of a candidate of the
same batch that was just added. For STMA the two are identical (the memory changes only between
iterations)."""

import abc
from collections.abc import Mapping
from types import MappingProxyType
from typing import ClassVar, Literal

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Bool, Float, Int

from ..errors import ConfigError


class MemoryAssistance(eqx.Module):
    """Memory assistance (paper Section 4.4): a candidate within the parameters' precisions of a
    record is not simulated. `kind` is the name result files and the CLI spell it."""

    kind: ClassVar[str] = ""

    @abc.abstractmethod
    def create(self, precision, pop, fit, evaluated, capacity: int) -> "Records | HashRecords":
        """The records of a run that starts with population `pop` (unit cube), its OFs `fit`,
        `evaluated` marking the members really simulated; `precision` in unit-cube units."""


class STMA(MemoryAssistance):
    """Short-term memory: the previous iteration's population."""

    kind: ClassVar[str] = "stma"

    def create(self, precision, pop, fit, evaluated, capacity: int) -> "Records":
        precision = jnp.asarray(precision, pop.dtype)
        zero = jnp.asarray(0)
        return Records(pop, fit, jnp.asarray(pop.shape[0]), precision, zero, pop.shape[0], newest_first=False, population=True)


class LTMA(MemoryAssistance):
    """Long-term memory: the whole history, searched oldest first (S1) or newest first (S2)."""

    order: Literal["oldest", "newest"] = eqx.field(static=True, default="newest")
    chunk: int = eqx.field(static=True, default=1024)

    def __check_init__(self):
        if self.order not in ("oldest", "newest"):
            raise ConfigError(f"LTMA order must be 'oldest' or 'newest', got {self.order!r}")

    @property
    def kind(self) -> str:  # pyright: ignore[reportIncompatibleVariableOverride]
        return "ltma-s1" if self.order == "oldest" else "ltma-s2"

    def create(self, precision, pop, fit, evaluated, capacity: int) -> "Records":
        precision = jnp.asarray(precision, pop.dtype)
        zero = jnp.asarray(0)
        capacity = max(int(capacity), pop.shape[0])
        chunk = min(self.chunk, capacity)
        d = pop.shape[1]
        empty = Records(
            jnp.zeros((capacity, d), pop.dtype),
            jnp.zeros(capacity, fit.dtype),
            zero,
            precision,
            zero,
            chunk,
            newest_first=self.order == "newest",
            population=False,
        )
        return empty.add(pop, fit, evaluated)


class IndexedLTMA(MemoryAssistance):
    """Long-term memory indexed by precision-grid cells (an open-addressing table, `HashRecords`)."""

    kind: ClassVar[str] = "ltma-hash"

    def create(self, precision, pop, fit, evaluated, capacity: int) -> "HashRecords":
        return HashRecords.create(precision, pop, fit, evaluated, capacity)


# The memories by the names the CLI, result files and the experiments' store spell them.
MEMORIES: Mapping[str, MemoryAssistance] = MappingProxyType(
    {m.kind: m for m in (STMA(), LTMA(order="oldest"), LTMA(order="newest"), IndexedLTMA())}
)


def get_memory(memory: "str | MemoryAssistance | None") -> MemoryAssistance | None:
    """A memory object from itself, None or its name (`MEMORIES`)."""
    if memory is None or isinstance(memory, MemoryAssistance):
        return memory
    if isinstance(memory, str) and memory.lower() in MEMORIES:
        return MEMORIES[memory.lower()]
    raise ConfigError(
        f"memory must be None, dcjax.STMA(), dcjax.LTMA(order=...), dcjax.IndexedLTMA() or one of {sorted(MEMORIES)}, got {memory!r}"
    )


class Records(eqx.Module):
    """Records `x` (unit cube) and `f`, the first `n` filled; `precision` in unit-cube units.
    `population`: STMA's records (the population, refreshed after each iteration, nothing
    appended); else an LTMA history searched in chunks, `newest_first` for S2."""

    x: Float[Array, "C D"]
    f: Float[Array, " C"]
    n: Int[Array, ""]
    precision: Float[Array, " D"]
    chunks: Int[Array, ""]  # memory chunks compared so far (search work)
    chunk: int = eqx.field(static=True)
    newest_first: bool = eqx.field(static=True, default=False)
    population: bool = eqx.field(static=True, default=False)

    def lookup(self, z: Float[Array, "P D"]) -> tuple[Bool[Array, " P"], Float[Array, "P D"], Float[Array, " P"], "Records"]:
        """(found, record x, record OF, memory with its work counter advanced) for each candidate:
        found where |z - x_r| < precision in every parameter for some filled record r; the first
        record in search order (oldest first for STMA and S1, newest first for S2)."""
        p, _ = z.shape
        cap, ch = self.x.shape[0], self.chunk
        newest_first = self.newest_first
        n_chunks = -(-self.n // ch)

        def cond(carry):
            k, found, _ = carry
            return (k < n_chunks) & ~jnp.all(found)

        def body(carry):
            k, found, idx = carry
            if newest_first:
                end = self.n - k * ch
                begin = end - ch
            else:
                begin = k * ch
                end = jnp.minimum(begin + ch, self.n)
            start = jnp.clip(begin, 0, cap - ch)
            pos = start + jnp.arange(ch)
            block = jax.lax.dynamic_slice_in_dim(self.x, start, ch)
            close = jnp.all(jnp.abs(z[:, None, :] - block[None, :, :]) < self.precision, axis=-1)
            match = close & ((pos >= begin) & (pos < end))[None, :] & ~found[:, None]
            hit = jnp.any(match, axis=1)
            j = ch - 1 - jnp.argmax(match[:, ::-1], axis=1) if newest_first else jnp.argmax(match, axis=1)
            return k + 1, found | hit, jnp.where(hit, pos[j], idx)

        init = (jnp.asarray(0), jnp.zeros(p, bool), jnp.zeros(p, self.n.dtype))
        k, found, idx = jax.lax.while_loop(cond, body, init)
        return found, self.x[idx], self.f[idx], eqx.tree_at(lambda m: m.chunks, self, self.chunks + k)

    def add(self, z: Float[Array, "P D"], f: Float[Array, " P"], new: Bool[Array, " P"]) -> "Records":
        """LTMA: append the rows of `z`, `f` where `new`, in order (rows past capacity are dropped).
        STMA: unchanged (see `refresh`)."""
        if self.population:
            return self
        pos = jnp.where(new, self.n + jnp.cumsum(new) - 1, self.x.shape[0])
        x = self.x.at[pos].set(z, mode="drop")
        fr = self.f.at[pos].set(f, mode="drop")
        n = jnp.minimum(self.n + jnp.sum(new), self.x.shape[0])
        return eqx.tree_at(lambda m: (m.x, m.f, m.n), self, (x, fr, n))

    def refresh(self, pop: Float[Array, "P D"], fit: Float[Array, " P"]) -> "Records":
        """STMA after each iteration: the memory becomes the current population."""
        if not self.population:
            return self
        return eqx.tree_at(lambda m: (m.x, m.f), self, (pop, fit))


# Odd 64-bit multipliers for the hash of a quantized vector (one per coordinate, cycled).
_HASH_MULTIPLIERS = np.array(
    [
        0x9E3779B97F4A7C15,
        0xC2B2AE3D27D4EB4F,
        0x165667B19E3779F9,
        0xD6E8FEB86659FD93,
        0xFF51AFD7ED558CCD,
        0xC4CEB9FE1A85EC53,
        0x94D049BB133111EB,
        0xBF58476D1CE4E5B9,
    ],
    dtype=np.uint64,
)


class HashRecords(eqx.Module):
    """LTMA with an index (`IndexedLTMA`, `"ltma-hash"`): every parameter is quantized at its precision,
    q = floor(z / precision), and a candidate is a duplicate when a stored record has the same q
    (the same cell of the precision grid) — an O(1) look-up in an open-addressing hash table
    instead of the paper's linear search over the history (Fig. 24). Each cell holds at most one
    record (a later candidate in it is a duplicate, so it is never stored), so the search order
    that distinguishes S1 from S2 has nothing to choose between.

    The cell test differs from the paper's |z - x| < precision box: a candidate just across a cell
    border from a record is not a duplicate, and one up to one precision away inside a cell is.
    Records that find no free slot within `PROBES` probes are dropped (the table is at least
    twice the capacity, so this is rare); zero precision in any parameter finds no duplicates."""

    keys: Int[Array, "T D"]
    xf: Float[Array, "T D+1"]  # record x and, in the last column, its OF (one table: one scatter)
    used: Bool[Array, " T"]
    n: Int[Array, ""]
    precision: Float[Array, " D"]
    chunks: Int[Array, ""]  # look-ups made (search work)

    PROBES = 8

    @staticmethod
    def create(precision, pop, fit, evaluated, capacity: int) -> "HashRecords":
        size = 1 << int(np.ceil(np.log2(max(2 * int(capacity), 16))))
        d = pop.shape[1]
        precision = jnp.asarray(precision, pop.dtype)
        empty = HashRecords(
            jnp.zeros((size, d), jnp.int64),
            jnp.zeros((size, d + 1), pop.dtype),
            jnp.zeros(size, bool),
            jnp.asarray(0),
            precision,
            jnp.asarray(0),
        )
        return empty.add(pop, fit, evaluated)

    def _quantize(self, z):
        p = jnp.where(jnp.isfinite(self.precision) & (self.precision > 0), self.precision, 1.0)
        q = jnp.floor(z / p).astype(jnp.int64)
        return jnp.where(jnp.isfinite(self.precision), q, 0)  # a fixed parameter: one cell

    def _slots(self, q):
        mult = jnp.asarray(np.resize(_HASH_MULTIPLIERS, q.shape[-1]))
        h = jnp.sum(q.astype(jnp.uint64) * mult, axis=-1)
        h = h ^ (h >> 29)
        size = self.used.shape[0]
        return ((h[..., None] + jnp.arange(self.PROBES, dtype=jnp.uint64)) & jnp.uint64(size - 1)).astype(jnp.int64)

    def lookup(self, z):
        """(found, record x, record OF, memory) for each candidate (see `Records.lookup`)."""
        q = self._quantize(z)
        slots = self._slots(q)  # (P, probes)
        hit = self.used[slots] & jnp.all(self.keys[slots] == q[:, None, :], axis=-1)
        hit = hit & jnp.all(self.precision > 0)
        found = jnp.any(hit, axis=1)
        slot = jnp.take_along_axis(slots, jnp.argmax(hit, axis=1)[:, None], axis=1)[:, 0]
        rec = self.xf[slot]
        return found, rec[:, :-1], rec[:, -1], eqx.tree_at(lambda m: m.chunks, self, self.chunks + 1)

    def add(self, z, f, new):
        """Store the rows of `z`, `f` where `new`, each in the first free slot of its probes (one
        vectorized scatter per batch). A row whose cell is already stored, or whose slot an earlier
        row of the same batch also takes, is not stored (two new candidates of one cell in a batch
        keep the first; a rare collision of different cells drops the later one)."""
        q = self._quantize(z)
        slots = self._slots(q)  # (P, probes)
        present = jnp.any(self.used[slots] & jnp.all(self.keys[slots] == q[:, None, :], axis=-1), axis=1)
        free = ~self.used[slots]
        k = jnp.take_along_axis(slots, jnp.argmax(free, axis=1)[:, None], axis=1)[:, 0]
        ok = new & ~present & jnp.any(free, axis=1)
        rows = jnp.arange(z.shape[0])
        earlier = (k[None, :] == k[:, None]) & ok[None, :] & (rows[None, :] < rows[:, None])
        ok = ok & ~jnp.any(earlier, axis=1)
        size = self.used.shape[0]
        k = jnp.where(ok, k, size)  # out of range: dropped by the scatter
        return eqx.tree_at(
            lambda m: (m.keys, m.xf, m.used, m.n),
            self,
            (
                self.keys.at[k].set(q, mode="drop"),
                self.xf.at[k].set(jnp.concatenate([z, f[:, None]], axis=1), mode="drop"),
                self.used.at[k].set(True, mode="drop"),
                self.n + jnp.sum(ok),
            ),
        )

    def refresh(self, pop, fit):
        return self
