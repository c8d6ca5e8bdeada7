"""One driver for every component under Amaranth's simulator (`run_component`): its input
streams fed from lists of payloads, its output streams collected, clock by clock.

A source offers its payloads in order and holds each (valid high, payload unchanged) until
it is taken. A sink is always ready. With a seed, before each offer the source idles a clock
with probability `idle`, and the sink stalls (ready low) with probability `stall` in every
clock; a beat offered under a stall must stay, unchanged, until taken
(`StreamProtocolError` otherwise). The run stops once every payload is taken, every sink has
its expected beats and `drain` clocks have passed with no beat (so a beat too many shows),
and raises `SimulationHang` after `stuck` clocks in which nothing was taken and no beat came
out while work was left.

Observation hooks, for the tests that read internal registers: a `Probe` samples its
signals at every clock edge (the values the registers held in that clock, as the stream
ports are sampled) and hands them to a callback; `final` signals are read once at the end.
Payloads are sampled as raw bits (much faster than `data.Const`) and decoded by the sink's
`decode` (`decoder` and `row_decoder` build them from a layout).
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from amaranth.hdl import Shape, Value
from amaranth.lib import data
from amaranth.sim import Simulator

from .streams import StreamProtocolError


class SimulationHang(RuntimeError):
    """Nothing was taken and no beat came out for the stuck limit while work was left."""


@dataclass(frozen=True)
class Source:
    """An input stream (`port`, the component's attribute) fed `payloads` in order; `side`
    names another input port set with each payload to `sides[n]` (the core's clip window,
    sampled with the edge), and with a seed set to `filler(rng)` in the clocks with no offer
    (whatever is there then must not matter)."""

    port: str
    payloads: Sequence
    side: str | None = None
    sides: Sequence = ()
    filler: Callable[[random.Random], object] | None = None


@dataclass(frozen=True)
class Sink:
    """An output stream (`port`) collected as (clock, `decode(raw payload bits)`); the run
    waits for `expected` beats before its drain."""

    port: str
    expected: int = 0
    decode: Callable[[int], object] = int


@dataclass(frozen=True)
class Probe:
    """`each(clock, *values)` in every clock, `values` the `signals` sampled at its edge."""

    signals: tuple
    each: Callable


@dataclass
class Trace:
    """What a run saw: per source the clock each payload was taken, per sink its beats."""

    clocks: int = 0
    accepts: list[list[int]] = field(default_factory=list)
    beats: list[list[tuple[int, object]]] = field(default_factory=list)
    final: tuple = ()  # the `final` signals' values after the last clock
    seconds: float = 0.0  # wall time of the simulation (the build excluded)


class _Feed:
    """The driving side of one `Source`."""

    def __init__(self, dut, source: Source):
        self.source, self.stream = source, getattr(dut, source.port)
        self.side = getattr(dut, source.side) if source.side else None
        self.index, self.offering, self.accepts = 0, False, []

    def busy(self) -> bool:
        return self.offering or self.index < len(self.source.payloads)

    def drive(self, ctx, rng, idle: float) -> None:
        if self.offering:
            return
        if self.index < len(self.source.payloads) and (rng is None or rng.random() >= idle):
            ctx.set(self.stream.payload, self.source.payloads[self.index])
            if self.side is not None:
                ctx.set(self.side, self.source.sides[self.index])
            ctx.set(self.stream.valid, 1)
            self.offering = True
        elif rng is not None and self.source.filler is not None:
            ctx.set(self.side, self.source.filler(rng))

    def taken(self, ctx, clock: int, ready) -> bool:
        if not (self.offering and ready):
            return False
        self.accepts.append(clock)
        self.index, self.offering = self.index + 1, False
        ctx.set(self.stream.valid, 0)
        return True


class _Drain:
    """The collecting side of one `Sink`, checking that a stalled beat holds."""

    def __init__(self, dut, sink: Sink):
        self.sink, self.stream = sink, getattr(dut, sink.port)
        self.bits = Value.cast(self.stream.payload)
        self.ready, self.held, self.beats = True, None, []

    def busy(self) -> bool:
        return len(self.beats) < self.sink.expected

    def drive(self, ctx, rng, stall: float) -> None:
        self.ready = rng is None or rng.random() >= stall
        ctx.set(self.stream.ready, self.ready)

    def taken(self, clock: int, valid, raw: int, tag: str) -> bool:
        if self.held is not None and not (valid and raw == self.held):
            raise StreamProtocolError(
                f"{tag} clock {clock}: a stalled beat on {self.sink.port} changed or vanished "
                f"(valid={valid}, payload {raw:#x}, was {self.held:#x})"
            )
        self.held = raw if valid and not self.ready else None
        if valid and self.ready:
            self.beats.append((clock, self.sink.decode(raw)))
            return True
        return False


def run_component(
    dut,
    sources: Sequence[Source],
    sinks: Sequence[Sink],
    *,
    drain: int,
    stuck: int,
    probes: Sequence[Probe] = (),
    final: Sequence = (),
    seed: int | None = None,
    idle: float = 0.0,
    stall: float = 0.0,
    progress: Callable[[int, int], None] | None = None,
    tag: str = "",
) -> Trace:
    """Drive `dut` (see the module docstring); `progress(taken, total)` as payloads go in,
    `tag` (the workload, seed and configuration) starts every error message."""
    rng = random.Random(seed) if seed is not None else None
    feeds, drains = [_Feed(dut, s) for s in sources], [_Drain(dut, s) for s in sinks]
    signals = [feed.stream.ready for feed in feeds]
    signals += [s for d in drains for s in (d.stream.valid, d.bits)]
    signals += [s for probe in probes for s in probe.signals]
    total = sum(len(s.payloads) for s in sources)
    trace = Trace()

    async def bench(ctx):
        clock = quiet = still = taken = 0
        while True:
            for feed in feeds:
                feed.drive(ctx, rng, idle)
            for sink in drains:
                sink.drive(ctx, rng, stall)
            values = (await ctx.tick().sample(*signals))[2:]  # clk, rst first
            accepted = sum(
                f.taken(ctx, clock, ready)
                for f, ready in zip(feeds, values[: len(feeds)], strict=True)
            )
            at, out = len(feeds), 0
            for sink in drains:
                out += sink.taken(clock, values[at], values[at + 1], tag)
                at += 2
            for probe in probes:
                probe.each(clock, *values[at : at + len(probe.signals)])
                at += len(probe.signals)
            taken += accepted
            if accepted and progress is not None:
                progress(taken, total)
            clock += 1
            busy = any(f.busy() for f in feeds) or any(d.busy() for d in drains)
            quiet = 0 if busy or out else quiet + 1
            still = 0 if accepted or out or not busy else still + 1
            if not busy and quiet >= drain:
                break
            if still >= stuck:
                raise SimulationHang(
                    f"{tag} nothing moved for {still:,} clocks, at clock {clock:,} "
                    f"({_left(feeds, drains)})"
                )
        trace.clocks, trace.final = clock, tuple(ctx.get(s) for s in final)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    start = time.perf_counter()
    sim.run()
    trace.seconds = time.perf_counter() - start
    trace.accepts = [feed.accepts for feed in feeds]
    trace.beats = [sink.beats for sink in drains]
    return trace


def _left(feeds, drains) -> str:
    """What a hung run still waited for, per stream."""
    taken = [f"{f.source.port}: {f.index} of {len(f.source.payloads)} taken" for f in feeds]
    out = [f"{d.sink.port}: {len(d.beats)} of {d.sink.expected} out" for d in drains]
    return ", ".join(taken + out)


# -- payload decoding ------------------------------------------------------------------------


def _fields(layout, prefix=""):
    """(dotted name, offset, width, signed) of each leaf field of a layout."""
    for name, fld in layout:
        shape = fld.shape
        key = f"{prefix}{name}"
        if isinstance(shape, data.Layout):
            for sub, offset, width, is_signed in _fields(shape, f"{key}."):
                yield sub, fld.offset + offset, width, is_signed
        else:
            shape = Shape.cast(shape)
            yield key, fld.offset, shape.width, shape.signed


def _leaf(raw: int, offset: int, width: int, is_signed: bool) -> int:
    value = (raw >> offset) & ((1 << width) - 1)
    return value - (1 << width) if is_signed and value >> (width - 1) else value


def decoder(layout) -> Callable[[int], dict[str, int]]:
    """Raw bits of `layout` -> {dotted leaf name (array elements ``name.j``): value}."""
    fields = list(_fields(layout))
    return lambda raw: {key: _leaf(raw, *rest) for key, *rest in fields}


def row_decoder(layout, names: Sequence[str]) -> Callable[[int], tuple[int, ...]]:
    """Raw bits of `layout` -> the values of the leaves `names` (dotted), in that order."""
    where = {key: rest for key, *rest in _fields(layout)}
    picked = [where[name] for name in names]
    return lambda raw: tuple(_leaf(raw, *rest) for rest in picked)
