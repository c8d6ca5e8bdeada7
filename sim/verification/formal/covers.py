"""Covers (``mode cover``): ``drop`` a dropped command; ``stepper`` a two-lane beat, a
neighbour in the row below, a beat that is not the last, a last beat, a held beat taken, two
edges in flight; ``deltas`` (the deltas core) a beat that is not the last, a last beat, a
held beat taken, two edges in flight, a piece starting in the row above, one ending in the
row below, a column holding both vertices, a y-major column, a negative delta. They read
what the check families computed (`count`: ``finished``, ``pending_good``; `bounds`:
``column``; `deltas`: ``live``)."""

from __future__ import annotations

from amaranth.hdl import Cover
from amaranth.lib import data

from ....hdl.layouts import write_layout
from .spec import axes


def add(ctx):
    m, writes = ctx.m, ctx.out
    if "drop" in ctx.covers:
        m.d.comb += Cover(ctx.error, "cover: dropped command")
    if "stepper" in ctx.covers:
        beat = data.View(write_layout(ctx.config), ctx.payload)
        taken = writes.valid & writes.ready
        column = ctx.column
        m.d.comb += [
            Cover(ctx.held & taken, "cover: held beat taken"),
            Cover(ctx.finished, "cover: last beat"),
            Cover(ctx.pending_good == 2, "cover: two edges in flight"),
            Cover(taken & beat.lane1_valid, "cover: two-lane beat"),
            Cover(ctx.stepper.step & column.two & column.below, "cover: neighbour below"),
            Cover(taken & ~beat.last, "cover: beat that is not the last"),
        ]
    if "deltas" in ctx.covers:
        _deltas(ctx)


def _deltas(ctx):
    m, out, live = ctx.m, ctx.out, ctx.live
    beat = data.View(ctx.layout, ctx.payload)
    taken = out.valid & out.ready
    step = ctx.stepper.step
    m.d.comb += [
        Cover(ctx.held & taken, "cover: held beat taken"),
        Cover(ctx.finished, "cover: last beat"),
        Cover(ctx.pending_good == 2, "cover: two edges in flight"),
        Cover(taken & ~beat.last, "cover: beat that is not the last"),
        Cover(step & live.up, "cover: piece starting in the row above"),
        Cover(step & (live.he > ctx.st.ifix), "cover: piece ending in the row below"),
        Cover(step & live.first & live.last, "cover: one column holding both vertices"),
        Cover(step & ~axes(ctx.st).x_major, "cover: y-major column"),
        Cover(taken & (beat.cell1.delta < 0), "cover: negative delta"),
    ]
