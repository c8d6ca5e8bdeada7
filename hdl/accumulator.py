# amaranth: UnusedElaboratable=no
"""The tile's accumulation memory (`TileAccumulator`): delta beats in, one per clock; on a
polygon's end, the touched rows' cell sums out to the resolve, each cell cleared as it is
read. `edgeaa.model.tile` is the model and the cycle model (`beat_clocks`, `tile_cycles`).

In: ``ops``, delta beats and tile, end and flush ops. A beat's nonzero cells are taken one a
clock, in cell order, and the beat in the clock of its last (one clock for a beat with none:
`edgeaa.model.tile.beat_clocks`), so ``ops.ready`` depends on the beat's deltas; any four
cells make a beat, repeats included. A cell left of the tile moves into its row's first
column; one right of, above or below it is dropped (it still takes its clock). A cell holds
its sum modulo ``2**cell_bits`` in one `amaranth.lib.memory.Memory` of ``width x height``
cells (a simple dual-port block RAM); back-to-back deltas to one cell are neither lost nor
doubled (read-modify-write with forwarding, `_rmw`).

Out: ``cells`` to the resolve. An end taken in clock a reads, from a + 2, the rows the
polygon touched in ascending order, one cell per clock while the output advances (``start``
marks a row's first cell, where the resolve's prefix sum restarts), each read clearing its
cell; a row already scanned in this tile is read over the polygon's scan span only
(`edgeaa.model.tile`, "Scan span", where it is shown exact). A cell read in clock s is
offered in s + 1 (the end's first in a + 3), and a stalled cell holds. Tile and flush ops go
out through the same output register, in order.

Reset clears the registers, not the memory: a memory holding deltas of an unfinished polygon
(``dirty``, kept through reset) is cleared, one cell a clock, ``width x height`` clocks,
before the first op after the reset; a clean one takes ops from the first clock. The
clock-by-clock story, the scan span's registers and the costs: docs/hardware.md, "Polygon
pipeline", Accumulation memory.
"""

from __future__ import annotations

import types

from amaranth.hdl import Cat, Const, Module, Mux, Signal, signed
from amaranth.lib import memory, stream, wiring
from amaranth.lib.wiring import In, Out

from ..model.tile import OPS, RESOLVE_OPS, TileConfig
from .layouts import log2, tile_cell_layout, tile_op_layout

__all__ = ["TileAccumulator", "lowest_set"]

OP = {name: code for code, name in enumerate(OPS)}
CELL_OP = {name: code for code, name in enumerate(RESOLVE_OPS)}


def _select(sel, values):
    """The value whose bit of the one-hot 4-bit `sel` is set, zero when none. Each bit as two
    LUT4s, where an AND-OR of the selects takes three: three selects (``hi``: value 2 or 3;
    ``a``: 0 or 3; ``b``: 1 or 3) and ``low``, value 0's or 1's bit or zero, or (when ``hi``)
    the choice of value 3 over 2."""
    hi, a, b = sel[2] | sel[3], sel[0] | sel[3], sel[1] | sel[3]
    v0, v1, v2, v3 = values
    low = Mux(a, Mux(b, Const(-1, v0.shape()), v0), Mux(b, v1, 0))
    return Mux(hi, (low & v3) | (~low & v2), low)


def lowest_set(bits: Signal, width: int):
    """Index of the lowest set bit of `bits` (0 when none) and that bit alone (one-hot, 0
    when none): ``bits & ~(bits - 1)`` (equal to ``bits & -bits``, and 30 LUT4 fewer for the
    32 rows) and an OR per index bit."""
    one_hot = (bits & ~(bits - 1))[:width]
    index = Cat(
        *(Cat(*(one_hot[k] for k in range(width) if k >> j & 1)).any() for j in range(log2(width)))
    )
    return index, one_hot


class TileAccumulator(wiring.Component):
    """Accumulation memory of a `TileConfig` tile. ``ops`` (in, `tile_op_layout`), ``cells``
    (out, `tile_cell_layout`); ``scanning`` is high while a polygon's rows are read, ``busy``
    while it takes an op or a beat's cell, or scans."""

    def __init__(self, tile: TileConfig):
        if not isinstance(tile, TileConfig):
            raise TypeError(f"tile must be a TileConfig, not {tile!r}")
        self._tile = tile
        super().__init__(
            {
                "ops": In(stream.Signature(tile_op_layout(tile))),
                "cells": Out(stream.Signature(tile_cell_layout(tile))),
                "scanning": Out(1),
                "busy": Out(1),
            }
        )

    @property
    def tile(self) -> TileConfig:
        return self._tile

    def elaborate(self, platform):
        m = Module()
        tile = self._tile
        mem = memory.Memory(shape=signed(tile.cell_bits), depth=tile.pixels, init=[])
        m.submodules.cells_memory = mem
        rd, wr = mem.read_port(), mem.write_port()
        self.observe = types.SimpleNamespace(memory=mem, read=rd)
        o_valid = Signal()
        advance = ~o_valid | self.cells.ready
        free = Signal()  # in ACC, the output register free and no clear pending: take
        cell = self._route(m, free)
        self._rmw(m, rd, wr, cell)
        self._control(m, rd, o_valid, advance, free, cell)
        return m

    def _route(self, m, free) -> types.SimpleNamespace:
        """The cell taken this clock: the beat's lowest nonzero cell not yet taken, moved into
        the tile (``keep``: it is inside after the move; ``x``, ``y`` tile coordinates),
        ``last`` when no other waits (the beat is taken with it), ``done`` the cells taken in
        earlier clocks."""
        tile, p = self._tile, self.ops.payload
        x0, y0 = Signal.like(p.x0), Signal.like(p.y0)  # the origin, set by a tile op
        with m.If(self.ops.valid & self.ops.ready & (p.op == OP["tile"])):
            m.d.sync += [x0.eq(p.x0), y0.eq(p.y0)]
        cells = [p.beat[f"cell{j}"] for j in range(4)]
        done = Signal(4)  # the beat's cells taken in earlier clocks
        pending = Signal(4)
        m.d.comb += pending.eq(Cat(*(c.delta != 0 for c in cells)) & ~done)
        sel = (pending & -pending)[:4]  # the lowest (as `lowest_set`; fewer LUT4s here)
        last = (pending & ~sel) == 0
        taking = Signal()  # a clock of a beat: its cell `sel` (none: an all-zero beat)
        m.d.comb += [
            taking.eq(self.ops.valid & free & (p.op == OP["beat"])),
            self.busy.eq((self.ops.valid & self.ops.ready) | taking | self.scanning),
        ]
        with m.If(taking):
            m.d.sync += done.eq(Mux(last, 0, done | sel))
        x, y = _select(sel, [c.x for c in cells]), _select(sel, [c.y for c in cells])
        tx, ty = x - x0, y - y0
        keep = taking & (sel != 0) & (ty >= 0) & (ty < tile.height) & (tx < tile.width)
        cell = types.SimpleNamespace(
            keep=Signal(name="cell_keep"),
            x=Signal(tile.x_bits, name="cell_x"),
            y=Signal(tile.y_bits, name="cell_y"),
            delta=Signal(signed(tile.cell_bits), name="cell_delta"),
            last=last,
            done=done,
        )
        m.d.comb += [
            cell.keep.eq(keep),
            cell.x.eq(Mux(tx < 0, 0, tx)),
            cell.y.eq(ty),
            cell.delta.eq(Mux(keep, _select(sel, [c.delta for c in cells]), 0)),
        ]
        self.observe.__dict__.update(origin=(x0, y0), cell=cell)
        return cell

    def _rmw(self, m, rd, wr, cell):
        """Read-modify-write in two stages: A (the cell is taken; read it), B (add the delta to
        what was read, or to the sum of the cell before if it wrote the same cell last clock,
        which the read did not see; write the sum). Stage B's delta is zero when it holds no
        cell, so a scan's clear is the same add with the read forced to zero. `self._clear`
        (the scan's) takes the write port when set and writes zero at `self._scan_addr`."""
        tile = self._tile
        addr_bits = len(rd.addr)
        self._scan_addr = Signal(addr_bits)
        self._clear = Signal()
        self._read_en = Signal()
        addr = Cat(cell.x, cell.y)
        b_valid, b_addr, b_delta = Signal(), Signal(addr_bits), Signal(signed(tile.cell_bits))
        c_valid, c_addr, c_sum = Signal(), Signal(addr_bits), Signal.like(b_delta)
        total = Signal.like(b_delta)
        self.observe.stage = types.SimpleNamespace(
            b_valid=b_valid,
            b_addr=b_addr,
            b_delta=b_delta,
            c_valid=c_valid,
            c_addr=c_addr,
            c_sum=c_sum,
        )
        m.d.comb += [
            rd.addr.eq(Mux(self.scanning, self._scan_addr, addr)),
            rd.en.eq(self._read_en),
        ]
        m.d.sync += [
            b_valid.eq(cell.keep),
            b_addr.eq(addr),
            b_delta.eq(cell.delta),
            c_valid.eq(b_valid),
            c_addr.eq(b_addr),
            c_sum.eq(total),
        ]
        # the write of the cell before (C) is not in the read B got; a clear writes zero
        # (b_delta is zero while scanning)
        base = Mux(c_valid & (c_addr == b_addr), c_sum, Mux(self._clear, 0, rd.data))
        m.d.comb += [
            total.eq(base + b_delta),
            wr.addr.eq(Mux(self._clear, self._scan_addr, b_addr)),
            wr.data.eq(total),
            wr.en.eq(self._clear | b_valid),
        ]

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
        # the polygon's kept columns (lo > hi: none yet) and rows; rows scanned since the tile
        # started (the resolve has written them whole)
        lo = Signal(tile.x_bits, init=tile.width - 1)
        hi = Signal(tile.x_bits)
        touched, seen = Signal(tile.height), Signal(tile.height)
        # kept deltas not yet scanned, through reset; the first clock after a reset
        dirty, check = Signal(reset_less=True), Signal(init=1)
        m.d.sync += check.eq(0)
        with m.If(cell.keep):
            m.d.sync += [
                dirty.eq(1),
                touched.eq(touched | (Const(1, tile.height) << cell.y)),
                lo.eq(Mux(cell.x < lo, cell.x, lo)),
                hi.eq(Mux(cell.x > hi, cell.x, hi)),
            ]
        with m.If(accept & ((p.op == OP["tile"]) | (p.op == OP["flush"]))):
            m.d.sync += seen.eq(0)
        self.observe.__dict__.update(
            o_valid=o_valid,
            o=o,
            touched=touched,
            seen=seen,
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
        m.d.comb += total.eq(Mux(o["start"], 0, rsum) + self.cells.payload.sum)
        with m.If(advance & o_valid & (o["op"] == CELL_OP["cell"])):
            m.d.sync += rsum.eq(total)
        self.observe.__dict__.update(rsum=rsum, total=total)
        with m.FSM() as fsm:
            with m.State("ACC"):
                m.d.comb += [
                    free.eq(advance & ~(check & dirty)),
                    self.ops.ready.eq(free & ((p.op != OP["beat"]) | cell.last)),
                ]
                with m.If(check & dirty):  # deltas left by a reset mid-polygon
                    m.next = "CLEAR"
                with m.If(accept):
                    self._take(m, p, o, o_valid, params, background, first)
                    with m.If(p.op == OP["end"]):
                        m.next = "WAIT"
            self._scan(m, o, o_valid, advance, first)
            self.observe.in_acc, self.observe.in_wait = fsm.ongoing("ACC"), fsm.ongoing("WAIT")
            self.observe.in_clear = fsm.ongoing("CLEAR")
        self._output(m, rd, o, params, background)

    def _scan(self, m, o, o_valid, advance, first):
        """WAIT and SCAN: the touched rows in ascending order, a row seen since the tile
        started from ``lo`` to ``hi`` and on to the last column when its sum through ``hi``
        is nonzero (`edgeaa.model.tile`, "Scan span"), a row not seen yet whole."""
        tile, obs = self._tile, self.observe
        lo, hi, touched, seen = obs.lo, obs.hi, obs.touched, obs.seen
        last = tile.width - 1
        scan_x, scan_y = Signal(tile.x_bits), Signal(tile.y_bits)
        scan_addr = Cat(scan_x, scan_y)
        partial = Signal()  # the row is read from lo (it was seen)
        row_start = Signal()  # the next read is the row's first
        decide = Signal()  # the cell waiting is the row's hi: the row may stop there
        total = obs.total
        # the next row to scan and its bit, taken out of `touched` when it is chosen
        next_y, next_bit = lowest_set(touched, tile.height)
        next_seen = (seen & next_bit).any()
        next_x = Mux(next_seen, lo, 0)

        def choose():
            m.d.sync += [
                scan_x.eq(next_x),
                scan_y.eq(next_y),
                partial.eq(next_seen),
                row_start.eq(1),
                touched.eq(touched & ~next_bit),
                seen.eq(seen | next_bit),
            ]

        def done():
            m.d.sync += [lo.eq(last), hi.eq(0), obs.dirty.eq(0)]
            m.next = "ACC"

        with m.State("WAIT"):  # the last beat's write landed in the clock before
            choose()
            m.next = "ACC"
            with m.If(touched != 0):
                m.next = "SCAN"
        with m.State("SCAN"):
            m.d.comb += [self.scanning.eq(1), self._scan_addr.eq(scan_addr)]
            with m.If(advance):
                # the cell waiting is the row's hi and the sum through it is 0: the row stops,
                # and this clock's read (hi + 1, a zero cell: its clear changes nothing) is
                # not sent
                stop = decide & (total == 0)
                m.d.comb += self._clear.eq(1)
                m.d.sync += [
                    o_valid.eq(~stop),
                    o["op"].eq(CELL_OP["cell"]),
                    o["x"].eq(scan_x),
                    o["y"].eq(scan_y),
                    o["first"].eq(first),
                    o["start"].eq(row_start),
                    first.eq(0),
                    row_start.eq(0),
                    scan_x.eq(scan_x + 1),
                    decide.eq(partial & (scan_x == hi) & (hi != last)),
                ]
                with m.If(stop | (scan_x == last)):
                    choose()
                    with m.If(touched == 0):
                        done()
        with m.State("CLEAR"):  # after a reset: zero to every cell, one a clock, no output
            m.d.comb += [self._clear.eq(1), self._scan_addr.eq(scan_addr)]
            m.d.sync += scan_x.eq(scan_x + 1)
            with m.If(scan_x == last):
                m.d.sync += scan_y.eq(scan_y + 1)
                with m.If(scan_y == tile.height - 1):
                    m.d.sync += [scan_x.eq(0), scan_y.eq(0), obs.dirty.eq(0)]
                    m.next = "ACC"
        obs.__dict__.update(
            scan_x=scan_x, scan_y=scan_y, partial=partial, row_start=row_start, decide=decide
        )

    def _take(self, m, p, o, o_valid, params, background, first):
        """An op taken in ACC: an end keeps the polygon's fields; tile and flush go out."""
        with m.If(p.op == OP["end"]):
            m.d.sync += [reg.eq(p[name]) for name, reg in params.items()]
            m.d.sync += first.eq(1)
        with m.If((p.op == OP["tile"]) | (p.op == OP["flush"])):
            code = Mux(p.op == OP["tile"], CELL_OP["tile"], CELL_OP["flush"])
            m.d.sync += [o_valid.eq(1), o["op"].eq(code), o["first"].eq(0)]
        with m.If(p.op == OP["tile"]):
            m.d.sync += background.eq(p.background)

    def _output(self, m, rd, o, params, background):
        out = self.cells.payload
        m.d.comb += [
            out.op.eq(o["op"]),
            out.x.eq(o["x"]),
            out.y.eq(o["y"]),
            out.first.eq(o["first"]),
            out.start.eq(o["start"]),
            out.sum.eq(rd.data),
            out.background.eq(background),
            *(out[name].eq(reg) for name, reg in params.items()),
        ]
