# amaranth: UnusedElaboratable=no
"""Formal checks of the tile stages (`edgeaa.hdl.accumulator.TileAccumulator`,
`edgeaa.hdl.resolve.TileResolve`) with SymbiYosys. The ``stream`` and ``pixels`` groups
are black-box (only the stages' ports); the accumulator's ``deltas`` and ``sums`` groups
also state invariants of its internals (its observation points, ``TileAccumulator.observe``,
and its memory read through combinational read ports the harness adds), which make
them inductive.

`TileHarness` wraps one stage of a `TileConfig`. Its input stream is free in every clock
(``AnySeq``) except for the hold rule, which is assumed of the source (a valid transfer not
taken stays valid with the same payload); the output's ready is free. Check groups:

``accumulator`` ``stream``
    The ``cells`` hold rule: a valid output not taken stays valid with the same payload in
    the next clock (the reset is a free input; a reset in between lifts the rule).
``accumulator`` ``deltas``
    One symbolic cell (X, Y) of the tile (``AnyConst``). Beats are any four cells (repeats
    included). Asserted: (X, Y) is sent
    after an end, before the accumulator takes another op, when a nonzero delta was kept
    there since the previous end (the model's `tile_cells`: the origin of the last tile op
    subtracted, a cell left of the tile moved into column 0), and at most once per end
    (nothing lost, nothing doubled); the cells come in rows, each row's cells in consecutive
    columns from its first (``start``), the rows ascending; a row's first pass since the
    last tile or flush op starts at column 0 and goes on to the last column (what the
    resolve's written rows need); a row stops before its last column only when the sums it
    sent add to zero (modulo ``2**cell_bits``), so right of it the prefix sum is zero;
    ``first`` on the polygon's first cell only, a row's first, with the end's intensity,
    I_out and fill rule; each tile and flush op comes out once, in order, with its
    background; no other op code is sent.
``accumulator`` ``sums``
    The shadow of cell (X, Y): the exact sum of every delta of an accepted beat placed there
    (back-to-back cells to one address through the read-modify-write forwarding) since
    (X, Y) was last sent, modulo ``2**cell_bits`` (a cell's width).
    Asserted: each (X, Y) sent carries the shadow, all ``cell_bits`` bits, and the shadow
    restarts from 0 (the clear).
``resolve`` ``stream``
    The ``pixels`` hold rule (as ``accumulator`` ``stream``).
``resolve`` ``pixels``
    The resolve's input is assumed to be what the accumulator is proved to send (rows of
    consecutive cells from a ``start``, ascending, a row's first pass since the tile or flush
    op whole, ``first`` on a polygon's first, the polygon's fields constant). Each cell's
    sum is the residue modulo ``2**cell_bits`` of a difference of two exact prefix sums
    chosen by the harness (``AnySeq``): the exact prefix sum of the row up to the cell (from
    the row's ``start``), assumed within the documented range ``[-L, L)``, ``L = 2**(h + 1) ifix``
    (`TileConfig.winding_limit`; polygons with ``I_in == I_out`` are not limited, as in the
    model). One symbolic pixel (X, Y) and its shadow: the background of the last tile op,
    then for each cell (X, Y) taken the model's own `composite` of `intensity_offset` of the
    model's `fill` of the exact prefix sum, computed on Amaranth values in full width.
    Asserted: a flush sends every pixel once, in raster order, ``last`` on the last, and
    pixel (X, Y) equals the shadow; no pixel is sent outside a flush. So the wrapping cells,
    the wrapping prefix sum and the ``h + 1``-step even-odd fold are exact in the documented
    range (no overflow); outside it they are not (fault ``wide_range``).

Faults (``fault``; each must make its proof fail): ``stall_cell`` / ``stall_pixel`` flip a
payload bit of a held output as the harness sees it; ``lost_delta`` gives the accumulator
the beat with cell 3's delta zeroed while the shadow counts it (a stage that loses a
delta); ``stale_origin`` gives it every op with x0 zeroed (a stage that ignores a tile's x
origin: cells land in the wrong columns); ``wide_range`` assumes the prefix sums within
``[-2 L, 2 L)``, twice the documented range; ``lost_first`` gives the resolve every cell
with ``first`` cleared (a stage that takes a polygon's first cell while the previous
polygon's cells are in flight, so its pixel read may miss their writes).

Invariants (``invariants``, on by default; each an assertion, so the proofs show they hold
in every reachable state). ``sums`` (`_memory_state`): the memory's row of (X, Y) plus stage
B's delta for its address plus the output's sum while (X, Y) waits in the output register
equals the shadow; stage C's sum is in the memory (written the clock before), stage B's read
is the memory's row unless stage C wrote that row the clock before (then B takes C's sum:
the forwarding), stage B only in ACC, stage C never in SCAN, a cell in the output register
is cleared in the memory and stage B is then empty, stage B's delta is zero when it is empty
(a clear adds it), and a nonzero (X, Y) is hit (ACC) or owed (after an end) or waits in the
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
next row's start is due above the last cell sent; a row's start is at ``lo`` if the row was
seen (the ghost's rows begun since the tile or flush op), else at column 0; the scan
position follows the waiting cell; ``decide`` only with that cell at ``hi`` below the last
column; the accumulator's ``seen`` is the ghost's rows plus the row whose start is still to
send; the waiting cell's ``first`` is the ghost's, a row's start, and follows the last cell
sent; a row's first pass goes on (the waiting cell is the next column, and the scan stays in
that row and reads it whole); ``rsum`` is the ghost's sum of the row's cells sent, and the
last row sent is closed (at its last column, or that sum zero) whenever no cell of it is
still to come; the end's fields are the ghost's; a tile or flush op waits exactly when the
ghost's does, with its code and background. Both: the origin is the ghost's. Each follows
from all of them in the clock before (`TILE_PROOFS` runs k = 2). ``pixels``
(`_resolve_invariants`): (X, Y) not in flight holds the shadow: its pixel memory row if its
row was written since the tile started or in the row's first pass ((X, Y) taken while the
row is open, or the row's end in flight), else the background; a row begun since the tile or
flush op (not in a flush) is written unless its first pass is open or its end in flight, and
the last cell's row was begun; in a flush the frame equals that until (X, Y) is read and the
waiting pixel (X, Y) equals the frame, the shadow being the background; the row's prefix sum
register is the exact prefix modulo ``2**cell_bits``; the pipeline's cells in taken order,
none after the last taken and none in a flush, with a pixel waiting or before a polygon's
first cell (a cell's position as read from the resolve's delay memory at the address its
stage names, the last stage's the delay line's read port data: `_resolve_stages`); the
flush and output positions and ``last`` follow the pixel count; the background is the
shadow's. A cell in flight has no invariant of its own: with k above the resolve's latency
every cell the induction step sees written was taken within the k clocks it assumes, from a
state where the invariants held (the delay lines' words it reads were written in them too).

All groups are proved by k-induction for every reachable state (``pixels`` from power-on,
the memories and registers at their initial values, no reset; the accumulator's from
power-on under a free reset, so its clear pass after a reset mid-polygon is proved).
`TILE_PROOFS` lists the runs and their configurations; `run_tile_proof` runs one
(``python -m edgeaa.sim.verification.formal.tile [proof ...]``).
"""

from __future__ import annotations

import types
from dataclasses import dataclass
from pathlib import Path

from amaranth.asserts import AnyConst, AnySeq
from amaranth.hdl import (
    Assert,
    Assume,
    Cat,
    ClockDomain,
    Const,
    Cover,
    Elaboratable,
    Module,
    Mux,
    Signal,
    Value,
    signed,
)

from ....hdl.accumulator import TileAccumulator
from ....hdl.resolve import TileResolve
from ....model.accumulate import composite, intensity_offset
from ....model.beat import CELLS
from ....model.config import EdgeConfig
from ....model.tile import OPS, RESOLVE_OPS, TileConfig, resolve_latency
from .run import FormalResult, find_tools, harness_rtlil, report, run_harness, sby_script

__all__ = [
    "SMALL_TILE",
    "TILE_CHECKS",
    "TILE_FAULTS",
    "TILE_PROOFS",
    "TileHarness",
    "TileProof",
    "main",
    "run_tile_proof",
]

TILE_CHECKS = {"accumulator": ("stream", "deltas", "sums"), "resolve": ("stream", "pixels")}
TILE_FAULTS = {
    "stall_cell": "accumulator",
    "lost_delta": "accumulator",
    "stale_origin": "accumulator",
    "stall_pixel": "resolve",
    "wide_range": "resolve",
    "lost_first": "resolve",
}
OP = {name: code for code, name in enumerate(OPS)}
CELL_OP = {name: code for code, name in enumerate(RESOLVE_OPS)}

# The smallest tile with W = 4, no sub-pixel bits and 4-bit intensity: 4 x 2 pixels, 18-bit
# cells.
SMALL_CONFIG = EdgeConfig(coord_bits=4, subpixel_bits=0, intensity_bits=4)
SMALL_TILE = TileConfig(SMALL_CONFIG, width=4, height=2)


def _all(conditions):
    result = Const(1, 1)
    for condition in conditions:
        result = result & condition
    return result


def _any(conditions):
    result = Const(0, 1)
    for condition in conditions:
        result = result | condition
    return result


def _implies(a, b):
    return ~a | b


@dataclass(frozen=True)
class _When:
    """An invariant ``premise -> conclusion`` (`_state_checks`)."""

    premise: Value
    conclusion: Value


def _state_checks(m, checks, covers, prefix="state: "):
    """Assert each invariant of `checks` ((condition or `_When`, message)); with `covers`, also
    cover each `_When`'s premise together with its conclusion (the premise is reachable, so
    the invariant is not vacuous)."""
    for condition, message in checks:
        if isinstance(condition, _When):
            m.d.comb += Assert(_implies(condition.premise, condition.conclusion), prefix + message)
            if covers:
                reached = condition.premise & condition.conclusion
                m.d.comb += Cover(reached, "cover: " + (prefix + message)[len("state: ") :])
        else:
            m.d.comb += Assert(condition, prefix + message)


class TileHarness(Elaboratable):
    """One tile stage (``"accumulator"`` or ``"resolve"``) with a free input stream and the
    check groups of `TILE_CHECKS` (the module docstring). ``reset``: the reset is a free
    input (else the registers and memories start at their initial values and never reset).
    ``invariants``: with the ``deltas`` or ``sums`` group, also assert the invariants of the
    accumulator's state that make the group inductive (off: the group's own assertions only,
    to show that they catch a fault by themselves). ``covers``: also cover each invariant's
    premise with its conclusion (for sby's cover mode: no invariant is vacuous).
    """

    def __init__(
        self,
        tile: TileConfig,
        stage: str,
        checks,
        *,
        reset=False,
        fault=None,
        invariants=True,
        covers=False,
    ):
        if not isinstance(tile, TileConfig):
            raise TypeError(f"tile must be a TileConfig, not {tile!r}")
        if stage not in TILE_CHECKS:
            raise ValueError(f"stage must be one of {', '.join(TILE_CHECKS)}, not {stage!r}")
        checks = tuple(checks)
        unknown = [c for c in checks if c not in TILE_CHECKS[stage]]
        if unknown:
            raise ValueError(f"checks must be among {', '.join(TILE_CHECKS[stage])}: {unknown}")
        if fault is not None and TILE_FAULTS.get(fault) != stage:
            faults = [f for f, s in TILE_FAULTS.items() if s == stage]
            raise ValueError(f"fault must be one of {', '.join(faults)} or None, not {fault!r}")
        self.tile, self.stage, self.checks = tile, stage, checks
        self.reset, self.fault, self.invariants = reset, fault, invariants
        self.covers = covers and invariants
        self.dut = TileAccumulator(tile) if stage == "accumulator" else TileResolve(tile)
        # The clock must be a port: Amaranth ties an undriven clock to 0 (a frozen design).
        self.domain = ClockDomain("sync", reset_less=not reset)

    @property
    def clk(self) -> Signal:
        return self.domain.clk

    def elaborate(self, platform):
        m = Module()
        dut = self.dut
        groups = {"deltas", "sums"} & set(self.checks)
        read = None
        if self.invariants and (groups or "pixels" in self.checks):
            # elaborated here: the invariants read its observation points, and the harness
            # adds read ports to its memories
            m.submodules.dut = dut.elaborate(platform)
            if {"sums", "pixels"} & set(self.checks):
                read = _memory_reader(m, dut.observe.memory)
        else:
            m.submodules.dut = dut
        m.domains.sync = self.domain
        if self.reset:
            m.d.comb += self.domain.rst.eq(AnySeq(1))
        source, sink = (dut.ops, dut.cells) if self.stage == "accumulator" else (dut.cells, None)
        sink = sink if sink is not None else dut.pixels
        payload, held_in = _free_source(m, source, self.fault)
        m.d.comb += sink.ready.eq(AnySeq(1))
        seen = Value.cast(sink.payload)
        held = _held(m, sink, "held_out")
        if self.fault in ("stall_cell", "stall_pixel"):
            seen = seen ^ held
        if "stream" in self.checks:
            _hold_rule(m, sink, seen, held)
        if groups:
            s = _accumulator_deltas(m, self.tile, dut, payload, sink, self.checks)
            s.held_in = held_in
            if self.invariants:
                _accumulator_invariants(m, self.tile, dut, read, s, self.checks, self.covers)
        if "pixels" in self.checks:
            wide = self.fault == "wide_range"
            g = _resolve_pixels(m, self.tile, source, payload, sink, wide=wide)
            if self.invariants:
                _resolve_invariants(m, self.tile, dut, read, g, self.covers)
        return m


# -- streams ---------------------------------------------------------------------------------


def _held(m, stream, name):
    """High in the clock after one where `stream` was valid and not ready."""
    held = Signal(name=name)
    m.d.sync += held.eq(stream.valid & ~stream.ready)
    return held


def _free_source(m, stream, fault):
    """Drive `stream` from a free source that keeps the hold rule; returns the source's
    payload (a view) and the flag of a held transfer (the payload is the clock before's).
    Faults ``lost_delta``, ``stale_origin``, ``lost_first``: the stage gets cell 3's delta,
    x0 or ``first`` zeroed."""
    layout = stream.payload.shape()
    free = Signal(layout, name="source")
    m.d.comb += [stream.valid.eq(AnySeq(1)), Value.cast(free).eq(AnySeq(layout.size))]
    given = Signal(layout, name="given")
    m.d.comb += given.eq(free)
    if fault == "lost_delta":
        m.d.comb += given.beat.cell3.delta.eq(0)
    if fault == "stale_origin":
        m.d.comb += given.x0.eq(0)
    if fault == "lost_first":
        m.d.comb += given.first.eq(0)
    m.d.comb += stream.payload.eq(given)
    held, prev = _held(m, stream, "held_in"), Signal(layout.size)
    m.d.sync += prev.eq(free.as_value())
    with m.If(held):
        m.d.comb += Assume(stream.valid & (free.as_value() == prev), "source: hold rule")
    return free, held


def _hold_rule(m, stream, seen, held):
    prev = Signal(len(seen))
    m.d.sync += prev.eq(seen)
    with m.If(held):
        m.d.comb += [
            Assert(stream.valid, "stream: a held output stays valid"),
            Assert(seen == prev, "stream: a held output keeps its payload"),
        ]


# -- the accumulator: one symbolic cell ------------------------------------------------------


def _placed(tile, beat, origin):
    """Per cell of `beat`: (kept, tile x, tile y, delta), the model's `tile_cells`."""
    out = []
    for name in CELLS:
        cell = beat[name]
        tx, ty = cell.x - origin[0], cell.y - origin[1]
        keep = (ty >= 0) & (ty < tile.height) & (tx < tile.width) & (cell.delta != 0)
        out.append((keep, Mux(tx < 0, 0, tx), ty, cell.delta))
    return out


def _ghost_cells(m, tile, dut, src, s, checks):
    """The ghost takes a beat's nonzero cells (of the source's payload `src`) one a clock, in
    cell order, in the clocks the accumulator takes a cell (``busy`` outside a scan with a
    beat offered; the port's meaning), and asserts that the beat is taken with its last: so
    it counts every cell of every beat taken, once. Returns, per cell, whether the ghost
    counts it this clock and where it lands (kept, x, y, delta: `_placed`)."""
    ops = dut.ops
    done = Signal(4, name="ghost_done")
    pending = Signal(4, name="ghost_pending")
    m.d.comb += pending.eq(Cat(*(src.beat[c].delta != 0 for c in CELLS)) & ~done)
    sel = (pending & -pending)[:4]
    last = (pending & ~sel) == 0
    taking = dut.busy & ~dut.scanning & ops.valid & (src.op == OP["beat"])
    with m.If(taking):
        m.d.sync += done.eq(Mux(last, 0, done | sel))
    take_beat = ops.valid & ops.ready & (src.op == OP["beat"])
    if "deltas" in checks or "sums" in checks:
        m.d.comb += Assert(take_beat == (taking & last), "cells: a beat taken with its last cell")
    s.ghost_done = done
    placed = _placed(tile, src.beat, s.origin)
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
        seen=Signal(tile.height, name="rows_seen"),  # rows begun since the tile or flush op
        open=Signal(name="row_open"),  # a row's first pass, not yet at its last column
        row_sum=Signal(tile.cell_bits, name="row_sum"),  # the row's sums sent, from its start
        params={n: Signal.like(src[n], name=f"end_{n}") for n in ("intensity", "i_out", "evenodd")},
        passing=Signal(name="pass_pending"),
        code=Signal.like(cells.payload.op, name="pass_code"),
        background=Signal.like(src.background, name="pass_background"),
        last=[Signal(tile.x_bits, name="last_x"), Signal(tile.y_bits, name="last_y")],
    )
    m.d.comb += [s.X.eq(AnyConst(tile.x_bits)), s.Y.eq(AnyConst(tile.y_bits))]
    s.cells = cells
    take = ops.valid & ops.ready
    is_op = {name: take & (src.op == code) for name, code in OP.items()}
    counted = _ghost_cells(m, tile, dut, src, s, checks)
    hits = sum(Mux(k & (x == s.X) & (y == s.Y), d, 0) for k, x, y, d in counted)
    out, sent = cells.payload, cells.valid & cells.ready
    tracked = sent & (out.op == CELL_OP["cell"]) & (out.x == s.X) & (out.y == s.Y)
    base = Mux(tracked, 0, s.shadow)
    m.d.sync += [
        s.shadow.eq((base + hits)[: tile.cell_bits]),
        s.hit.eq(s.hit | _any(k & (x == s.X) & (y == s.Y) for k, x, y, _ in counted)),
        s.any.eq(s.any | _any(k for k, _, _, _ in counted)),
    ]
    with m.If(is_op["end"]):
        m.d.sync += [s.owed.eq(s.hit), s.first.eq(s.any), s.hit.eq(0), s.any.eq(0)]
        m.d.sync += [reg.eq(src[name]) for name, reg in s.params.items()]
    with m.If(is_op["tile"]):
        m.d.sync += [s.origin[0].eq(src.x0), s.origin[1].eq(src.y0)]
    condition = _implies(take, ~s.owed | tracked)
    if "deltas" in checks:
        m.d.comb += Assert(condition, "deltas: op taken before a cell")
    if "sums" in checks:
        same = out.sum[: tile.cell_bits] == s.shadow
        m.d.comb += Assert(_implies(tracked, same), "sums: cell sum")
    _accumulator_outputs(m, tile, s, out, sent, tracked, "deltas" in checks)
    with m.If(tracked):
        m.d.sync += s.owed.eq(0)
    # a cell sent with an end taken is the scan's before
    m.d.sync += s.may.eq(is_op["end"] | (s.may & ~tracked & ~take))
    passing = is_op["tile"] | is_op["flush"]
    if "deltas" in checks:
        overtaken = _implies(passing, ~s.passing | (sent & (out.op != CELL_OP["cell"])))
        m.d.comb += Assert(overtaken, "deltas: tile or flush overtaken")
    with m.If(passing):
        code = Mux(src.op == OP["tile"], CELL_OP["tile"], CELL_OP["flush"])
        m.d.sync += [s.passing.eq(1), s.code.eq(code), s.background.eq(src.background)]
        m.d.sync += s.seen.eq(0)
    return s


def _accumulator_invariants(m, tile, dut, read, s, checks, covers):
    """The invariants of the groups in `checks` (`_memory_state`, `_scan_state`)."""
    origin = zip(dut.observe.origin, s.origin, strict=True)
    m.d.comb += Assert(_all(a == b for a, b in origin), "state: origin")
    if "sums" in checks:
        _memory_state(m, tile, dut, read, s, covers)
    _scan_state(m, tile, dut, s, covers)  # the sums group needs it too (a scan's extra read)


def _memory_reader(m, mem):
    """A reader of a stage's memory `mem` (``observe.memory``, or a resolve's delay line):
    ``read(address)`` adds a combinational read port at `address` (the harness's; the stage's
    own ports are untouched) and returns its data. A port per address the invariants name, not
    per row, so the memory stays an array for the solver at any tile size."""

    def read(address):
        port = mem.read_port(domain="comb")
        m.d.comb += port.addr.eq(address)
        return port.data

    return read


def _memory_state(m, tile, dut, read, s, covers):
    """Invariants of the accumulator's state (what makes the groups inductive): the read-
    modify-write stages agree with the memory, the output register's cell was cleared, and
    the tracked cell's shadow is the memory's row plus stage B's delta for it plus the
    output's sum while the cell waits there. Each is implied by the ones before in the clock
    before."""
    obs, out, st = dut.observe, s.cells.payload, dut.observe.stage
    o = obs.o
    pending = obs.o_valid & (o["op"] == CELL_OP["cell"])
    o_addr, t_addr = Cat(o["x"], o["y"]), Cat(s.X, s.Y)
    forwarded = st.c_valid & (st.c_addr == st.b_addr)
    waiting = pending & (o["x"] == s.X) & (o["y"] == s.Y)
    # after a reset with deltas in the memory (``check`` and ``dirty``, then CLEAR) the
    # memory holds what the reset left until the clear pass has zeroed it
    clearing = obs.in_clear | (obs.check & obs.dirty)
    cleared_to = Cat(obs.scan_x, obs.scan_y)  # CLEAR has zeroed the cells below
    checks = [
        (_When(pending, read(o_addr) == 0), "state: output cell cleared"),
        (_When(clearing, ~st.b_valid & ~st.c_valid), "state: no write pending in a clear"),
        (
            _When(obs.in_clear & (t_addr < cleared_to), read(t_addr) == 0),
            "state: the clear pass zeroed the cells below it",
        ),
        (
            _When(~obs.dirty & ~obs.in_clear, ~st.b_valid & ~st.c_valid & (read(t_addr) == 0)),
            "state: a clean memory",
        ),
        (_When(obs.check | obs.in_clear, s.shadow == 0), "state: no delta since a reset"),
        (_When(s.shadow != 0, obs.dirty | waiting), "state: a delta kept is dirty"),
        (_When(st.b_valid, obs.in_acc), "state: stage B outside ACC"),
        (_When(~st.b_valid, st.b_delta == 0), "state: stage B's delta when empty"),
        (_When(st.c_valid, ~dut.scanning), "state: stage C in SCAN"),
        (_When(st.c_valid, read(st.c_addr) == st.c_sum), "state: stage C written"),
        (
            _When(st.b_valid & ~forwarded, obs.read.data == read(st.b_addr)),
            "state: stage B read",
        ),
        # a cell is taken only as the output advances
        (_When(pending, ~st.b_valid), "state: stage B empty while a cell waits"),
    ]
    stage_b = Mux(st.b_valid & (st.b_addr == t_addr), st.b_delta, 0)
    total = read(t_addr) + stage_b + Mux(waiting, out.sum, 0)
    checks.append((_When(~clearing, s.shadow == total[: len(s.shadow)]), "state: shadow"))
    # so a cell outside the scan span is zero (the read after a row's hi clears one)
    owed = Mux(obs.in_acc, s.hit, s.owed) | waiting
    checks.append((_When(s.shadow != 0, owed), "state: a nonzero cell is owed"))
    _state_checks(m, checks, covers, prefix="")


def _follows(x, y, start, last_x, last_y):
    """Cell (x, y) comes right after (last_x, last_y): the next column, or a later row's first
    cell (`start`)."""
    return Mux(start, y > last_y, (x == last_x + 1) & (y == last_y))


def _bit(tile, y):
    return (Const(1, tile.height) << y)[: tile.height]


def _closed(tile, s):
    """The last row sent ended at its last column or its cells sent sum to zero (modulo
    ``2**cell_bits``): right of it the prefix sum is zero, so the row may stop there."""
    return (s.last[0] == tile.width - 1) | (s.row_sum == 0)


def _scan_state(m, tile, dut, s, covers):
    """Invariants of the accumulator's control against the ``deltas`` ghost: while the
    accumulator takes ops, a cell hit lies in a touched row and in the span ``lo .. hi``;
    after an end, an owed cell waits in the output register or lies in the span of a row still
    to scan or ahead of the scan in the current row, and a cell still to read has not been
    sent; the scan moves up through the rows in order, a row from column 0 (not seen since the
    tile started) or from ``lo`` (seen), the output register holding the cell before the scan
    position; a row's first pass goes on to the last column; ``seen`` is the ghost's rows
    plus a row whose first cell is still to send; a tile or flush op waiting there is the
    ghost's. Each follows from all of them in the clock before."""
    obs, o = dut.observe, dut.observe.o
    scan, last = dut.scanning, tile.width - 1
    touched, scan_x, scan_y, lo, hi = obs.touched, obs.scan_x, obs.scan_y, obs.lo, obs.hi
    row_start, partial, decide = obs.row_start, obs.partial, obs.decide
    pending = obs.o_valid & (o["op"] == CELL_OP["cell"])
    passing = obs.o_valid & (o["op"] != CELL_OP["cell"])
    row_left = touched.bit_select(s.Y, 1)
    in_span = (lo <= s.X) & (hi >= s.X)
    ahead = (scan_y == s.Y) & (scan_x <= s.X)
    waiting = pending & (o["x"] == s.X) & (o["y"] == s.Y)
    above = _all(~touched[r] | (scan_y < r) for r in range(tile.height))
    due = Mux(scan & row_start, _bit(tile, scan_y), 0) | Mux(
        pending & o["start"], _bit(tile, o["y"]), 0
    )
    current = scan & ~row_start & (scan_y == o["y"]) & ~decide  # the waiting cell's row goes on
    done, src = obs.cell.done, dut.ops
    # the ghost and the accumulator as a reset leaves them: nothing kept, owed or waiting
    quiet = _all(
        [~s.hit, ~s.any, ~s.owed, ~s.first, ~s.passing, ~s.open, done == 0, ~obs.o_valid]
        + [touched == 0, obs.seen == 0, s.seen == 0, _closed(tile, s)]
    )
    checks = [
        (_When(obs.check, quiet & obs.in_acc & (scan_x == 0) & (scan_y == 0)), "after a reset"),
        (_When(obs.in_clear, quiet & obs.dirty), "in the clear pass"),
        (_When((touched != 0) | scan | s.hit, obs.dirty), "dirty"),
        (
            _When(done != 0, s.held_in & obs.in_acc & src.valid & (src.payload.op == OP["beat"])),
            "a beat taken in part is held",
        ),
        (done == s.ghost_done, "the beat's cells taken"),
        (
            _When(obs.in_acc, _implies(s.hit, row_left & in_span) & (s.any == (touched != 0))),
            "acc rows",
        ),
        (_When(~obs.in_acc, ~s.hit & ~s.any & (done == 0)), "no beat after an end"),
        (_When(obs.in_acc, _implies(s.owed, waiting)), "owed in ACC"),
        (_When(obs.in_acc & ~pending, ~s.first), "first in ACC"),
        (_When(obs.in_acc & pending, touched == 0), "no beat while the last cell waits"),
        (_When(obs.in_wait, ~obs.o_valid & obs.first & s.may), "WAIT output"),
        (_When(obs.in_wait, _implies(s.owed, row_left & in_span)), "owed in WAIT"),
        (_When(obs.in_wait, s.first == (touched != 0)), "WAIT"),
        (_When(scan, _implies(s.owed, waiting | ((row_left | ahead) & in_span))), "owed in SCAN"),
        (_When(scan & (row_left | ahead), s.may), "not sent yet in SCAN"),
        (_When(waiting, s.may), "waiting, not sent"),
        (_When(scan, above), "rows above the scan"),
        (_When(decide, scan & pending & partial & (o["x"] == hi) & (hi != last)), "decide"),
        (_When(scan & obs.first, ~obs.o_valid & s.first & row_start), "SCAN start"),
        (_When(scan & ~obs.first, pending | (~obs.o_valid & row_start)), "SCAN output"),
        (_When(scan & ~obs.o_valid & ~obs.first, scan_y > s.last[1]), "scan after a stop"),
        (
            _When(
                scan & row_start,
                (scan_x == Mux(partial, lo, 0)) & (partial == s.seen.bit_select(scan_y, 1)),
            ),
            "row start",
        ),
        (
            _When(
                scan & pending,
                Mux(
                    row_start,
                    (o["x"] == last) & (scan_y > o["y"]),
                    (scan_x == o["x"] + 1) & (scan_y == o["y"]),
                ),
            ),
            "scan after the output",
        ),
        (obs.seen == (s.seen | due), "rows seen"),
        (obs.rsum.as_unsigned() == s.row_sum, "row sum"),
        (_When(obs.in_acc & pending, o["x"] == last), "the scan's last cell at the last column"),
        (
            _When(
                (obs.in_acc & ~pending) | obs.in_wait | (scan & ~obs.o_valid) | passing,
                _closed(tile, s),
            ),
            "rows closed",
        ),
        (_When(pending & o["start"], _closed(tile, s)), "rows closed before a start"),
        (_When(pending, o["first"] == s.first), "output first"),
        (_When(pending & o["first"], o["start"]), "output first starts a row"),
        (
            _When(
                pending & o["start"] & ~s.seen.bit_select(o["y"], 1),
                (o["x"] == 0) & current & ~partial,
            ),
            "first pass from column 0",
        ),
        (
            _When(pending & ~o["first"], _follows(o["x"], o["y"], o["start"], *s.last)),
            "output after the last sent",
        ),
        (
            _When(
                s.open,
                pending
                & ~o["start"]
                & (o["y"] == s.last[1])
                & (o["x"] == s.last[0] + 1)
                & _implies(o["x"] != last, current & ~partial),
            ),
            "first pass goes on",
        ),
        (_all(obs.params[n] == r for n, r in s.params.items()), "polygon fields"),
        (_When(obs.o_valid, o["op"] < len(RESOLVE_OPS)), "output op"),
        (s.passing == passing, "tile or flush waiting"),
        (_When(passing, o["op"] == s.code), "tile or flush code"),
        (
            _When(passing & (o["op"] == CELL_OP["tile"]), obs.background == s.background),
            "tile background",
        ),
        (obs.in_acc | obs.in_wait | scan | obs.in_clear, "a known state"),
    ]
    _state_checks(m, checks, covers)


def _accumulator_outputs(m, tile, s, out, sent, tracked, check):
    """What each output transfer must be (the ``deltas`` group's output side, asserted when
    `check`), and the ghost's record of it."""
    is_cell = sent & (out.op == CELL_OP["cell"])
    follows = _follows(out.x, out.y, out.start, *s.last)
    seen = s.seen.bit_select(out.y, 1)
    checks = [
        (_implies(tracked, s.may), "deltas: a cell sent twice or not after an end"),
        (_implies(is_cell, out.first == s.first), "deltas: first flag"),
        (_implies(is_cell & out.first, out.start), "deltas: first cell not a row's first"),
        (_implies(is_cell & ~out.first, follows), "deltas: cells out of order"),
        (
            _implies(is_cell & out.start, ~s.open & (seen | (out.x == 0))),
            "deltas: a row's first pass not whole",
        ),
        (_implies(is_cell, _all(out[k] == r for k, r in s.params.items())), "deltas: fields"),
        (
            _implies(sent & ~is_cell, s.passing & ~s.owed & ~s.open),
            "deltas: tile or flush not taken",
        ),
        (
            _implies((is_cell & out.start) | (sent & ~is_cell), _closed(tile, s)),
            "deltas: a row stopped before its last column on a nonzero sum",
        ),
        (_implies(sent & ~is_cell, out.op == s.code), "deltas: tile or flush code"),
        (
            _implies(sent & (out.op == CELL_OP["tile"]), out.background == s.background),
            "deltas: tile background",
        ),
        (_implies(sent, out.op < len(RESOLVE_OPS)), "deltas: unknown op code sent"),
    ]
    for condition, message in checks if check else ():
        m.d.comb += Assert(condition, message)
    with m.If(is_cell):
        m.d.sync += [s.first.eq(0), s.last[0].eq(out.x), s.last[1].eq(out.y)]
        whole = Mux(out.start, ~seen, s.open)
        m.d.sync += s.open.eq(whole & (out.x != tile.width - 1))
        m.d.sync += s.row_sum.eq(Mux(out.start, 0, s.row_sum) + out.sum)
        with m.If(out.start):
            m.d.sync += s.seen.eq(s.seen | _bit(tile, out.y))
    with m.If(sent & ~is_cell):
        m.d.sync += s.passing.eq(0)


# -- the resolve: one symbolic pixel ---------------------------------------------------------


def model_fill(exact, evenodd, ifix):
    """The model's `fill` (`edgeaa.model.accumulate`) on Amaranth values, full width."""
    mag = Mux(exact < 0, -exact, exact)
    nonzero = Mux(mag > ifix, ifix, mag)
    folded = exact % (ifix << 1)
    odd = Mux(folded > ifix, (ifix << 1) - folded, folded)
    return Mux(evenodd, odd, nonzero)


def _resolve_source(m, tile, cells, src, wide):
    """Assumptions on the resolve's input (what the accumulator is proved to send; `src`, the
    source's payload) and the exact prefix sums; returns (the ghost of the input: ``exact``
    the exact prefix of the cell taken now, ``prev`` the last one, ``last``, ``row_open``,
    ``need_first``; d; a cell taken)."""
    c = src
    take = cells.valid & cells.ready
    is_cell = c.op == CELL_OP["cell"]
    last = [Signal(tile.x_bits, name="last_x"), Signal(tile.y_bits, name="last_y")]
    params = {n: Signal.like(c[n], name=f"poly_{n}") for n in ("intensity", "i_out", "evenodd")}
    seen = Signal(tile.height, name="rows_seen")  # rows passed since the tile or flush op
    row_open = Signal(name="row_open")  # a row's first pass, not yet at its last column
    need_first = Signal(init=1, name="need_first")
    follows = Mux(c.start, c.y > last[1], (c.x == last[0] + 1) & (c.y == last[1]))
    well_formed = [
        c.op < len(RESOLVE_OPS),
        _implies(is_cell, c.first | (~need_first & follows)),
        _implies(is_cell & c.first, c.start),
        _implies(is_cell & c.start, ~row_open & (seen.bit_select(c.y, 1) | (c.x == 0))),
        _implies(is_cell & ~c.first, _all(c[n] == r for n, r in params.items())),
        _implies(~is_cell, ~row_open),
    ]
    with m.If(cells.valid):
        m.d.comb += Assume(_all(well_formed), "source: cells as the accumulator sends them")
    with m.If(take & is_cell):
        m.d.sync += [last[0].eq(c.x), last[1].eq(c.y), need_first.eq(0)]
        whole = Mux(c.start, ~seen.bit_select(c.y, 1), row_open)
        m.d.sync += row_open.eq(whole & (c.x != tile.width - 1))
        with m.If(c.start):
            m.d.sync += seen.eq(seen | (Const(1, tile.height) << c.y)[: tile.height])
        with m.If(c.first):
            m.d.sync += [r.eq(c[n]) for n, r in params.items()]
    with m.If(take & ~is_cell):
        m.d.sync += [need_first.eq(1), seen.eq(0)]
    n = tile.cell_bits
    exact, prev = Signal(signed(n + 4), name="exact"), Signal(signed(n + 4), name="exact_prev")
    m.d.comb += exact.eq(AnySeq(n + 4))
    d = Mux(c.intensity >= c.i_out, c.intensity - c.i_out, c.i_out - c.intensity)
    limit = (tile.winding_limit * (2 if wide else 1)) * (d << tile.config.F)
    residue = (exact - Mux(c.start, 0, prev))[:n]
    in_range = (d == 0) | ((exact >= -limit) & (exact < limit))
    with m.If(cells.valid & is_cell):
        m.d.comb += Assume(in_range & (c.sum[:n] == residue), "source: exact sums")
    with m.If(take & is_cell):
        m.d.sync += prev.eq(exact)
    ghost = types.SimpleNamespace(
        last=last, seen=seen, row_open=row_open, need_first=need_first, prev=prev, exact=exact
    )
    return ghost, d, take & is_cell


def _resolve_pixels(m, tile, cells, src, pixels, *, wide):
    """The ``pixels`` group (module docstring); `src` is the source's payload."""
    config, c = tile.config, src
    g, d, took = _resolve_source(m, tile, cells, src, wide)
    exact = g.exact
    X, Y = Signal(tile.x_bits, name="track_x"), Signal(tile.y_bits, name="track_y")
    m.d.comb += [X.eq(AnyConst(tile.x_bits)), Y.eq(AnyConst(tile.y_bits))]
    bits = config.intensity_bits
    value, frame, background = (Signal(bits, name=n) for n in ("value", "frame", "background"))
    take = cells.valid & cells.ready
    ifix = d << config.F
    q = intensity_offset(model_fill(exact, c.evenodd, ifix), config.F)
    new = composite(value, q, c.intensity, d)
    with m.If(took & (c.x == X) & (c.y == Y) & (d != 0)):
        m.d.sync += value.eq(new)
    with m.If(take & (c.op == CELL_OP["tile"])):
        m.d.sync += [value.eq(c.background), background.eq(c.background)]
    flushing = Signal(name="flushing_h")
    count = Signal(range(tile.pixels), name="pixel_count")
    p, sent = pixels.payload, pixels.valid & pixels.ready
    mine = (p.x == X) & (p.y == Y)
    checks = [
        (_implies(sent, flushing), "pixels: a pixel outside a flush"),
        (_implies(sent, (p.x | (p.y << tile.x_bits)) == count), "pixels: raster order"),
        (_implies(sent, p.last == (count == tile.pixels - 1)), "pixels: last flag"),
        (_implies(sent & mine, p.value == frame), "pixels: value"),
    ]
    for condition, message in checks:
        m.d.comb += Assert(condition, message)
    with m.If(sent):
        m.d.sync += count.eq(count + 1)
        with m.If(p.last):
            m.d.sync += flushing.eq(0)
    # after the pixel: a flush may be taken in the clock its predecessor's last pixel goes
    with m.If(take & (c.op == CELL_OP["flush"])):
        m.d.sync += [frame.eq(value), value.eq(background), flushing.eq(1), count.eq(0)]
    g.__dict__.update(
        X=X, Y=Y, value=value, frame=frame, background=background, flushing=flushing, count=count
    )
    g.pixels = pixels
    return g


def _resolve_stages(m, dut):
    """The resolve's stages as the invariants see them (each with ``valid``, ``x``, ``y``, ...):
    a stage's own registers, and the values it carries in the resolve's delay lines
    (``observe.delays``) as read from the delay memory at the address the stage names
    (``delayed``; a combinational read port of the harness's each). The last stage's carried
    values are the delay lines' read ports' data, what its write uses."""
    delays = dut.observe.delays
    readers = {name: _memory_reader(m, mem) for name, mem in delays.items()}
    views = []
    for st in dut.observe.stages:
        fields = {k: v for k, v in vars(st).items() if k != "delayed"}
        for name, address in getattr(st, "delayed", {}).items():
            word = readers[name](address)
            fields.update((k, word[k]) for k in delays[name].shape.members)
        views.append(types.SimpleNamespace(**fields))
    return views


def _resolve_invariants(m, tile, dut, read, g, covers):
    """Invariants of the resolve's state against the ``pixels`` ghost (what makes the group
    inductive, with k above the pipeline's latency: a cell in flight is written within it)."""
    obs = dut.observe
    stages, written = _resolve_stages(m, dut), obs.written
    busy = _any(st.valid for st in stages)
    flush = dut.flushing
    last_pos = Cat(*g.last)
    tracked = Cat(g.X, g.Y)

    def in_flight(position):
        return _any(st.valid & (Cat(st.x, st.y) == position) for st in stages)

    written_y = written.bit_select(g.Y, 1)
    pixel = read(tracked)
    shown = Mux(written_y, pixel, obs.background)  # what a read of (X, Y) gives
    row_end = Cat(Const(tile.width - 1, tile.x_bits), g.Y)
    # written in this pass of its row, the row not yet marked written: the row's end is in
    # flight, or the row is still open and (X, Y) was taken
    row_open = (g.last[1] == g.Y) & g.row_open & ~g.need_first
    done = in_flight(row_end) | (row_open & (g.last[0] >= g.X))
    seen_y = g.seen.bit_select(g.Y, 1)
    n = tile.cell_bits
    count = g.count
    p = obs.p
    checks = [
        (g.background == obs.background, "background"),
        (obs.acc[:n] == g.prev[:n], "row prefix sum"),
        (g.flushing == (flush | obs.p_valid), "flushing"),
        (_When(flush | obs.p_valid | g.need_first, ~busy), "nothing in flight"),
        (_When(flush | obs.p_valid, g.need_first), "no cell since the flush"),
        (_When(g.row_open, ~g.need_first & (g.last[0] != tile.width - 1)), "open row"),
        (_When(~g.need_first, g.seen.bit_select(g.last[1], 1)), "last row seen"),
        (_When(g.flushing, g.seen == 0), "no row seen in a flush"),
        (_When(seen_y & ~row_open & ~in_flight(row_end) & ~flush, written_y), "seen row written"),
        (
            _When(obs.p_valid, (Cat(p.x, p.y) == count) & (p.last == (count == tile.pixels - 1))),
            "output position",
        ),
        (_When(obs.p_valid, p.last == ~flush), "the last pixel waits after the flush"),
        (
            _When(flush, Cat(obs.fx, obs.fy) == (count + obs.p_valid)[: len(count)]),
            "flush position",
        ),
        (
            _When(flush & (tracked >= Cat(obs.fx, obs.fy)), g.frame == shown),
            "frame not yet read",
        ),
        (
            _When(obs.p_valid & (Cat(p.x, p.y) == tracked), g.pixels.payload.value == g.frame),
            "frame waiting",
        ),
        (_When(flush, g.value == g.background), "value in a flush"),
        (
            _When(~flush & ~in_flight(tracked), g.value == Mux(done, pixel, shown)),
            "value",
        ),
    ]
    for i, st in enumerate(stages):
        position = Cat(st.x, st.y)
        checks.append((_When(st.valid, position <= last_pos), f"stage {i} taken"))
        for older in stages[i + 1 :]:
            both = st.valid & older.valid
            checks.append((_When(both, Cat(older.x, older.y) < position), f"stage {i} order"))
    _state_checks(m, checks, covers)


# -- running ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class TileProof:
    """One SymbiYosys run of a `TileHarness`."""

    name: str
    stage: str
    checks: tuple[str, ...]
    mode: str  # prove (k-induction) or bmc
    depth: int
    tile: TileConfig = SMALL_TILE
    reset: bool = False
    memory_map: bool = True
    description: str = ""


TILE_PROOFS: dict[str, TileProof] = {
    proof.name: proof
    for proof in (
        TileProof(
            "acc_stream",
            "accumulator",
            ("stream",),
            "prove",
            1,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="cells hold rule, any reachable state (k-induction), default tile",
        ),
        TileProof(
            "res_stream",
            "resolve",
            ("stream",),
            "prove",
            1,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="pixels hold rule, any reachable state (k-induction), default tile",
        ),
        TileProof(
            "acc_deltas",
            "accumulator",
            ("deltas",),
            "prove",
            2,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="every touched cell sent once per end and before the next op, "
            "untouched rows not sent, order, fields, tile and flush passed on (k-induction "
            "with the scan's invariants)",
        ),
        TileProof(
            "acc_sums",
            "accumulator",
            ("sums",),
            "prove",
            2,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="each cell sent carries the sum of its deltas since the last time it "
            "was sent or the last reset (a reset with deltas kept sends the accumulator through "
            "its clear pass), modulo 2**cell_bits (k-induction with the memory's and "
            "read-modify-write stages' invariants), default tile",
        ),
        TileProof(
            "res_pixels",
            "resolve",
            ("pixels",),
            "prove",
            resolve_latency(SMALL_CONFIG) + 1,  # a cell in flight is written within k
            description="pixels equal the model's composite of exact prefix sums within the "
            "documented range (no overflow; k-induction with the pipeline's and the pixel "
            "memory's invariants)",
        ),
        *(
            TileProof(
                f"{name}_cover",
                stage,
                (check,),
                "cover",
                depth,
                reset=stage == "accumulator",  # the clear pass's invariants reached too
                description=f"each invariant of {name} (an implication) has its premise reached "
                "with its conclusion (not vacuous; cover from power-on, with resets for the "
                "accumulator)",
            )
            for name, stage, check, depth in (
                ("acc_deltas", "accumulator", "deltas", 16),
                ("acc_sums", "accumulator", "sums", 16),
                ("res_pixels", "resolve", "pixels", 14),
            )
        ),
    )
}


def _lookup(proof) -> TileProof:
    if isinstance(proof, TileProof):
        return proof
    try:
        return TILE_PROOFS[proof]
    except KeyError:
        names = ", ".join(TILE_PROOFS)
        raise ValueError(f"proof must be one of {names} or a TileProof, not {proof!r}") from None


def run_tile_proof(
    proof,
    *,
    tile: TileConfig | None = None,
    fault: str | None = None,
    depth: int | None = None,
    mode: str | None = None,
    solver: str = "yices",
    workdir=None,
    timeout: float | None = None,
    tail: int = 40,
    invariants: bool = True,
) -> FormalResult:
    """Build the harness of `proof` (a `TILE_PROOFS` name or a `TileProof`), run sby, return
    the result (`edgeaa.sim.verification.formal.run.run_proof`'s, for the tile stages).
    ``invariants``: `TileHarness`'s (off: the groups' own assertions only); in ``cover`` mode
    the harness covers each invariant's premise (`TileHarness` ``covers``)."""
    proof = _lookup(proof)
    mode, depth = mode or proof.mode, proof.depth if depth is None else depth
    tools = find_tools(solver)
    harness = TileHarness(
        tile or proof.tile,
        proof.stage,
        proof.checks,
        reset=proof.reset,
        fault=fault,
        invariants=invariants,
        covers=mode == "cover",
    )
    script = sby_script(mode, depth, solver=solver)
    if proof.memory_map:  # the memories as flip-flops: faster for the small tiles
        script = script.replace("prep -top formal_top", "prep -top formal_top\nmemory_map")
    name = proof.name + (f"+{fault}" if fault else "")
    return run_harness(
        name,
        harness_rtlil(harness),
        script,
        tools,
        mode=mode,
        depth=depth,
        workdir=workdir,
        timeout=timeout,
        tail=tail,
    )


def main(argv=None) -> int:
    """``python -m edgeaa.sim.verification.formal.tile [proof ...]``."""
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m edgeaa.sim.verification.formal.tile",
        description="Formal proofs of the tile stages.",
        epilog="proofs: " + ", ".join(f"{p.name} ({p.description})" for p in TILE_PROOFS.values()),
    )
    parser.add_argument("proofs", nargs="*", default=list(TILE_PROOFS))
    parser.add_argument("--fault", choices=tuple(TILE_FAULTS))
    parser.add_argument("--depth", type=int)
    parser.add_argument("--mode", choices=("prove", "bmc", "cover"))
    parser.add_argument("--workdir", help="keep the runs in WORKDIR/<proof>")
    parser.add_argument("--timeout", type=float)
    parser.add_argument(
        "--no-invariants",
        dest="invariants",
        action="store_false",
        help="the groups' own assertions only (not inductive)",
    )
    args = parser.parse_args(argv)
    return report(
        run_tile_proof(
            name,
            fault=args.fault,
            depth=args.depth,
            mode=args.mode,
            workdir=Path(args.workdir) / name if args.workdir else None,
            timeout=args.timeout,
            invariants=args.invariants,
        )
        for name in args.proofs
    )


if __name__ == "__main__":
    raise SystemExit(main())
