"""``stream``: the hold rule of the output stream (``writes``, or ``deltas`` for the deltas
core) and, for the writes core, of the setup's ``bank`` stream (whose payload is formed from
the setup's registers, held by its HOLD state). A beat that is valid and not taken stays
valid with the same payload in the next clock (unless the reset is asserted in between)."""

from __future__ import annotations

from amaranth.hdl import Signal, Value


def check(ctx):
    m, out = ctx.m, ctx.out
    prev = Signal(len(ctx.payload))
    m.d.sync += prev.eq(ctx.payload)
    if "stream" in ctx.checks or "stream" in ctx.assumes:
        with m.If(ctx.held):
            ctx.emit("stream", out.valid, "stream: a held beat stays valid")
            ctx.emit("stream", ctx.payload == prev, "stream: a held beat keeps its payload")
        # The bank's hold is the setup's HOLD, the same for both outputs; the deltas bank's
        # extra fields (a product among them) make its induction take minutes, not seconds.
        if ctx.output == "writes":
            _bank(ctx)


def _bank(ctx):
    m, bank = ctx.m, ctx.setup.bank
    payload = Value.cast(bank.payload)
    prev, held = Signal(len(payload)), Signal()
    m.d.sync += held.eq(bank.valid & ~bank.ready)
    if ctx.fault == "stall_bank":
        payload = payload ^ held
    m.d.sync += prev.eq(payload)
    with m.If(held):
        ctx.emit("stream", bank.valid, "stream: a held bank stays valid")
        ctx.emit("stream", payload == prev, "stream: a held bank keeps its payload")
