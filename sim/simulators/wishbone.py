"""The bus peripheral (`edgeaa.hdl.peripheral.EdgePeripheral`) under Amaranth's simulator,
with Wishbone B4 pipelined bus-functional models: a CPU that writes commands into the
register window as a driver would (random idle clocks between requests, back to back
otherwise, each write held while the target stalls), a memory that takes the framebuffer
writes and one that holds a display list (`DisplayList`) and answers its reads, each with
random stalls and random ack latencies, in order. All check the handshake: an ack only for
a request taken, one each, in order; no ack or err while ``cyc`` is low; the memories that a
request they stalled is offered again unchanged (while ``cyc`` stays high); requests not
answered when the initiator drops ``cyc`` are counted as aborted (the peripheral does it
only on a reset).
"""

from __future__ import annotations

import random
from collections import Counter, deque
from dataclasses import dataclass, field

import numpy as np
from amaranth.sim import Simulator

from ...hdl.peripheral import REGISTERS, EdgePeripheral, pack_command
from ...hdl.pipeline import STATS
from ...model.framebuffer import FORMATS, PixelFormat
from ...model.tile import TileConfig

__all__ = ["BusProtocolError", "DisplayList", "PeripheralRun", "run_peripheral"]


class BusProtocolError(AssertionError):
    """A Wishbone handshake rule broken (the message has the clock and the seed)."""


@dataclass
class PeripheralRun:
    writes: Counter  # byte address -> how many times written
    memory: dict  # byte address -> the last byte written
    registers: dict  # status, errors, tiles, stats.* and irq_status read at the end
    irqs: int  # clocks on which irq rose
    clocks: int
    cpu_stalls: int  # clocks the CPU's requests waited (the command FIFO full)
    aborted: int  # framebuffer writes taken, then cyc dropped before their ack (a reset)
    reads: Counter = field(default_factory=Counter)  # display-list word address -> reads
    requests: int = 0  # framebuffer write requests taken


@dataclass(frozen=True)
class DisplayList:
    """A display list in memory for `run_peripheral`: `commands` packed (`pack_command`)
    from byte address `base` (word aligned) up, started with `length` commands (default all
    of them); its memory stalls with probability `stall`, acks after 0 to `latency` clocks
    and answers a read of a byte in `errors` with err. `restart`: once running, `dl_base`
    is moved past the list and the start bit written again (it must be ignored: a read past
    the list fails the run). `during`: commands written through the window right after the
    start (they go between the list's at command boundaries); `after`: once the list is
    done."""

    commands: tuple
    base: int = 0x40000
    length: int | None = None
    stall: float = 0.0
    latency: int = 0
    errors: frozenset = frozenset()
    restart: bool = False
    during: tuple = ()
    after: tuple = ()

    def words(self, tile: TileConfig) -> dict[int, int]:
        """Word address -> the word, the list's commands one after another."""
        packed = [word for command in self.commands for word in pack_command(tile, command)]
        return {self.base // 4 + k: word for k, word in enumerate(packed)}


@dataclass(frozen=True)
class Framebuffer:
    base: int
    stride: int
    width: int
    height: int
    x0: int = 0
    y0: int = 0
    format: PixelFormat = FORMATS["grey8"]

    def setup(self) -> list[tuple[str, int]]:
        return [
            ("fb_base", self.base),
            ("fb_stride", self.stride),
            ("fb_size", self.width | self.height << 16),
            ("fb_origin", self.x0 | self.y0 << 16),
            ("fb_format", self.format.code),
        ]

    def addresses(self, y: int, x: int) -> list[int]:
        """The byte addresses of framebuffer pixel (x, y), lowest first."""
        first = self.base + y * self.stride + x * self.format.bytes
        return list(range(first, first + self.format.bytes))

    def image(self, memory: dict, missing: int = -1) -> np.ndarray:
        """The framebuffer's bytes: (height, width) for one byte a pixel, else (height,
        width, bytes) as `edgeaa.model.framebuffer.framebuffer_bytes` has them."""
        image = np.array(
            [
                [[memory.get(a, missing) for a in self.addresses(y, x)] for x in range(self.width)]
                for y in range(self.height)
            ]
        )
        return image[..., 0] if self.format.bytes == 1 else image


class _Memory:
    """A target on one of the peripheral's initiator ports: stalls with probability `stall`,
    answers each taken request after 0 to `latency` clocks (in order, at most one a clock).
    On ``fb`` it takes writes (the bytes of their lanes, any ``sel`` but none); on ``dl``
    (`words`: word address -> word) reads of the list's words only. A request touching a
    byte of `errors` gets err (a write is not done)."""

    def __init__(
        self,
        dut,
        rng: random.Random,
        stall: float,
        latency: int,
        tag: str,
        errors=frozenset(),
        *,
        words: dict | None = None,
    ):
        self.reading = words is not None
        self.bus = dut.dl if self.reading else dut.fb
        self.irq, self.rng, self.tag = dut.irq, rng, tag
        self.done = dut.datapath.writer.done  # a probe: no tile is done before its acks
        self.stall, self.latency = stall, latency
        self.errors = frozenset(errors)
        self.words = words or {}
        self.queue: deque = deque()  # (clock due, {byte address: byte} written, word read)
        self.writes: Counter = Counter()
        self.reads: Counter = Counter()
        self.memory: dict = {}
        self.clock = self.irqs = self.aborted = self.requests = 0

    async def run(self, ctx):
        bus, irq, held = self.bus, 0, None
        while True:
            self.irqs += ctx.get(self.irq) and not irq  # rising edges of the interrupt
            irq = ctx.get(self.irq)
            head = self.queue[0] if self.queue else None
            ack = head is not None and head[0] <= self.clock
            err = ack and not self.errors.isdisjoint(head[1])
            ctx.set(bus.ack, ack and not err)
            ctx.set(bus.err, err)
            ctx.set(bus.dat_r, head[2] if ack and not err else 0)
            ctx.set(bus.stall, self.rng.random() < self.stall)
            cyc, stb = ctx.get(bus.cyc), ctx.get(bus.stb)
            request = [ctx.get(s) for s in (bus.adr, bus.sel, bus.dat_w, bus.we)]
            if held is not None and cyc and (not stb or request != held):
                self._fail("a stalled request not offered again unchanged")
            held = request if cyc and stb and ctx.get(bus.stall) else None
            if self.queue and not cyc:  # the initiator aborts the cycle: no ack comes
                self.aborted += len(self.queue)
                self.queue.clear()
                ctx.set(bus.ack, ack := False)
                ctx.set(bus.err, False)
            if not self.reading and ctx.get(self.done) and self.queue:
                self._fail("a tile done with its writes unanswered")
            if ack:
                _, data, _ = self.queue.popleft()
                if self.errors.isdisjoint(data) and not self.reading:
                    self.memory |= data
                    self.writes.update(data.keys())
            if cyc and stb and not ctx.get(bus.stall):
                self._take(ctx)
            await ctx.tick()
            self.clock += 1

    def _take(self, ctx):
        bus = self.bus
        adr, sel = ctx.get(bus.adr), ctx.get(bus.sel)
        if ctx.get(bus.we) == self.reading:
            self._fail("a write on the display-list bus" if self.reading else "a read")
        if sel == 0:
            self._fail("a request with no byte lane")
        word = 0
        if self.reading:
            if adr not in self.words:
                self._fail(f"a read of word {adr:#x}, outside the display list")
            self.reads[adr] += 1
            word = self.words[adr]
            data = {adr * 4 + k: None for k in range(4)}
        else:
            lanes = [k for k in range(4) if sel >> k & 1]
            data = {adr * 4 + k: (ctx.get(bus.dat_w) >> 8 * k) & 0xFF for k in lanes}
        due = max(self.clock + 1 + self.rng.randint(0, self.latency), self._last_due() + 1)
        self.queue.append((due, data, word))
        self.requests += 1

    def _last_due(self) -> int:
        return self.queue[-1][0] if self.queue else 0

    def _fail(self, what: str):
        bus = "display-list" if self.reading else "framebuffer"
        raise BusProtocolError(f"{bus} bus, clock {self.clock}: {what} ({self.tag})")


class _Cpu:
    """The register window's initiator: single writes and reads, each request held until
    taken, its ack (and read data) counted after."""

    def __init__(self, bus, rng: random.Random, idle: float, tag: str, max_clocks: int):
        self.bus, self.rng, self.idle, self.tag = bus, rng, idle, tag
        self.max_clocks = max_clocks
        self.clock = 0
        self.waiting = 0  # requests taken, not yet acked
        self.stalls = 0  # clocks a request waited on stall
        self.data = 0  # the last ack's read data

    async def tick(self, ctx):
        await ctx.tick()
        self.clock += 1
        if self.clock > self.max_clocks:
            self._fail(f"still not done after {self.max_clocks} clocks (a hang)")
        if ctx.get(self.bus.ack):
            if not self.waiting:
                self._fail("an ack for no request")
            self.waiting -= 1
            self.data = ctx.get(self.bus.dat_r)

    async def request(self, ctx, address: int, value: int | None = None):
        """One request (a write of `value`, or a read), back to back after the last one
        unless an idle clock is drawn."""
        bus = self.bus
        while self.rng.random() < self.idle:
            ctx.set(bus.stb, 0)
            await self.tick(ctx)
        ctx.set(bus.cyc, 1)
        ctx.set(bus.stb, 1)
        ctx.set(bus.we, value is not None)
        ctx.set(bus.adr, address)
        ctx.set(bus.dat_w, value or 0)
        ctx.set(bus.sel, 0xF)
        while True:
            taken = not ctx.get(bus.stall)
            self.waiting += taken
            self.stalls += not taken
            await self.tick(ctx)
            if taken:
                break
        ctx.set(bus.stb, 0)

    async def finish(self, ctx, limit: int = 64) -> int:
        """Wait for every ack, then drop cyc; the last ack's read data."""
        for _ in range(limit):
            if not self.waiting:
                break
            await self.tick(ctx)
        else:
            self._fail("an ack never came")
        ctx.set(self.bus.cyc, 0)
        return self.data

    async def read(self, ctx, address: int) -> int:
        await self.request(ctx, address)
        return await self.finish(ctx)

    def _fail(self, what: str):
        raise BusProtocolError(f"register bus, clock {self.clock}: {what} ({self.tag})")


def run_peripheral(
    tile: TileConfig,
    commands,
    fb: Framebuffer,
    *,
    seed: int = 0,
    idle: float = 0.0,
    stall: float = 0.0,
    latency: int = 0,
    fifo_depth: int = 4,
    max_clocks: int = 100_000,
    before_reset=(),
    errors=frozenset(),
    display_list: DisplayList | None = None,
) -> PeripheralRun:
    """`commands` written as a CPU would (set-up registers, the interrupt enabled, each
    command's words), then the status polled until not busy; the framebuffer writes
    collected. `idle`: the CPU's chance of an idle clock before each request; `stall`,
    `latency`: the memory's; a run past `max_clocks` is a hang. `before_reset`: commands
    written first, then, once a framebuffer write is taken and not yet answered (they must
    flush a tile), the control register's reset bit (whatever they were doing is
    dropped). `errors`: byte addresses the memory answers with err. `display_list`: after
    `commands`, its base and length written and the list started (its interrupt enabled
    too), ``status`` polled until the list is done, then its `after` commands written."""
    dut = EdgePeripheral(tile, fifo_depth=fifo_depth)
    tag = f"seed {seed}"
    rng = random.Random(seed)
    memory = _Memory(dut, random.Random(rng.random()), stall, latency, tag, errors)
    cpu = _Cpu(dut.bus, random.Random(rng.random()), idle, tag, max_clocks)
    dl = display_list
    lister = None
    if dl is not None:
        args = random.Random(rng.random()), dl.stall, dl.latency, tag, dl.errors
        lister = _Memory(dut, *args, words=dl.words(tile))
    result: dict = {}

    async def write_commands(ctx, commands):
        for command in commands:
            for k, word in enumerate(pack_command(tile, command)):
                await cpu.request(ctx, REGISTERS["cmd"] + k, word)

    async def run_list(ctx):
        length = len(dl.commands) if dl.length is None else dl.length
        await cpu.request(ctx, REGISTERS["dl_base"], dl.base)
        await cpu.request(ctx, REGISTERS["dl_length"], length)
        await cpu.request(ctx, REGISTERS["ctrl"], 0b10)
        if dl.restart:
            result["status_at_restart"] = await cpu.read(ctx, REGISTERS["status"])
            await cpu.request(ctx, REGISTERS["dl_base"], dl.base + 4 * len(dl.words(tile)))
            await cpu.request(ctx, REGISTERS["ctrl"], 0b10)
        await write_commands(ctx, dl.during)
        await cpu.finish(ctx)
        while (await cpu.read(ctx, REGISTERS["status"])) & 0b1000:
            pass
        result["irq_at_list_done"] = ctx.get(dut.irq)
        result["tiles_at_list_done"] = await cpu.read(ctx, REGISTERS["tiles"])
        await write_commands(ctx, dl.after)

    async def program(ctx):
        for name, value in fb.setup():
            await cpu.request(ctx, REGISTERS[name], value)
        await cpu.request(ctx, REGISTERS["irq_enable"], 1 if dl is None else 0b101)
        if before_reset:
            await write_commands(ctx, before_reset)
            while not memory.queue:  # the reset comes with a framebuffer write unanswered
                await cpu.tick(ctx)
            await cpu.request(ctx, REGISTERS["ctrl"], 1)
            await cpu.request(ctx, REGISTERS["irq_status"], 0b11)
        await write_commands(ctx, commands)
        if dl is not None:
            await run_list(ctx)
        await cpu.finish(ctx)
        while (await cpu.read(ctx, REGISTERS["status"])) & 1:
            pass
        names = ["status", "errors", "tiles", "irq_status", "fb_format", "dl_base", "dl_length"]
        for name in names:
            result[name] = await cpu.read(ctx, REGISTERS[name])
        for i, name in enumerate(STATS):
            result[f"stats.{name}"] = await cpu.read(ctx, REGISTERS["stats"] + i)
        result["irq"] = ctx.get(dut.irq)
        await cpu.request(ctx, REGISTERS["irq_status"], 0b111)  # clear
        await cpu.finish(ctx)
        await cpu.tick(ctx)
        result["irq_after_clear"] = ctx.get(dut.irq)

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(memory.run, background=True)
    if lister is not None:
        sim.add_testbench(lister.run, background=True)
    sim.add_testbench(program)
    sim.run()
    reads = lister.reads if lister is not None else Counter()
    return PeripheralRun(
        memory.writes,
        memory.memory,
        result,
        memory.irqs,
        cpu.clock,
        cpu.stalls,
        memory.aborted,
        reads,
        memory.requests,
    )
