"""`dcjax fit --each`: one fit per file, each in its own sub-folder of --out, a summary of all,
and where the command's wall time went."""

import time
from pathlib import Path

from ..analysis.report import loose_parameters
from ..fitting.each import fit_each
from ..fitting.result import FailedFit, FitResult
from ..fitting.summary import summary_rows, write_summary
from .fit_command import FitCommand
from .fit_lines import uncertainty_command
from .flags import as_flags
from .output import announce, file_names, remove_earlier, save_fit
from .progress import FileBar, WallSplit


def fit_each_command(command: FitCommand) -> int:
    """`dcjax fit --each`: one fit per file (`dcjax.fit_each`: the files of one structure in one
    compiled call); a file that fails to load, fails a data check or fails to fit is reported and
    the others are fitted. One line per finished file on stderr (a bar on a terminal); the last
    line splits the wall time. The exit status: 0 all fitted, 1 some, 2 none."""

    with WallSplit() as split, command.out as folder:
        plots = command.plots or "summary"
        n = len(command.data)
        model = command.model
        params = split.timed("estimate", lambda rec: command.params.resolve(model, [rec]))
        results = fit_each(
            command.data,
            model,
            params,
            command.search,
            observation=command.observation,
            integrator=command.integrator,
            load=split.timed("load+checks", command.loader),
        )
        split.add("search")
        seconds: list[float] = [0.0] * n
        at_bound: list[list[str]] = [[] for _ in range(n)]
        for k, r in enumerate(results):  # a fit with no finite candidate is a failed file, not parameters
            t = time.perf_counter()
            if isinstance(r, FitResult) and r.failure:
                results[k] = FailedFit(r.recording.name if r.recording else f"#{k}", r.failure, command.data[k], checks=list(r.checks))
            elif isinstance(r, FitResult):
                at_bound[k] = r.at_bound()
                results[k] = r.uncertainty() if command.uncertainty else r
            seconds[k] = time.perf_counter() - t + (r.timing.get("run_s", 0.0) if isinstance(r, FitResult) else 0.0)
        fitted = [r for r in results if isinstance(r, FitResult)]
        out = announce(folder)
        remove_earlier(folder.replaced)
        folders = dict(zip(map(id, fitted), file_names([r.recording.name if r.recording else "" for r in fitted])))
        bar = FileBar(n, command.progress)
        for k, result in enumerate(results):
            t = time.perf_counter()
            if isinstance(result, FitResult):
                where = out / folders[id(result)]
                save_fit(result, where, plot=plots == "each")
                name = result.recording.name if result.recording else f"#{k}"
                print(file_line(name, result, at_bound[k], where, spread=not command.uncertainty))
            else:
                print(f"{result.name}: failed: {as_flags(result.error)}")
                name = result.name
            bar.done(k + 1, name, result, seconds[k] + time.perf_counter() - t)
        bar.close()
        rows = summary_rows(results)
        for row, result in zip(rows, results):
            row["folder"] = folders.get(id(result), "")
        csv_path, png = write_summary(rows, out, model, plot=plots != "none")
        ok = sum(r["status"] == "ok" for r in rows)
        flagged = flagged_names(rows)
        split.add("write+plots")
        print(
            f"{ok}/{len(rows)} fitted; outliers: {', '.join(flagged) or 'none'}; wrote {csv_path}"
            + (f" and {png}" if plots != "none" else "")
        )
        print(split.line(n))
    return 0 if ok == len(rows) else 1 if ok else 2


def file_line(name: str, result: FitResult, at_bound: list[str], where: Path, spread: bool = True) -> str:
    """A fitted file's line: its OF, the parameters at a bound of their range, the data checks'
    findings, with `spread` the parameters its equally good runs spread in (`loose_parameters`, as
    `dcjax fit` notes them) and the command that names what the data do determine, and where it
    was written."""
    warn = [f.label for f in result.checks]
    loose = loose_parameters(result)[1] if spread else {}
    return (
        f"{name}: OF {result.of:.4e}"
        + (f"; at bound: {', '.join(at_bound)}" if at_bound else "")
        + (f"; checks: {' '.join(warn)}" if warn else "")
        + (f"; runs as good spread in: {', '.join(loose)} (`{uncertainty_command(result, where)}`)" if loose else "")
        + f"; wrote {where}"
    )


def flagged_names(rows: list[dict]) -> list[str]:
    """The summary rows marked as outliers, by name, or, where recordings share a name (their
    sidecars', say), by their output folder (the file where none), as summary.csv tells them apart."""
    names = [r["name"] for r in rows]
    unique = len(set(names)) == len(names)
    return [r["name"] if unique else r.get("folder") or r["file"] for r in rows if r.get("outlier")]
