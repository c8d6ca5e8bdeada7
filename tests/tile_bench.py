# amaranth: UnusedElaboratable=no
"""Driving the tile stages in Amaranth's simulator: ops as payloads, and a runner that
records every transfer's clock (for `edgeaa.model.tile.tile_cycles`) and the frames."""

from __future__ import annotations

import random
from dataclasses import dataclass, field

import numpy as np
from amaranth.hdl import Module
from amaranth.lib import wiring
from amaranth.sim import Simulator

from edgeaa.hdl.accumulator import TileAccumulator
from edgeaa.hdl.layouts import tile_op_layout
from edgeaa.hdl.resolve import TileResolve
from edgeaa.model.beat import CELL_FIELDS, CELLS
from edgeaa.model.tile import OPS, Beats, Flush, PolygonEnd, TileConfig, TileStart


def op_payloads(tile: TileConfig, ops) -> list:
    """One `tile_op_layout` constant per transfer (a `Beats` op gives one per beat)."""
    layout = tile_op_layout(tile)
    # Another op's beat field is don't-care: a live-looking beat checks it is ignored.
    junk = {cell: {"x": 1, "y": 1, "delta": 1 << tile.config.F} for cell in CELLS}
    out = []

    def put(op: str, **fields):
        value = {"op": OPS.index(op), "beat": {**junk, "last": 0}}
        value.update(fields)
        out.append(layout.const(value))

    for op in ops:
        if isinstance(op, Beats):
            for beat in op.cells.tolist():
                pairs = zip(CELLS, beat, strict=True)
                cells = {c: dict(zip(CELL_FIELDS, v, strict=True)) for c, v in pairs}
                put("beat", beat={**cells, "last": 0})
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
    """The accumulator and the resolve, connected (the top's tile half, for tests)."""

    def __init__(self, tile: TileConfig):
        self.acc, self.res = TileAccumulator(tile), TileResolve(tile)
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
    stalled_changed: int = 0

    def frames(self, tile: TileConfig) -> list[np.ndarray]:
        values = np.array([p[3] for p in self.pixels], dtype=np.int64)
        return list(values.reshape(-1, tile.height, tile.width))


def run_stages(tile: TileConfig, ops, *, seed=None, idle=0.0, stall=0.0) -> StageRun:
    """Offer the ops' payloads in order and take the pixels (random idles and stalls with a
    seed); stops once the pixels of every flush are out and nothing has moved for a while."""
    dut = Stages(tile)
    payloads = op_payloads(tile, ops)
    want = sum(isinstance(op, Flush) for op in ops) * tile.pixels
    rng = random.Random(seed) if seed is not None else None
    run = StageRun()

    async def bench(ctx):
        index, clock, quiet, held = 0, 0, 0, None
        while quiet < 64 and clock < 200_000:
            offer = index < len(payloads) and (rng is None or rng.random() >= idle)
            ctx.set(dut.ops.valid, offer)
            if offer:
                ctx.set(dut.ops.payload, payloads[index])
            ready = rng is None or rng.random() >= stall
            ctx.set(dut.pixels.ready, ready)
            sample = await ctx.tick().sample(
                dut.ops.ready,
                dut.acc.cells.valid,
                dut.acc.cells.ready,
                dut.acc.cells.payload.op,
                dut.pixels.valid,
                dut.pixels.payload,
            )
            taken, c_valid, c_ready, c_op, p_valid, pixel = sample[2:]
            if offer and taken:
                run.accepts.append(clock)
                index += 1
            if c_valid and c_ready and c_op == 0:  # a cell (not a tile or flush op)
                run.cells.append(clock)
            value = (int(pixel.x), int(pixel.y), int(pixel.value), int(pixel.last))
            if held is not None and (not p_valid or value != held):
                run.stalled_changed += 1
            held = value if p_valid and not ready else None
            if p_valid and ready:
                run.pixels.append((clock, *value))
            clock += 1
            done = index == len(payloads) and len(run.pixels) >= want
            quiet = quiet + 1 if done else 0

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    return run
