"""Covers (``mode cover``): ``drop`` a dropped command; ``stepper`` a two-lane beat, a
neighbour in the row below, a beat that is not the last, a last beat, a held beat taken, two
edges in flight. They read what the check families computed (`count`: ``finished``,
``pending_good``; `bounds`: ``column``)."""

from __future__ import annotations

from amaranth.hdl import Cover
from amaranth.lib import data

from ....hdl.layouts import write_layout


def add(ctx):
    m, writes = ctx.m, ctx.core.writes
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
