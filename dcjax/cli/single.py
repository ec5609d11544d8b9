"""`dcjax fit` of one recording, or a joint fit of several: result.json (and fit.png) in --out."""

from ..errors import ConfigError
from ..fitting.fit import fit
from .fit_command import FitCommand
from .fit_lines import print_fit
from .output import announce, remove_earlier, save_fit


def fit_one(command: FitCommand) -> int:
    """Read the recordings, fit them (`dcjax.fit`), write the result, print its report."""

    with command.out as folder:
        recs = [command.loader(d) for d in command.data]
        result = fit(
            recs,
            command.model,
            command.params,
            command.search,
            observation=command.observation,
            integrator=command.integrator,
            progress=command.progress,
        )
        if result.failure:
            raise ConfigError(result.failure)
        if command.uncertainty:
            result = result.uncertainty()
        announce(folder)  # where it writes, once there is something to write
        remove_earlier(folder.replaced)
        save_fit(result, folder.path, plot=command.plots is None)
    print_fit(result, recs, folder.path, command.plots is None)
    return 0
