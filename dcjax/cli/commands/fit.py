"""`dcjax fit`: a fit of one recording, a joint fit of several, or `--each` file on its own."""

from ..each import fit_each_command
from ..fit_command import FitCommand, add_arguments
from ..single import fit_one


def add_parser(sub) -> None:
    add_arguments(sub.add_parser("fit", help="identify a model's parameters from recordings"))


def run(args) -> int:
    command = FitCommand.of(args)
    return fit_each_command(command) if command.each else fit_one(command)
