# amaranth: UnusedElaboratable=no
"""The polygon pipeline (`edgeaa.hdl.pipeline.EdgePipeline`) compiled by Verilator with the
generated harness (`edgeaa.sim.simulators.harness`): pipeline commands in, every pixel out,
with the clock it came in.

A command row is `edgeaa.model.pipeline.Command`'s fields (a grey pipeline's without
``paint``, `command_fields`); a pixel row is `PIXEL_COLUMNS` (a beat of several pixel lanes,
`PipelineConfig.pixel_lanes`, comes as `beat_columns` and is split into a row per pixel,
`pixel_rows`, each with the beat's clock); the
clock each command was taken is kept too (`edgeaa.model.pipeline_timing` predicts both). A run
stops when it has every pixel the flushes ask for and then `pixel_drain_clocks` quiet clocks
have passed (an extra pixel in them is kept, so a duplicate shows), or when neither a command
nor a pixel has moved for `stuck_limit` clocks while work is left (a hang: raised as
`PipelineHang`, never silent). The counters ``errors``, ``edge_errors`` and the stage
counters `STATS` are read at the end.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...hdl.layouts import pixel_value_fields
from ...hdl.pipeline import STATS, EdgePipeline, pipeline_verilog
from ...model.pipeline import CODE, Command, PipelineConfig, command_fields, pipeline_config
from ...model.tile import TileConfig
from . import harness

TOP = "edgeaa_pipeline"
PIXEL_COLUMNS = ("clock", "x", "y", "value", "last")
PipelineHang = harness.HarnessHang  # the name the pipeline's callers catch


@dataclass(frozen=True)
class PipelineRun:
    """What came out of the pipeline: pixel rows (`PIXEL_COLUMNS`), the counters at the end,
    clocks simulated (drain included) and the simulation's wall time (build excluded)."""

    pixels: np.ndarray
    clocks: int
    errors: int
    edge_errors: int
    stats: dict = field(default_factory=dict)
    seconds: float = 0.0
    engine: str = "verilator"
    commands: np.ndarray | None = None  # the clock each command was taken (Verilator)

    @property
    def clocks_per_second(self) -> float:
        return self.clocks / self.seconds if self.seconds else 0.0

    def frames(self, tile: TileConfig) -> list[np.ndarray]:
        """The flushed tiles' values, (height, width) each ((height, width, channels) for a
        colour tile), in order. Raises RuntimeError
        unless the pixels came as the pipeline sends them: whole tiles, row by row, each
        pixel at its place and ``last`` on a tile's final pixel only."""
        x, y, values, last = (self.pixels[:, PIXEL_COLUMNS.index(n)] for n in PIXEL_COLUMNS[1:])
        if len(values) % tile.pixels:
            raise RuntimeError(
                f"{len(values)} pixels are not whole {tile.width} x {tile.height} tiles"
            )
        k = np.arange(len(values)) % tile.pixels
        want_y, want_x = np.divmod(k, tile.width)
        want_last = k == tile.pixels - 1
        wrong = np.flatnonzero((x != want_x) | (y != want_y) | (last != want_last))
        if len(wrong):
            i = wrong[0]
            raise RuntimeError(
                f"pixel {i} is at ({x[i]}, {y[i]}) with last {last[i]}; a tile sent row by row "
                f"has ({want_x[i]}, {want_y[i]}) with last {int(want_last[i])} there"
            )
        values = values.reshape(-1, tile.height, tile.width)
        if tile.channels > 1:  # red in the low bits (`pack_paint`)
            bits = tile.config.intensity_bits
            shifts = np.arange(tile.channels) * bits
            values = (values[..., None] >> shifts) & ((1 << bits) - 1)
        return list(values)


def expected_pixels(tile: TileConfig, commands: list[Command]) -> int:
    """Every flush sends the whole tile (`edgeaa.model.pipeline`)."""
    return tile.pixels * sum(c.op == CODE["flush"] for c in commands)


def beat_columns(lanes: int) -> tuple[str, ...]:
    """The payload fields of a pixel beat of `lanes` pixels, in row order
    (`edgeaa.hdl.layouts.tile_pixel_layout`)."""
    return ("x", "y", *pixel_value_fields(lanes), "last")


def pixel_rows(beats: np.ndarray, lanes: int) -> np.ndarray:
    """Beat rows (the clock, then `beat_columns`) as pixel rows (`PIXEL_COLUMNS`): lane k of a
    beat is the pixel at column ``x + k``, ``last`` the beat's on its last lane only."""
    beats = np.asarray(beats, dtype=np.int64).reshape(-1, lanes + 4)
    if lanes == 1:
        return beats
    clock, x, y, last = beats[:, 0], beats[:, 1], beats[:, 2], beats[:, -1]
    rows = np.zeros((len(beats), lanes, len(PIXEL_COLUMNS)), dtype=np.int64)
    rows[..., 0], rows[..., 2] = clock[:, None], y[:, None]
    rows[..., 1] = x[:, None] + np.arange(lanes)
    rows[..., 3] = beats[:, 3 : 3 + lanes]
    rows[:, -1, 4] = last
    return rows.reshape(-1, len(PIXEL_COLUMNS))


def pixel_drain_clocks(tile: TileConfig) -> int:
    """Quiet clocks after the last expected pixel: a whole tile's more would start by then."""
    return tile.pixels + 256


def stuck_limit(tile: TileConfig, idle: float = 0.0, stall: float = 0.0) -> int:
    """Clocks with no command taken and no pixel out after which a run is a hang: more than
    the longest such wait of a working pipeline, an edge of every column the coordinates
    allow stepped behind a polygon end's scan of the whole tile, stretched by the random
    idle and stall clocks."""
    config = tile.config
    longest = (1 << (config.coord_bits + 1)) + 4 * tile.pixels + 1_000
    return int(4 * longest / ((1 - idle) * (1 - stall)))


def command_format(tile: TileConfig) -> harness.StreamFormat:
    """A command row: the `Command` fields the tile's pipeline takes (`command_fields`)."""
    return harness.StreamFormat("commands", tuple((name,) for name in command_fields(tile)))


def pipeline_top(pipeline: PipelineConfig | TileConfig) -> harness.HarnessTop:
    """The pipeline as the harness drives it: `command_format` in, its pixel beats
    (`beat_columns`) out."""
    return _top(pipeline_config(pipeline))


@functools.cache
def _top(pipeline: PipelineConfig) -> harness.HarnessTop:
    tile = pipeline.tile
    beats = tuple((name,) for name in beat_columns(pipeline.pixel_lanes))
    pixels = harness.StreamFormat("pixels", beats)
    return harness.harness_top(EdgePipeline(pipeline), TOP, command_format(tile), pixels)


def build(pipeline: PipelineConfig | TileConfig, *, optimize: str = harness.OPTIMIZE) -> Path:
    """Compile the pipeline (a `PipelineConfig`, or a `TileConfig`: the compact one) and the
    harness (cached by their text); returns the executable."""
    pipeline = pipeline_config(pipeline)
    verilog = functools.partial(pipeline_verilog, pipeline, name=TOP)
    key = ("pipeline", pipeline, optimize)
    return harness.build(key, pipeline_top(pipeline), verilog, optimize)


def use_executable(
    pipeline: PipelineConfig | TileConfig, exe: Path, *, optimize=harness.OPTIMIZE
) -> None:
    """Run `pipeline`'s pipeline from `exe`, a build the caller already has (`edgeaa verify`'s
    workers are handed the driver's), instead of generating and hashing the Verilog again."""
    harness.use_executable(("pipeline", pipeline_config(pipeline), optimize), exe)


def _command_rows(tile: TileConfig, commands: list[Command]) -> np.ndarray:
    rows = np.array(commands, dtype=np.int64).reshape(-1, len(Command._fields))
    return rows[:, : len(command_fields(tile))]  # `paint` is last: a grey pipeline has none


def run(
    pipeline: PipelineConfig | TileConfig,
    commands: list[Command],
    *,
    seed: int = 0,
    idle: float = 0.0,
    stall: float = 0.0,
    max_quiet: int | None = None,
) -> PipelineRun:
    """Simulate the pipeline (a `PipelineConfig`, or a `TileConfig`: the compact one) on
    `commands`; `idle`/`stall` are probabilities per clock."""
    harness.check_probabilities(idle, stall)
    pipeline = pipeline_config(pipeline)
    tile = pipeline.tile
    done = harness.run_harness(
        build(pipeline),
        pipeline_top(pipeline),
        _command_rows(tile, commands),
        seed=seed,
        idle=idle,
        stall=stall,
        expected=expected_pixels(tile, commands) // pipeline.pixel_lanes,
        drain=pixel_drain_clocks(tile),
        max_quiet=stuck_limit(tile, idle, stall) if max_quiet is None else max_quiet,
    )
    counters = done.counters
    stats = {name: counters[f"stats__{name}"] for name in STATS}
    return PipelineRun(
        pixel_rows(done.rows, pipeline.pixel_lanes), done.clocks, counters["errors"],
        counters["edge_errors"], stats,
        done.seconds, commands=done.taken,
    )  # fmt: skip
