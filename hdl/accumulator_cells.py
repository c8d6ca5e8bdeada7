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

from amaranth.hdl import Cat, Const, Mux, Signal, signed

from .layouts import TILE_OP, log2

__all__ = ["read_modify_write", "route_cell", "route_pair", "route_quad"]


def _select(sel, values):
    """The value of `values` (four, of one shape) whose bit of the one-hot 4-bit `sel` is set,
    zero when none: three selects (``hi``: value 2 or 3; ``a``: 0 or 3; ``b``: 1 or 3) and
    ``low``, value 0's or 1's bit or zero, or (when ``hi``) the choice of value 3 over 2 (why
    this form: docs/hardware.md, "Accumulation memory")."""
    hi, a, b = sel[2] | sel[3], sel[0] | sel[3], sel[1] | sel[3]
    v0, v1, v2, v3 = values
    low = Mux(a, Mux(b, Const(-1, v0.shape()), v0), Mux(b, v1, 0))
    return Mux(hi, (low & v3) | (~low & v2), low)


def _beat_source(m, unit):
    """The tile op's origin register, the beat's cells and their ``done`` (taken in earlier
    clocks) and ``pending`` (nonzero, not yet taken) masks."""
    p = unit.ops.payload
    x0, y0 = Signal.like(p.x0), Signal.like(p.y0)  # the origin, set by a tile op
    with m.If(unit.ops.valid & unit.ops.ready & (p.op == TILE_OP["tile"])):
        m.d.sync += [x0.eq(p.x0), y0.eq(p.y0)]
    cells = [p.beat[f"cell{j}"] for j in range(4)]
    done = Signal(4)  # the beat's cells taken in earlier clocks
    pending = Signal(4)
    m.d.comb += pending.eq(p.beat.nonzero & ~done)  # the core's flags: no compare here
    return (x0, y0), cells, done, pending


def _take(m, unit, free, done, sel, last):
    """``taking``: a clock of a beat, its cells `sel` (none: an all-zero beat); `done`
    follows, cleared with the beat's `last`."""
    p = unit.ops.payload
    taking = Signal()
    m.d.comb += [
        taking.eq(unit.ops.valid & free & (p.op == TILE_OP["beat"])),
        unit.busy.eq((unit.ops.valid & unit.ops.ready) | taking | unit.scanning),
    ]
    with m.If(taking):
        m.d.sync += done.eq(Mux(last, 0, done | sel))
    return taking


def route_cell(m, unit, free) -> types.SimpleNamespace:
    """The cell taken this clock (one lane): the beat's lowest nonzero cell not yet taken,
    moved into the tile (``keep``: it is inside after the move; ``x``, ``y`` tile
    coordinates), ``last`` when no other waits (the beat is taken with it), ``done`` the
    cells taken in earlier clocks."""
    tile = unit.tile
    (x0, y0), cells, done, pending = _beat_source(m, unit)
    sel = (pending & -pending)[:4]  # the lowest (as `lowest_set`; fewer LUT4s here)
    # at most one cell waits: a function of `pending` alone, not behind `sel`'s carry chain
    # (Fmax: ``last`` is on the way to ``ops.ready`` and the core's enable)
    p0, p1, p2, p3 = pending
    last = ~((p0 & (p1 | p2 | p3)) | (p1 & (p2 | p3)) | (p2 & p3))
    taking = _take(m, unit, free, done, sel, last)
    # every cell's place in the tile is formed from the beat's coordinates beside its
    # nonzero flags, and `sel` picks one: the subtractions and compares are not behind the
    # pick (Fmax: compact's critical path ran flags, pick, subtraction, compare)
    places = [_place(m, tile, c, x0, y0, k) for k, c in enumerate(cells)]
    inside, col, row = (_select(sel, [p[j] for p in places]) for j in range(3))
    keep = taking & inside  # zero when `sel` picks none
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
        cell.x.eq(col),
        cell.y.eq(row),
        cell.delta.eq(Mux(keep, _select(sel, [c.delta for c in cells]), 0)),
    ]
    unit.observe.__dict__.update(origin=(x0, y0), cell=cell)
    return cell


def route_pair(m, unit, free) -> types.SimpleNamespace:
    """The cells taken this clock with two lanes (a memory bank per column parity,
    `edgeaa.model.tile.beat_clocks`): the pair (0, 1) while either waits, else (2, 3), both
    at once unless they clash (both kept, one bank, two cells: then the first, and the second
    the clock after). ``banks``: per bank, the cell it adds this clock (``keep``, tile ``x``
    and ``y``, ``delta``: the pair's two deltas added when both land on that one cell);
    ``keep`` when either bank keeps one; ``last`` and ``done`` as `route_cell`'s."""
    tile = unit.tile
    (x0, y0), cells, done, pending = _beat_source(m, unit)
    first = pending[0] | pending[1]  # the pair taken: (0, 1), then (2, 3)
    wait = Mux(first, pending[:2], pending[2:])
    # Every cell's place in the tile and each pair's bank clash are formed from the beat's
    # coordinates alone, beside its nonzero flags, and `first` picks the pair's last: its
    # flags are not in front of the subtractions on the way to ``ops.ready`` (Fmax).
    places = [_place(m, tile, c, x0, y0, k) for k, c in enumerate(cells)]
    clashes = [_clash(places[j], places[j + 1]) for j in (0, 2)]
    pair = []
    for j in range(2):
        (in_a, x_a, y_a), (in_b, x_b, y_b) = places[j], places[j + 2]
        col = Signal(tile.x_bits, name=f"pair{j}_x")
        m.d.comb += col.eq(Mux(first, x_a, x_b))
        inside, row = Mux(first, in_a, in_b), Mux(first, y_a, y_b)
        delta = Mux(first, cells[j].delta, cells[j + 2].delta)
        pair.append((wait[j] & inside, col, row, delta))
    (k0, _, _, _), (k1, _, _, _) = pair
    clash = k0 & k1 & Mux(first, clashes[0], clashes[1])
    take = Cat(wait[0], wait[1] & ~clash)
    sel = Cat(Mux(first, take, 0), Mux(first, 0, take))
    last = (pending & ~sel) == 0
    taking = _take(m, unit, free, done, sel, last)
    banks = []
    for k in range(2):
        hits = [taking & take[j] & kept & (x[0] == k) for j, (kept, x, _, _) in enumerate(pair)]
        cell = types.SimpleNamespace(
            keep=Signal(name=f"bank{k}_keep"),
            # kept if the beat is taken this clock: the payload's alone (no ``taking``, so
            # the sink's ready is not in front of the span's compares: Fmax)
            want=Signal(name=f"bank{k}_want"),
            x=Signal(tile.x_bits, name=f"bank{k}_x"),
            y=Signal(tile.y_bits, name=f"bank{k}_y"),
            delta=Signal(signed(tile.cell_bits), name=f"bank{k}_delta"),
        )
        wants = [take[j] & kept & (x[0] == k) for j, (kept, x, _, _) in enumerate(pair)]
        m.d.comb += [
            cell.want.eq(wants[0] | wants[1]),
            cell.keep.eq(hits[0] | hits[1]),
            cell.x.eq(Mux(hits[0], pair[0][1], pair[1][1])),
            cell.y.eq(Mux(hits[0], pair[0][2], pair[1][2])),
            cell.delta.eq(Mux(hits[0], pair[0][3], 0) + Mux(hits[1], pair[1][3], 0)),
        ]
        banks.append(cell)

    def span(lo, hi):  # the banks' cells in turn
        for c in banks:
            lo = Mux(c.want & (c.x < lo), c.x, lo)
            hi = Mux(c.want & (c.x > hi), c.x, hi)
        return lo, hi

    out = types.SimpleNamespace(
        banks=banks, keep=banks[0].keep | banks[1].keep, last=last, done=done, span=span
    )
    unit.observe.__dict__.update(origin=(x0, y0), cell=out)
    return out


def route_quad(m, unit, free) -> types.SimpleNamespace:
    """The cells taken this clock with four lanes (a memory bank per column modulo 4,
    `edgeaa.model.tile.beat_clocks`): every bank takes its lowest waiting kept cell (its
    *lead*) and the waiting cells at that same cell, their deltas added; waiting cells not
    kept go at once. ``banks``, ``keep``, ``last`` and ``done`` as `route_pair`'s."""
    tile = unit.tile
    (x0, y0), cells, done, pending = _beat_source(m, unit)
    # places, banks and which cells are one cell: from the beat's coordinates alone, beside
    # its flags (Fmax, as `route_pair`)
    places = [_place(m, tile, c, x0, y0, k) for k, c in enumerate(cells)]
    bank = [x[:2] for _, x, _ in places]
    same = {
        (j, k): (places[j][1] == places[k][1]) & (places[j][2] == places[k][2])
        for k in range(4)
        for j in range(k)
    }
    kept = [pending[k] & places[k][0] for k in range(4)]
    lead = [kept[k] & ~_any(kept[j] & (bank[j] == bank[k]) for j in range(k)) for k in range(4)]
    take = [kept[k] & (lead[k] | _any(lead[j] & same[j, k] for j in range(k))) for k in range(4)]
    sel = Cat(*(take[k] | (pending[k] & ~places[k][0]) for k in range(4)))
    last = (pending & ~sel) == 0
    taking = _take(m, unit, free, done, sel, last)
    banks = []
    for b in range(4):
        leads = [lead[k] & (bank[k] == b) for k in range(4)]
        # zero unless taken: a scan's clear writes stage B's delta (`read_modify_write`)
        adds = [taking & take[k] & (bank[k] == b) for k in range(4)]
        cell = types.SimpleNamespace(
            keep=Signal(name=f"bank{b}_keep"),
            want=Signal(name=f"bank{b}_want"),  # as `route_pair`'s: without ``taking``
            x=Signal(tile.x_bits, name=f"bank{b}_x"),
            y=Signal(tile.y_bits, name=f"bank{b}_y"),
            delta=Signal(signed(tile.cell_bits), name=f"bank{b}_delta"),
        )
        m.d.comb += [
            cell.want.eq(_any(leads)),
            cell.keep.eq(taking & cell.want),
            cell.x.eq(_select(Cat(*leads), [x for _, x, _ in places])),
            cell.y.eq(_select(Cat(*leads), [y for _, _, y in places])),
            cell.delta.eq(sum(Mux(adds[k], cells[k].delta, 0) for k in range(4))),
        ]
        banks.append(cell)

    def span(lo, hi):
        # every kept cell of the beat, taken this clock or later in it (the span ends the
        # same): not behind the banks' picks, and a tree of compares, not a chain (Fmax)
        xs = [x for _, x, _ in places]
        low = _tree(lambda a, b: Mux(a < b, a, b), [lo, *map(Mux, kept, xs, [lo] * 4)])
        high = _tree(lambda a, b: Mux(a > b, a, b), [hi, *map(Mux, kept, xs, [hi] * 4)])
        return low, high

    out = types.SimpleNamespace(
        banks=banks, keep=_any(c.keep for c in banks), last=last, done=done, span=span
    )
    unit.observe.__dict__.update(origin=(x0, y0), cell=out)
    return out


def _tree(pick, values):
    """`values` reduced pairwise by `pick` (of two), in a balanced tree."""
    while len(values) > 1:
        pairs = [pick(a, b) for a, b in zip(values[::2], values[1::2], strict=False)]
        values = pairs + values[len(pairs) * 2 :]
    return values[0]


def _any(bits):
    """The OR of `bits` (0 when none)."""
    return Cat(Const(0, 1), *bits).any()


def _place(m, tile, cell, x0, y0, k: int):
    """Cell `k` of a beat in the tile: (inside: not right of, above or below it; its column,
    one left of the tile moved into column 0; its row)."""
    tx, ty = cell.x - x0, cell.y - y0
    col = Signal(tile.x_bits, name=f"cell{k}_x")
    m.d.comb += col.eq(Mux(tx < 0, 0, tx))
    inside = (ty >= 0) & (ty < tile.height) & (tx < tile.width)
    return inside, col, ty[: tile.y_bits]


def _clash(a, b):
    """Two `_place`d cells in one bank (column parity) but not one cell: they take two
    clocks when both are kept."""
    (_, x_a, y_a), (_, x_b, y_b) = a, b
    return (x_a[0] == x_b[0]) & ((x_a != x_b) | (y_a != y_b))


def read_modify_write(m, unit, rd, wr, cell):
    """Read-modify-write in two stages: A (the cell is taken; read it), B (add the delta to
    what was read, or to the sum of the cell before if it wrote the same cell last clock,
    which the read did not see; write the sum). Stage B's delta is zero when it holds no
    cell, so a scan's clear is the same add with the read forced to zero. `unit._clear`
    (the scan's) takes the write port when set and writes zero at `unit._scan_addr`. `rd` and
    `wr` may be lists, a port of each lane's memory (banked by column modulo the lanes):
    then `cell` is `route_pair`'s or `route_quad`'s and each bank runs its own stages on its cell
    (`_stages`), and a clear zeroes every lane's word at the beat `unit._scan_addr`."""
    tile = unit.tile
    addr_bits = tile.x_bits + tile.y_bits  # a cell's full address (lanes: bank and word)
    unit._scan_addr = Signal(addr_bits)
    unit._clear = Signal()
    unit._read_en = Signal()
    if isinstance(rd, list):
        low = log2(len(rd))  # the bank: the column's low bits
        banks = zip(rd, wr, cell.banks, strict=True)
        unit.observe.stages = [
            _stages(m, unit, r, w, bank, Cat(bank.x[low:], bank.y), unit._scan_addr[low:], k)
            for k, (r, w, bank) in enumerate(banks)
        ]
    else:
        addr = Cat(cell.x, cell.y)
        unit.observe.stages = [_stages(m, unit, rd, wr, cell, addr, unit._scan_addr)]


def _stages(m, unit, rd, wr, cell, addr, scan_addr, bank: int | None = None):
    """Stages A and B and their forwarding on `cell` through one memory's ports, `addr` the
    cell's address in it and `scan_addr` the scan's (bank `bank`'s: the column's bank bit
    dropped; the one memory's: the full address). Returns the stages for the formal harness,
    the addresses full (bank and word) and ``read`` the read data."""
    name = "" if bank is None else f"bank{bank}_"
    b_valid = Signal(name=f"{name}b_valid")
    b_addr = Signal(len(addr), name=f"{name}b_addr")
    b_delta = Signal(signed(unit.tile.cell_bits), name=f"{name}b_delta")
    c_valid = Signal(name=f"{name}c_valid")
    c_addr = Signal(len(addr), name=f"{name}c_addr")
    c_sum = Signal.like(b_delta, name=f"{name}c_sum")
    total = Signal.like(b_delta, name=f"{name}total")
    m.d.comb += [
        rd.addr.eq(Mux(unit.scanning, scan_addr, addr)),
        rd.en.eq(unit._read_en),
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
    base = Mux(c_valid & (c_addr == b_addr), c_sum, Mux(unit._clear, 0, rd.data))
    m.d.comb += total.eq(base + b_delta)
    m.d.comb += [
        wr.addr.eq(Mux(unit._clear, scan_addr, b_addr)),
        wr.data.eq(total),
        wr.en.eq(unit._clear | b_valid),
    ]

    def full(address):  # a bank's word with its bank bits: the cell's full address
        return address if bank is None else Cat(Const(bank, log2(unit.lanes)), address)

    return types.SimpleNamespace(
        b_valid=b_valid,
        b_addr=full(b_addr),
        b_delta=b_delta,
        c_valid=c_valid,
        c_addr=full(c_addr),
        c_sum=c_sum,
        read=rd.data,
    )
