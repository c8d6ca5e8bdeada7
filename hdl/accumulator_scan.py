"""The accumulator's scan (`edgeaa.hdl.accumulator.TileAccumulator`): the states WAIT, SCAN
and CLEAR of its state machine.

`scan_states` reads, after a polygon's end, the rows it touched in ascending order, each cell
cleared as it is read, and after a reset mid-polygon clears the whole memory. It takes the
accumulator (its ports, tile and ``observe`` registers) and adds the states inside the
caller's ``m.FSM()``; docs/hardware.md, "Polygon pipeline", Accumulation memory, tells it
clock by clock.
"""

from __future__ import annotations

from amaranth.hdl import Cat, Const, Signal

from .layouts import CELL_OP, log2

__all__ = ["lowest_set", "scan_states"]


def lowest_set(bits: Signal, width: int):
    """Index of the lowest set bit of the `width`-bit `bits` (0 when none) and that bit alone
    (one-hot, 0 when none): ``bits & ~(bits - 1)`` and an OR per index bit (why not ``bits &
    -bits``: docs/hardware.md, "Accumulation memory")."""
    one_hot = (bits & ~(bits - 1))[:width]
    index = Cat(
        *(Cat(*(one_hot[k] for k in range(width) if k >> j & 1)).any() for j in range(log2(width)))
    )
    return index, one_hot


def scan_states(m, unit, o, o_valid, advance, first):
    """WAIT and SCAN: the touched rows in ascending order, each from ``lo`` to ``hi`` and on
    to the last column when its sum through ``hi`` is nonzero (`edgeaa.model.tile`, "Scan
    span"); in beats of ``unit.lanes`` cells (``scan_x`` a multiple of the lanes, the span
    widened to them)."""
    tile, obs, lanes = unit.tile, unit.observe, unit.lanes
    lo, hi, touched = obs.lo, obs.hi, obs.touched
    last = tile.width - 1
    last_beat = tile.width - lanes  # the row's last beat (its first column)
    if lanes > 1:  # lo and hi down to their beats' first columns
        low = log2(lanes)
        lo, hi = Cat(Const(0, low), lo[low:]), Cat(Const(0, low), hi[low:])
    scan_x, scan_y = Signal(tile.x_bits), Signal(tile.y_bits)
    scan_addr = Cat(scan_x, scan_y)
    row_start = Signal()  # the next read is the row's first
    decide = Signal()  # the cell waiting is the row's hi: the row may stop there
    total = obs.total
    # the next row to scan and its bit, taken out of `touched` when it is chosen
    next_y, next_bit = lowest_set(touched, tile.height)

    def choose():
        m.d.sync += [
            scan_x.eq(lo),
            scan_y.eq(next_y),
            row_start.eq(1),
            touched.eq(touched & ~next_bit),
        ]

    def done():
        m.d.sync += [obs.lo.eq(last), obs.hi.eq(0), obs.dirty.eq(0)]
        m.next = "ACC"

    with m.State("WAIT"):  # the last beat's write landed in the clock before
        choose()
        m.next = "ACC"
        with m.If(touched != 0):
            m.next = "SCAN"
    with m.State("SCAN"):
        m.d.comb += [unit.scanning.eq(1), unit._scan_addr.eq(scan_addr)]
        with m.If(advance):
            # the cell waiting is the row's hi and the sum through it is 0: the row stops,
            # and this clock's read (hi + 1, a zero cell: its clear changes nothing) is
            # not sent
            # (two lanes: `_sum_is`, carry-free for the ECP5's Fmax; compact keeps the
            # compare, its HX8K fit measured with it)
            stop = decide & ((total == 0) if lanes == 1 else obs.cancels)
            m.d.comb += unit._clear.eq(1)
            m.d.sync += [
                o_valid.eq(~stop),
                o["op"].eq(CELL_OP["cell"]),
                o["x"].eq(scan_x),
                o["y"].eq(scan_y),
                o["first"].eq(first),
                o["start"].eq(row_start),
                first.eq(0),
                row_start.eq(0),
                scan_x.eq(scan_x + lanes),
                decide.eq((scan_x == hi) & (hi != last_beat)),
            ]
            with m.If(stop | (scan_x == last_beat)):
                choose()
                with m.If(touched == 0):
                    done()
    with m.State("CLEAR"):  # after a reset: zero to every cell, a beat a clock, no output
        m.d.comb += [unit._clear.eq(1), unit._scan_addr.eq(scan_addr)]
        m.d.sync += scan_x.eq(scan_x + lanes)
        with m.If(scan_x == last_beat):
            m.d.sync += scan_y.eq(scan_y + 1)
            with m.If(scan_y == tile.height - 1):
                m.d.sync += [scan_x.eq(0), scan_y.eq(0), obs.dirty.eq(0)]
                m.next = "ACC"
    obs.__dict__.update(scan_x=scan_x, scan_y=scan_y, row_start=row_start, decide=decide)
