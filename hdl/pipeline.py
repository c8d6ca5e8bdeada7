# amaranth: UnusedElaboratable=no
"""The polygon pipeline (`EdgePipeline`): polygon commands in (`edgeaa.model.pipeline`,
version 2), a tile's pixels out. A tile of 3 or 4 channels (`TileConfig.channels`) takes
each begin's paint (red, green, blue and alpha) and each tile's background from the
command's ``paint`` field and sends a value per channel. Setup and stepper (`PolygonCore`),
accumulation memory (`TileAccumulator`) and resolve (`TileResolve`), joined by streams.

The command stage passes each edge of a polygon to the core with the polygon's intensities
and the tile's clip window (`edgeaa.model.pipeline.tile_clip`). An end waits until the core is
idle (every beat of the polygon is in the accumulator), then goes to the accumulator; the
next polygon's edges enter the core while the accumulator scans, and their beats wait for it.
Tile and flush ops go to the accumulator too (the core is idle outside a polygon), so the
accumulator's input is the core's beats or the command stage's op, never both at once.

Counters (``stats``, 32 bits each, wrapping): per stage, clocks busy and clocks stalled
(output valid, not taken): ``core_*`` (not idle; beats waiting), ``acc_*`` (taking an op or
a beat's cell, or scanning; cells waiting), ``resolve_*`` (taking a cell or flushing; pixels
waiting).
"""

from __future__ import annotations

from amaranth.hdl import Cat, Module, Mux, ResetSignal, Signal, unsigned
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from ..model.pipeline import CODE, OP_BITS, PipelineConfig, command_fields, pipeline_config
from ..model.tile import OPS, PAINT, TileConfig
from .accumulator import TileAccumulator
from .core import ERRORS_BITS, PolygonCore, flat_verilog
from .layouts import tile_pixel_layout
from .resolve import TileResolve
from .skid import SkidBuffer

__all__ = ["STATS", "EdgePipeline", "command_const", "command_layout", "pipeline_verilog"]

STATS = ("core_busy", "core_stall", "acc_busy", "acc_stall", "resolve_busy", "resolve_stall")
STATS_BITS = 32


def command_layout(tile: TileConfig) -> data.StructLayout:
    """One command (`edgeaa.model.pipeline.Command`)."""
    config = tile.config
    coord = unsigned(config.coord_bits + config.subpixel_bits)
    intensity = unsigned(config.intensity_bits)
    fields = {"op": unsigned(OP_BITS), "x0": coord, "y0": coord, "x1": coord, "y1": coord}
    fields.update({"i_in": intensity, "i_out": intensity, "flag": unsigned(1)})
    if tile.channels > 1:  # the begin's colour, the tile's background (`Command.paint`)
        fields["paint"] = unsigned(config.intensity_bits * len(PAINT))
    return data.StructLayout(fields)


def command_const(tile: TileConfig, command):
    """`command` (`edgeaa.model.pipeline.Command`) as a constant of `command_layout` (a
    grey pipeline's has no paint)."""
    fields = command_fields(tile)
    return command_layout(tile).const({name: getattr(command, name) for name in fields})


class EdgePipeline(wiring.Component):
    """Commands in (``commands``), pixels out (``pixels``); ``errors`` counts bad commands
    (saturating), ``edge_errors`` the core's, ``stats`` the stage counters. `pipeline`: a
    `PipelineConfig` (its tile, and the core's setup units), or a `TileConfig` alone (one
    setup unit, the compact pipeline)."""

    def __init__(self, pipeline: PipelineConfig | TileConfig):
        self._pipeline = pipeline_config(pipeline)
        self._tile = tile = self._pipeline.tile
        self.core = PolygonCore(
            tile.config, setup_units=self._pipeline.setup_units, fmt=self._pipeline.deltas
        )
        lanes, scan = self._pipeline.pixel_lanes, self._pipeline.scan_lanes
        self.acc = TileAccumulator(tile, scan)
        self.res = TileResolve(tile, lanes, scan, self._pipeline.product_stages)
        # between the core and the accumulator (`beat_skid`): the core's ready a register
        beats = self.core.deltas.payload.shape()
        self.skid = SkidBuffer(beats) if self._pipeline.beat_skid else None
        stats = data.StructLayout({name: unsigned(STATS_BITS) for name in STATS})
        super().__init__(
            {
                "commands": In(stream.Signature(command_layout(tile))),
                "pixels": Out(stream.Signature(tile_pixel_layout(tile, lanes))),
                "errors": Out(unsigned(ERRORS_BITS)),
                "edge_errors": Out(unsigned(ERRORS_BITS)),
                "stats": Out(stats),
            }
        )

    @property
    def tile(self) -> TileConfig:
        return self._tile

    @property
    def pipeline(self) -> PipelineConfig:
        return self._pipeline

    def elaborate(self, platform):
        m = Module()
        core, acc, res = self.core, self.acc, self.res
        m.submodules.core, m.submodules.acc, m.submodules.res = core, acc, res
        beats, self._core_idle = core.deltas, core.idle
        if self.skid is not None:  # idle: every beat of the polygon taken from the buffer
            m.submodules.skid = self.skid
            wiring.connect(m, core.deltas, self.skid.sink)
            beats, self._core_idle = self.skid.source, core.idle & ~self.skid.held
        wiring.connect(m, acc.cells, res.cells)
        wiring.connect(m, res.pixels, wiring.flipped(self.pixels))
        op_valid, op, code = self._commands(m)
        # The core's beats or the command stage's op (only when the core is idle).
        m.d.comb += [
            acc.ops.valid.eq(beats.valid | op_valid),
            beats.ready.eq(acc.ops.ready),
            op.op.eq(Mux(beats.valid, OPS.index("beat"), code)),
            op.beat.eq(beats.payload),
            acc.ops.payload.eq(op),
            self.edge_errors.eq(core.errors),
        ]
        self._stats(m)
        return m

    def _commands(self, m):
        """The command stage: returns the valid, payload and op code of the op it offers the
        accumulator (the payload's op and beat are the caller's)."""
        tile, config = self._tile, self._tile.config
        c, core = self.commands.payload, self.core
        op = Signal(self.acc.ops.payload.shape())
        op_valid, code = Signal(), Signal(len(op.op))
        params = {name: Signal(config.intensity_bits, name=name) for name in ("intensity", "i_out")}
        evenodd = Signal()
        paint, intensity, background = None, params["intensity"], c.i_in
        if tile.channels > 1:  # the end carries the paint after the intensity
            paint = Signal(len(c.paint), name="paint")
            background = c.paint[: config.intensity_bits * tile.channels]
            intensity = Cat(params["intensity"], paint)
        origin = [Signal(config.coord_bits + 1, name=n) for n in ("tile_x0", "tile_y0")]
        top = 1 << config.coord_bits
        is_ = {key: c.op == code for key, code in CODE.items()}
        # Nothing is accepted while rst is high: the stage sees no command, ready is low.
        rst = ResetSignal(allow_reset_less=True)
        valid = Signal()
        m.d.comb += valid.eq(self.commands.valid & ~rst)
        take = valid & self.commands.ready
        error = Signal()
        m.d.comb += [
            core.edges.payload.x0.eq(c.x0),
            core.edges.payload.y0.eq(c.y0),
            core.edges.payload.x1.eq(c.x1),
            core.edges.payload.y1.eq(c.y1),
            core.edges.payload.i_in.eq(params["intensity"]),
            core.edges.payload.i_out.eq(params["i_out"]),
            core.edges.payload.inside.eq(c.flag),
            core.clip.x_min.eq(0),
            core.clip.y_min.eq(origin[1]),
            core.clip.x_max.eq(
                Mux(origin[0] + tile.width - 1 > top, top, origin[0] + tile.width - 1)
            ),
            core.clip.y_max.eq(
                Mux(origin[1] + tile.height - 1 > top, top, origin[1] + tile.height - 1)
            ),
            op.intensity.eq(intensity),
            op.i_out.eq(params["i_out"]),
            op.evenodd.eq(evenodd),
            op.x0.eq(c.x0),
            op.y0.eq(c.y0),
            op.background.eq(background),
        ]
        good_tile = (c.x0 <= top) & (c.y0 <= top)
        with m.FSM(name="commands"):
            with m.State("OUT"):
                send = valid & self._core_idle & ((is_["tile"] & good_tile) | is_["flush"])
                m.d.comb += [
                    op_valid.eq(send),
                    code.eq(Mux(is_["tile"], OPS.index("tile"), OPS.index("flush"))),
                    self.commands.ready.eq(Mux(send, self.acc.ops.ready, 1)),
                ]
                with m.If(take):
                    with m.If(is_["begin"]):
                        m.d.sync += [params["intensity"].eq(c.i_in), params["i_out"].eq(c.i_out)]
                        m.d.sync += evenodd.eq(c.flag)
                        if paint is not None:
                            m.d.sync += paint.eq(c.paint)
                        m.next = "IN"
                    with m.Elif(is_["tile"] & good_tile):
                        m.d.sync += [origin[0].eq(c.x0), origin[1].eq(c.y0)]
                    with m.Elif(~is_["flush"]):
                        m.d.comb += error.eq(1)
            with m.State("IN"):
                ending = valid & ~is_["edge"]
                known = Mux(c.op < len(CODE), 1, 0)
                m.d.comb += [
                    core.edges.valid.eq(valid & is_["edge"]),
                    op_valid.eq(ending & known & self._core_idle),
                    code.eq(OPS.index("end")),
                ]
                with m.If(is_["edge"]):
                    m.d.comb += self.commands.ready.eq(core.edges.ready)
                with m.Elif(is_["end"]):
                    m.d.comb += self.commands.ready.eq(self._core_idle & self.acc.ops.ready)
                with m.Elif(~known):
                    m.d.comb += [self.commands.ready.eq(1), error.eq(valid)]
                with m.If(op_valid & self.acc.ops.ready):
                    m.d.comb += error.eq(~is_["end"])  # a polygon with no end: ended here
                    m.next = "OUT"
        with m.If(rst):
            m.d.comb += self.commands.ready.eq(0)
        with m.If(error & (self.errors != (1 << ERRORS_BITS) - 1)):
            m.d.sync += self.errors.eq(self.errors + 1)
        return op_valid, op, code

    def _stats(self, m):
        core, acc, res = self.core, self.acc, self.res
        events = {
            "core_busy": ~self._core_idle,
            "core_stall": core.deltas.valid & ~core.deltas.ready,
            "acc_busy": acc.busy,
            "acc_stall": acc.cells.valid & ~acc.cells.ready,
            "resolve_busy": (res.cells.valid & res.cells.ready) | res.flushing,
            "resolve_stall": res.pixels.valid & ~res.pixels.ready,
        }
        for name, event in events.items():
            counter = self.stats[name]
            with m.If(event):
                m.d.sync += counter.eq(counter + 1)


def pipeline_verilog(tile: PipelineConfig | TileConfig, *, name: str = "edgeaa_pipeline") -> str:
    """The pipeline as Verilog, every payload and stats field its own port
    (``commands__payload__op``, ``pixels__payload__value``, ``stats__core_busy``, ...)."""
    return flat_verilog(EdgePipeline(tile), name)
