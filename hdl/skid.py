"""A skid buffer (`SkidBuffer`): a stream passed through with no clock of latency, its
``sink.ready`` the complement of a register (``held``), so a long ``ready`` path downstream
ends here and goes no further upstream.

While the buffer is empty a beat goes straight through (``source`` is ``sink``), and
``sink.ready`` is high. A beat offered and not taken downstream is still taken from the
sink, into the buffer (``held``); from the next clock ``source`` offers the held beat and
``sink.ready`` is low, until the held beat is taken. So the upstream sees a stall a clock
late and at most one beat more than downstream took: the one the buffer holds. The fast
polygon pipeline puts one between its core and its accumulator (`PipelineConfig.beat_skid`;
its cycle model, `edgeaa.model.timing.schedule` with ``skid``; docs/hardware.md, "A skid
buffer before the accumulator").
"""

from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import stream, wiring
from amaranth.lib.wiring import In, Out

__all__ = ["SkidBuffer"]


class SkidBuffer(wiring.Component):
    """`sink` to `source`, a stream of `shape` (module docstring); ``held``: a beat waits in
    the buffer (the sink's ready is its complement)."""

    def __init__(self, shape):
        super().__init__(
            {
                "sink": In(stream.Signature(shape)),
                "source": Out(stream.Signature(shape)),
                "held": Out(1),
            }
        )

    def elaborate(self, platform):
        m = Module()
        buffer = Signal.like(self.sink.payload, name="buffer")
        m.d.comb += [
            self.sink.ready.eq(~self.held),
            self.source.valid.eq(self.held | self.sink.valid),
            self.source.payload.eq(Mux(self.held, buffer, self.sink.payload)),
        ]
        with m.If(self.held & self.source.ready):
            m.d.sync += self.held.eq(0)
        with m.If(~self.held & self.sink.valid & ~self.source.ready):
            m.d.sync += [self.held.eq(1), buffer.eq(self.sink.payload)]
        return m
