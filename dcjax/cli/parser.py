"""The command line's parser: every subcommand's own (`dcjax.cli.commands`), under `dcjax`."""

from ..version import __version__
from .commands import COMMANDS
from .values import Parser


def build_parser() -> Parser:
    p = Parser(prog="dcjax", description="Motor and drive parameter identification (Jesenik et al. 2020).")
    p.add_argument("--version", action="version", version=f"dcjax {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    for command in COMMANDS.values():
        command.add_parser(sub)
    return p
