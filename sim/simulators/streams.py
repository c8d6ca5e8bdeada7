"""Testbench helpers for `amaranth.lib.stream` interfaces (Amaranth 0.5 async testbenches).

Use them inside ``sim.add_testbench(async def bench(ctx): ...)``; ``stream`` is the
interface seen from the design (``dut.i`` for a source you drive, ``dut.o`` for a sink you
drain). Each call consumes whole clock cycles and returns right after the clock edge at
which the transfer happened, with valid/ready deasserted again, so calls chain back to back
and a transfer per cycle is possible.

- `stream_put` / `stream_get`: one transfer at full rate (Glasgow's helpers).
- `stream_put_random` / `stream_get_random`: the same with random idle cycles before valid
  (a source with bubbles) or ready randomly low (a sink with back-pressure), drawn from a
  seeded ``random.Random`` so failures replay.
- `stream_put_all` / `stream_get_packet`: sequences of the above.

`stream_get_random` also checks the hold rule the edgeaa cores keep (as in AXI-Stream): once
``valid`` is high it stays high, with the same payload, until the transfer. A violation raises
`StreamProtocolError` naming the cycle's values.

The waits are plain ``await ctx.tick().sample(...)`` loops rather than ``.until(...)``: when a
test fails, the other testbenches stay suspended and are closed later by the garbage
collector, and a suspended ``until`` then raises "aclose(): asynchronous generator is already
running" from a finaliser, which on CPython 3.11 can crash pytest's report (INTERNALERROR,
"AST constructor recursion depth mismatch") and hide the real failure.

Payloads: `stream_put` takes anything ``ctx.set`` accepts for the payload (an int, or a dict
or `data.Const` for a `data.StructLayout`); the getters return what ``ctx.get`` returns (an
int, or a `data.Const` whose fields read as attributes: ``pixel.x``).
"""

from __future__ import annotations

import random

from amaranth.hdl import Value

__all__ = [
    "StreamProtocolError",
    "stream_get",
    "stream_get_packet",
    "stream_get_random",
    "stream_put",
    "stream_put_all",
    "stream_put_random",
]


class StreamProtocolError(AssertionError):
    """The design broke the stream hold rule (valid dropped or payload changed while held)."""


def _check_probability(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not 0 <= value < 1:
        raise ValueError(f"{name} must be a probability in [0, 1), not {value!r}")
    return float(value)


def _check_rng(rng) -> random.Random:
    if not isinstance(rng, random.Random):
        raise TypeError(f"rng must be a random.Random (seeded, so runs replay), not {rng!r}")
    return rng


async def stream_put(ctx, stream, payload) -> None:
    """Offer `payload` with valid high until the design takes it (ready high at an edge)."""
    ctx.set(stream.payload, payload)
    ctx.set(stream.valid, 1)
    while True:
        _, _, ready = await ctx.tick().sample(stream.ready)
        if ready:
            break
    ctx.set(stream.valid, 0)


async def stream_get(ctx, stream):
    """Hold ready high until valid is high at an edge; return the payload taken there."""
    ctx.set(stream.ready, 1)
    while True:
        _, _, valid, payload = await ctx.tick().sample(stream.valid, stream.payload)
        if valid:
            break
    ctx.set(stream.ready, 0)
    return payload


async def stream_put_random(ctx, stream, payload, rng: random.Random, *, idle: float = 0.5):
    """`stream_put` after a random number of idle cycles (valid low).

    Each cycle before the offer is idle with probability `idle`, so the gap is geometric with
    mean idle / (1 - idle) cycles (0 cycles with probability 1 - idle). Once valid is raised
    it stays high until the transfer.
    """
    _check_rng(rng)
    idle = _check_probability("idle", idle)
    ctx.set(stream.valid, 0)
    while rng.random() < idle:
        await ctx.tick()
    await stream_put(ctx, stream, payload)


async def stream_get_random(
    ctx, stream, rng: random.Random, *, stall: float = 0.5, check_hold: bool = True
):
    """`stream_get` with random back-pressure: ready is low in some cycles.

    Each cycle until the transfer, ready is low with probability `stall` and high otherwise,
    so with a source that is always valid the wait is geometric, mean stall / (1 - stall)
    cycles. With `check_hold`, a payload seen valid at an edge with ready low must still be
    valid, unchanged, at the next edge (and so on up to the transfer).
    """
    _check_rng(rng)
    stall = _check_probability("stall", stall)
    bits = Value.cast(stream.payload)
    held = None  # the raw payload bits seen valid at the previous edge without a transfer
    while True:
        ready = not rng.random() < stall
        ctx.set(stream.ready, ready)
        _, _, valid, payload, raw = await ctx.tick().sample(stream.valid, stream.payload, bits)
        if check_hold and held is not None and (not valid or raw != held):
            raise StreamProtocolError(
                f"{stream!r}: payload {held:#x} was valid while ready was low, but at the next "
                f"clock edge valid={valid} and payload={raw:#x} (valid must stay high with the "
                f"payload unchanged until the transfer)"
            )
        if valid and ready:
            ctx.set(stream.ready, 0)
            return payload
        held = raw if valid else None


async def stream_put_all(
    ctx, stream, payloads, rng: random.Random | None = None, *, idle: float = 0.0
) -> None:
    """Put every payload in order; with `rng`, with random idle cycles before each."""
    for payload in payloads:
        if rng is None:
            await stream_put(ctx, stream, payload)
        else:
            await stream_put_random(ctx, stream, payload, rng, idle=idle)


async def stream_get_packet(
    ctx,
    stream,
    rng: random.Random | None = None,
    *,
    stall: float = 0.0,
    last: str = "last",
    limit: int | None = None,
) -> list:
    """Take payloads up to and including the first whose field `last` is set.

    `limit` bounds the packet length: a design that never sets `last` raises AssertionError
    instead of hanging the simulation.
    """
    packet = []
    while True:
        if rng is None:
            payload = await stream_get(ctx, stream)
        else:
            payload = await stream_get_random(ctx, stream, rng, stall=stall)
        packet.append(payload)
        if getattr(payload, last):
            return packet
        if limit is not None and len(packet) >= limit:
            raise AssertionError(f"no payload with {last} set within {limit} transfers")
