"""The one Amaranth driver (`edgeaa.sim.simulators.amaranth_runner.run_component`) on a
one-beat register stage: payloads in order under seeded idles and stalls, probes every
clock, and its own checks can fail (a stalled beat that changes, a stage that stops, a beat
too many)."""

from __future__ import annotations

import pytest
from amaranth.hdl import Module, Signal
from amaranth.lib import stream, wiring
from amaranth.lib.wiring import In, Out

from edgeaa.sim.simulators.amaranth_runner import (
    Probe,
    SimulationHang,
    Sink,
    Source,
    run_component,
)
from edgeaa.sim.simulators.streams import StreamProtocolError


class Stage(wiring.Component):
    """A register stage from `i` to `o` adding one; `bug` breaks it on purpose: ``"drop"``
    lets a stalled beat go (valid falls without a transfer), ``"stop"`` takes nothing after
    the third payload, ``"twice"`` sends the first payload twice."""

    def __init__(self, bug: str | None = None):
        self.bug = bug  # `count`: the transfers taken
        ports = {"i": In(stream.Signature(8)), "o": Out(stream.Signature(8)), "count": Out(8)}
        super().__init__(ports)

    def elaborate(self, platform):
        m = Module()
        again = Signal(init=self.bug == "twice")
        room = ~self.o.valid | (self.o.ready & ~again)
        m.d.comb += self.i.ready.eq(room & (self.count < 3) if self.bug == "stop" else room)
        with m.If(self.o.valid & self.o.ready):
            m.d.sync += self.o.valid.eq(again)
            m.d.sync += again.eq(0)
        if self.bug == "drop":
            with m.If(self.o.valid & ~self.o.ready):
                m.d.sync += self.o.valid.eq(0)
        with m.If(self.i.valid & self.i.ready):
            m.d.sync += [self.o.valid.eq(1), self.o.payload.eq(self.i.payload + 1)]
            m.d.sync += self.count.eq(self.count + 1)
        return m


def run(bug=None, *, seed=None, payloads=range(20), expected=20, stuck=200):
    dut = Stage(bug)
    seen = []
    probe = Probe((dut.i.valid, dut.i.ready), lambda clock, *values: seen.append(clock))
    trace = run_component(
        dut, [Source("i", list(payloads))], [Sink("o", expected)], drain=16, stuck=stuck,
        probes=[probe], final=[dut.count], seed=seed, idle=0.4, stall=0.5,
        tag=f"[stage seed={seed}]",
    )  # fmt: skip
    return trace, seen


@pytest.mark.parametrize("seed", [None, 1, 2])
def test_every_payload_in_order_each_once(seed):
    trace, seen = run(seed=seed)
    assert [beat for _, beat in trace.beats[0]] == list(range(1, 21)), f"seed {seed}"
    assert len(trace.accepts[0]) == 20 and trace.final == (20,), f"seed {seed}"
    assert seen == list(range(trace.clocks)), "a probe sees every clock"
    if seed is None:  # back to back: one transfer a clock, then the drain
        assert trace.accepts[0] == list(range(20)) and trace.clocks == 21 + 16
    else:
        assert trace.clocks > 40, f"seed {seed}: no idles or stalls"


def test_a_stalled_beat_that_vanishes_is_caught():
    with pytest.raises(StreamProtocolError, match=r"\[stage seed=3\] clock \d+: a stalled beat"):
        run("drop", seed=3)


def test_a_stage_that_stops_is_a_hang_not_a_wait():
    left = r"nothing moved for 50 clocks, .*\(i: 3 of 20 taken, o: 3 of 20 out\)"
    with pytest.raises(SimulationHang, match=left):
        run("stop", seed=None, stuck=50)


def test_a_beat_too_many_is_collected_in_the_drain():
    trace, _ = run("twice")
    assert [beat for _, beat in trace.beats[0]][:3] == [1, 1, 2]
    assert len(trace.beats[0]) == 21
