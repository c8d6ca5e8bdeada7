"""The hold rule, once for every proof (`held`, `hold_rule`), and the ``stream`` group of the
core's harness (`check`): the hold rule of the output stream (``writes``, or ``deltas`` for
the deltas core) and, for the writes core, of the setup's ``bank`` stream (whose payload is
formed from the setup's registers, held by its HOLD state). A beat that is valid and not
taken stays valid with the same payload in the next clock (unless the reset is asserted in
between)."""

from __future__ import annotations

from amaranth.hdl import Signal, Value


def held(m, stream, name: str = "held") -> Signal:
    """High in the clock after one where `stream` was valid and not ready."""
    flag = Signal(name=name)
    m.d.sync += flag.eq(stream.valid & ~stream.ready)
    return flag


def hold_rule(m, valid, payload, was_held, emit, what: str) -> None:
    """The hold rule of a stream as `emit(condition, message)` states it (an Assert of a
    stage's output, an Assume of a free source): after a clock where it was valid and not
    taken (`was_held`, from `held`), it is valid with the same `payload` (as the checks see
    it: a fault acts there)."""
    payload = Value.cast(payload)
    prev = Signal(len(payload), name=f"{what.replace(' ', '_')}_prev")
    m.d.sync += prev.eq(payload)
    with m.If(was_held):
        emit(valid, f"stream: a held {what} stays valid")
        emit(payload == prev, f"stream: a held {what} keeps its payload")


def check(ctx):
    if "stream" in ctx.checks or "stream" in ctx.assumes:

        def emit(condition, message):
            ctx.emit("stream", condition, message)

        hold_rule(ctx.m, ctx.out.valid, ctx.payload, ctx.held, emit, "beat")
        # The bank's hold is the setup's HOLD, the same for both outputs; the deltas bank's
        # extra fields (a product among them) make its induction take minutes, not seconds.
        if not ctx.format.pieces:
            bank = ctx.setup.bank
            payload, was_held = Value.cast(bank.payload), held(ctx.m, bank, "bank_held")
            if ctx.fault == "stall_bank":
                payload = payload ^ was_held
            hold_rule(ctx.m, bank.valid, payload, was_held, emit, "bank")
