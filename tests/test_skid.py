"""The skid buffer (`edgeaa.hdl.skid.SkidBuffer`) in Amaranth's simulator, under random
valid and ready patterns: every beat comes out once, in order; a beat goes straight
through while the buffer is empty; the sink's ready is a register (no path from the
source's ready to it); a source beat not taken stays valid with the same payload."""

from __future__ import annotations

from amaranth.sim import Simulator
from hypothesis import given, settings
from hypothesis import strategies as st

from edgeaa.hdl.skid import SkidBuffer

WIDTH = 8


def run(offers: list[bool], readies: list[bool]) -> tuple[list[int], int]:
    """Offer beats 1, 2, ... in the clocks `offers` says (a beat offered stays offered until
    taken), the source ready as `readies` says; returns the payloads taken at the source and
    the number of beats the sink took."""
    dut = SkidBuffer(WIDTH)
    out: list[int] = []
    sent = []

    async def bench(ctx):
        beat, offering, waiting = 1, False, None
        for want, ready in zip(offers, readies, strict=True):
            offering = offering or want
            ctx.set(dut.sink.valid, offering)
            ctx.set(dut.sink.payload, beat)
            ctx.set(dut.source.ready, 0)
            ready_if_not = ctx.get(dut.sink.ready)
            ctx.set(dut.source.ready, ready)
            assert ctx.get(dut.sink.ready) == ready_if_not, "a path from source.ready"
            assert ctx.get(dut.sink.ready) == (not ctx.get(dut.held))
            valid, payload = ctx.get(dut.source.valid), ctx.get(dut.source.payload)
            if waiting is not None:  # not taken last clock: the same beat again
                assert valid and payload == waiting
            if not ctx.get(dut.held) and offering:  # empty: straight through
                assert valid and payload == beat
            if valid and ready:
                out.append(payload)
            waiting = payload if valid and not ready else None
            if offering and ctx.get(dut.sink.ready):
                beat, offering = beat + 1, False
            await ctx.tick()
        ctx.set(dut.sink.valid, 0)
        ctx.set(dut.source.ready, 1)
        for _ in range(2):  # the held beat, if any, comes out
            if ctx.get(dut.source.valid):
                out.append(ctx.get(dut.source.payload))
            await ctx.tick()
        assert not ctx.get(dut.source.valid)
        sent.append(beat - 1)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    return out, sent[0]


@settings(max_examples=40, deadline=None)
@given(pattern=st.lists(st.tuples(st.booleans(), st.booleans()), min_size=1, max_size=60))
def test_every_beat_comes_out_once_in_order(pattern):
    offers, readies = [p[0] for p in pattern], [p[1] for p in pattern]
    out, sent = run(offers, readies)
    assert out == list(range(1, sent + 1))


def test_a_stalled_source_holds_one_beat_and_stops_the_sink():
    """Beat 1 offered and not taken goes into the buffer; beat 2 then waits at the sink."""
    out, sent = run([True, True, True, False], [False, False, True, True])
    assert (out, sent) == ([1, 2], 2)
