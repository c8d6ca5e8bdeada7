"""The polygon pipeline's command format (version 2) and its model: commands in, the tile ops
of `edgeaa.model.tile` out (`command_ops`), whose frames are the pipeline's pixels.

One command per transfer of the top's ``commands`` stream (`edgeaa.hdl.pipeline`), the
fields ``op, x0, y0, x1, y1, i_in, i_out, flag``:

* ``tile`` (0): ``x0, y0`` the tile's origin in whole engine pixels (at most 2**W), ``i_in``
  the background. The tile's pixels become the background; later edges get its clip window.
* ``begin`` (1): ``i_in`` the polygon's intensity, ``i_out``, ``flag`` 1 for even-odd.
* ``edge`` (2): ``x0, y0, x1, y1`` in sub-pixel units, ``flag`` the inside (0 left, 1 right):
  one boundary edge of the polygon (`edgeaa.model.Edge`, clip `tile_clip`).
* ``end`` (3): resolve the polygon into the tile's pixels.
* ``flush`` (4): send the tile's pixels (row by row); the tile is the background again.

A pipeline of 3 or 4 channels (`TileConfig.channels`) has one more field, ``paint``: red,
green, blue and alpha (`PAINT`), ``intensity_bits`` each, red in the low bits
(`pack_paint`), whatever the channels. A begin's paint is the polygon's colour, straight
(not premultiplied), and its alpha: its coverage, in steps of ``|i_in - i_out|``, times
alpha / full scale (rounded half up) composites each channel towards it. A tile's paint is
its background, premultiplied, its first ``channels`` values (a 3-channel tile's alpha
unused; ``i_in`` unused). Grey pipelines have no paint field and ignore it.

Versions (`COMMAND_VERSION`, in the peripheral's ``info`` register): 1 had a paint of the
tile's channels, opaque (the alpha, if any, was the alpha channel's target); 2 (issue 27)
a paint of red, green, blue and alpha in every colour pipeline. Grey commands are the same
in both.

Codes 5 to 7 are unknown. Bad commands are dropped and counted in ``errors``, never hang the
pipeline and never touch another polygon's pixels: an unknown code; an edge or an end outside
a polygon; a tile whose origin is past 2**W. A begin, tile or flush inside a polygon (a
polygon with no end) ends it first (counted). Edges the core refuses (zero length, I_in ==
I_out) are the core's bad commands, counted in its own ``errors`` (``edge_errors``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

from .beat import DELTAS, DELTAS_FAST, BeatFormat, delta_column_beats
from .config import EdgeConfig
from .edge import Clip, Edge, EdgeError
from .step import run_edge_deltas
from .tile import (
    PAINT,
    PRODUCT_STAGES,
    Beats,
    Flush,
    PolygonEnd,
    TileConfig,
    TileStart,
    unpack_paint,
)
from .timing import MAX_SETUP_UNITS

__all__ = [
    "COMMANDS",
    "COMMAND_VERSION",
    "PIPELINES",
    "PIXEL_LANES",
    "SCAN_LANES",
    "Command",
    "PipelineConfig",
    "Decoded",
    "command_fields",
    "command_ops",
    "decode_commands",
    "pipeline_config",
    "tile_clip",
]

COMMAND_VERSION = 2
COMMANDS = ("tile", "begin", "edge", "end", "flush")  # codes 0 .. 4
OP_BITS = 3
CODE = {name: code for code, name in enumerate(COMMANDS)}


@dataclass(frozen=True)
class PipelineConfig:
    """What a polygon pipeline is built with: its tile (`TileConfig`, with the stepper's
    `EdgeConfig`); the setup units feeding its deltas stepper (`edgeaa.hdl.dispatch.
    SetupArray` when more than one); the pixel lanes, the pixels the resolve's flush sends
    a clock, side by side in one beat of its ``pixels`` stream (lane k the column ``x + k``;
    its pixel memories banked by column modulo the lanes); the scan lanes, the accumulated
    cells its accumulator's scan reads and its resolve composites a clock, side by side in
    one beat of the ``cells`` stream (lane k the column ``x + k``; the accumulation memory
    banked by column modulo the lanes; more than one needs at least as many pixel lanes,
    whose memories the resolve then reads and writes a lane a cell, the group of lanes the
    beat's column picks); the clocks the resolve's
    composite products take (`product_stages`, `edgeaa.model.tile.resolve_latency`: two
    halve each clock's carry chains there, for Fmax); its core (`fast_core`, the output
    `deltas`); and whether a skid buffer sits between the core and the accumulator
    (`beat_skid`, `edgeaa.hdl.skid.SkidBuffer`: the core's ready is then a register, for
    Fmax). The commands, the frames and the images do not depend on any of these but the
    tile; only the clocks (`edgeaa.model.pipeline_timing`) and the area do."""

    tile: TileConfig = field(default_factory=TileConfig)
    setup_units: int = 1
    pixel_lanes: int = 1
    scan_lanes: int = 1
    fast_core: bool = False  # the core's output: DELTAS, or DELTAS_FAST (`deltas`)
    product_stages: int = 2  # compact's and fast's (`PIPELINES`)
    beat_skid: bool = False

    def __post_init__(self):
        if not isinstance(self.tile, TileConfig):
            raise TypeError(f"tile must be a TileConfig, not {self.tile!r}")
        _check_count("setup_units", self.setup_units, range(1, MAX_SETUP_UNITS + 1))
        lanes = _check_count("pixel_lanes", self.pixel_lanes, PIXEL_LANES)  # a row: whole beats
        scan = _check_count("scan_lanes", self.scan_lanes, SCAN_LANES)
        if scan > lanes:  # the resolve reads and writes a pixel lane per cell
            raise ValueError(f"scan_lanes {scan} needs at least {scan} pixel_lanes, not {lanes}")
        _check_count("product_stages", self.product_stages, PRODUCT_STAGES)
        for name in ("fast_core", "beat_skid"):
            if not isinstance(getattr(self, name), bool):
                raise TypeError(f"{name} must be True or False, not {getattr(self, name)!r}")

    @property
    def deltas(self) -> BeatFormat:
        """The core's output (`edgeaa.model.beat`): `DELTAS_FAST` with `fast_core` (the
        deltas stepper copying the bank, and a setup whose FINAL multiplies and whose lanes
        take two steps a clock), else `DELTAS`."""
        return DELTAS_FAST if self.fast_core else DELTAS

    @classmethod
    def named(cls, name: str, tile: TileConfig | None = None) -> PipelineConfig:
        """The named configuration `name` (a key of `PIPELINES`) with `tile` (the default
        tile if None)."""
        if name not in PIPELINES:
            raise ValueError(f"no pipeline named {name!r}: {', '.join(PIPELINES)}")
        return cls(TileConfig() if tile is None else tile, **PIPELINES[name])


def _check_count(name: str, value, allowed) -> int:
    """`value` if it is an integer in `allowed` (a range or a tuple); TypeError or ValueError
    saying which otherwise."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"{name} must be an integer, not {value!r}")
    if value not in allowed:
        ranged = isinstance(allowed, range)
        shown = f"in [{allowed.start}, {allowed.stop - 1}]" if ranged else f"one of {allowed}"
        raise ValueError(f"{name} must be {shown}, not {value}")
    return value


PIXEL_LANES = (1, 2, 4)  # a tile is at least 4 pixels wide: a row is whole beats
SCAN_LANES = (1, 2, 4)  # cells a clock through the accumulator's scan and the resolve

# The named configurations, built from the same components (docs/hardware.md, "Display
# rate"): their setup units, pixel lanes and scan lanes. compact: the smallest, fits an iCE40
# HX8K; fast: for the ECP5, four units (of 2, 3, 4 and 6 measured on the HUD and on text, the
# knee of clocks over area), a flush of four pixels a clock, a scan of two cells a clock and
# the fast core (`DELTAS_FAST`: its copied bank and its setup's second lane steps do not fit
# compact's HX8K, which has no multipliers for its FINAL), and a skid buffer before the
# accumulator (its ready chain was fast's critical path). Both take the resolve's products
# over two clocks (a clock of latency a polygon; the product's rows were on the critical
# path of each).
PIPELINES = {
    "compact": {
        "setup_units": 1,
        "pixel_lanes": 1,
        "scan_lanes": 1,
        "fast_core": False,
        "product_stages": 2,
        "beat_skid": False,
    },
    "fast": {
        "setup_units": 4,
        "pixel_lanes": 4,
        "scan_lanes": 2,
        "fast_core": True,
        "product_stages": 2,
        "beat_skid": True,
    },
}


def pipeline_config(pipeline) -> PipelineConfig:
    """`pipeline` as a `PipelineConfig` (a `TileConfig` alone is the compact pipeline)."""
    if isinstance(pipeline, PipelineConfig):
        return pipeline
    if isinstance(pipeline, TileConfig):
        return PipelineConfig(pipeline)
    raise TypeError(f"expected a PipelineConfig or TileConfig, not {pipeline!r}")


class Command(NamedTuple):
    op: int  # a code of COMMANDS (others are unknown)
    x0: int = 0
    y0: int = 0
    x1: int = 0
    y1: int = 0
    i_in: int = 0
    i_out: int = 0
    flag: int = 0
    paint: int = 0  # colour only: the polygon's colour and alpha, or the tile's background

    @classmethod
    def tile(cls, x0: int, y0: int, background: int, paint: int = 0) -> Command:
        return cls(CODE["tile"], x0, y0, i_in=background, paint=paint)

    @classmethod
    def begin(cls, intensity: int, i_out: int, rule: str = "nonzero", paint: int = 0) -> Command:
        flag = int(rule == "evenodd")
        return cls(CODE["begin"], i_in=intensity, i_out=i_out, flag=flag, paint=paint)

    @classmethod
    def edge(cls, x0: int, y0: int, x1: int, y1: int, inside: str = "left") -> Command:
        return cls(CODE["edge"], x0, y0, x1, y1, flag=int(inside == "right"))

    @classmethod
    def end(cls) -> Command:
        return cls(CODE["end"])

    @classmethod
    def flush(cls) -> Command:
        return cls(CODE["flush"])

    @property
    def name(self) -> str:
        return COMMANDS[self.op] if 0 <= self.op < len(COMMANDS) else "unknown"


def command_fields(tile: TileConfig) -> tuple[str, ...]:
    """The fields of `Command` a pipeline of `tile` takes (a grey one has no paint)."""
    return Command._fields if tile.channels > 1 else Command._fields[:-1]


def tile_clip(config: EdgeConfig, tile: TileConfig, x0: int, y0: int) -> Clip:
    """The clip window of a tile's edges: its rows, and its columns without the left bound
    (columns left of the tile carry their cover into it)."""
    top = 1 << config.coord_bits
    return Clip(0, y0, min(x0 + tile.width - 1, top), min(y0 + tile.height - 1, top))


class CommandResult(NamedTuple):
    ops: list  # tile ops (`edgeaa.model.tile`)
    errors: int  # bad commands the top dropped
    edge_errors: int  # edges the core dropped


class Decoded(NamedTuple):
    """What the top makes of one command (`decode_commands`)."""

    command: Command
    ended: PolygonEnd | None  # a polygon with no end, ended before this command (an error)
    op: object  # the tile op the command makes (None: none)
    edge: Edge | None  # an edge of a polygon (with its clip): the core takes it
    error: str | None  # "top": dropped by the top; "edge": dropped by the core


def decode_commands(tile: TileConfig, commands):
    """`Decoded` of each command, in order (`command_ops`; the cycle model's input)."""
    config = tile.config
    polygon = None  # the open polygon's end, or None outside one
    clip = tile_clip(config, tile, 0, 0)
    colour, bits = tile.channels > 1, config.intensity_bits
    for command in commands:
        paint = unpack_paint(command.paint, bits, len(PAINT)) if colour else None
        name, ended = command.name, None
        if polygon is not None and name in ("begin", "tile", "flush"):
            ended, polygon = polygon, None  # a polygon with no end: ended here
        op = edge = error = None
        if name == "tile" and max(command.x0, command.y0) <= 1 << config.coord_bits:
            op = TileStart(
                command.x0, command.y0, paint[: tile.channels] if colour else command.i_in
            )
            clip = tile_clip(config, tile, command.x0, command.y0)
        elif name == "begin":
            rule = "evenodd" if command.flag else "nonzero"
            polygon = PolygonEnd(command.i_in, command.i_out, rule, paint)
        elif name == "edge" and polygon is not None:
            inside = "right" if command.flag else "left"
            c = command
            edge = Edge(c.x0, c.y0, c.x1, c.y1, inside, polygon.intensity, polygon.i_out, clip)
            try:
                op = Beats.of(delta_column_beats(run_edge_deltas(config, edge)))
            except EdgeError:
                error = "edge"
        elif name == "end" and polygon is not None:
            op, polygon = polygon, None
        elif name == "flush":
            op = Flush()
        else:
            error = "top"
        yield Decoded(command, ended, op, edge, error)


def command_ops(tile: TileConfig, commands) -> CommandResult:
    """What the top makes of `commands`: the tile ops, in order, and the errors."""
    ops: list = []
    errors = edge_errors = 0
    for d in decode_commands(tile, commands):
        if d.ended is not None:
            ops.append(d.ended)
            errors += 1
        if d.op is not None:
            ops.append(d.op)
        errors += d.error == "top"
        edge_errors += d.error == "edge"
    return CommandResult(ops, errors, edge_errors)
