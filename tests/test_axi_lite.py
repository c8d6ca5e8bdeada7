# amaranth: UnusedElaboratable=no
"""The AXI4-Lite register window (`edgeaa.hdl.axi_lite`) in Amaranth's simulator: the bridge
alone between a seeded random AXI4-Lite manager and a Wishbone register file that stalls,
answers late and errs, every answer checked against the register file and the AXI4-Lite
handshake rules; then the whole peripheral behind it, its registers read and written."""

from __future__ import annotations

import random
import re
import subprocess
import sys

import pytest
from amaranth.sim import Simulator

from edgeaa.hdl.axi_lite import (
    SLVERR,
    AxiLiteBridge,
    AxiLitePeripheral,
    axi_lite_signature,
    axi_lite_verilog,
)
from edgeaa.hdl.peripheral import REGISTERS, info_word
from edgeaa.model import EdgeConfig
from edgeaa.model.tile import TileConfig

TILE = TileConfig(EdgeConfig(), 16, 8)
WORDS = 64
ERR_WORD = 13  # the register file answers this word with err


class _Target:
    """A Wishbone B4 pipelined register file: random stalls, each ack 1 to 3 clocks after its
    request is taken, `ERR_WORD` answered with err."""

    def __init__(self, bus, rng: random.Random):
        self.bus, self.rng = bus, rng
        self.words = [rng.getrandbits(32) for _ in range(WORDS)]

    async def run(self, ctx):
        bus, rng, due = self.bus, self.rng, []
        async for _ in ctx.tick():
            ctx.set(bus.ack, 0)
            ctx.set(bus.err, 0)
            if due and due[0][0] == 0:
                _, err, data = due.pop(0)
                ctx.set(bus.err if err else bus.ack, 1)
                ctx.set(bus.dat_r, data)
            due = [(d - 1, e, v) for d, e, v in due]
            stall = rng.random() < 0.3
            ctx.set(bus.stall, stall)
            if ctx.get(bus.cyc & bus.stb) and not stall:
                due.append((rng.randrange(3), *self._take(ctx)))

    def _take(self, ctx) -> tuple[bool, int]:
        bus = self.bus
        adr = ctx.get(bus.adr)
        if adr == ERR_WORD:
            return True, 0
        if ctx.get(bus.we):
            sel, data, old = ctx.get(bus.sel), ctx.get(bus.dat_w), self.words[adr]
            mask = sum(0xFF << 8 * k for k in range(4) if sel >> k & 1)
            self.words[adr] = (old & ~mask) | (data & mask)
        return False, self.words[adr]


class _Manager:
    """An AXI4-Lite manager: random delays before each valid and before each ready, every
    valid held until its handshake and every response checked held while it waits."""

    def __init__(self, axi, rng: random.Random):
        self.axi, self.rng = axi, rng

    async def _delay(self, ctx, chance=0.4):
        while self.rng.random() < chance:
            await ctx.tick()

    async def _handshake(self, ctx, valid, ready, limit=50):
        for _ in range(limit):
            if ctx.get(ready):
                await ctx.tick()
                ctx.set(valid, 0)
                return
            await ctx.tick()
        raise AssertionError(f"{ready.name} never came")

    async def _response(self, ctx, valid, ready, fields, limit=50):
        for _ in range(limit):
            if ctx.get(valid):
                break
            await ctx.tick()
        else:
            raise AssertionError(f"{valid.name} never came")
        seen = [ctx.get(f) for f in fields]
        while self.rng.random() < 0.4:  # the response must hold while ready is low
            await ctx.tick()
            assert ctx.get(valid) and [ctx.get(f) for f in fields] == seen
        ctx.set(ready, 1)
        await ctx.tick()
        ctx.set(ready, 0)
        return seen

    async def write(self, ctx, address: int, data: int, strb: int = 0xF) -> int:
        axi = self.axi
        await self._delay(ctx)
        ctx.set(axi.awaddr, address)
        ctx.set(axi.wdata, data)
        ctx.set(axi.wstrb, strb)
        ctx.set(axi.awvalid, 1)
        ctx.set(axi.wvalid, 1)
        await self._handshake(ctx, axi.awvalid, axi.awready)
        ctx.set(axi.wvalid, 0)
        (resp,) = await self._response(ctx, axi.bvalid, axi.bready, [axi.bresp])
        return resp

    async def read(self, ctx, address: int) -> tuple[int, int]:
        axi = self.axi
        await self._delay(ctx)
        ctx.set(axi.araddr, address)
        ctx.set(axi.arvalid, 1)
        await self._handshake(ctx, axi.arvalid, axi.arready)
        data, resp = await self._response(ctx, axi.rvalid, axi.rready, [axi.rdata, axi.rresp])
        return data, resp


@pytest.mark.parametrize("seed", range(3))
def test_the_bridge_reads_and_writes_a_stalling_register_file(seed):
    rng = random.Random(seed)
    dut = AxiLiteBridge()
    target = _Target(dut.wb, random.Random(rng.random()))
    manager = _Manager(dut.axi, random.Random(rng.random()))
    expected = list(target.words)
    checked = []

    async def program(ctx):
        for _ in range(150):
            word = rng.randrange(WORDS)
            if rng.random() < 0.5:
                data, strb = rng.getrandbits(32), rng.randrange(16)
                resp = await manager.write(ctx, 4 * word, data, strb)
                if word != ERR_WORD:
                    mask = sum(0xFF << 8 * k for k in range(4) if strb >> k & 1)
                    expected[word] = (expected[word] & ~mask) | (data & mask)
            else:
                data, resp = await manager.read(ctx, 4 * word)
                if word != ERR_WORD:
                    assert data == expected[word], f"seed {seed}: word {word}"
            assert resp == (SLVERR if word == ERR_WORD else 0), f"seed {seed}: word {word}"
            checked.append(word)

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(target.run, background=True)
    sim.add_testbench(program)
    sim.run()
    assert len(checked) == 150 and ERR_WORD in checked
    assert target.words == expected, f"seed {seed}"


def test_the_peripheral_answers_over_axi_lite():
    dut = AxiLitePeripheral(TILE)
    manager = _Manager(dut.axi, random.Random(7))
    seen = {}

    async def program(ctx):
        seen["info"] = await manager.read(ctx, 4 * REGISTERS["info"])
        seen["write"] = await manager.write(ctx, 4 * REGISTERS["fb_stride"], 1234)
        seen["stride"] = await manager.read(ctx, 4 * REGISTERS["fb_stride"])
        seen["status"] = await manager.read(ctx, 4 * REGISTERS["status"])

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(program)
    sim.run()
    assert seen["info"] == (info_word(TILE), 0)
    assert seen["write"] == 0
    assert seen["stride"] == (1234, 0)
    assert seen["status"] == (0, 0)  # idle, no error, FIFO empty


def test_the_axi_lite_top_has_the_axi_ports_and_is_lint_clean():
    from edgeaa.sim.simulators.verilator import lint

    source = axi_lite_verilog(TileConfig(EdgeConfig(7, 2, 4), 8, 4))
    header = re.search(r"module edgeaa_peripheral\((.*?)\);", source, re.S).group(1)
    ports = {port.strip() for port in header.split(",")}
    axi = {name for name in axi_lite_signature(8).members}
    assert {port for port in ports if port.startswith("axi__")} == {f"axi__{n}" for n in axi}
    assert {"fb__cyc", "fb__stb", "fb__adr", "irq", "clk", "rst"} <= ports
    assert not any(port.startswith("bus__") for port in ports)
    proc = lint(source)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_edgeaa_verilog_writes_the_axi_lite_top_and_refuses_bus_without_the_peripheral(tmp_path):
    out = tmp_path / "p.v"
    done = subprocess.run(
        [sys.executable, "-m", "edgeaa", "verilog", "--top", "peripheral", "--bus", "axi-lite",
         "--tile", "8x4", "-o", str(out)],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "axi__awvalid" in out.read_text() and "axi__arvalid (0 when idle)" in done.stderr
    refused = subprocess.run(
        [sys.executable, "-m", "edgeaa", "verilog", "--bus", "axi-lite"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert refused.returncode == 2 and "Traceback" not in refused.stderr
    assert refused.stderr.strip().endswith("add --top peripheral")
