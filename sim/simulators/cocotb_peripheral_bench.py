"""The cocotb bench of the Verilated peripheral (`edgeaa.sim.simulators.cocotb_peripheral`
builds and runs it; this module runs inside the simulator). Both buses are driven by
cocotbext-wishbone's bus-functional models (PyPI): its `WishboneMaster` is the CPU, writing
the framebuffer registers and a scene's command words into the register window and polling
``status``, with seeded random idle clocks before each request; its `WishboneSlave`, sampling
a request on every clock (`PipelinedSlave`), is the framebuffer's memory with seeded random
stalls and ack latencies. The run's parameters come from the JSON file named by `RUN_ENV`;
the memory's bytes, the registers read at the end and the counts go back in the same file's
``result`` next to it (``<name>.result.json``).
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


class BenchError(AssertionError):
    """A handshake rule broken or a run past its clock limit (the message has the seed)."""


class PipelinedSlave(WishboneSlave):
    """cocotbext-wishbone's slave with its request loop replaced: the package's own loop
    (`WishboneSlave._monitor_recv`) waits for its ack after each request, missing the
    requests a pipelined initiator makes meanwhile, and never answers a request it first
    sees under its own stall. This one looks at the bus on every clock and hands each request
    to the package's `_respond` (which takes it unless stalled and queues its reply for the
    package's ack process: its stall generator, ack latencies and records are kept). It
    checks the initiator: a stalled request offered again unchanged, writes only."""

    def __init__(self, *args, tag: str, **kwargs):
        self.tag = tag
        self.held = None  # the request stalled at the last clock
        self.stalled = 0  # clocks a request waited on stall
        self.aborted = 0  # requests taken, cyc dropped before their ack
        self.memory: dict[int, int] = {}
        self.writes: Counter = Counter()
        super().__init__(*args, callback=self._store, **kwargs)

    async def _monitor_recv(self):
        bus = self.bus
        while True:
            await RisingEdge(self.clock)  # the values the peripheral saw at this edge
            cyc = bus.cyc.value == 1
            if cyc and bus.stb.value == 1:
                request = tuple(int(v.value) for v in (bus.we, bus.adr, bus.sel, bus.datwr))
                if self.held not in (None, request):
                    self._fail(f"a stalled request changed: {self.held} then {request}")
                if not request[0]:
                    self._fail("a read on the framebuffer bus")
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

    def _store(self, replies):
        for reply in replies:
            address, sel, word = int(reply.adr) * 4, int(reply.sel), int(reply.datwr)
            for lane in (k for k in range(4) if sel >> k & 1):
                self.memory[address + lane] = word >> 8 * lane & 0xFF
                self.writes[address + lane] += 1

    def _fail(self, what: str):
        raise BenchError(f"framebuffer bus: {what} ({self.tag})")


def _geometric(rng: random.Random, p: float) -> int:
    """A run of clocks, each drawn with probability `p` (a stall, an idle wait). Runs of
    stalls with one clock without between them are a share `p` of the clocks."""
    n = 0
    while rng.random() < p:
        n += 1
    return n


async def _requests(cpu: WishboneMaster, rng: random.Random, idle: float, ops) -> list:
    """One bus cycle of `ops` ((word address, value or None for a read)), each after its
    random idle clocks; the package's results (ack, read data, clocks stalled)."""
    cycle = [WBOp(adr, value, idle=_geometric(rng, idle)) for adr, value in ops]
    return await cpu.send_cycle(cycle)


async def _program(dut, cpu: WishboneMaster, rng: random.Random, run: dict) -> dict:
    """The CPU's part: the set-up registers, each command's words (one bus cycle a command,
    as a driver's stores), then ``status`` polled until not busy and the counters read."""
    regs, idle = run["registers"], run["idle"]
    stalls = 0
    for result in await _requests(cpu, rng, idle, run["setup"]):
        stalls += result.waitStall
    for words in run["commands"]:
        ops = [(regs["cmd"] + k, word) for k, word in enumerate(words)]
        for result in await _requests(cpu, rng, idle, ops):
            stalls += result.waitStall
    polls = 0
    while True:
        (status,) = await _requests(cpu, rng, idle, [(regs["status"], None)])
        polls += 1
        if not int(status.datrd) & 1:
            break
    names = ["status", "errors", "tiles", "irq_status", "fb_format"]
    read = await _requests(cpu, rng, idle, [(regs[name], None) for name in names])
    values = {name: int(result.datrd) for name, result in zip(names, read, strict=True)}
    return {"registers": values, "cpu_stalls": stalls, "polls": polls}


@cocotb.test()
async def peripheral_scene(dut):
    """The run in the file `RUN_ENV` names: reset, program, collect."""
    path = Path(os.environ[RUN_ENV])
    run = json.loads(path.read_text())
    tag = f"seed {run['seed']}"
    rng = random.Random(run["seed"])
    cpu_rng, memory_rng = random.Random(rng.random()), random.Random(rng.random())
    cocotb.start_soon(Clock(dut.clk, PERIOD_NS, unit="ns").start())
    dut.rst.value = 1
    common = {"signals_dict": SIGNALS, "bus_separator": "__", "width": 32}
    stalls = ((_geometric(memory_rng, run["stall"]), 1) for _ in itertools.count())
    latencies = (memory_rng.randint(0, run["latency"]) for _ in itertools.count())
    memory = PipelinedSlave(
        dut, "fb", dut.clk, tag=tag, waitstallgen=stalls, waitreplygen=latencies, **common
    )
    cpu = WishboneMaster(dut, "bus", dut.clk, timeout=run["max_clocks"], **common)
    for _ in range(3):
        await RisingEdge(dut.clk)
    dut.rst.value = 0
    start = get_sim_time("ns")
    try:
        result = await with_timeout(
            _program(dut, cpu, cpu_rng, run), run["max_clocks"] * PERIOD_NS, "ns"
        )
    except SimTimeoutError:
        raise BenchError(f"not done after {run['max_clocks']} clocks, a hang ({tag})") from None
    result |= {
        "clocks": int((get_sim_time("ns") - start) // PERIOD_NS),
        "memory": sorted(memory.memory.items()),
        "writes": sorted(memory.writes.items()),
        "fb_stalls": memory.stalled,
        "aborted": memory.aborted,
    }
    path.with_suffix(".result.json").write_text(json.dumps(result))
