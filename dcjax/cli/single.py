"""`dcjax fit` of one recording, or a joint fit of several: result.json (and fit.png) in --out."""

from ..errors import ConfigError
from ..fitting.fit import fit
from ..fitting.search import Search
from ..io.recording import Recording
from .fit_command import FitCommand
from .fit_lines import no_finite_candidate, print_fit
from .output import announce, remove_earlier, save_fit


def search_for(command: FitCommand, recs: list[Recording]) -> Search:
    """The search of a fit of `recs`: the flags' changes to the default for its size
    (`Search.for_steps`: a joint fit of many recordings searches shorter)."""
    steps = sum(len(r.t) for r in recs) * command.substeps if len(recs) > 1 else 0
    return Search.for_steps(steps, **command.search)


def fit_one(command: FitCommand) -> int:
    """Read the recordings, fit them (`dcjax.fit`), write the result, print its report."""

    with command.out as folder:
        recs = [command.loader(d) for d in command.data]
        result = fit(
            recs,
            command.model,
            command.params,
            search_for(command, recs),
            observation=command.observation,
            integrator=command.integrator,
            progress=command.progress,
        )
        failed = no_finite_candidate(result)
        if failed:
            raise ConfigError(failed)
        if command.uncertainty:
            result = result.uncertainty()
        announce(folder)  # where it writes, once there is something to write
        remove_earlier(folder.replaced)
        save_fit(result, folder.path, plot=command.plots is None)
    print_fit(result, recs, folder.path, command.plots is None)
    return 0
