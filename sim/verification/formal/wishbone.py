# amaranth: UnusedElaboratable=no
"""The Wishbone B4 pipelined rules of the peripheral's two buses.

**The framebuffer writer** (initiator rules)
(`edgeaa.hdl.peripheral.FramebufferWriter`), proven by k-induction for any pixels, tile
origins, framebuffer registers, reset, and any target that stalls at will and answers (ack
or err, not both) only requests it has taken:

* ``stb`` only within ``cyc``; ``cyc`` stays high while a taken request is unanswered;
* a request not taken (``stb & stall``) is offered again in the next clock with the same
  ``adr``, ``sel``, ``dat_w`` and ``we`` (unless the reset comes between);
* at most `MAX_OUTSTANDING` requests unanswered; ``we`` high; ``sel`` a run of byte lanes
  (a pixel of 1 to 4 bytes, or its part in one word, in any ``fb_format``: free too).

The proof runs on a grey and a 3-channel writer (`run_writer_proof`'s ``channels``).

Fault ``drop_stb`` (the harness sees ``stb`` low in the clock after a stall) shows the hold
check can fail. `run_writer_proof` runs it (`tests/test_peripheral.py`, marked formal; about 1 s).

**The display-list reader** (initiator rules) (`edgeaa.hdl.peripheral.DisplayListReader`),
proven the same way for any start, base, length, idle, FIFO ready and reset and any target
as above: ``stb`` only within ``cyc``, ``cyc`` held while a read is unanswered, a stalled
request offered again unchanged, at most `command_words` in flight (its count is the
harness's), ``we`` low and ``sel`` all four lanes; and its command stream's hold rule (a
command not taken stays valid, unchanged). Fault ``drop_stb`` as the writer's.
`run_reader_proof` runs it (in the default run; about 3 s).

**The register window** (`edgeaa.hdl.peripheral.EdgePeripheral`'s target rules), proven by
k-induction for any initiator that keeps the B4 rules (``stb`` only within ``cyc``, a
stalled request held unchanged), any reset and any datapath behind the window (its FIFO's
``ready``, level, counters, framebuffer and display-list buses free: `_FreeDatapath`):

* one ``ack`` per taken request, in the clock after it; no ``ack`` without one (a reset
  drops the one in flight), none while ``cyc`` is and was low (wb2axip's ``fwb_slave.v``
  rules, for a target that answers in one clock); ``err`` never;
* ``stall`` only for a write of the last command word while the FIFO is not ready (reads
  and every other write never wait);
* after ``rst``: no ``ack``, ``irq`` low; a read of ``info`` answers `info_word`.

Fault ``ack_stalled`` (the harness sees an ``ack`` for a request the target stalled) shows
the one-ack check can fail. `run_window_proof` runs it (in the default run; about 1 s).
"""

from __future__ import annotations

from dataclasses import replace

from amaranth.asserts import AnySeq
from amaranth.hdl import (
    Assert,
    Assume,
    Cat,
    ClockDomain,
    ClockSignal,
    Module,
    Signal,
    Value,
)
from amaranth.lib import wiring

from ....hdl.peripheral import (
    MAX_OUTSTANDING,
    REGISTERS,
    DisplayListReader,
    EdgePeripheral,
    FramebufferWriter,
    _Datapath,
    command_words,
    info_word,
)
from ....model.config import EdgeConfig
from ....model.tile import TileConfig
from .harness import ClockedHarness
from .run import FormalResult, find_tools, run_harness, sby_script
from .stream import held, hold_rule

__all__ = [
    "READER_FAULTS",
    "WINDOW_FAULTS",
    "WRITER_FAULTS",
    "ReaderHarness",
    "WindowHarness",
    "WriterHarness",
    "run_reader_proof",
    "run_window_proof",
    "run_writer_proof",
]

WRITER_FAULTS = ("drop_stb",)
WINDOW_FAULTS = ("ack_stalled",)
READER_FAULTS = ("drop_stb",)
SMALL = TileConfig(EdgeConfig(coord_bits=7, subpixel_bits=2, intensity_bits=4), 8, 4)
LANE_RUNS = tuple((1 << n) - 1 << k for n in range(1, 5) for k in range(5 - n))


class _Request:
    """The request as a stream for `held`: valid ``stb``, ready ``~stall``."""

    def __init__(self, bus):
        self.valid, self.ready = bus.stb, ~bus.stall


def initiator_rules(m: Module, bus, limit: int, fault: str | None):
    """A Wishbone B4 pipelined initiator's rules against a target that answers only the
    requests it took (ack or err, not both): `stb` only within `cyc`, `cyc` held while a
    request is unanswered, at most `limit` in flight, a stalled request offered again
    unchanged. The fault ``drop_stb`` drops a held request. Returns the harness's `check`
    and its count of unanswered requests, for the initiator's own rules."""
    unanswered = Signal(range(limit + 2))
    taken = bus.cyc & bus.stb & ~bus.stall
    answer = bus.ack | bus.err
    m.d.comb += Assume(~(bus.ack & bus.err))
    m.d.comb += Assume(~answer | (unanswered != 0))
    m.d.sync += unanswered.eq(unanswered + taken - answer)
    stb = bus.stb
    was_held = held(m, _Request(bus), "request_held")
    if fault == "drop_stb":
        stb = bus.stb & ~was_held

    def check(condition, message):
        m.d.comb += Assert(condition, message)

    check(~bus.stb | bus.cyc, "wishbone: stb only within cyc")
    check((unanswered == 0) | bus.cyc, "wishbone: cyc held while a request is unanswered")
    check(unanswered <= limit, f"wishbone: at most {limit} requests in flight")
    hold_rule(m, stb, Cat(bus.adr, bus.sel, bus.dat_w, bus.we), was_held, check, "request")
    return check, unanswered


class WriterHarness(ClockedHarness):
    def __init__(self, tile: TileConfig = SMALL, fault: str | None = None):
        if fault is not None and fault not in WRITER_FAULTS:
            raise ValueError(f"fault must be one of {', '.join(WRITER_FAULTS)} or None")
        super().__init__(reset=True)
        self.dut, self.fault = FramebufferWriter(tile), fault

    def elaborate(self, platform):
        m = Module()
        dut = self.dut
        m.submodules.dut = dut.elaborate(platform)  # here: the harness reads `outstanding`
        m.domains.sync = self.domain
        m.d.comb += self.domain.rst.eq(AnySeq(1))
        bus = dut.bus
        free = [dut.pixels.valid, dut.pixels.payload, dut.origins.valid, dut.origins.payload]
        free += [dut.fb_base, dut.fb_stride, dut.fb_size, dut.fb_origin, dut.fb_format]
        free += [bus.stall, bus.ack, bus.err, bus.dat_r]
        for port in map(Value.cast, free):
            m.d.comb += port.eq(AnySeq(len(port)))
        check, unanswered = initiator_rules(m, bus, MAX_OUTSTANDING, self.fault)
        check(unanswered == dut.outstanding, "writer: its count of writes in flight")
        check(~bus.stb | bus.we, "wishbone: the writer only writes")
        run = Cat(*(bus.sel == lanes for lanes in LANE_RUNS)).any()
        check(run, "wishbone: sel a run of byte lanes")
        rest = Cat(*(dut.hi_sel == lanes for lanes in (0, 1, 3, 7))).any()
        check(rest, "writer: a pixel's part in the next word starts at lane 0")
        return m


def run_writer_proof(
    *,
    fault: str | None = None,
    channels: int = 1,
    depth: int = 4,
    timeout: float | None = None,
) -> FormalResult:
    """k-induction of `WriterHarness` (``depth`` clocks; a writer of `channels`) with
    SymbiYosys."""
    harness = WriterHarness(replace(SMALL, channels=channels), fault=fault)
    script = sby_script("prove", depth)
    proof = f"writer_wishbone_c{channels}"
    return run_harness(proof, fault, harness, script, find_tools(), "prove", depth, timeout=timeout)


class ReaderHarness(ClockedHarness):
    def __init__(self, tile: TileConfig = SMALL, fault: str | None = None):
        if fault is not None and fault not in READER_FAULTS:
            raise ValueError(f"fault must be one of {', '.join(READER_FAULTS)} or None")
        super().__init__(reset=True)
        self.dut, self.tile, self.fault = DisplayListReader(tile), tile, fault

    def elaborate(self, platform):
        m = Module()
        dut = self.dut
        m.submodules.dut = dut.elaborate(platform)  # here: the harness reads its counts
        m.domains.sync = self.domain
        m.d.comb += self.domain.rst.eq(AnySeq(1))
        bus, out = dut.bus, dut.commands
        free = [dut.start, dut.base, dut.length, dut.idle, out.ready]
        free += [bus.stall, bus.ack, bus.err, bus.dat_r]
        for port in map(Value.cast, free):
            m.d.comb += port.eq(AnySeq(len(port)))
        words = command_words(self.tile)
        check, unanswered = initiator_rules(m, bus, words, self.fault)
        check(dut.issued <= words, "reader: at most a command's reads issued")
        check(dut.answered <= dut.issued, "reader: no more answers than reads")
        check(unanswered == dut.issued - dut.answered, "reader: its count of reads in flight")
        check(~bus.we & (bus.sel == 0xF), "wishbone: the reader reads whole words")
        command_held = held(m, out, "command_held")
        hold_rule(m, out.valid, out.payload, command_held, check, "command")
        return m


def run_reader_proof(
    *, fault: str | None = None, depth: int = 4, timeout: float | None = None
) -> FormalResult:
    """k-induction of `ReaderHarness` (``depth`` clocks) with SymbiYosys."""
    harness = ReaderHarness(fault=fault)
    script = sby_script("prove", depth)
    return run_harness(
        "reader_wishbone", fault, harness, script, find_tools(), "prove", depth, timeout=timeout
    )


class _FreeDatapath(_Datapath):
    """The window's datapath with every output free (the FIFO's ready and level, busy,
    counters, the framebuffer bus): the window's rules hold whatever it does."""

    def elaborate(self, platform):
        m = Module()
        for _, member, value in self.signature.flatten(self):
            if member.flow == wiring.Out:
                m.d.comb += value.eq(AnySeq(len(Value.cast(value))))
        return m


class WindowHarness(ClockedHarness):
    def __init__(self, tile: TileConfig = SMALL, fault: str | None = None):
        if fault is not None and fault not in WINDOW_FAULTS:
            raise ValueError(f"fault must be one of {', '.join(WINDOW_FAULTS)} or None")
        super().__init__(reset=True)
        self.dut, self.tile, self.fault = EdgePeripheral(tile, fifo_depth=4), tile, fault
        self.dut.datapath = _FreeDatapath(tile, 4, pack_grey=True)

    def elaborate(self, platform):
        m = Module()
        dut, rst = self.dut, self.domain.rst
        m.submodules.dut = dut
        m.domains.sync = self.domain
        # The harness's own registers: not cleared by the reset they observe.
        m.domains.past = ClockDomain("past", reset_less=True)
        m.d.comb += [ClockSignal("past").eq(self.domain.clk), rst.eq(AnySeq(1))]
        bus, fb, dl = dut.bus, dut.fb, dut.dl
        free = [bus.cyc, bus.stb, bus.we, bus.adr, bus.dat_w, bus.sel]
        free += [fb.ack, fb.stall, fb.err, fb.dat_r, dl.ack, dl.stall, dl.err, dl.dat_r]
        for port in map(Value.cast, free):
            m.d.comb += port.eq(AnySeq(len(port)))
        # The initiator: stb within cyc; a stalled request offered again unchanged.
        m.d.comb += Assume(~bus.stb | bus.cyc)
        was_held = Signal()
        m.d.past += was_held.eq(bus.cyc & bus.stb & bus.stall & ~rst)
        request = Cat(bus.adr, bus.we, bus.dat_w, bus.sel)
        prev = Signal(len(request))
        m.d.past += prev.eq(request)
        with m.If(was_held & bus.cyc):
            m.d.comb += Assume(bus.stb & (request == prev))
        taken = bus.cyc & bus.stb & ~bus.stall
        ack = bus.ack
        stalled = Signal()  # the fault: an ack for the request the target stalled
        m.d.past += stalled.eq(bus.cyc & bus.stb & bus.stall)
        if self.fault == "ack_stalled":
            ack = bus.ack | stalled
        # Requests taken and not yet answered (a reset drops them).
        waiting, was_reset = Signal(2), Signal()
        m.d.past += was_reset.eq(rst)
        with m.If(rst):
            m.d.past += waiting.eq(0)
        with m.Else():
            m.d.past += waiting.eq(waiting + taken - ack)
        was_cyc = Signal()
        m.d.past += was_cyc.eq(bus.cyc)
        info_read = Signal()
        m.d.past += info_read.eq(taken & ~bus.we & (bus.adr == REGISTERS["info"]) & ~rst)

        def check(condition, message):
            m.d.comb += Assert(condition, message)

        check(~bus.err, "wishbone: err never")
        check(ack == (waiting == 1), "wishbone: one ack a taken request, the next clock")
        check(waiting <= 1, "wishbone: no ack without a request")
        check(was_cyc | bus.cyc | ~ack, "wishbone: no ack a clock after cyc was low")
        last = REGISTERS["cmd"] + command_words(self.tile) - 1
        push = bus.cyc & bus.stb & bus.we & (bus.adr == last)
        check(~bus.stall | (push & ~dut.datapath.push.ready), "window: stall only on a full FIFO")
        check(~was_reset | ~ack, "reset: no ack after it")
        check(~was_reset | ~dut.irq, "reset: irq low after it")
        check(~info_read | (bus.dat_r == info_word(self.tile)), "window: info reads its word")
        return m


def run_window_proof(
    *, fault: str | None = None, depth: int = 3, timeout: float | None = None
) -> FormalResult:
    """k-induction of `WindowHarness` (``depth`` clocks) with SymbiYosys."""
    harness = WindowHarness(fault=fault)
    script = sby_script("prove", depth)
    return run_harness(
        "window_wishbone", fault, harness, script, find_tools(), "prove", depth, timeout=timeout
    )
