"""The peripheral's register window over AXI4-Lite (`AxiLitePeripheral`): an `AxiLiteBridge`
in front of `EdgePeripheral`'s Wishbone target, every other port passed through unchanged.

The bridge carries one transaction at a time, which is all a register window needs (a CPU's
uncached loads and stores to a peripheral are one at a time): a read or a write is accepted
(AW and W together), issued as one Wishbone B4 pipelined request, and answered once the
target's ``ack`` or ``err`` comes (``err`` is SLVERR). Reads go first when both are asked on
one clock. The AXI side follows the AXI4-Lite rules the bridge must keep (AMBA AXI4 spec,
A3.3): no ready waits on a valid, and a valid once raised holds until its handshake.
docs/hardware.md, "Integrating edgeaa", has the timing.
"""

from __future__ import annotations

from amaranth.hdl import Module, Mux, Signal
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

from ..model.tile import TileConfig
from .core import flat_verilog
from .peripheral import SLAVE_ADDR_BITS, WORD_BITS, EdgePeripheral, bus_signature

__all__ = ["AxiLiteBridge", "AxiLitePeripheral", "axi_lite_signature", "axi_lite_verilog"]

BYTE_ADDR_BITS = SLAVE_ADDR_BITS + 2  # AXI addresses bytes; the window's words are 4 bytes
OKAY, SLVERR = 0b00, 0b10


def axi_lite_signature(addr_width: int) -> wiring.Signature:
    """An AXI4-Lite bus from the manager's side, 32-bit data, the five channels' signals
    named as the AMBA spec names them (``aw``, ``w``, ``b``, ``ar``, ``r``)."""
    return wiring.Signature(
        {
            "awvalid": Out(1),
            "awready": In(1),
            "awaddr": Out(addr_width),
            "awprot": Out(3),
            "wvalid": Out(1),
            "wready": In(1),
            "wdata": Out(WORD_BITS),
            "wstrb": Out(WORD_BITS // 8),
            "bvalid": In(1),
            "bready": Out(1),
            "bresp": In(2),
            "arvalid": Out(1),
            "arready": In(1),
            "araddr": Out(addr_width),
            "arprot": Out(3),
            "rvalid": In(1),
            "rready": Out(1),
            "rdata": In(WORD_BITS),
            "rresp": In(2),
        }
    )


class AxiLiteBridge(wiring.Component):
    """AXI4-Lite target in, Wishbone B4 pipelined initiator out, one transaction at a time.

    A transaction takes its handshake clock, the Wishbone request (one clock when the target
    does not stall), the target's latency and the response handshake: four clocks for a
    write or read to `EdgePeripheral`, whose ``ack`` comes the clock after its request."""

    def __init__(self, addr_width: int = BYTE_ADDR_BITS):
        self._addr_width = addr_width
        super().__init__(
            {
                "axi": In(axi_lite_signature(addr_width)),
                "wb": Out(bus_signature(addr_width - 2)),
            }
        )

    def elaborate(self, platform):
        m = Module()
        axi, wb = self.axi, self.wb
        reply = Signal(2)  # OKAY or SLVERR, kept for the response
        answered = wb.ack | wb.err
        with m.If(wb.cyc & answered):
            m.d.sync += [reply.eq(Mux(wb.err, SLVERR, OKAY)), axi.rdata.eq(wb.dat_r)]
        with m.FSM():
            with m.State("IDLE"):
                with m.If(axi.arvalid):
                    m.d.comb += axi.arready.eq(1)
                    m.d.sync += [wb.adr.eq(axi.araddr[2:]), wb.we.eq(0), wb.sel.eq(~0)]
                    m.next = "REQUEST"
                with m.Elif(axi.awvalid & axi.wvalid):
                    m.d.comb += [axi.awready.eq(1), axi.wready.eq(1)]
                    m.d.sync += [
                        wb.adr.eq(axi.awaddr[2:]),
                        wb.we.eq(1),
                        wb.dat_w.eq(axi.wdata),
                        wb.sel.eq(axi.wstrb),
                    ]
                    m.next = "REQUEST"
            with m.State("REQUEST"):
                m.d.comb += [wb.cyc.eq(1), wb.stb.eq(1)]
                with m.If(~wb.stall):  # a target may answer on the clock it takes it
                    m.next = "WAIT"
                    with m.If(answered):
                        m.next = "RESPOND"
            with m.State("WAIT"):
                m.d.comb += wb.cyc.eq(1)
                with m.If(answered):
                    m.next = "RESPOND"
            with m.State("RESPOND"):
                with m.If(wb.we):
                    m.d.comb += [axi.bvalid.eq(1), axi.bresp.eq(reply)]
                    with m.If(axi.bready):
                        m.next = "IDLE"
                with m.Else():
                    m.d.comb += [axi.rvalid.eq(1), axi.rresp.eq(reply)]
                    with m.If(axi.rready):
                        m.next = "IDLE"
        return m


class AxiLitePeripheral(wiring.Component):
    """`EdgePeripheral` with its register window on AXI4-Lite (``axi``, byte addresses: a
    register's address is 4 times its word offset); its other ports (the framebuffer
    initiator, ``irq``) are the peripheral's own, under the same names."""

    top_kind = "axi-lite peripheral"  # `edgeaa verilog`'s header (`edgeaa.hdl.integration`)

    def __init__(self, tile: TileConfig, fifo_depth: int = 16):
        self.peripheral = EdgePeripheral(tile, fifo_depth)
        self.bridge = AxiLiteBridge()
        members = dict(self.peripheral.signature.members.items())
        del members["bus"]
        super().__init__({"axi": In(axi_lite_signature(BYTE_ADDR_BITS)), **members})

    @property
    def tile(self) -> TileConfig:
        return self.peripheral.tile

    def elaborate(self, platform):
        m = Module()
        m.submodules.peripheral = inner = self.peripheral
        m.submodules.bridge = bridge = self.bridge
        wiring.connect(m, wiring.flipped(self.axi), bridge.axi)
        wiring.connect(m, bridge.wb, inner.bus)
        for name in self.signature.members:
            if name != "axi":
                port, inner_port = getattr(self, name), getattr(inner, name)
                if isinstance(port, Signal):  # a plain signal: driven by the peripheral
                    m.d.comb += port.eq(inner_port)
                else:
                    wiring.connect(m, wiring.flipped(port), inner_port)
        return m


def axi_lite_verilog(tile: TileConfig, *, name: str = "edgeaa_peripheral") -> str:
    """The peripheral with its register window on AXI4-Lite, as Verilog: ports clk, rst,
    ``axi__*`` (the register window, an AXI4-Lite subordinate), ``fb__*`` and ``irq``."""
    return flat_verilog(AxiLitePeripheral(tile), name)
