"""The accumulator's input side (`edgeaa.hdl.accumulator.TileAccumulator`): a delta beat's
cells taken one a clock into the accumulation memory.

`route_cell` picks the beat's lowest nonzero cell not yet taken and moves it into the tile;
`read_modify_write` adds its delta to the memory in two stages (read, then add and write, with
the write of the clock before forwarded). Each takes the accumulator (its ports, tile and
``observe`` namespace) and adds its logic to the module; docs/hardware.md, "Polygon
pipeline", Accumulation memory, tells it clock by clock.
"""

from __future__ import annotations

import types

from amaranth.hdl import Array, Cat, Const, Mux, Signal, signed

from .layouts import TILE_OP, log2

__all__ = ["read_modify_write", "route_cell"]


def _select(sel, values):
    """The value of `values` (four, of one shape) whose bit of the one-hot 4-bit `sel` is set,
    zero when none: three selects (``hi``: value 2 or 3; ``a``: 0 or 3; ``b``: 1 or 3) and
    ``low``, value 0's or 1's bit or zero, or (when ``hi``) the choice of value 3 over 2 (why
    this form: docs/hardware.md, "Accumulation memory")."""
    hi, a, b = sel[2] | sel[3], sel[0] | sel[3], sel[1] | sel[3]
    v0, v1, v2, v3 = values
    low = Mux(a, Mux(b, Const(-1, v0.shape()), v0), Mux(b, v1, 0))
    return Mux(hi, (low & v3) | (~low & v2), low)


def route_cell(m, unit, free) -> types.SimpleNamespace:
    """The cell taken this clock: the beat's lowest nonzero cell not yet taken, moved into
    the tile (``keep``: it is inside after the move; ``x``, ``y`` tile coordinates),
    ``last`` when no other waits (the beat is taken with it), ``done`` the cells taken in
    earlier clocks."""
    tile, p = unit.tile, unit.ops.payload
    x0, y0 = Signal.like(p.x0), Signal.like(p.y0)  # the origin, set by a tile op
    with m.If(unit.ops.valid & unit.ops.ready & (p.op == TILE_OP["tile"])):
        m.d.sync += [x0.eq(p.x0), y0.eq(p.y0)]
    cells = [p.beat[f"cell{j}"] for j in range(4)]
    done = Signal(4)  # the beat's cells taken in earlier clocks
    pending = Signal(4)
    m.d.comb += pending.eq(Cat(*(c.delta != 0 for c in cells)) & ~done)
    sel = (pending & -pending)[:4]  # the lowest (as `lowest_set`; fewer LUT4s here)
    last = (pending & ~sel) == 0
    taking = Signal()  # a clock of a beat: its cell `sel` (none: an all-zero beat)
    m.d.comb += [
        taking.eq(unit.ops.valid & free & (p.op == TILE_OP["beat"])),
        unit.busy.eq((unit.ops.valid & unit.ops.ready) | taking | unit.scanning),
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
    unit.observe.__dict__.update(origin=(x0, y0), cell=cell)
    return cell


def read_modify_write(m, unit, rd, wr, cell):
    """Read-modify-write in two stages: A (the cell is taken; read it), B (add the delta to
    what was read, or to the sum of the cell before if it wrote the same cell last clock,
    which the read did not see; write the sum). Stage B's delta is zero when it holds no
    cell, so a scan's clear is the same add with the read forced to zero. `unit._clear`
    (the scan's) takes the write port when set and writes zero at `unit._scan_addr`. `rd` and
    `wr` may be lists, a port of each lane's memory (banked by column modulo the lanes): B
    takes its lane's read data, writes its lane's memory, and a clear zeroes every lane's
    word at the beat `unit._scan_addr`."""
    tile = unit.tile
    addr_bits = tile.x_bits + tile.y_bits  # a cell's full address (lanes: bank and word)
    unit._scan_addr = Signal(addr_bits)
    unit._clear = Signal()
    unit._read_en = Signal()
    addr = Cat(cell.x, cell.y)
    b_valid, b_addr, b_delta = Signal(), Signal(addr_bits), Signal(signed(tile.cell_bits))
    c_valid, c_addr, c_sum = Signal(), Signal(addr_bits), Signal.like(b_delta)
    total = Signal.like(b_delta)
    unit.observe.stage = types.SimpleNamespace(
        b_valid=b_valid,
        b_addr=b_addr,
        b_delta=b_delta,
        c_valid=c_valid,
        c_addr=c_addr,
        c_sum=c_sum,
    )
    lanes = rd if isinstance(rd, list) else None  # a memory per lane, banked by column
    if lanes is None:
        m.d.comb += [
            rd.addr.eq(Mux(unit.scanning, unit._scan_addr, addr)),
            rd.en.eq(unit._read_en),
        ]
        read = rd.data
    else:
        lane_bits = log2(len(lanes))
        read = Array(port.data for port in lanes)[b_addr[:lane_bits]]  # the lane B read
        unit.observe.read = types.SimpleNamespace(data=read)  # as one memory's read port
        for port in lanes:
            m.d.comb += [
                port.addr.eq(Mux(unit.scanning, unit._scan_addr, addr)[lane_bits:]),
                port.en.eq(unit._read_en),
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
    base = Mux(c_valid & (c_addr == b_addr), c_sum, Mux(unit._clear, 0, read))
    m.d.comb += total.eq(base + b_delta)
    if lanes is None:
        m.d.comb += [
            wr.addr.eq(Mux(unit._clear, unit._scan_addr, b_addr)),
            wr.data.eq(total),
            wr.en.eq(unit._clear | b_valid),
        ]
        return
    # a clear zeroes a beat (every lane's word); stage B writes its cell's lane
    for j, port in enumerate(wr):
        m.d.comb += [
            port.addr.eq(Mux(unit._clear, unit._scan_addr, b_addr)[lane_bits:]),
            port.data.eq(total),
            port.en.eq(unit._clear | (b_valid & (b_addr[:lane_bits] == j))),
        ]
