"""What every `edgeaa` command shares: the registry, one-line errors, configuration, progress.

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
import sys
import time

from .model import ACCUMULATORS, MODES, EdgeConfig
from .model.config import COORD_BITS_RANGE, INTENSITY_BITS_RANGE, SUBPIXEL_BITS_RANGE

PROG = "edgeaa"
EXIT_BAD_INPUT = 2


class UsageError(Exception):
    """Bad command-line input: reported as one line, exit status 2."""


def usage_error(prog: str, message: str) -> UsageError:
    """The one-line error of `prog` (e.g. "edgeaa render") about bad input."""
    return UsageError(f"{prog}: error: {message}")


class OneLineErrorParser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (no usage dump) with exit status 2."""

    def error(self, message):
        raise usage_error(self.prog, message)


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
        type=int,
        default=11,
        help=f"integer bits of a vertex coordinate, {COORD_BITS_RANGE[0]}-{COORD_BITS_RANGE[1]}"
        " (default 11: vertices in [0, 2048) px)",
    )
    group.add_argument(
        "--subpixel-bits",
        type=int,
        default=4,
        help=f"fractional bits of a vertex coordinate, {SUBPIXEL_BITS_RANGE[0]}-"
        f"{SUBPIXEL_BITS_RANGE[1]} (default 4: 1/16 px steps)",
    )
    group.add_argument(
        "--intensity-bits",
        type=int,
        default=8,
        help=f"bits of an output intensity, {INTENSITY_BITS_RANGE[0]}-{INTENSITY_BITS_RANGE[1]}"
        " (default 8)",
    )
    group.add_argument(
        "--frac-bits",
        type=int,
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


# -- progress --------------------------------------------------------------------------------

DELAY = 0.5  # seconds before the bar first appears: short jobs print nothing
EVERY = 0.2  # seconds between redraws (a line per redraw when stderr is not a terminal: 2 s)


class ProgressBar:
    """A progress bar on stderr for long jobs (nothing on stdout, nothing for short ones).

    Either called with the counts, `bar(done, total, stage)`, or stepped through a total
    given up front, `bar.step(stage)`.
    """

    def __init__(self, label: str, total: int = 0, enabled: bool = True, stream=None):
        self.label, self.total, self.enabled = label, total, enabled
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.start = time.perf_counter()
        self.last = -1.0
        self.shown = False
        self.stage = ""
        self.done = 0

    def step(self, stage: str = "", n: int = 1) -> None:
        """Count n more of `total` done; the last step ends the bar's line."""
        self.done += n
        self(self.done, self.total, stage)
        if self.done >= self.total:
            self.close()

    def __call__(self, done: int, total: int, stage: str | None = None) -> None:
        if stage is not None:
            self.stage = stage
        if not self.enabled:
            return
        now = time.perf_counter() - self.start
        finished = done >= total
        every = EVERY if self.tty else 10 * EVERY
        if now < DELAY or (not finished and now - self.last < every):
            return
        self.last = now
        self.shown = True
        fraction = done / total if total else 1.0
        width = 30
        bar = "#" * round(width * fraction) + "-" * (width - round(width * fraction))
        text = (
            f"{self.label}: {self.stage:<12} [{bar}] {100 * fraction:5.1f}% "
            f"({done}/{total}, {now:.1f} s)"
        )
        if self.tty:
            self.stream.write("\r" + text)
        else:
            self.stream.write(text + "\n")
        self.stream.flush()

    def close(self) -> None:
        if self.shown and self.tty:
            self.stream.write("\n")
            self.stream.flush()
