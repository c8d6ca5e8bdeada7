# amaranth: UnusedElaboratable=no
"""Driving the tile stages in Amaranth's simulator: ops as payloads, and a runner (the one
driver, `edgeaa.sim.simulators.amaranth_runner`) that records every transfer's clock (for
`edgeaa.model.tile.tile_cycles`) and the frames."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from amaranth.hdl import Module
from amaranth.lib import wiring

from edgeaa.hdl.accumulator import TileAccumulator
from edgeaa.hdl.layouts import tile_op_layout
from edgeaa.hdl.resolve import TileResolve
from edgeaa.model.beat import CELL_FIELDS, CELLS, nonzero_mask
from edgeaa.model.tile import OPS, Beats, Flush, PolygonEnd, TileConfig, TileStart
from edgeaa.sim.simulators.amaranth_runner import Probe, Sink, Source, row_decoder, run_component
from edgeaa.sim.simulators.pipeline_harness import (
    beat_columns,
    pixel_drain_clocks,
    pixel_rows,
    stuck_limit,
)


def op_payloads(tile: TileConfig, ops) -> list:
    """One `tile_op_layout` constant per transfer (a `Beats` op gives one per beat)."""
    layout = tile_op_layout(tile)
    # Another op's beat field is don't-care: a live-looking beat checks it is ignored.
    junk = {cell: {"x": 1, "y": 1, "delta": 1 << tile.config.F} for cell in CELLS}
    out = []

    def put(op: str, **fields):
        value = {"op": OPS.index(op), "beat": {**junk, "nonzero": 0b1111, "last": 0}}
        value.update(fields)
        out.append(layout.const(value))

    for op in ops:
        if isinstance(op, Beats):
            for beat in op.cells.tolist():
                pairs = zip(CELLS, beat, strict=True)
                cells = {c: dict(zip(CELL_FIELDS, v, strict=True)) for c, v in pairs}
                put("beat", beat={**cells, "nonzero": nonzero_mask(beat), "last": 0})
        elif isinstance(op, PolygonEnd):
            put("end", intensity=op.intensity, i_out=op.i_out, evenodd=int(op.rule == "evenodd"))
        elif isinstance(op, TileStart):
            put("tile", x0=op.x0, y0=op.y0, background=op.background)
        elif isinstance(op, Flush):
            put("flush")
        else:
            raise TypeError(op)
    return out


class Stages(wiring.Component):
    """The accumulator and the resolve, connected (the top's tile half, for tests), with
    `lanes` scan and pixel lanes (the fast pipeline's 2: `PipelineConfig.scan_lanes`) and the
    resolve's `product_stages` (the fast pipeline's 2)."""

    def __init__(self, tile: TileConfig, lanes: int = 1, product_stages: int = 1):
        self.acc = TileAccumulator(tile, lanes)
        self.res = TileResolve(tile, lanes, lanes, product_stages)
        super().__init__(
            {
                "ops": wiring.In(self.acc.ops.signature.flip()),
                "pixels": wiring.Out(self.res.pixels.signature),
            }
        )

    def elaborate(self, platform):
        m = Module()
        m.submodules.acc, m.submodules.res = self.acc, self.res
        wiring.connect(m, wiring.flipped(self.ops), self.acc.ops)
        wiring.connect(m, self.acc.cells, self.res.cells)
        wiring.connect(m, self.res.pixels, wiring.flipped(self.pixels))
        return m


@dataclass
class StageRun:
    accepts: list = field(default_factory=list)
    cells: list = field(default_factory=list)
    pixels: list = field(default_factory=list)  # (clock, x, y, value, last)

    def frames(self, tile: TileConfig) -> list[np.ndarray]:
        values = np.array([p[3] for p in self.pixels], dtype=np.int64)
        return list(values.reshape(-1, tile.height, tile.width))


def run_stages(
    tile: TileConfig, ops, *, seed=None, idle=0.0, stall=0.0, lanes=1, product_stages=1
) -> StageRun:
    """Offer the ops' payloads in order and take the pixels (random idles and stalls with a
    seed, a stalled pixel must hold: `amaranth_runner.run_component`), observing the clock
    of every beat of cells the accumulator hands the resolve; stops once the pixels of every
    flush are out and a drain has passed. `lanes`: `Stages`'s (a pixel beat is split into
    its pixels, each with the beat's clock); `product_stages`: the resolve's."""
    dut = Stages(tile, lanes, product_stages)
    run = StageRun()

    def cell(clock, valid, ready, op):
        if valid and ready and op == 0:  # a cell (not a tile or flush op)
            run.cells.append(clock)

    cells = dut.acc.cells
    want = sum(isinstance(op, Flush) for op in ops) * tile.pixels
    pixels = row_decoder(dut.pixels.payload.shape(), beat_columns(lanes))
    trace = run_component(
        dut, [Source("ops", op_payloads(tile, ops))], [Sink("pixels", want // lanes, pixels)],
        drain=pixel_drain_clocks(tile), stuck=stuck_limit(tile, idle, stall),
        probes=[Probe((cells.valid, cells.ready, cells.payload.op), cell)], seed=seed,
        idle=idle, stall=stall, tag=f"[stages seed={seed} idle={idle} stall={stall} {tile}]",
    )  # fmt: skip
    (run.accepts,) = trace.accepts
    beats = [(clock, *pixel) for clock, pixel in trace.beats[0]]
    run.pixels = [tuple(row) for row in pixel_rows(beats, lanes).tolist()]
    return run
