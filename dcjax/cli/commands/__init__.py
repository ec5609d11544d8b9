"""One module per subcommand, each with `add_parser(subparsers)` and `run(args) -> exit status`."""

from . import design, fit, report, sample, simulate, track, validate

COMMANDS = {m.__name__.rsplit(".", 1)[-1]: m for m in (fit, simulate, validate, report, design, sample, track)}
