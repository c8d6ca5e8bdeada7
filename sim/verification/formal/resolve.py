# amaranth: UnusedElaboratable=no
"""The resolve's ``pixels`` group and its invariants (`check_pixels`), for `tile.TileHarness`.

``resolve`` ``pixels``
    The resolve's input is assumed to be what the accumulator is proved to send (rows of
    consecutive cells from a ``start``, ascending, ``first`` on a polygon's first, the
    polygon's fields constant). Each cell's
    sum is the residue modulo ``2**cell_bits`` of a difference of two exact prefix sums
    chosen by the harness (``AnySeq``): the exact prefix sum of the row up to the cell (from
    the row's ``start``), assumed within the documented range ``[-L, L)``, ``L = 2**(h + 1) ifix``
    (`TileConfig.winding_limit`; polygons with ``I_in == I_out`` are not limited, as in the
    model). One symbolic pixel (X, Y) and its shadow: the background of the last tile op,
    then for each cell (X, Y) taken the model's own `composite` of `intensity_offset` of the
    model's `fill_coverage` of the exact prefix sum, computed on Amaranth values in full
    width. Asserted: a flush sends every pixel once, in raster order, ``last`` on the last,
    and pixel (X, Y) equals the shadow; no pixel is sent outside a flush. So the wrapping
    cells, the wrapping prefix sum and the ``h + 1``-step even-odd fold are exact in the
    documented range (no overflow); outside it they are not (fault ``wide_range``). With
    pixel lanes (`TileResolve.lanes` > 1: the fast pipeline's two) a beat is the ``lanes``
    pixels from its (x, y) on: the count goes by beats, ``last`` is on the tile's last beat,
    and each lane's value is asserted where its pixel is (X, Y), so no pixel is lost,
    doubled or sent in another lane's place (fault ``swap_lanes``). With scan lanes
    (`TileResolve.scan_lanes` 2: the fast pipeline's) the input is beats of two cells, ``x``
    even, the beats following one another as the cells do; each cell's sum is the residue
    of its exact prefix less the one before it (the beat's first cell's or the row's last
    one's), each in the range, and (X, Y) takes the composite of the exact prefix of the
    beat's cell in its column.

Invariants (`_resolve_invariants`): (X, Y) not in flight holds the shadow: its word in the
pixel memory the resolve writes (``bank``) if the word's written flag is set, else the
background; in a flush (not a sweep, which sends nothing) the frame equals what the flush
side reads of (X, Y) (the other memory's word if its flag is set, else the flushed tile's
background; with lanes, the word of (X, Y)'s lane memory) until (X, Y) is read, the flush
reads whole beats, and the waiting pixel (X, Y) equals the frame; a memory not written since
its last flush or sweep holds no flag for (X, Y), nor do the beats a flush or sweep has
read, but for the clear of the beat read the clock before; no sweep after power-on; the
row's prefix sum register is the exact prefix modulo ``2**cell_bits``; the pipeline's cells
in taken order, none after the last taken and none before a polygon's first cell (a cell's
position as read from the resolve's delay memory at the address its stage names, the last
stage's the delay line's read port data: `_resolve_stages`); the flush and output positions
and ``last`` follow the pixel count; the background is the shadow's. A cell in flight has no
invariant of its own: with k above the resolve's latency every cell the induction step sees
written was taken within the k clocks it assumes, from a state where the invariants held
(the delay lines' words it reads were written in them too).
"""

from __future__ import annotations

import types

from amaranth.asserts import AnyConst, AnySeq
from amaranth.hdl import Assert, Assume, Cat, Const, Mux, Signal, signed

from ....hdl.layouts import CELL_OP, cell_sum_fields, pixel_value_fields
from ....model.accumulate import composite, fill_coverage, intensity_offset
from ....model.tile import RESOLVE_OPS
from .spec import HdlArith, all_, implies
from .tile_common import When, any_, follows, memory_reader, state_checks, track_rows

__all__ = ["check_pixels"]


def check_pixels(m, tile, dut, payload, read, *, wide, invariants, covers, pixels=None):
    """The ``pixels`` group on `dut` (a `TileResolve`) given the source's `payload`; with
    `invariants`, also the invariants that make it inductive (`read`: the harness's reader of
    the pixel memory). ``wide``: fault ``wide_range``; `pixels`: the output stream as the
    group sees it (None: the resolve's; fault ``swap_lanes``)."""
    pixels = dut.pixels if pixels is None else pixels
    g = _resolve_pixels(
        m, tile, dut.cells, payload, pixels, wide=wide, lanes=dut.lanes, scan=dut.scan_lanes
    )
    if invariants:
        _resolve_invariants(m, tile, dut, read, g, covers)


def _resolve_source(m, tile, cells, src, wide, scan=1):
    """Assumptions on the resolve's input (what the accumulator is proved to send, in beats of
    `scan` cells, ``x`` a multiple of `scan`; `src`, the source's payload) and the exact
    prefix sums; returns (the ghost of the input: ``exact`` the exact prefix of each cell of
    the beat taken now, ``prev`` the beat before's last, ``last``, ``row_open``,
    ``need_first``; d; a beat taken)."""
    c = src
    take = cells.valid & cells.ready
    is_cell = c.op == CELL_OP["cell"]
    last = [Signal(tile.x_bits, name="last_x"), Signal(tile.y_bits, name="last_y")]
    params = {n: Signal.like(c[n], name=f"poly_{n}") for n in ("intensity", "i_out", "evenodd")}
    need_first = Signal(init=1, name="need_first")
    well_formed = [
        c.op < len(RESOLVE_OPS),
        implies(is_cell, c.first | (~need_first & follows(c.x, c.y, c.start, *last, scan))),
        implies(is_cell, (c.x & (scan - 1)) == 0),
        implies(is_cell & c.first, c.start),
        implies(is_cell & ~c.first, all_(c[n] == r for n, r in params.items())),
    ]
    with m.If(cells.valid):
        m.d.comb += Assume(all_(well_formed), "source: cells as the accumulator sends them")
    track_rows(m, c, take & is_cell, last)
    with m.If(take & is_cell):
        m.d.sync += need_first.eq(0)
        with m.If(c.first):
            m.d.sync += [r.eq(c[n]) for n, r in params.items()]
    with m.If(take & ~is_cell):
        m.d.sync += need_first.eq(1)
    n = tile.cell_bits
    prev = Signal(signed(n + 4), name="exact_prev")
    exact = [Signal(signed(n + 4), name="exact" + (f"{k}" if k else "")) for k in range(scan)]
    m.d.comb += [e.eq(AnySeq(n + 4)) for e in exact]
    d = Mux(c.intensity >= c.i_out, c.intensity - c.i_out, c.i_out - c.intensity)
    limit = (tile.winding_limit * (2 if wide else 1)) * (d << tile.config.F)
    before = Mux(c.start, 0, prev)  # each cell's exact prefix less the one before it
    for e, name in zip(exact, cell_sum_fields(scan), strict=True):
        residue = (e - before)[:n]
        in_range = (d == 0) | ((e >= -limit) & (e < limit))
        with m.If(cells.valid & is_cell):
            m.d.comb += Assume(in_range & (c[name][:n] == residue), "source: exact sums")
        before = e
    with m.If(take & is_cell):
        m.d.sync += prev.eq(exact[-1])
    exact = exact if scan > 1 else exact[0]
    ghost = types.SimpleNamespace(last=last, need_first=need_first, prev=prev, exact=exact)
    return ghost, d, take & is_cell


def _resolve_pixels(m, tile, cells, src, pixels, *, wide, lanes=1, scan=1):
    """The ``pixels`` group (module docstring); `src` is the source's payload; `lanes` the
    pixels a beat carries (lane k the pixel after lane 0's k places in raster order); `scan`
    the cells a beat of the input carries (lane k the column ``x + k``)."""
    config, c = tile.config, src
    g, d, took = _resolve_source(m, tile, cells, src, wide, scan)
    exacts = g.exact if scan > 1 else [g.exact]
    X, Y = Signal(tile.x_bits, name="track_x"), Signal(tile.y_bits, name="track_y")
    m.d.comb += [X.eq(AnyConst(tile.x_bits)), Y.eq(AnyConst(tile.y_bits))]
    bits = config.intensity_bits
    value, frame, background = (Signal(bits, name=n) for n in ("value", "frame", "background"))
    take = cells.valid & cells.ready
    ifix = d << config.F
    for k, exact in enumerate(exacts):  # (X, Y) in lane k of the beat taken
        coverage = fill_coverage(HdlArith(config), exact, c.evenodd, ifix)
        q = intensity_offset(coverage, config.F)
        new = composite(value, q, c.intensity, d)
        mine = (c.x == X) if k == 0 else (c.x + k == X)
        with m.If(took & mine & (c.y == Y) & (d != 0)):
            m.d.sync += value.eq(new)
    with m.If(take & (c.op == CELL_OP["tile"])):
        m.d.sync += [value.eq(c.background), background.eq(c.background)]
    flushing = Signal(name="flushing_h")
    count = Signal(range(tile.pixels), name="pixel_count")
    p, sent = pixels.payload, pixels.valid & pixels.ready
    checks = [
        (implies(sent, flushing), "pixels: a pixel outside a flush"),
        (implies(sent, (p.x | (p.y << tile.x_bits)) == count), "pixels: raster order"),
        (implies(sent, p.last == (count == tile.pixels - lanes)), "pixels: last flag"),
    ]
    for k, name in enumerate(pixel_value_fields(lanes)):  # (X, Y) in lane k
        mine = (p.x == X) & (p.y == Y) if lanes == 1 else Cat(p.x, p.y) + k == Cat(X, Y)
        checks.append((implies(sent & mine, p[name] == frame), "pixels: value"))
    for condition, message in checks:
        m.d.comb += Assert(condition, message)
    with m.If(sent):
        m.d.sync += count.eq(count + lanes)
        with m.If(p.last):
            m.d.sync += flushing.eq(0)
    # after the pixel: a flush may be taken in the clock its predecessor's last pixel goes
    with m.If(take & (c.op == CELL_OP["flush"])):
        m.d.sync += [frame.eq(value), value.eq(background), flushing.eq(1), count.eq(0)]
    g.__dict__.update(
        X=X, Y=Y, value=value, frame=frame, background=background, flushing=flushing, count=count
    )
    g.lanes, g.scan = lanes, scan
    g.pixels = pixels
    return g


def _resolve_stages(m, dut):
    """The resolve's stages as the invariants see them (each with ``valid``, ``x``, ``y``, ...):
    a stage's own registers, and the values it carries in the resolve's delay lines
    (``observe.delays``) as read from the delay memory at the address the stage names
    (``delayed``; a combinational read port of the harness's each). The last stage's carried
    values are the delay lines' read ports' data, what its write uses."""
    delays = dut.observe.delays
    readers = {name: memory_reader(m, mem) for name, mem in delays.items()}
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
    stages = _resolve_stages(m, dut)
    busy = any_(st.valid for st in stages)
    flush, silent = dut.flushing, obs.silent
    last_pos = Cat(*g.last)
    tracked = Cat(g.X, g.Y)
    scan, count, lanes = g.scan, g.count, g.lanes
    # the beat of cells holding (X, Y), and the flush's beat holding it: their first columns
    scan_bits = scan.bit_length() - 1
    tracked_beat = Cat(Const(0, scan_bits), g.X[scan_bits:], g.Y) if scan > 1 else tracked
    lane_bits = lanes.bit_length() - 1
    flush_beat = Cat(Const(0, lane_bits), tracked[lane_bits:]) if lanes > 1 else tracked

    def in_flight(position):
        return any_(st.valid & (Cat(st.x, st.y) == position) for st in stages)

    def flag(bank):  # (X, Y)'s written flag in memory `bank`
        return read(tracked, bank)[-1]

    word = read(tracked, obs.bank)  # the memory the resolve writes
    shown = Mux(word[-1], word[:-1], obs.background)  # what a read of (X, Y) gives
    # what the flush reads of (X, Y): the other memory, the flushed tile's background
    fword = read(tracked, ~obs.bank)
    flushed = Mux(fword[-1], fword[:-1], obs.fbackground)
    position = Cat(obs.fx, obs.fy)
    # the clear of (X, Y)'s beat, read a clock ago, still to be written (the other memory)
    clearing = obs.clear.en & (obs.clear.addr == flush_beat)
    p = obs.p
    beat = Cat(p.x, p.y)
    waiting = [  # (X, Y) in lane k of the waiting beat: its value is the frame
        (
            When(obs.p_valid & (beat + k == tracked), g.pixels.payload[name] == g.frame),
            "frame waiting",
        )
        for k, name in enumerate(pixel_value_fields(lanes))
    ]
    if lanes > 1:  # the flush reads whole beats: a lane's memory word each
        waiting.append((count[: lanes.bit_length() - 1] == 0, "whole beats"))
    checks = [
        (g.background == obs.background, "background"),
        (obs.acc[: tile.cell_bits] == g.prev[: tile.cell_bits], "row prefix sum"),
        (g.flushing == ((flush & ~silent) | obs.p_valid), "flushing"),
        (When(flush & silent, ~obs.p_valid), "a sweep sends nothing"),
        (When(g.need_first, ~busy), "nothing in flight"),
        (~obs.recover | ~(obs.dirty[0] | obs.dirty[1]), "no sweep after power-on"),
        (When(obs.clear.en, (obs.clear.addr + lanes)[: len(position)] == position), "clear"),
        *(
            (When(~obs.dirty[k] & ~(clearing & (obs.bank != k)), ~flag(k)), f"clean {k}")
            for k in range(2)
        ),
        (When(flush & (flush_beat < position) & ~clearing, ~flag(~obs.bank)), "swept"),
        (
            When(obs.p_valid, (beat == count) & (p.last == (count == tile.pixels - lanes))),
            "output position",
        ),
        (When(obs.p_valid, p.last == ~flush), "the last pixel waits after the flush"),
        (
            When(flush & ~silent, position == (count + lanes * obs.p_valid)[: len(count)]),
            "flush position",
        ),
        (
            When(flush & ~silent & (tracked >= position), g.frame == flushed),
            "frame not yet read",
        ),
        *waiting,
        (When(~in_flight(tracked_beat), g.value == shown), "value"),
    ]
    for i, st in enumerate(stages):
        position = Cat(st.x, st.y)
        checks.append((When(st.valid, position <= last_pos), f"stage {i} taken"))
        for older in stages[i + 1 :]:
            both = st.valid & older.valid
            checks.append((When(both, Cat(older.x, older.y) < position), f"stage {i} order"))
    state_checks(m, checks, covers)
