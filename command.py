"""What every `edgeaa` command shares: the registry, one-line errors, configuration.

A command is a subclass of `Command` with a `name`, `help`, `description`, `add_arguments` and
`run`; defining it registers it in `COMMANDS` (in definition order, the order of
`edgeaa --help`), in the style of Glasgow's applets. The entry point, `edgeaa.cli`, imports
the modules that define commands and builds its parser from `COMMANDS`; command modules
import this module, never the entry point.

Bad input is reported as one line on stderr with exit status 2, never a traceback: raise
`usage_error(prog, message)` naming what was wrong and what is allowed.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import tempfile

from .model import ACCUMULATORS, MODES, EdgeConfig
from .model.config import COORD_BITS_RANGE, INTENSITY_BITS_RANGE, SUBPIXEL_BITS_RANGE
from .model.numbers import decimal, shown

PROG = "edgeaa"
EXIT_BAD_INPUT = 2


class UsageError(Exception):
    """Bad command-line input: reported as one line, exit status 2."""


def usage_error(prog: str, message: str) -> UsageError:
    """The one-line error of `prog` (e.g. "edgeaa render") about bad input."""
    return UsageError(f"{prog}: error: {message}")


class OneLineErrorParser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (no usage dump) with exit status 2.

    An option that takes a value may be given once: a second one would silently replace the
    first (`--inside left --inside right`), so it is refused. Flags may repeat (no effect).
    """

    def error(self, message):
        raise usage_error(self.prog, message)

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # The registry is shared with argument groups: their options are checked too.
        self.register("action", None, StoreOnce)
        self.register("action", "store", StoreOnce)


class StoreOnce(argparse.Action):
    """`store`, refusing a second occurrence of the option."""

    def __call__(self, parser, namespace, values, option_string=None):
        seen = namespace.__dict__.setdefault("_given_once", set())
        if self.dest in seen:
            raise argparse.ArgumentError(self, "given twice; give it once")
        seen.add(self.dest)
        setattr(namespace, self.dest, values)


# -- numbers and values in messages ----------------------------------------------------------


def integer_type(lo: int | None = None, hi: int | None = None):
    """An argparse type: an integer (in [lo, hi] when given), read only when it is short."""
    allowed = "an integer" if lo is None else f"an integer in [{lo}, {hi}]"

    def parse(text: str) -> int:
        text = text.strip()
        if not re.fullmatch(r"[+-]?\d{1,18}", text):
            raise argparse.ArgumentTypeError(f"must be {allowed}, not {shown(text)}")
        value = int(text)
        if lo is not None and not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be {allowed}, not {value}")
        return value

    parse.__name__ = "integer"
    return parse


def number_type(lo: float, hi: float):
    """An argparse type: a finite decimal in [lo, hi] (no inf, nan or huge exponents)."""

    def parse(text: str) -> float:
        try:
            value = decimal(text)
        except ValueError:
            value = None
        if value is None or not lo <= value <= hi:
            raise argparse.ArgumentTypeError(
                f"must be a number in [{lo:g}, {hi:g}], not {shown(text)}"
            )
        return float(value)

    parse.__name__ = "number"
    return parse


INTEGER = integer_type()  # the model checks the range and names it


# -- output files ----------------------------------------------------------------------------


def check_output(prog: str, path: str, suffixes: tuple[str, ...], inputs=()) -> None:
    """Refuse, before any work, an output that cannot be written or would replace an input."""
    if os.path.isdir(path):
        raise usage_error(prog, f"-o {shown(path)} is a directory; give a file name")
    if not path.lower().endswith(suffixes):
        allowed = ", ".join(suffixes)
        raise usage_error(prog, f"-o {shown(path)}: unsupported format (allowed: {allowed})")
    directory = os.path.dirname(path) or "."
    if not os.path.isdir(directory):
        raise usage_error(prog, f"-o {shown(path)}: directory {shown(directory)} does not exist")
    if not os.access(directory, os.W_OK | os.X_OK):
        raise usage_error(prog, f"-o {shown(path)}: directory {shown(directory)} is not writable")
    for source in inputs:
        if source is not None and _same_file(path, source):
            raise usage_error(prog, f"-o {shown(path)} is the input file; give another name")


def _same_file(a: str, b: str) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet)
        return os.path.realpath(a) == os.path.realpath(b)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_output(prog: str, path: str):
    """Yield a temporary file name beside `path` (same suffix) to write; on success it is
    renamed to `path` in one step, on any failure removed: `path` is never half-written."""
    directory, name = os.path.split(path)
    suffix = os.path.splitext(name)[1]
    try:
        handle, temporary = tempfile.mkstemp(
            prefix=f".{name}.", suffix=suffix, dir=directory or "."
        )
    except OSError as error:
        raise usage_error(prog, f"cannot write {shown(path)}: {error.strerror}") from None
    os.close(handle)
    os.chmod(temporary, 0o666 & ~_umask())  # mkstemp's 0600 would outlive the rename
    try:
        yield temporary
        os.replace(temporary, path)
    except OSError as error:
        raise usage_error(prog, f"cannot write {shown(path)}: {error.strerror or error}") from None
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.remove(temporary)


# -- the registry ----------------------------------------------------------------------------

COMMANDS: dict[str, type[Command]] = {}


class Command:
    """One `edgeaa` subcommand; defining a subclass registers it under its `name`."""

    name: str
    help: str
    description: str

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        if cls.name in COMMANDS:
            raise ValueError(f"two commands are named {cls.name!r}")
        COMMANDS[cls.name] = cls

    @property
    def prog(self) -> str:
        return f"{PROG} {self.name}"

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """Add the command's options (and `add_config_options` if it takes them)."""

    def run(self, args: argparse.Namespace) -> int:
        """Do the job; return the exit status."""
        raise NotImplementedError


# -- the configuration shared by the model and the hardware ----------------------------------


def add_config_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("configuration (shared by the model and the hardware)")
    group.add_argument(
        "--coord-bits",
        type=INTEGER,
        default=11,
        help=f"integer bits of a vertex coordinate, {COORD_BITS_RANGE[0]}-{COORD_BITS_RANGE[1]}"
        " (default 11: vertices in [0, 2048) px)",
    )
    group.add_argument(
        "--subpixel-bits",
        type=INTEGER,
        default=4,
        help=f"fractional bits of a vertex coordinate, {SUBPIXEL_BITS_RANGE[0]}-"
        f"{SUBPIXEL_BITS_RANGE[1]} (default 4: 1/16 px steps)",
    )
    group.add_argument(
        "--intensity-bits",
        type=INTEGER,
        default=8,
        help=f"bits of an output intensity, {INTENSITY_BITS_RANGE[0]}-{INTENSITY_BITS_RANGE[1]}"
        " (default 8)",
    )
    group.add_argument(
        "--frac-bits",
        type=INTEGER,
        default=None,
        help="fraction bits of the accumulator below one intensity LSB "
        "(default: derived from the error budget, see docs/model.md)",
    )
    group.add_argument(
        "--mode",
        choices=MODES,
        default="paper",
        help="coverage estimate: pw = one pixel per column (error k/8), paper = two-pixel "
        "add-only estimate (k/64, default), seg2 / seg4 = N-segment correction (k/256, k/1024)",
    )
    group.add_argument(
        "--accumulator",
        choices=ACCUMULATORS,
        default="exact",
        help="exact = quotient and remainder, no drift (default); truncated = the paper's "
        "fixed-point slope, which drifts with edge length",
    )


def config_from_args(args: argparse.Namespace) -> EdgeConfig:
    return EdgeConfig(
        coord_bits=args.coord_bits,
        subpixel_bits=args.subpixel_bits,
        intensity_bits=args.intensity_bits,
        frac_bits=args.frac_bits,
        mode=args.mode,
        accumulator=args.accumulator,
    )


def config_arguments(config: EdgeConfig) -> list[str]:
    """The options `add_config_options` reads back as `config` (every one spelled out): the
    inverse of `config_from_args`, for printed reproducers."""
    argv = ["--mode", config.mode, "--accumulator", config.accumulator]
    argv += ["--coord-bits", str(config.coord_bits), "--subpixel-bits", str(config.subpixel_bits)]
    argv += ["--intensity-bits", str(config.intensity_bits)]
    if config.frac_bits is not None:
        argv += ["--frac-bits", str(config.frac_bits)]
    return argv


def tile_from_args(prog: str, text: str, config: EdgeConfig):
    """`--tile WIDTHxHEIGHT` as the pipeline's `TileConfig` (a usage error if it is not)."""
    from .model.tile import TileConfig

    match = re.fullmatch(r"(\d{1,5})x(\d{1,5})", text)
    try:
        if not match:
            raise ValueError("expected WIDTHxHEIGHT, e.g. 64x32")
        return TileConfig(config, int(match[1]), int(match[2]))
    except ValueError as error:
        raise usage_error(prog, f"--tile {shown(text)}: {error}") from None
