"""The bus peripheral (`edgeaa.hdl.peripheral.EdgePeripheral`) under Amaranth's simulator,
with two Wishbone B4 pipelined bus-functional models: a CPU that writes commands into the
register window as a driver would (random idle clocks between requests, back to back
otherwise, each write held while the target stalls) and a memory that takes the
framebuffer writes with random stalls and random ack latencies, in order. Both check the
handshake: an ack only for a request taken, one each, in order; no ack or err while ``cyc``
is low; requests not answered when the initiator drops ``cyc`` are counted as aborted (the
peripheral does it only on a reset).
"""

from __future__ import annotations

import random
from collections import Counter, deque
from dataclasses import dataclass

import numpy as np
from amaranth.sim import Simulator

from ...hdl.peripheral import REGISTERS, EdgePeripheral, pack_command
from ...hdl.pipeline import STATS
from ...model.framebuffer import FORMATS, PixelFormat
from ...model.tile import TileConfig

__all__ = ["BusProtocolError", "PeripheralRun", "run_peripheral"]


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
    """The framebuffer's target: stalls with probability `stall`, acks each taken write
    after 0 to `latency` clocks (in order, at most one a clock), writes the bytes of its
    lanes (any ``sel`` but none)."""

    def __init__(
        self, dut, rng: random.Random, stall: float, latency: int, tag: str, errors=frozenset()
    ):
        self.bus, self.irq, self.rng, self.tag = dut.fb, dut.irq, rng, tag
        self.done = dut.datapath.writer.done  # a probe: no tile is done before its acks
        self.stall, self.latency = stall, latency
        self.errors = frozenset(errors)  # a write to one of these bytes gets err (not done)
        self.queue: deque = deque()  # (clock due, {byte address: byte})
        self.writes: Counter = Counter()
        self.memory: dict = {}
        self.clock = self.irqs = self.aborted = 0

    async def run(self, ctx):
        bus, irq = self.bus, 0
        while True:
            self.irqs += ctx.get(self.irq) and not irq  # rising edges of the interrupt
            irq = ctx.get(self.irq)
            head = self.queue[0] if self.queue else None
            ack = head is not None and head[0] <= self.clock
            err = ack and not self.errors.isdisjoint(head[1])
            ctx.set(bus.ack, ack and not err)
            ctx.set(bus.err, err)
            ctx.set(bus.stall, self.rng.random() < self.stall)
            cyc, stb = ctx.get(bus.cyc), ctx.get(bus.stb)
            if self.queue and not cyc:  # the initiator aborts the cycle: no ack comes
                self.aborted += len(self.queue)
                self.queue.clear()
                ctx.set(bus.ack, ack := False)
                ctx.set(bus.err, False)
            if ctx.get(self.done) and self.queue:
                self._fail("a tile done with its writes unanswered")
            if ack:
                _, data = self.queue.popleft()
                if self.errors.isdisjoint(data):
                    self.memory |= data
                    self.writes.update(data.keys())
            if cyc and stb and not ctx.get(bus.stall):
                self._take(ctx)
            await ctx.tick()
            self.clock += 1

    def _take(self, ctx):
        bus = self.bus
        if not ctx.get(bus.we):
            self._fail("a read on the framebuffer bus")
        sel, word = ctx.get(bus.sel), ctx.get(bus.dat_w)
        if sel == 0:
            self._fail("a write with no byte lane")
        lanes = [k for k in range(4) if sel >> k & 1]
        data = {ctx.get(bus.adr) * 4 + k: (word >> 8 * k) & 0xFF for k in lanes}
        due = max(self.clock + 1 + self.rng.randint(0, self.latency), self._last_due() + 1)
        self.queue.append((due, data))

    def _last_due(self) -> int:
        return self.queue[-1][0] if self.queue else 0

    def _fail(self, what: str):
        raise BusProtocolError(f"framebuffer bus, clock {self.clock}: {what} ({self.tag})")


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
) -> PeripheralRun:
    """`commands` written as a CPU would (set-up registers, the interrupt enabled, each
    command's words), then the status polled until not busy; the framebuffer writes
    collected. `idle`: the CPU's chance of an idle clock before each request; `stall`,
    `latency`: the memory's; a run past `max_clocks` is a hang. `before_reset`: commands
    written first, then the control register's reset bit (whatever they were doing is
    dropped). `errors`: byte addresses the memory answers with err."""
    dut = EdgePeripheral(tile, fifo_depth=fifo_depth)
    tag = f"seed {seed}"
    rng = random.Random(seed)
    memory = _Memory(dut, random.Random(rng.random()), stall, latency, tag, errors)
    cpu = _Cpu(dut.bus, random.Random(rng.random()), idle, tag, max_clocks)
    result: dict = {}

    async def write_commands(ctx, commands):
        for command in commands:
            for k, word in enumerate(pack_command(tile, command)):
                await cpu.request(ctx, REGISTERS["cmd"] + k, word)

    async def program(ctx):
        for name, value in fb.setup():
            await cpu.request(ctx, REGISTERS[name], value)
        await cpu.request(ctx, REGISTERS["irq_enable"], 1)
        if before_reset:
            await write_commands(ctx, before_reset)
            await cpu.request(ctx, REGISTERS["ctrl"], 1)
            await cpu.request(ctx, REGISTERS["irq_status"], 0b11)
        await write_commands(ctx, commands)
        await cpu.finish(ctx)
        while (await cpu.read(ctx, REGISTERS["status"])) & 1:
            pass
        names = ["status", "errors", "tiles", "irq_status", "fb_format"]
        for name in names:
            result[name] = await cpu.read(ctx, REGISTERS[name])
        for i, name in enumerate(STATS):
            result[f"stats.{name}"] = await cpu.read(ctx, REGISTERS["stats"] + i)
        result["irq"] = ctx.get(dut.irq)
        await cpu.request(ctx, REGISTERS["irq_status"], 1)  # clear
        await cpu.finish(ctx)
        await cpu.tick(ctx)
        result["irq_after_clear"] = ctx.get(dut.irq)

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(memory.run, background=True)
    sim.add_testbench(program)
    sim.run()
    return PeripheralRun(
        memory.writes, memory.memory, result, memory.irqs, cpu.clock, cpu.stalls, memory.aborted
    )
