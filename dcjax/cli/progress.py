"""How far a command is and where its time went: `FileBar` (a line, or a bar on a terminal, per
finished file) and `WallSplit` (the wall time split into its phases and compilation)."""

import dataclasses
import sys
import time

import jax.monitoring
from tqdm import tqdm

from ..fitting.result import FailedFit, FitResult

COMPILE_EVENTS = (
    "/jax/core/compile/jaxpr_trace_duration",
    "/jax/core/compile/jaxpr_to_mlir_module_duration",
    "/jax/core/compile/backend_compile_duration",
)


class WallSplit:
    """Where an --each command's wall time goes (its last line). JAX's compilation (tracing,
    lowering, XLA), wherever it happens (the first estimate's scoring, the search, the summary's
    simulations), is counted as `compile` (`jax.monitoring`), the rest of each phase as the phase:
    the time inside a `timed` function goes to its part, the rest between two `add`s to theirs."""

    def __init__(self):
        self.seconds = {"load+checks": 0.0, "estimate": 0.0, "compile": 0.0, "search": 0.0, "write+plots": 0.0}
        self._compiled = 0.0

    def _listen(self, event: str, duration_secs: float, **_: str | int) -> None:
        if event in COMPILE_EVENTS:
            self._compiled += duration_secs

    def __enter__(self):

        jax.monitoring.register_event_duration_secs_listener(self._listen)
        self._t, self._c, self._inside, self._inside_c = time.perf_counter(), 0.0, 0.0, 0.0
        return self

    def __exit__(self, *exc):

        jax.monitoring.unregister_event_duration_listener(self._listen)

    def _book(self, part: str, seconds: float, compiled: float) -> None:
        self.seconds["compile"] += compiled
        self.seconds[part] += max(0.0, seconds - compiled)

    def timed(self, part: str, fn):
        """`fn`, its time (less its compilation) booked to `part` at every call."""

        def call(*a, **kw):
            t, c = time.perf_counter(), self._compiled
            try:
                return fn(*a, **kw)
            finally:
                dt, dc = time.perf_counter() - t, self._compiled - c
                self._book(part, dt, dc)
                self._inside, self._inside_c = self._inside + dt, self._inside_c + dc

        return call

    def add(self, part: str) -> None:
        """The time since the last call (or the start) that no `timed` call booked goes to `part`."""
        t, c = time.perf_counter(), self._compiled
        self._book(part, t - self._t - self._inside, c - self._c - self._inside_c)
        self._t, self._c, self._inside, self._inside_c = t, c, 0.0, 0.0

    def line(self, n: int) -> str:
        return f"{n} files: " + ", ".join(f"{k} {v:.1f} s" for k, v in self.seconds.items())


@dataclasses.dataclass
class FileBar:
    """One report per finished file of `n`: a tqdm bar on a terminal (`tty`; made at the first
    file), else a line on stderr, `[k/n] name: ok, OF ..., S s, L left` (S: the file's share of
    its batch's search and its writing)."""

    n: int
    tty: bool
    bar: tqdm | None = None

    def done(self, k: int, name: str, result: FitResult | FailedFit, seconds: float) -> None:
        if self.tty:
            self.bar = self.bar or tqdm(total=self.n, unit="file", desc="files", leave=False, dynamic_ncols=True)
            self.bar.update(1)
            return
        status = "failed" if isinstance(result, FailedFit) else f"ok, OF {result.of:.4e}"
        print(f"[{k}/{self.n}] {name}: {status}, {seconds:.3g} s, {self.n - k} left", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
