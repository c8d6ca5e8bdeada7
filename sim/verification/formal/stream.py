"""``stream``: the ``writes`` hold rule. A beat that is valid and not taken stays valid with
the same payload in the next clock (unless the reset is asserted in between)."""

from __future__ import annotations

from amaranth.hdl import Signal


def check(ctx):
    m, writes = ctx.m, ctx.core.writes
    prev = Signal(len(ctx.payload))
    m.d.sync += prev.eq(ctx.payload)
    if "stream" in ctx.checks or "stream" in ctx.assumes:
        with m.If(ctx.held):
            ctx.emit("stream", writes.valid, "stream: a held beat stays valid")
            ctx.emit("stream", ctx.payload == prev, "stream: a held beat keeps its payload")
