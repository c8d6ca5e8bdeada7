# amaranth: UnusedElaboratable=no
"""The tile's accumulation memory (`TileAccumulator`): delta beats in, one per clock; on a
polygon's end, the touched rows' cell sums out to the resolve, each cell cleared as it is
read. `edgeaa.model.tile` is the model and the cycle model (`beat_clocks`, `tile_cycles`).

In: ``ops``, delta beats and tile, end and flush ops. A beat's nonzero cells are taken one a
clock, in cell order, and the beat in the clock of its last (one clock for a beat with none:
`edgeaa.model.tile.beat_clocks`), so ``ops.ready`` depends on the beat's deltas; any four
cells make a beat, repeats included. With two scan lanes the cells go in by pairs, (0, 1)
then (2, 3), a clock for a pair with a nonzero cell, each cell into its column's bank (two
cells at one cell added first), two clocks when the pair's cells are two cells of one bank
(`accumulator_cells.route_pair`). With four, every bank (column modulo 4) takes a cell a
clock, with the cells of the beat at that cell (`accumulator_cells.route_quad`). A cell
left of the tile moves into its row's first
column; one right of, above or below it is dropped (it still takes its clock). A cell holds
its sum modulo ``2**cell_bits`` in one `amaranth.lib.memory.Memory` of ``width x height``
cells (a simple dual-port block RAM; with more lanes a memory per bank); back-to-back deltas
to one cell are neither lost nor doubled (read-modify-write with forwarding,
`accumulator_cells.read_modify_write`, a copy per bank).

Out: ``cells`` to the resolve. An end taken in clock a reads, from a + 2, the rows the
polygon touched in ascending order, one beat of ``lanes`` cells per clock while the output
advances (`edgeaa.model.pipeline.PipelineConfig.scan_lanes`: 1 in the compact pipeline, the
memory then one; 2 in the fast one, a memory per lane, banked by column modulo the lanes,
so a beat is a word of each, and the input side writes each cell's lane; ``start`` marks a
row's first beat, where the resolve's prefix sum restarts), each read clearing its cells;
a row is read over the polygon's scan span only, widened to whole beats (`edgeaa.model.tile`,
"Scan span", where it is shown exact: the resolve's pixels hold a written flag each). A cell
read in clock s is offered in s + 1 (the end's first in a + 3), and a stalled cell holds. Tile
and flush ops go out through the same output register, in order.

Reset clears the registers, not the memory: a memory holding deltas of an unfinished polygon
(``dirty``, kept through reset) is cleared, a beat a clock, ``width x height / lanes`` clocks,
before the first op after the reset; a clean one takes ops from the first clock. The
clock-by-clock story, the scan span's registers and the costs: docs/hardware.md, "Polygon
pipeline", Accumulation memory.
"""

from __future__ import annotations

import types

from amaranth.hdl import Cat, Const, Module, Mux, Signal, signed
from amaranth.lib import memory, stream, wiring
from amaranth.lib.wiring import In, Out

from ..model.pipeline import SCAN_LANES
from ..model.tile import TileConfig
from .accumulator_cells import read_modify_write, route_cell, route_pair, route_quad
from .accumulator_scan import scan_states
from .layouts import CELL_OP, TILE_OP, cell_sum_fields, tile_cell_layout, tile_op_layout

__all__ = ["TileAccumulator"]


class TileAccumulator(wiring.Component):
    """Accumulation memory of a `TileConfig` tile. ``ops`` (in, `tile_op_layout`), ``cells``
    (out, `tile_cell_layout`); ``scanning`` is high while a polygon's rows are read, ``busy``
    while it takes an op or a beat's cell, or scans. `elaborate` sets ``observe``, the memory,
    its read port and the registers the formal harness reads
    (`edgeaa.sim.verification.formal.accumulator`); its input side is
    `edgeaa.hdl.accumulator_cells`, its scan `edgeaa.hdl.accumulator_scan`."""

    def __init__(self, tile: TileConfig, lanes: int = 1):
        if not isinstance(tile, TileConfig):
            raise TypeError(f"tile must be a TileConfig, not {tile!r}")
        if lanes not in SCAN_LANES:
            raise ValueError(f"lanes must be one of {SCAN_LANES}, not {lanes!r}")
        self._tile, self._lanes = tile, lanes
        super().__init__(
            {
                "ops": In(stream.Signature(tile_op_layout(tile))),
                "cells": Out(stream.Signature(tile_cell_layout(tile, lanes))),
                "scanning": Out(1),
                "busy": Out(1),
            }
        )

    @property
    def tile(self) -> TileConfig:
        return self._tile

    @property
    def lanes(self) -> int:
        """Cells the scan reads a clock (`PipelineConfig.scan_lanes`)."""
        return self._lanes

    def elaborate(self, platform):
        m = Module()
        tile, lanes = self._tile, self._lanes
        if lanes == 1:
            mem = memory.Memory(shape=signed(tile.cell_bits), depth=tile.pixels, init=[])
            m.submodules.cells_memory = mem
            rd, wr = mem.read_port(), mem.write_port()
            self.observe = types.SimpleNamespace(memory=mem, read=rd)
        else:  # a memory per lane, banked by column modulo the lanes: a beat is a word of each
            mems = [
                memory.Memory(shape=signed(tile.cell_bits), depth=tile.pixels // lanes, init=[])
                for _ in range(lanes)
            ]
            for j, mem in enumerate(mems):
                m.submodules[f"cells_memory_lane{j}"] = mem
            rd, wr = [mem.read_port() for mem in mems], [mem.write_port() for mem in mems]
            self.observe = types.SimpleNamespace(memories=mems, reads=rd)
        o_valid = Signal()
        advance = ~o_valid | self.cells.ready
        free = Signal()  # in ACC, the output register free and no clear pending: take
        cell = {1: route_cell, 2: route_pair, 4: route_quad}[lanes](m, self, free)
        read_modify_write(m, self, rd, wr, cell)
        self._control(m, rd, o_valid, advance, free, cell)
        return m

    def _control(self, m, rd, o_valid, advance, free, cell):
        """Input acceptance, the polygon's span and the rows it touched, the scan, and the
        output register."""
        tile, p = self._tile, self.ops.payload
        accept = self.ops.valid & self.ops.ready
        first = Signal()
        out = self.cells.payload
        o = {name: Signal.like(out[name]) for name in ("op", "x", "y", "first", "start")}
        params = {name: Signal.like(p[name]) for name in ("intensity", "i_out", "evenodd")}
        background = Signal.like(p.background)
        m.d.comb += [self._read_en.eq(advance), self.cells.valid.eq(o_valid)]
        with m.If(advance):
            m.d.sync += o_valid.eq(0)
        # the polygon's kept columns (lo > hi: none yet) and rows
        lo = Signal(tile.x_bits, init=tile.width - 1)
        hi = Signal(tile.x_bits)
        touched = Signal(tile.height)
        # kept deltas not yet scanned, through reset; the first clock after a reset
        dirty, check = Signal(reset_less=True), Signal(init=1)
        m.d.sync += check.eq(0)
        if self._lanes == 1:
            rows = touched | (Const(1, tile.height) << cell.y)
            new_lo, new_hi = Mux(cell.x < lo, cell.x, lo), Mux(cell.x > hi, cell.x, hi)
        else:  # a cell a bank this clock, each kept or not (``want``: if taken; the
            # registers load only when one is); the span as the router says (`span`)
            rows = touched
            for c in cell.banks:
                rows = rows | Mux(c.want, Const(1, tile.height) << c.y, 0)
            new_lo, new_hi = cell.span(lo, hi)
        with m.If(cell.keep):
            m.d.sync += [dirty.eq(1), touched.eq(rows), lo.eq(new_lo), hi.eq(new_hi)]
        self.observe.__dict__.update(
            o_valid=o_valid,
            o=o,
            touched=touched,
            lo=lo,
            hi=hi,
            dirty=dirty,
            check=check,
            first=first,
            params=params,
            background=background,
        )
        rsum = Signal(signed(tile.cell_bits))  # the row's sum through the cells sent
        total = Signal(signed(tile.cell_bits))  # ... and through the cell waiting
        sums = [self.cells.payload[name] for name in cell_sum_fields(self._lanes)]
        base = Mux(o["start"], 0, rsum)
        m.d.comb += total.eq(base + sum(sums[1:], start=sums[0]))
        with m.If(advance & o_valid & (o["op"] == CELL_OP["cell"])):
            m.d.sync += rsum.eq(total)
        self.observe.__dict__.update(rsum=rsum, total=total)
        if self._lanes > 1:  # the scan's row-stop test, total == 0, with no carry chain
            self.observe.cancels = _sum_is(*_carry_save(sums), (-base)[: tile.cell_bits])
        with m.FSM() as fsm:
            with m.State("ACC"):
                m.d.comb += [
                    free.eq(advance & ~(check & dirty)),
                    self.ops.ready.eq(free & ((p.op != TILE_OP["beat"]) | cell.last)),
                ]
                with m.If(check & dirty):  # deltas left by a reset mid-polygon
                    m.next = "CLEAR"
                with m.If(accept):
                    self._take(m, p, o, o_valid, params, background, first)
                    with m.If(p.op == TILE_OP["end"]):
                        m.next = "WAIT"
            scan_states(m, self, o, o_valid, advance, first)
            self.observe.in_acc, self.observe.in_wait = fsm.ongoing("ACC"), fsm.ongoing("WAIT")
            self.observe.in_clear = fsm.ongoing("CLEAR")
        self._output(m, rd, o, params, background)

    def _take(self, m, p, o, o_valid, params, background, first):
        """An op taken in ACC: an end keeps the polygon's fields; tile and flush go out."""
        with m.If(p.op == TILE_OP["end"]):
            m.d.sync += [reg.eq(p[name]) for name, reg in params.items()]
            m.d.sync += first.eq(1)
        with m.If((p.op == TILE_OP["tile"]) | (p.op == TILE_OP["flush"])):
            code = Mux(p.op == TILE_OP["tile"], CELL_OP["tile"], CELL_OP["flush"])
            m.d.sync += [o_valid.eq(1), o["op"].eq(code), o["first"].eq(0)]
        with m.If(p.op == TILE_OP["tile"]):
            m.d.sync += background.eq(p.background)

    def _output(self, m, rd, o, params, background):
        out = self.cells.payload
        ports = rd if isinstance(rd, list) else [rd]  # a beat: each lane's memory's word
        m.d.comb += [
            out.op.eq(o["op"]),
            out.x.eq(o["x"]),
            out.y.eq(o["y"]),
            out.first.eq(o["first"]),
            out.start.eq(o["start"]),
            *(
                out[name].eq(port.data)
                for name, port in zip(cell_sum_fields(self._lanes), ports, strict=True)
            ),
            out.background.eq(background),
            *(out[name].eq(reg) for name, reg in params.items()),
        ]


def _carry_save(values):
    """Two values whose sum is the sum of `values` (two or more, of one width) modulo
    ``2**width``, with no carry chain: three become two by a full adder per bit (the sum bits
    and the carries one place up) until two are left."""
    width = len(values[0])
    values = [v.as_unsigned() for v in values]
    while len(values) > 2:
        a, b, c, *rest = values
        carries = (a & b) | (a & c) | (b & c)
        values = [(a ^ b ^ c)[:width], Cat(Const(0, 1), carries)[:width], *rest]
    return values


def _sum_is(a, b, t):
    """``a + b == t`` modulo ``2**len(t)`` (`a`, `b` of that width) bit by bit, with no carry
    chain: when the sum is `t`, the carry into bit i is ``c_i = a_i ^ b_i ^ t_i`` and the
    carry out of it ``(a_i & b_i) | ((a_i | b_i) & ~t_i)``; the sum is `t` exactly when
    each bit's carry in is the carry out of the bit below (0 into bit 0). The scan's stop
    test on the memory's read data (a + b + base == 0, ``t = -base`` from registers) was
    the fast pipeline's critical path with two adders in front of the compare."""
    width = len(t)
    a, b = a.as_unsigned()[:width], b.as_unsigned()[:width]
    into = a ^ b ^ t
    out = (a & b) | ((a | b) & ~t)
    return (into == Cat(Const(0, 1), out[:-1])).as_unsigned()
