"""The cocotb bench of the Verilated peripheral (`edgeaa.sim.simulators.cocotb_peripheral`
builds and runs it; this module runs inside the simulator). Every bus is driven by a PyPI
bus-functional model. The CPU is cocotbext-wishbone's `WishboneMaster` on the Wishbone
window (`WishboneCpu`, the test `wishbone_cpu`) or cocotbext-axi's `AxiLiteMaster` on the
AXI4-Lite top (`AxiLiteCpu`, the test `axi_lite_cpu`): it writes the framebuffer registers
and a scene's command words into the register window, or starts a display list, and polls
``status``, with seeded random idle clocks (AXI: pauses on each channel). The memories are
cocotbext-wishbone's `WishboneSlave`, sampling a request on every clock (`PipelinedSlave`):
the framebuffer's, and the display list's answering the ``dl`` reads from the list's words,
each with seeded random stalls and ack latencies. The run's parameters come from the JSON
file named by `RUN_ENV`; the memory's bytes, the registers read at the end and the counts
go back in the same file's ``result`` next to it (``<name>.result.json``).
"""

from __future__ import annotations

import itertools
import json
import os
import random
from collections import Counter
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import RisingEdge, SimTimeoutError, with_timeout
from cocotb.utils import get_sim_time
from cocotbext.axi import AxiLiteBus, AxiLiteMaster, AxiResp
from cocotbext.wishbone.driver import WBOp, WishboneMaster
from cocotbext.wishbone.monitor import WishboneSlave

RUN_ENV = "EDGEAA_BFM_RUN"
PERIOD_NS = 10
# The package's names for the required lines -> the peripheral's (``bus__dat_w`` ...); its
# optional sel, stall and err keep their names.
SIGNALS = {
    "cyc": "cyc",
    "stb": "stb",
    "we": "we",
    "adr": "adr",
    "datwr": "dat_w",
    "datrd": "dat_r",
    "ack": "ack",
}
COMMON = {"signals_dict": SIGNALS, "bus_separator": "__", "width": 32}
BUSY, RUNNING = 0b1, 0b1000  # status bits: busy, the display list running
START, LIST_DONE = 0b10, 0b100  # ctrl's start bit; irq_enable's list-done bit


class BenchError(AssertionError):
    """A handshake rule broken or a run past its clock limit (the message has the seed)."""


class PipelinedSlave(WishboneSlave):
    """cocotbext-wishbone's slave with its request loop replaced: the package's own loop
    (`WishboneSlave._monitor_recv`) waits for its ack after each request, missing the
    requests a pipelined initiator makes meanwhile, and never answers a request it first
    sees under its own stall. This one looks at the bus on every clock and hands each request
    to the package's `_respond` (which takes it unless stalled and queues its reply for the
    package's ack process: its stall generator, ack latencies and records are kept). A read
    is answered from `words` (word address -> word; a read of any other word fails), a write
    lands in `memory`. It checks the initiator: a stalled request offered again unchanged."""

    def __init__(self, *args, tag: str, words: dict[int, int], **kwargs):
        self.tag = tag
        self.words = words
        self.held = None  # the request stalled at the last clock
        self.stalled = 0  # clocks a request waited on stall
        self.aborted = 0  # requests taken, cyc dropped before their ack
        self.memory: dict[int, int] = {}
        self.writes: Counter = Counter()
        self.reads: Counter = Counter()  # word address -> reads
        super().__init__(*args, callback=self._store, datgen=self._read(), **kwargs)

    async def _monitor_recv(self):
        bus = self.bus
        while True:
            await RisingEdge(self.clock)  # the values the peripheral saw at this edge
            cyc = bus.cyc.value == 1
            if cyc and bus.stb.value == 1:
                request = tuple(int(v.value) for v in (bus.we, bus.adr, bus.sel, bus.datwr))
                if self.held not in (None, request):
                    self._fail(f"a stalled request changed: {self.held} then {request}")
                stalled = bus.stall.value == 1
                self.held = request if stalled else None
                self.stalled += stalled
                self._respond()
            elif self.held is not None:
                self._fail(f"a stalled request withdrawn: {self.held}")
            if self._cycle and not cyc:  # the cycle ends: its writes land
                self.aborted += self._reply_Q.qsize()
                self._reply_Q.queue.clear()
                self._recv(self._res_buf)
                self._res_buf = []
            self._cycle = cyc

    def _read(self):
        """The package's read data, drawn by `_respond` for each read it takes."""
        while True:
            address = int(self.bus.adr.value)
            if address not in self.words:
                self._fail(f"a read of word {address:#x}, which the memory does not hold")
            self.reads[address] += 1
            yield self.words[address]

    def _store(self, replies):
        for reply in (r for r in replies if r.datwr is not None):  # the writes
            address, sel, word = int(reply.adr) * 4, int(reply.sel), int(reply.datwr)
            for lane in (k for k in range(4) if sel >> k & 1):
                self.memory[address + lane] = word >> 8 * lane & 0xFF
                self.writes[address + lane] += 1

    def _fail(self, what: str):
        raise BenchError(f"{self.name} bus: {what} ({self.tag})")


def _geometric(rng: random.Random, p: float) -> int:
    """A run of clocks, each drawn with probability `p` (a stall, an idle wait). Runs of
    stalls with one clock without between them are a share `p` of the clocks."""
    n = 0
    while rng.random() < p:
        n += 1
    return n


def _memory(dut, name: str, rng: random.Random, stall: float, latency: int, **kwargs):
    """A `PipelinedSlave` on the port `name`: stalls a share `stall` of the clocks, acks
    after 0 to `latency` clocks."""
    stalls = ((_geometric(rng, stall), 1) for _ in itertools.count())
    latencies = (rng.randint(0, latency) for _ in itertools.count())
    return PipelinedSlave(
        dut, name, dut.clk, waitstallgen=stalls, waitreplygen=latencies, **kwargs, **COMMON
    )


class WishboneCpu:
    """cocotbext-wishbone's master on the Wishbone window (``bus__*``): each request after
    its seeded random idle clocks; `stalls` counts the clocks its requests waited."""

    def __init__(self, dut, rng: random.Random, run: dict):
        self.master = WishboneMaster(dut, "bus", dut.clk, timeout=run["max_clocks"], **COMMON)
        self.rng, self.idle = rng, run["idle"]
        self.stalls = 0

    async def _cycle(self, ops) -> list:
        cycle = [WBOp(adr, value, idle=_geometric(self.rng, self.idle)) for adr, value in ops]
        results = await self.master.send_cycle(cycle)
        self.stalls += sum(result.waitStall for result in results)
        return results

    async def write(self, address: int, words: list[int]):
        """`words` to consecutive registers from `address`, one bus cycle."""
        await self._cycle([(address + k, word) for k, word in enumerate(words)])

    async def read(self, addresses: list[int]) -> list[int]:
        return [int(result.datrd) for result in await self._cycle([(a, None) for a in addresses])]


class AxiLiteCpu:
    """cocotbext-axi's master on the AXI4-Lite window (``axi__*``, byte addresses), each of
    the five channels paused on a seeded random share `idle` of the clocks (a valid or a
    ready held back). `stalls`: the clocks the window made writes wait, as the AXI side sees
    them: each write's clocks from its AW handshake to its response, less the fastest's."""

    def __init__(self, dut, rng: random.Random, run: dict):
        bus = AxiLiteBus.from_prefix(dut, "axi", bus_separator="__")
        self.master = AxiLiteMaster(bus, dut.clk, dut.rst)
        write, read = self.master.write_if, self.master.read_if
        channels = (write.aw_channel, write.w_channel, write.b_channel)
        for channel in (*channels, read.ar_channel, read.r_channel):
            pause_rng = random.Random(rng.random())
            channel.set_pause_generator(pause_rng.random() < run["idle"] for _ in itertools.count())
        self.latencies: list[int] = []
        cocotb.start_soon(self._watch(dut))

    async def _watch(self, dut):
        taken = None  # clocks since the last AW handshake
        while True:
            await RisingEdge(dut.clk)
            if taken is not None:
                taken += 1
            if dut.axi__awvalid.value == 1 and dut.axi__awready.value == 1:
                taken = 0
            if dut.axi__bvalid.value == 1 and taken is not None:
                self.latencies.append(taken)
                taken = None

    @property
    def stalls(self) -> int:
        fastest = min(self.latencies, default=0)
        return sum(latency - fastest for latency in self.latencies)

    async def write(self, address: int, words: list[int]):
        """`words` to consecutive registers from `address`: the master's one write of their
        bytes, which it issues as one AXI4-Lite write a word."""
        data = b"".join(word.to_bytes(4, "little") for word in words)
        response = await self.master.write(4 * address, data)
        if response.resp != AxiResp.OKAY:
            raise BenchError(f"a write to register {address} answered {response.resp!r}")

    async def read(self, addresses: list[int]) -> list[int]:
        values = []
        for address in addresses:
            response = await self.master.read(4 * address, 4)
            if response.resp != AxiResp.OKAY:
                raise BenchError(f"a read of register {address} answered {response.resp!r}")
            values.append(int.from_bytes(response.data, "little"))
        return values


async def _poll(cpu, status: int, mask: int) -> int:
    """``status`` read until its `mask` bits are all 0; how many reads."""
    polls = 1
    while (await cpu.read([status]))[0] & mask:
        polls += 1
    return polls


async def _start_list(dut, cpu, regs: dict, dl: dict) -> dict:
    """The display list started (its done interrupt enabled) and polled until done."""
    await cpu.write(regs["irq_enable"], [LIST_DONE])
    await cpu.write(regs["dl_base"], [dl["base"]])
    await cpu.write(regs["dl_length"], [dl["length"]])
    await cpu.write(regs["ctrl"], [START])
    polls = await _poll(cpu, regs["status"], RUNNING)
    return {"list_polls": polls, "list_irq": int(dut.irq.value)}


async def _program(dut, cpu, run: dict) -> dict:
    """The CPU's part: the set-up registers, each command's words (one write a command, as
    a driver's stores), the display list if any, then ``status`` polled until not busy and
    the counters read."""
    regs = run["registers"]
    for address, value in run["setup"]:
        await cpu.write(address, [value])
    for words in run["commands"]:
        await cpu.write(regs["cmd"], words)
    result = {"list_polls": 0, "list_irq": None}
    if run["display_list"] is not None:
        result = await _start_list(dut, cpu, regs, run["display_list"])
    polls = await _poll(cpu, regs["status"], BUSY)
    names = ["status", "errors", "tiles", "irq_status", "fb_format"]
    read = await cpu.read([regs[name] for name in names])
    values = dict(zip(names, read, strict=True))
    return result | {"registers": values, "cpu_stalls": cpu.stalls, "polls": polls}


async def _scene(dut, cpu_model):
    """The run in the file `RUN_ENV` names, with the CPU `cpu_model`: reset, program,
    collect."""
    path = Path(os.environ[RUN_ENV])
    run = json.loads(path.read_text())
    tag = f"seed {run['seed']}"
    rng = random.Random(run["seed"])
    cpu_rng, memory_rng, list_rng = (random.Random(rng.random()) for _ in range(3))
    cocotb.start_soon(Clock(dut.clk, PERIOD_NS, unit="ns").start())
    dut.rst.value = 1
    memory = _memory(dut, "fb", memory_rng, run["stall"], run["latency"], tag=tag, words={})
    dl, lister = run["display_list"], None
    if dl is not None:
        words = dict(dl["words"])
        lister = _memory(dut, "dl", list_rng, dl["stall"], dl["latency"], tag=tag, words=words)
    cpu = cpu_model(dut, cpu_rng, run)
    for _ in range(3):
        await RisingEdge(dut.clk)
    dut.rst.value = 0
    start = get_sim_time("ns")
    try:
        result = await with_timeout(_program(dut, cpu, run), run["max_clocks"] * PERIOD_NS, "ns")
    except SimTimeoutError:
        raise BenchError(f"not done after {run['max_clocks']} clocks, a hang ({tag})") from None
    result |= {
        "clocks": int((get_sim_time("ns") - start) // PERIOD_NS),
        "memory": sorted(memory.memory.items()),
        "writes": sorted(memory.writes.items()),
        "fb_stalls": memory.stalled,
        "aborted": memory.aborted + (lister.aborted if lister is not None else 0),
        "list_reads": sorted(lister.reads.items()) if lister is not None else [],
        "list_writes": len(lister.writes) if lister is not None else 0,
        "list_stalls": lister.stalled if lister is not None else 0,
    }
    path.with_suffix(".result.json").write_text(json.dumps(result))


@cocotb.test()
async def wishbone_cpu(dut):
    """The peripheral's own top, its Wishbone window driven by cocotbext-wishbone."""
    await _scene(dut, WishboneCpu)


@cocotb.test()
async def axi_lite_cpu(dut):
    """The AXI4-Lite top (`AxiLitePeripheral`), its window driven by cocotbext-axi."""
    await _scene(dut, AxiLiteCpu)
