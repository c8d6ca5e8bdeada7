# amaranth: UnusedElaboratable=no
"""The tile's accumulation memory (`TileAccumulator`): delta beats in, one per clock; on a
polygon's end, the touched rows' cell sums out to the resolve, each cell cleared as it is
read. `edgeaa.model.tile` is the model and the cycle model.

Memory. The tile's cells are split over four banks by ``(x + 2 y) mod 4``: a beat's cells
(a 2 x 2 block, ``k .. k + 3`` in some order, or four consecutive cells of a row) fall in
distinct banks, except cells left of the tile, which all move into the row's first column;
those are added together first (the lowest-indexed of equal cells takes the others' deltas),
and the distinct cells left still fall in distinct banks. Each bank is an
`amaranth.lib.memory.Memory` with one synchronous read port (not transparent) and one write
port: a simple dual-port block RAM. A cell holds its sum modulo ``2**cell_bits``.

Read-modify-write, one beat per clock, two stages per bank: A (the beat is taken; read the
cell), B (add the delta to what was read, or to the sum of the beat before if it wrote the
same cell last clock, which the read did not see; write the sum). So back-to-back deltas to
one cell are neither lost nor doubled; the forwarding compares bank addresses only. The
bank's delta is selected from the beat's cells by an AND-OR (one cell at most per bank) and
is zero when no beat is taken, so a scan's clear is the same add with the read forced to
zero.

Scan. An end taken in clock a: the last beat's write lands in a (WAIT in a + 1); from a + 2 the
touched rows (a bit per row, set by every nonzero delta kept) are read in ascending order,
one cell per clock while the output advances, each read clearing its cell through the write
port (the read returns the old value), so the clear costs no pass. The read port's enable is
the output's advance: a stalled cell stays in the bank's output register, and the output
payload's sum is the selected bank's read data. Tile and flush ops go out through the same
output register, in order. Latency: a cell read in clock s is offered in s + 1.

Scan span (`edgeaa.model.tile`, "Scan span", where it is shown exact). Two registers hold the
least and greatest column of the polygon's kept cells (``lo``, ``hi``), a bit per row the
rows scanned since the tile started (``seen``: the resolve has written them whole). A seen
row is read from ``lo``; at ``hi`` (below the last column) the row may stop: its sum through
``hi`` (``rsum``, the row's cells as they leave the output register, plus the cell waiting
there) is known once ``hi`` waits in the output register. The scan reads ``hi + 1`` as ``hi``
is taken; when the sum is zero that cell (zero: no delta lies right of ``hi``) is not sent
and the next row is chosen, so a row that stops at ``hi`` costs a clock more than its cells.
A row not seen yet is read whole. The output's ``start`` marks a row's first cell, where the
resolve's prefix sum restarts. The decision only loads registers (no read address depends on
a sum).

Reset. A reset clears the registers but not the memory, so deltas written before a reset in
the middle of a polygon (between its first kept delta and the end of its scan) would add to a
later polygon's. ``dirty`` is kept through reset (``reset_less``): set by a kept delta,
cleared when its polygon's scan ends. In the first clock after a reset (``check``, whose
reset value is 1) a dirty memory sends the accumulator through CLEAR, which writes zero to
the four banks' cells at one address a clock, ``width x height / 4`` clocks (512 by
default), before it takes an op; a clean one takes ops from that first clock, so power-up and
a reset when idle cost no clock.
"""

from __future__ import annotations

import types

from amaranth.hdl import Cat, Const, Module, Mux, Signal, signed
from amaranth.lib import memory, stream, wiring
from amaranth.lib.wiring import In, Out

from ..model.tile import OPS, RESOLVE_OPS, TileConfig
from .layouts import log2, tile_cell_layout, tile_op_layout

__all__ = ["BANKS", "TileAccumulator", "bank_of", "lowest_set"]

BANKS = 4  # (x + 2 y) mod 4
OP = {name: code for code, name in enumerate(OPS)}
CELL_OP = {name: code for code, name in enumerate(RESOLVE_OPS)}


def bank_of(x, y):
    """The bank of cell (x, y): ``(x + 2 y) mod 4`` (the cell's address in it is
    ``(y, x >> 2)``)."""
    return Cat(x[0], x[1] ^ y[0])


def _one_hot(selects, values):
    """The value whose select is set (at most one is), zero when none: an AND-OR."""
    total = 0
    for select, value in zip(selects, values, strict=True):
        total = total | Mux(select, value, 0)
    return total


def lowest_set(bits: Signal, width: int):
    """Index of the lowest set bit of `bits` (0 when none) and that bit alone (one-hot, 0
    when none): ``bits & -bits`` and an OR per index bit."""
    one_hot = (bits & -bits)[:width]
    index = Cat(
        *(Cat(*(one_hot[k] for k in range(width) if k >> j & 1)).any() for j in range(log2(width)))
    )
    return index, one_hot


class TileAccumulator(wiring.Component):
    """Accumulation memory of a `TileConfig` tile. ``ops`` (in, `tile_op_layout`), ``cells``
    (out, `tile_cell_layout`); ``scanning`` is high while a polygon's rows are read."""

    def __init__(self, tile: TileConfig):
        if not isinstance(tile, TileConfig):
            raise TypeError(f"tile must be a TileConfig, not {tile!r}")
        self._tile = tile
        super().__init__(
            {
                "ops": In(stream.Signature(tile_op_layout(tile))),
                "cells": Out(stream.Signature(tile_cell_layout(tile))),
                "scanning": Out(1),
            }
        )

    @property
    def tile(self) -> TileConfig:
        return self._tile

    def elaborate(self, platform):
        m = Module()
        tile = self._tile
        depth = tile.pixels // BANKS
        ports, banks = [], []
        self.observe = types.SimpleNamespace(banks=banks, stages=[])
        for b in range(BANKS):
            mem = memory.Memory(shape=signed(tile.cell_bits), depth=depth, init=[])
            m.submodules[f"bank{b}"] = mem
            banks.append(mem)
            ports.append((mem.read_port(), mem.write_port()))
        self.observe.reads = [rd for rd, _ in ports]
        o_valid = Signal()
        advance = ~o_valid | self.cells.ready
        accept = self.ops.valid & self.ops.ready
        cells = self._route(m, accept)
        # only a beat op adds its cells (another op's beat field is don't-care)
        self._rmw(m, ports, cells, accept & (self.ops.payload.op == OP["beat"]))
        self._control(m, ports, o_valid, advance, accept)
        return m

    def _route(self, m, accept):
        """Stage A's cells: (valid, bank, address, delta) of each of the beat's four, cells
        left of the tile moved to column 0 and equal cells merged into the first of them."""
        tile, p = self._tile, self.ops.payload
        x0, y0 = Signal.like(p.x0), Signal.like(p.y0)  # the origin, set by a tile op
        with m.If(accept & (p.op == OP["tile"])):
            m.d.sync += [x0.eq(p.x0), y0.eq(p.y0)]
        self.observe.origin = (x0, y0)
        raw = []
        for j in range(4):
            cell = p.beat[f"cell{j}"]
            tx, ty = cell.x - x0, cell.y - y0
            keep = (ty >= 0) & (ty < tile.height) & (tx < tile.width) & (cell.delta != 0)
            cx = Mux(tx < 0, 0, tx)[: tile.x_bits]
            raw.append((keep, cx, ty[: tile.y_bits], cell.delta))
        self._touched_set = Signal(tile.height)
        rows = [Mux(keep, Const(1, tile.height) << cy, 0) for keep, _, cy, _ in raw]
        m.d.comb += self._touched_set.eq(rows[0] | rows[1] | rows[2] | rows[3])
        # the least and greatest kept column (width - 1 and 0 when none is kept)
        self._beat_lo, self._beat_hi = Const(tile.width - 1, tile.x_bits), Const(0, tile.x_bits)
        for keep, cx, _, _ in raw:
            self._beat_lo = Mux(keep & (cx < self._beat_lo), cx, self._beat_lo)
            self._beat_hi = Mux(keep & (cx > self._beat_hi), cx, self._beat_hi)
        out = []
        for j, (keep, cx, cy, delta) in enumerate(raw):
            same = [raw[k][0] & (raw[k][1] == cx) & (raw[k][2] == cy) for k in range(4)]
            # an earlier equal cell takes this one's delta
            mine = keep if j == 0 else keep & ~Cat(*same[:j]).any()
            total = delta
            for k in range(j + 1, 4):
                total = total + Mux(same[k], raw[k][3], 0)
            sum_j = Signal(signed(tile.cell_bits), name=f"merged{j}")
            m.d.comb += sum_j.eq(total)
            out.append((mine, bank_of(cx, cy), Cat(cx[2:], cy), sum_j))
        return out

    def _rmw(self, m, ports, cells, accept):
        """Stages A and B of every bank (see the module docstring); `self._clear` (the
        scan's) takes the write port when set and writes zero."""
        tile = self._tile
        addr_bits = len(ports[0][0].addr)
        self._scan_addr = Signal(addr_bits)
        self._clear = Signal(BANKS)
        self._read_en = Signal()
        for b, (rd, wr) in enumerate(ports):
            # one-hot AND-OR selection of the bank's cell; zero when no beat is taken
            sel = [accept & keep & (bank == b) for keep, bank, _, _ in cells]
            addr, delta = Signal(addr_bits), Signal(signed(tile.cell_bits))
            m.d.comb += [
                addr.eq(_one_hot(sel, [cell_addr for _, _, cell_addr, _ in cells])),
                delta.eq(_one_hot(sel, [cell_delta for _, _, _, cell_delta in cells])),
            ]
            b_valid, b_addr, b_delta = Signal(), Signal(addr_bits), Signal.like(delta)
            c_valid, c_addr, c_sum = Signal(), Signal(addr_bits), Signal.like(delta)
            total = Signal.like(delta)
            self.observe.stages.append(
                types.SimpleNamespace(
                    b_valid=b_valid,
                    b_addr=b_addr,
                    b_delta=b_delta,
                    c_valid=c_valid,
                    c_addr=c_addr,
                    c_sum=c_sum,
                )
            )
            m.d.comb += rd.addr.eq(Mux(self.scanning, self._scan_addr, addr))
            m.d.comb += rd.en.eq(self._read_en)
            m.d.sync += [
                b_valid.eq(Cat(*sel).any()),
                b_addr.eq(addr),
                b_delta.eq(delta),
                c_valid.eq(b_valid),
                c_addr.eq(b_addr),
                c_sum.eq(total),
            ]
            # the write of the beat before (C) is not in the read B got; a clear writes
            # zero (b_delta is zero while scanning)
            base = Mux(c_valid & (c_addr == b_addr), c_sum, Mux(self._clear[b], 0, rd.data))
            m.d.comb += [
                total.eq(base + b_delta),
                wr.addr.eq(Mux(self._clear[b], self._scan_addr, b_addr)),
                wr.data.eq(total),
                wr.en.eq(self._clear[b] | b_valid),
            ]

    def _control(self, m, ports, o_valid, advance, accept):
        """Input acceptance, the polygon's span and the rows it touched, the scan, and the
        output register."""
        tile, p = self._tile, self.ops.payload
        first = Signal()
        out = self.cells.payload
        o = {name: Signal.like(out[name]) for name in ("op", "x", "y", "first", "start")}
        o["sel"] = Signal(range(BANKS))  # the bank whose read data is the cell's sum
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
        with m.If(accept & (p.op == OP["beat"])):
            m.d.sync += [
                dirty.eq(dirty | (self._touched_set != 0)),
                touched.eq(touched | self._touched_set),
                lo.eq(Mux(self._beat_lo < lo, self._beat_lo, lo)),
                hi.eq(Mux(self._beat_hi > hi, self._beat_hi, hi)),
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
                m.d.comb += self.ops.ready.eq(advance & ~(check & dirty))
                with m.If(check & dirty):  # deltas left by a reset mid-polygon
                    m.next = "CLEAR"
                with m.If(accept):
                    self._take(m, p, o, o_valid, params, background, first)
                    with m.If(p.op == OP["end"]):
                        m.next = "WAIT"
            self._scan(m, o, o_valid, advance, first)
            self.observe.in_acc, self.observe.in_wait = fsm.ongoing("ACC"), fsm.ongoing("WAIT")
        self._output(m, ports, o, params, background)

    def _scan(self, m, o, o_valid, advance, first):
        """WAIT and SCAN: the touched rows in ascending order, a row seen since the tile
        started from ``lo`` to ``hi`` and on to the last column when its sum through ``hi``
        is nonzero (`edgeaa.model.tile`, "Scan span"), a row not seen yet whole."""
        tile, obs = self._tile, self.observe
        lo, hi, touched, seen = obs.lo, obs.hi, obs.touched, obs.seen
        last = tile.width - 1
        scan_x, scan_y = Signal(tile.x_bits), Signal(tile.y_bits)
        scan_addr = Cat(scan_x[2:], scan_y)  # the cell's address in its bank
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
                bank = bank_of(scan_x, scan_y)
                m.d.comb += self._clear.eq(1 << bank)
                m.d.sync += [
                    o_valid.eq(~stop),
                    o["op"].eq(CELL_OP["cell"]),
                    o["x"].eq(scan_x),
                    o["y"].eq(scan_y),
                    o["first"].eq(first),
                    o["start"].eq(row_start),
                    o["sel"].eq(bank),
                    first.eq(0),
                    row_start.eq(0),
                    scan_x.eq(scan_x + 1),
                    decide.eq(partial & (scan_x == hi) & (hi != last)),
                ]
                with m.If(stop | (scan_x == last)):
                    choose()
                    with m.If(touched == 0):
                        done()
        with m.State("CLEAR"):  # after a reset: zero to every cell, four a clock, no output
            m.d.comb += [self._clear.eq((1 << BANKS) - 1), self._scan_addr.eq(scan_addr)]
            m.d.sync += scan_x.eq(scan_x + BANKS)
            with m.If(scan_x == tile.width - BANKS):
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

    def _output(self, m, ports, o, params, background):
        out = self.cells.payload
        data = ports[0][0].data
        for b in range(1, BANKS):
            data = Mux(o["sel"] == b, ports[b][0].data, data)
        m.d.comb += [
            out.op.eq(o["op"]),
            out.x.eq(o["x"]),
            out.y.eq(o["y"]),
            out.first.eq(o["first"]),
            out.start.eq(o["start"]),
            out.sum.eq(data),
            out.background.eq(background),
            *(out[name].eq(reg) for name, reg in params.items()),
        ]
