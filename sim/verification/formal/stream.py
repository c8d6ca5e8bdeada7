"""``stream``: the output stream's hold rule (``writes``, or ``deltas`` for the deltas core).
A beat that is valid and not taken stays valid with the same payload in the next clock
(unless the reset is asserted in between)."""

from __future__ import annotations

from amaranth.hdl import Signal


def check(ctx):
    m, out = ctx.m, ctx.out
    prev = Signal(len(ctx.payload))
    m.d.sync += prev.eq(ctx.payload)
    if "stream" in ctx.checks or "stream" in ctx.assumes:
        with m.If(ctx.held):
            ctx.emit("stream", out.valid, "stream: a held beat stays valid")
            ctx.emit("stream", ctx.payload == prev, "stream: a held beat keeps its payload")
