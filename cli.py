"""The `edgeaa` entry point: a parser built from the registered commands (`edgeaa.command`).

Bad input (a coordinate out of range, a zero-length edge, widths that cannot hold the edge,
an unknown mode) is reported as one line on stderr with exit status 2, never a traceback.
No command module imports this one (only `__main__` and the tests do): the commands live in
their own modules and register themselves.
"""

from __future__ import annotations

import argparse
import sys

from . import edge_cli, verify_cli
from .analysis import cli as analysis_cli
from .command import COMMANDS, EXIT_BAD_INPUT, PROG, OneLineErrorParser, UsageError, usage_error
from .model import ConfigError, EdgeError
from .render import cli as render_cli

# Their commands register as they are imported, above: edge, demo, verilog, synth; verify;
# plot, bench, stress; render. That import order is the order of `edgeaa --help`.
COMMAND_MODULES = (edge_cli, verify_cli, analysis_cli, render_cli)


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineErrorParser(
        prog=PROG,
        description="Fixed-point antialiased edge rasterizer: bit-accurate model, Amaranth "
        "core and cycle-accurate simulation. Coordinates are pixels (x right, y down, pixel "
        "(x, y) centred on integers) and may carry sub-pixel fractions.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineErrorParser)
    sub.required = True
    for command_class in COMMANDS.values():
        command = command_class()
        command_parser = sub.add_parser(
            command.name, help=command.help, description=command.description
        )
        command.add_arguments(command_parser)
        command_parser.set_defaults(run=command.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        return args.run(args)
    except (UsageError, ConfigError, EdgeError) as error:
        message = str(error)
        if not message.startswith(PROG):
            message = str(usage_error(PROG, message))
        print(message, file=sys.stderr)
        return EXIT_BAD_INPUT
