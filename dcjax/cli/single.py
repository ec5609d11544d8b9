"""`dcjax fit` of one recording, or a joint fit of several: result.json (and fit.png) in --out."""

from ..errors import ConfigError
from ..fitting.fit import fit
from .fit_command import FitCommand
from .fit_lines import print_fit
from .output import announce, remove_earlier, save_fit
from .validation_lines import validation_report


def fit_one(command: FitCommand) -> int:
    """Read the recordings, fit them (`dcjax.fit`), write the result, print its report; with
    `held_out`, validate the fit on those recordings (read first: a bad file fails before the fit)."""

    held = command.held_out
    with command.out as folder:
        recs = [command.loader(d) for d in command.data]
        held_recs = [command.loader(d) for d in held.data] if held else []
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
        lines = validation_report(result, held_recs, held.initial, held.skip, folder.path) if held else []
    print_fit(result, recs, folder.path, command.plots is None)
    if lines:
        print("\nheld-out validation:")
        print("\n".join(lines))
    return 0
