"""`dcjax fit --each`: one fit per file, each in its own sub-folder of --out, a summary of all,
and where the command's wall time went."""

import sys
import time

import jax.monitoring
from tqdm import tqdm

from ..fitting.each import fit_each
from ..fitting.result import FailedFit
from ..fitting.search import Search
from ..fitting.summary import summary_rows, write_summary
from .fit_command import FitCommand
from .fit_lines import no_finite_candidate
from .output import announce, file_names, remove_earlier, save_fit

COMPILE_EVENTS = (
    "/jax/core/compile/jaxpr_trace_duration",
    "/jax/core/compile/jaxpr_to_mlir_module_duration",
    "/jax/core/compile/backend_compile_duration",
)


class _Split:
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


def _progress_line(k: int, n: int, name: str, result, seconds: float) -> str:
    """`[k/n] name: ok, OF ..., S s, L left`: S the file's share of its batch's search and its writing."""

    status = "failed" if isinstance(result, FailedFit) else f"ok, OF {result.of:.4e}"
    return f"[{k}/{n}] {name}: {status}, {seconds:.3g} s, {n - k} left"


def fit_each_command(command: FitCommand) -> int:
    """`dcjax fit --each`: one fit per file (`dcjax.fit_each`: the files of one structure in one
    compiled call); a file that fails to load, fails a data check or fails to fit is reported and
    the others are fitted. One line per finished file on stderr (a bar on a terminal); the last
    line splits the wall time. The exit status: 0 all fitted, 1 some, 2 none."""

    with _Split() as split, command.out as folder:
        plots = command.plots or "summary"
        n = len(command.data)
        model = command.model
        params = split.timed("estimate", lambda rec: command.params.resolve(model, [rec]))
        results = fit_each(
            command.data,
            model,
            params,
            Search.for_steps(0, **command.search),
            observation=command.observation,
            integrator=command.integrator,
            load=split.timed("load+checks", command.loader),
        )
        for k, r in enumerate(results):  # a fit with no finite candidate is a failed file, not parameters
            why = None if isinstance(r, FailedFit) else no_finite_candidate(r)
            if why is not None and not isinstance(r, FailedFit):
                results[k] = FailedFit(r.recording.name if r.recording else f"#{k}", why, command.data[k], checks=list(r.checks))
        split.add("search")
        out = announce(folder)
        remove_earlier(folder.replaced)
        bar = _file_bar(n, command.progress)
        folders = iter(file_names([r.recording.name for r in results if not isinstance(r, FailedFit) and r.recording is not None]))
        written: dict[int, str] = {}
        for k, result in enumerate(results, start=1):
            t_file = time.perf_counter()
            if isinstance(result, FailedFit):
                print(f"{result.name}: failed: {result.error}")
            else:
                label = result.recording.name
                written[k - 1] = next(folders)
                where = out / written[k - 1]
                if command.uncertainty:
                    result = results[k - 1] = result.uncertainty()
                save_fit(result, where, plot=plots == "each")
                at = result.at_bound()
                warn = [f.label for f in result.checks]
                print(
                    f"{label}: OF {result.of:.4e}"
                    + (f"; at bound: {', '.join(at)}" if at else "")
                    + (f"; checks: {' '.join(warn)}" if warn else "")
                    + f"; wrote {where}"
                )
            share = 0.0 if isinstance(result, FailedFit) else float(result.timing.get("run_s", 0.0))  # its share of the batch's search
            name = result.name if isinstance(result, FailedFit) else result.recording.name
            bar(_progress_line(k, n, name, result, share + time.perf_counter() - t_file))
        bar(None)
        rows = summary_rows(results, model)
        for k, row in enumerate(rows):
            row["folder"] = written.get(k, "")
        csv_path, png = write_summary(rows, out, model, plot=plots != "none")
        ok = sum(r["status"] == "ok" for r in rows)
        flagged = [r["name"] for r in rows if r.get("outlier")]
        split.add("write+plots")
        print(
            f"{ok}/{len(rows)} fitted; outliers: {', '.join(flagged) or 'none'}; wrote {csv_path}"
            + (f" and {png}" if plots != "none" else "")
        )
        print(split.line(n))
    return 0 if ok == len(rows) else 1 if ok else 2


def _file_bar(n: int, tty: bool):
    """A per-file reporter: a tqdm bar (on a terminal, or with --progress), else one line per file
    on stderr; called with a line per finished file, then None."""
    if not tty:
        return lambda line: None if line is None else print(line, file=sys.stderr, flush=True)
    bar = tqdm(total=n, unit="file", desc="files", leave=False, dynamic_ncols=True)

    def report(line):
        if line is None:
            bar.close()
        else:
            bar.update(1)

    return report
