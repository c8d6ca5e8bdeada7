"""What the tile stages' proofs share (`accumulator`, `resolve`, `tile`): the check groups and
faults, the small tile, the source that keeps the hold rule, the invariant
record `When` and its assertion, the harness's memory read ports, and the ghost's record of
the rows of cells sent (what the accumulator is proved to send and the resolve assumes)."""

from __future__ import annotations

from dataclasses import dataclass

from amaranth.asserts import AnySeq
from amaranth.hdl import Assert, Assume, Const, Cover, Mux, Signal, Value

from ....model.config import EdgeConfig
from ....model.tile import TileConfig
from .spec import implies
from .stream import held, hold_rule

TILE_CHECKS = {"accumulator": ("stream", "deltas", "sums"), "resolve": ("stream", "pixels")}
TILE_FAULTS = {
    "stall_cell": "accumulator",
    "swap_cells": "accumulator",
    "lost_delta": "accumulator",
    "stale_origin": "accumulator",
    "stall_pixel": "resolve",
    "wide_range": "resolve",
    "lost_first": "resolve",
    "swap_lanes": "resolve",
    "swap_sums": "resolve",
}

# The smallest tile with W = 4, no sub-pixel bits and 4-bit intensity: 4 x 2 pixels, 18-bit
# cells.
SMALL_CONFIG = EdgeConfig(coord_bits=4, subpixel_bits=0, intensity_bits=4)
SMALL_TILE = TileConfig(SMALL_CONFIG, width=4, height=2)


def any_(conditions):
    result = Const(0, 1)
    for condition in conditions:
        result = result | condition
    return result


@dataclass(frozen=True)
class When:
    """An invariant ``premise -> conclusion`` (`state_checks`)."""

    premise: Value
    conclusion: Value


def state_checks(m, checks, covers, prefix="state: "):
    """Assert each invariant of `checks` ((condition or `When`, message)); with `covers`, also
    cover each `When`'s premise together with its conclusion (the premise is reachable, so
    the invariant is not vacuous)."""
    for condition, message in checks:
        if isinstance(condition, When):
            m.d.comb += Assert(implies(condition.premise, condition.conclusion), prefix + message)
            if covers:
                reached = condition.premise & condition.conclusion
                m.d.comb += Cover(reached, "cover: " + (prefix + message)[len("state: ") :])
        else:
            m.d.comb += Assert(condition, prefix + message)


def free_source(m, stream, fault):
    """Drive `stream` from a free source that keeps the hold rule; returns the source's
    payload (a view) and the flag of a held transfer (the payload is the clock before's).
    Faults ``lost_delta``, ``stale_origin``, ``lost_first``: the stage gets cell 3's delta
    (and its ``nonzero`` flag), x0 or ``first`` zeroed; ``swap_sums``: a beat of two cells
    with their sums swapped."""
    layout = stream.payload.shape()
    free = Signal(layout, name="source")
    m.d.comb += [stream.valid.eq(AnySeq(1)), Value.cast(free).eq(AnySeq(layout.size))]
    given = Signal(layout, name="given")
    m.d.comb += given.eq(free)
    if fault == "lost_delta":  # cell 3 dropped: its delta and its nonzero flag
        m.d.comb += [given.beat.cell3.delta.eq(0), given.beat.nonzero[3].eq(0)]
    if fault == "stale_origin":
        m.d.comb += given.x0.eq(0)
    if fault == "lost_first":
        m.d.comb += given.first.eq(0)
    if fault == "swap_sums":
        m.d.comb += [given.sum.eq(free.sum1), given.sum1.eq(free.sum)]
    m.d.comb += stream.payload.eq(given)
    was_held = held(m, stream, "held_in")

    def assume(condition, message):
        m.d.comb += Assume(condition, message)

    hold_rule(m, stream.valid, free, was_held, assume, "input")
    return free, was_held


def memory_reader(m, mem):
    """A reader of a stage's memory `mem` (``observe.memory``, or a resolve's delay line):
    ``read(address)`` adds a combinational read port at `address` (the harness's; the stage's
    own ports are untouched) and returns its data. A port per address the invariants name, not
    per row, so the memory stays an array for the solver at any tile size."""

    def read(address):
        port = mem.read_port(domain="comb")
        m.d.comb += port.addr.eq(address)
        return port.data

    return read


def bit(tile, y):
    return (Const(1, tile.height) << y)[: tile.height]


def follows(x, y, start, last_x, last_y, step=1):
    """Cell (x, y) comes right after (last_x, last_y): the next column (the next beat of
    `step` cells), or a later row's first cell (`start`)."""
    return Mux(start, y > last_y, (x == last_x + step) & (y == last_y))


def track_rows(m, cell, took, last):
    """The ghost's record of the cells sent: with a cell (a beat) taken (`took`), its position
    (`last`)."""
    with m.If(took):
        m.d.sync += [last[0].eq(cell.x), last[1].eq(cell.y)]
