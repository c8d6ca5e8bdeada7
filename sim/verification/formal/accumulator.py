# amaranth: UnusedElaboratable=no
"""The accumulator's ``deltas`` and ``sums`` groups and their invariants (`check_cells`), for
`tile.TileHarness`.

``accumulator`` ``deltas``
    One symbolic cell (X, Y) of the tile (``AnyConst``). Beats are any four cells (repeats
    included). Asserted: each beat is taken in the clocks `edgeaa.model.tile.beat_clocks`
    gives it (a nonzero cell a clock, by pairs with two scan lanes: `_ghost_sel`); (X, Y) is
    sent after an end, before the accumulator takes another op, when a nonzero delta was
    kept there since the previous end (the model's
    `tile_cells`: the origin of the last tile op subtracted, a cell left of the tile moved
    into column 0), and at most once per end (nothing lost, nothing doubled); the cells come
    in rows, each row's cells in consecutive columns from its first (``start``), the rows
    ascending; a row stops before its
    last column only when the sums it sent add to zero (modulo ``2**cell_bits``), so right
    of it the prefix sum is zero; ``first`` on the polygon's first cell only, a row's first,
    with the end's intensity, I_out and fill rule; each tile and flush op comes out once, in
    order, with its background; no other op code is sent.
``accumulator`` ``sums``
    The shadow of cell (X, Y): the exact sum of every delta of an accepted beat placed there
    (back-to-back cells to one address through the read-modify-write forwarding) since
    (X, Y) was last sent, modulo ``2**cell_bits`` (a cell's width). Asserted: each (X, Y)
    sent carries the shadow, all ``cell_bits`` bits, and the shadow restarts from 0 (the
    clear).

Invariants. ``sums`` (`_memory_state`, each bank's stages with two scan lanes): the
memory's row of (X, Y) plus stage B's delta for
its address plus the output's sum while (X, Y) waits in the output register equals the
shadow; stage C's sum is in the memory (written the clock before), stage B's read is the
memory's row unless stage C wrote that row the clock before (then B takes C's sum: the
forwarding), stage B only in ACC, stage C never in SCAN, a cell in the output register is
cleared in the memory and stage B is then empty, stage B's delta is zero when it is empty (a
clear adds it), and a nonzero (X, Y) is hit (ACC) or owed (after an end) or waits in the
output register (so the read past a row's ``hi``, not sent, clears a zero). The scan's
(`_scan_state`, in both groups): a beat taken in part (``done``) is held by the source in
ACC, and its cells taken are the ghost's; in ACC a hit (X, Y) lies in a touched row and in
the span ``lo .. hi``, and any row is touched exactly when the ghost kept a delta; in WAIT
and SCAN the ghost saw no beat and no beat is taken in part; (X, Y) owed waits in the output
register (ACC), lies in the span of a touched row (WAIT), or waits, or lies in the span of a
row still to scan or ahead of the scan in the current row (SCAN), and a cell still to read
has not been sent since the end; the rows left to scan are above the scan row; SCAN's first
read has not happened exactly while the ``first`` register is set (nothing in the output
register, a row's start due), else a cell waits there or, after a row stopped at ``hi``, the
next row's start is due above the last cell sent; a row's start is at ``lo``; the scan
position follows the waiting cell; ``decide`` only with that cell at ``hi`` below the last
column; the waiting cell's ``first`` is the ghost's, a row's start, and follows the last
cell sent; ``rsum`` is the ghost's sum of the row's cells sent, and the
last row sent is closed (at its last column, or that sum zero) whenever no cell of it is
still to come; the end's fields are the ghost's; a tile or flush op waits exactly when the
ghost's does, with its code and background. Both: the origin is the ghost's. Each follows
from all of them in the clock before (`TILE_PROOFS` runs k = 2).
"""

from __future__ import annotations

import types

from amaranth.asserts import AnyConst
from amaranth.hdl import Array, Assert, Cat, Const, Mux, Signal

from ....hdl.layouts import CELL_OP, cell_sum_fields
from ....hdl.layouts import TILE_OP as OP
from ....model.beat import CELLS
from ....model.tile import RESOLVE_OPS
from .spec import all_, implies
from .tile_common import When, any_, follows, state_checks, track_rows

__all__ = ["check_cells", "nonzero_flags"]


def check_cells(m, tile, dut, payload, held_in, read, checks, *, invariants, covers, cells=None):
    """The ``deltas`` and ``sums`` groups of `checks` on `dut` (a `TileAccumulator`) given the
    source's `payload` and its held flag `held_in`; with `invariants`, also the invariants
    that make them inductive (`read`: the harness's reader of the memory, for ``sums``);
    `cells`: the output stream as the groups see it (None: the accumulator's; fault
    ``swap_cells``)."""
    cells = dut.cells if cells is None else cells
    s = _accumulator_deltas(m, tile, dut, payload, cells, checks)
    s.held_in = held_in
    if invariants:
        _accumulator_invariants(m, tile, dut, read, s, checks, covers)


def _beat_of(x, lanes: int):
    """The first column of the beat of `lanes` cells holding column `x`."""
    low = lanes.bit_length() - 1
    return x if lanes == 1 else Cat(Const(0, low), x[low:])


def _sum_at(out, x, lanes: int):
    """The sum a beat of cells (`out`) carries for column `x` (in the beat)."""
    if lanes == 1:
        return out.sum
    return Array(out[name] for name in cell_sum_fields(lanes))[x[: lanes.bit_length() - 1]]


def _beat_sum(out, lanes: int):
    """The sum of a beat's cells (modulo a cell's width, as the accumulator adds them)."""
    sums = [out[name] for name in cell_sum_fields(lanes)]
    return sum(sums[1:], start=sums[0])


def _placed(tile, beat, origin):
    """Per cell of `beat`: (kept, tile x, tile y, delta), the model's `tile_cells`."""
    out = []
    for name in CELLS:
        cell = beat[name]
        tx, ty = cell.x - origin[0], cell.y - origin[1]
        keep = (ty >= 0) & (ty < tile.height) & (tx < tile.width) & (cell.delta != 0)
        out.append((keep, Mux(tx < 0, 0, tx), ty, cell.delta))
    return out


def nonzero_flags(beat):
    """The ``nonzero`` field a beat's deltas give (bit k: cell k's delta is not zero)."""
    return Cat(*(beat[c].delta != 0 for c in CELLS))


def _ghost_sel(pending, placed, lanes: int):
    """The cells of the beat the ghost counts this clock, from its `pending` ones (nonzero, not
    yet counted), as `edgeaa.model.tile.beat_clocks` times them: one lane, the lowest; two,
    the pair (0, 1) while either is pending, else (2, 3), both unless they clash (both kept
    at two cells of one column parity: then the first); four, `_ghost_sel_banks`."""
    if lanes == 1:
        return (pending & -pending)[:4]
    if lanes == 4:
        return _ghost_sel_banks(pending, placed)
    takes = []
    for a in (0, 2):
        (ka, xa, ya, _), (kb, xb, yb, _) = placed[a], placed[a + 1]
        both = pending[a] & pending[a + 1] & ka & kb
        clash = both & (xa[0] == xb[0]) & ((xa != xb) | (ya != yb))
        takes.append(Cat(pending[a], pending[a + 1] & ~clash))
    first = pending[0] | pending[1]
    return Mux(first, Cat(takes[0], Const(0, 2)), Cat(Const(0, 2), takes[1]))


def _ghost_sel_banks(pending, placed):
    """Four lanes (a bank per column modulo 4): the cells not kept at once; of the kept, in
    each bank the lowest pending one and those at its cell, so a beat takes as many clocks as
    its busiest bank has cells."""
    kept = [pending[k] & keep for k, (keep, _, _, _) in enumerate(placed)]
    bank = [x[:2] for _, x, _, _ in placed]

    def one_cell(j, k):
        return (placed[j][1] == placed[k][1]) & (placed[j][2] == placed[k][2])

    lowest = [kept[k] & ~any_(kept[j] & (bank[j] == bank[k]) for j in range(k)) for k in range(4)]
    taken = [
        kept[k] & (lowest[k] | any_(lowest[j] & one_cell(j, k) for j in range(k))) for k in range(4)
    ]
    return Cat(*(taken[k] | (pending[k] & ~placed[k][0]) for k in range(4)))


def _ghost_cells(m, tile, dut, src, s, checks):
    """The ghost takes a beat's nonzero cells (of the source's payload `src`) as the model
    times them (`_ghost_sel`: one a clock in cell order, or by pairs with two scan lanes), in
    the clocks the accumulator takes cells (``busy`` outside a scan with a beat offered; the
    port's meaning), and asserts that the beat is taken with its last: so it counts every
    cell of every beat taken, once. Returns, per cell, whether the ghost counts it this clock
    and where it lands (kept, x, y, delta: `_placed`)."""
    ops = dut.ops
    done = Signal(4, name="ghost_done")
    pending = Signal(4, name="ghost_pending")
    m.d.comb += pending.eq(nonzero_flags(src.beat) & ~done)
    placed = _placed(tile, src.beat, s.origin)
    sel = _ghost_sel(pending, placed, dut.lanes)
    last = (pending & ~sel) == 0
    taking = dut.busy & ~dut.scanning & ops.valid & (src.op == OP["beat"])
    with m.If(taking):
        m.d.sync += done.eq(Mux(last, 0, done | sel))
    take_beat = ops.valid & ops.ready & (src.op == OP["beat"])
    if "deltas" in checks or "sums" in checks:
        m.d.comb += Assert(take_beat == (taking & last), "cells: a beat taken with its last cell")
    s.ghost_done = done
    return [(taking & sel[j] & keep, x, y, d) for j, (keep, x, y, d) in enumerate(placed)]


def _accumulator_deltas(m, tile, dut, src, cells, checks):
    """The ``deltas`` group (module docstring); `src` is the source's payload."""
    ops = dut.ops
    s = types.SimpleNamespace(
        X=Signal(tile.x_bits, name="track_x"),
        Y=Signal(tile.y_bits, name="track_y"),
        origin=[Signal.like(src.x0, name="origin_x"), Signal.like(src.y0, name="origin_y")],
        shadow=Signal(tile.cell_bits, name="shadow"),  # modulo 2**cell_bits, as a cell
        hit=Signal(name="cell_hit"),  # a kept delta placed at (X, Y) since the last end
        any=Signal(name="any_touched"),
        owed=Signal(name="owed"),
        may=Signal(name="may_send"),  # (X, Y) not sent since the last end, no op taken since
        first=Signal(name="first_due"),
        row_sum=Signal(tile.cell_bits, name="row_sum"),  # the row's sums sent, from its start
        params={n: Signal.like(src[n], name=f"end_{n}") for n in ("intensity", "i_out", "evenodd")},
        passing=Signal(name="pass_pending"),
        code=Signal.like(cells.payload.op, name="pass_code"),
        background=Signal.like(src.background, name="pass_background"),
        last=[Signal(tile.x_bits, name="last_x"), Signal(tile.y_bits, name="last_y")],
    )
    m.d.comb += [s.X.eq(AnyConst(tile.x_bits)), s.Y.eq(AnyConst(tile.y_bits))]
    s.cells, s.lanes = cells, dut.lanes
    s.bx = _beat_of(s.X, s.lanes)  # (X, Y)'s beat's first column
    take = ops.valid & ops.ready
    is_op = {name: take & (src.op == code) for name, code in OP.items()}
    counted = _ghost_cells(m, tile, dut, src, s, checks)
    hits = sum(Mux(k & (x == s.X) & (y == s.Y), d, 0) for k, x, y, d in counted)
    out, sent = cells.payload, cells.valid & cells.ready
    tracked = sent & (out.op == CELL_OP["cell"]) & (out.x == s.bx) & (out.y == s.Y)
    base = Mux(tracked, 0, s.shadow)
    m.d.sync += [
        s.shadow.eq((base + hits)[: tile.cell_bits]),
        s.hit.eq(s.hit | any_(k & (x == s.X) & (y == s.Y) for k, x, y, _ in counted)),
        s.any.eq(s.any | any_(k for k, _, _, _ in counted)),
    ]
    with m.If(is_op["end"]):
        m.d.sync += [s.owed.eq(s.hit), s.first.eq(s.any), s.hit.eq(0), s.any.eq(0)]
        m.d.sync += [reg.eq(src[name]) for name, reg in s.params.items()]
    with m.If(is_op["tile"]):
        m.d.sync += [s.origin[0].eq(src.x0), s.origin[1].eq(src.y0)]
    condition = implies(take, ~s.owed | tracked)
    if "deltas" in checks:
        m.d.comb += Assert(condition, "deltas: op taken before a cell")
    if "sums" in checks:
        same = _sum_at(out, s.X, s.lanes)[: tile.cell_bits] == s.shadow
        m.d.comb += Assert(implies(tracked, same), "sums: cell sum")
    _accumulator_outputs(m, tile, s, out, sent, tracked, "deltas" in checks)
    with m.If(tracked):
        m.d.sync += s.owed.eq(0)
    # a cell sent with an end taken is the scan's before
    m.d.sync += s.may.eq(is_op["end"] | (s.may & ~tracked & ~take))
    passing = is_op["tile"] | is_op["flush"]
    if "deltas" in checks:
        overtaken = implies(passing, ~s.passing | (sent & (out.op != CELL_OP["cell"])))
        m.d.comb += Assert(overtaken, "deltas: tile or flush overtaken")
    with m.If(passing):
        code = Mux(src.op == OP["tile"], CELL_OP["tile"], CELL_OP["flush"])
        m.d.sync += [s.passing.eq(1), s.code.eq(code), s.background.eq(src.background)]
    return s


def _accumulator_invariants(m, tile, dut, read, s, checks, covers):
    """The invariants of the groups in `checks` (`_memory_state`, `_scan_state`)."""
    origin = zip(dut.observe.origin, s.origin, strict=True)
    m.d.comb += Assert(all_(a == b for a, b in origin), "state: origin")
    if "sums" in checks:
        _memory_state(m, tile, dut, read, s, covers)
    _scan_state(m, tile, dut, s, covers)  # the sums group needs it too (a scan's extra read)


def _memory_state(m, tile, dut, read, s, covers):
    """Invariants of the accumulator's state (what makes the groups inductive): the read-
    modify-write stages (one, or one per bank with two scan lanes) agree with the memory, the
    output register's cell was cleared, and the tracked cell's shadow is the memory's row plus
    stage B's delta for it plus the output's sum while the cell waits there. Each is implied
    by the ones before in the clock before."""
    obs, out, stages = dut.observe, s.cells.payload, dut.observe.stages
    o = obs.o
    pending = obs.o_valid & (o["op"] == CELL_OP["cell"])
    t_addr = Cat(s.X, s.Y)
    waiting = pending & (o["x"] == s.bx) & (o["y"] == s.Y)
    # the output register's beat: each cell's address
    o_addrs = [Cat(o["x"] | k, o["y"]) for k in range(s.lanes)]
    # after a reset with deltas in the memory (``check`` and ``dirty``, then CLEAR) the
    # memory holds what the reset left until the clear pass has zeroed it
    clearing = obs.in_clear | (obs.check & obs.dirty)
    cleared_to = Cat(obs.scan_x, obs.scan_y)  # CLEAR has zeroed the cells below
    empty = all_(~st.b_valid & ~st.c_valid for st in stages)
    checks = [
        (When(pending, all_(read(a) == 0 for a in o_addrs)), "state: output cell cleared"),
        (When(clearing, empty), "state: no write pending in a clear"),
        (
            When(obs.in_clear & (t_addr < cleared_to), read(t_addr) == 0),
            "state: the clear pass zeroed the cells below it",
        ),
        (When(~obs.dirty & ~obs.in_clear, empty & (read(t_addr) == 0)), "state: a clean memory"),
        (When(obs.check | obs.in_clear, s.shadow == 0), "state: no delta since a reset"),
        (When(s.shadow != 0, obs.dirty | waiting), "state: a delta kept is dirty"),
    ]
    for k, st in enumerate(stages):
        name = "" if len(stages) == 1 else f" (bank {k})"
        forwarded = st.c_valid & (st.c_addr == st.b_addr)
        checks += [
            (When(st.b_valid, obs.in_acc), "state: stage B outside ACC" + name),
            (When(~st.b_valid, st.b_delta == 0), "state: stage B's delta when empty" + name),
            (When(st.c_valid, ~dut.scanning), "state: stage C in SCAN" + name),
            (When(st.c_valid, read(st.c_addr) == st.c_sum), "state: stage C written" + name),
            (
                When(st.b_valid & ~forwarded, st.read == read(st.b_addr)),
                "state: stage B read" + name,
            ),
            # a cell is taken only as the output advances
            (When(pending, ~st.b_valid), "state: stage B empty while a cell waits" + name),
        ]
    stage_b = sum(Mux(st.b_valid & (st.b_addr == t_addr), st.b_delta, 0) for st in stages)
    total = read(t_addr) + stage_b + Mux(waiting, _sum_at(out, s.X, s.lanes), 0)
    checks.append((When(~clearing, s.shadow == total[: len(s.shadow)]), "state: shadow"))
    # so a cell outside the scan span is zero (the read after a row's hi clears one)
    owed = Mux(obs.in_acc, s.hit, s.owed) | waiting
    checks.append((When(s.shadow != 0, owed), "state: a nonzero cell is owed"))
    state_checks(m, checks, covers, prefix="")


def _closed(tile, s):
    """The last row sent ended at its last column or its cells sent sum to zero (modulo
    ``2**cell_bits``): right of it the prefix sum is zero, so the row may stop there."""
    return (s.last[0] == tile.width - s.lanes) | (s.row_sum == 0)


def _scan_state(m, tile, dut, s, covers):
    """Invariants of the accumulator's control against the ``deltas`` ghost: while the
    accumulator takes ops, a cell hit lies in a touched row and in the span ``lo .. hi``;
    after an end, an owed cell waits in the output register or lies in the span of a row still
    to scan or ahead of the scan in the current row, and a cell still to read has not been
    sent; the scan moves up through the rows in order, each from ``lo``, the output register
    holding the cell before the scan position; a tile or flush op waiting there is the
    ghost's. Each follows from all of them in the clock before."""
    obs, o = dut.observe, dut.observe.o
    scan, last = dut.scanning, tile.width - s.lanes  # the row's last beat
    touched, scan_x, scan_y, lo, hi = obs.touched, obs.scan_x, obs.scan_y, obs.lo, obs.hi
    row_start, decide = obs.row_start, obs.decide
    pending = obs.o_valid & (o["op"] == CELL_OP["cell"])
    passing = obs.o_valid & (o["op"] != CELL_OP["cell"])
    row_left = touched.bit_select(s.Y, 1)
    in_span = (lo <= s.X) & (hi >= s.X)
    ahead = (scan_y == s.Y) & (scan_x <= s.X)
    waiting = pending & (o["x"] == s.bx) & (o["y"] == s.Y)
    above = all_(~touched[r] | (scan_y < r) for r in range(tile.height))
    done, src = obs.cell.done, dut.ops
    # the ghost and the accumulator as a reset leaves them: nothing kept, owed or waiting
    quiet = all_(
        [~s.hit, ~s.any, ~s.owed, ~s.first, ~s.passing, done == 0, ~obs.o_valid]
        + [touched == 0, _closed(tile, s)]
    )
    checks = [
        (When(obs.check, quiet & obs.in_acc & (scan_x == 0) & (scan_y == 0)), "after a reset"),
        (When(obs.in_clear, quiet & obs.dirty), "in the clear pass"),
        (When((touched != 0) | scan | s.hit, obs.dirty), "dirty"),
        (
            When(done != 0, s.held_in & obs.in_acc & src.valid & (src.payload.op == OP["beat"])),
            "a beat taken in part is held",
        ),
        (done == s.ghost_done, "the beat's cells taken"),
        (
            When(obs.in_acc, implies(s.hit, row_left & in_span) & (s.any == (touched != 0))),
            "acc rows",
        ),
        (When(~obs.in_acc, ~s.hit & ~s.any & (done == 0)), "no beat after an end"),
        (When(obs.in_acc, implies(s.owed, waiting)), "owed in ACC"),
        (When(obs.in_acc & ~pending, ~s.first), "first in ACC"),
        (When(obs.in_acc & pending, touched == 0), "no beat while the last cell waits"),
        (When(obs.in_wait, ~obs.o_valid & obs.first & s.may), "WAIT output"),
        (When(obs.in_wait, implies(s.owed, row_left & in_span)), "owed in WAIT"),
        (When(obs.in_wait, s.first == (touched != 0)), "WAIT"),
        (When(scan, implies(s.owed, waiting | ((row_left | ahead) & in_span))), "owed in SCAN"),
        (When(scan & (row_left | ahead), s.may), "not sent yet in SCAN"),
        (When(waiting, s.may), "waiting, not sent"),
        (When(scan, above), "rows above the scan"),
        (
            When(
                decide,
                scan
                & pending
                & (o["x"] == _beat_of(hi, s.lanes))
                & (_beat_of(hi, s.lanes) != last),
            ),
            "decide",
        ),
        (When(scan & obs.first, ~obs.o_valid & s.first & row_start), "SCAN start"),
        (When(scan & ~obs.first, pending | (~obs.o_valid & row_start)), "SCAN output"),
        (When(scan & ~obs.o_valid & ~obs.first, scan_y > s.last[1]), "scan after a stop"),
        (When(scan & row_start, scan_x == _beat_of(lo, s.lanes)), "row start"),
        (
            When(
                scan & pending,
                Mux(
                    row_start,
                    (o["x"] == last) & (scan_y > o["y"]),
                    (scan_x == o["x"] + s.lanes) & (scan_y == o["y"]),
                ),
            ),
            "scan after the output",
        ),
        (obs.rsum.as_unsigned() == s.row_sum, "row sum"),
        (When(obs.in_acc & pending, o["x"] == last), "the scan's last cell at the last column"),
        (
            When(
                (obs.in_acc & ~pending) | obs.in_wait | (scan & ~obs.o_valid) | passing,
                _closed(tile, s),
            ),
            "rows closed",
        ),
        (When(pending & o["start"], _closed(tile, s)), "rows closed before a start"),
        (When(pending, o["first"] == s.first), "output first"),
        (When(pending & o["first"], o["start"]), "output first starts a row"),
        (
            When(pending & ~o["first"], follows(o["x"], o["y"], o["start"], *s.last, s.lanes)),
            "output after the last sent",
        ),
        (all_(obs.params[n] == r for n, r in s.params.items()), "polygon fields"),
        (When(obs.o_valid, o["op"] < len(RESOLVE_OPS)), "output op"),
        (s.passing == passing, "tile or flush waiting"),
        (When(passing, o["op"] == s.code), "tile or flush code"),
        (
            When(passing & (o["op"] == CELL_OP["tile"]), obs.background == s.background),
            "tile background",
        ),
        (obs.in_acc | obs.in_wait | scan | obs.in_clear, "a known state"),
    ]
    if s.lanes > 1:  # the scan and the output register hold whole beats
        low = s.lanes.bit_length() - 1
        checks.append((scan_x[:low] == 0, "scan on a beat"))
        checks.append((When(pending, o["x"][:low] == 0), "output on a beat"))
    state_checks(m, checks, covers)


def _accumulator_outputs(m, tile, s, out, sent, tracked, check):
    """What each output transfer must be (the ``deltas`` group's output side, asserted when
    `check`), and the ghost's record of it."""
    is_cell = sent & (out.op == CELL_OP["cell"])
    after_last = follows(out.x, out.y, out.start, *s.last, s.lanes)
    checks = [
        (implies(tracked, s.may), "deltas: a cell sent twice or not after an end"),
        (implies(is_cell, out.first == s.first), "deltas: first flag"),
        (implies(is_cell & out.first, out.start), "deltas: first cell not a row's first"),
        (implies(is_cell & ~out.first, after_last), "deltas: cells out of order"),
        (implies(is_cell, all_(out[k] == r for k, r in s.params.items())), "deltas: fields"),
        (
            implies(sent & ~is_cell, s.passing & ~s.owed),
            "deltas: tile or flush not taken",
        ),
        (
            implies((is_cell & out.start) | (sent & ~is_cell), _closed(tile, s)),
            "deltas: a row stopped before its last column on a nonzero sum",
        ),
        (implies(sent & ~is_cell, out.op == s.code), "deltas: tile or flush code"),
        (
            implies(sent & (out.op == CELL_OP["tile"]), out.background == s.background),
            "deltas: tile background",
        ),
        (implies(sent, out.op < len(RESOLVE_OPS)), "deltas: unknown op code sent"),
    ]
    for condition, message in checks if check else ():
        m.d.comb += Assert(condition, message)
    track_rows(m, out, is_cell, s.last)
    with m.If(is_cell):
        m.d.sync += s.first.eq(0)
        m.d.sync += s.row_sum.eq(Mux(out.start, 0, s.row_sum) + _beat_sum(out, s.lanes))
    with m.If(sent & ~is_cell):
        m.d.sync += s.passing.eq(0)
