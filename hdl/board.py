# amaranth: UnusedElaboratable=no
"""The board build's top (docs/hardware.md, "Board build"): the peripheral drawing into a
640 x 480 8-bit grey framebuffer in block RAM, a display list in ROM played through the
peripheral's command FIFO, and the framebuffer shown over DVI.

`BoardCore` is everything in one clock domain (``sync``, the pixel clock, which the
pipeline shares): `DisplayListPlayer` (the ROM of the pages' commands, written into the
register window as a CPU would), `EdgePeripheral`, `FramebufferRAM` (its writes in, the
video's reads out), `VideoTimer` and three `TMDSEncoder` s. Its ``page`` stream says which
page to draw next; its ``video`` stream shows each active pixel with its TMDS words (what
the Verilator simulation records, `edgeaa.sim.simulators.board_harness`), and ``tmds`` has
the three channels' words every clock. `ULX3STop` adds what only the board has: the PLL
(25 MHz in; 25 MHz pixel clock, 125 MHz for the serializer), the page sequence, the 10:1
serializers (5 clocks of two bits through ODDRX1F) onto the GPDI connector's pairs, and LEDs.
"""

from __future__ import annotations

from amaranth.hdl import (
    Cat,
    ClockDomain,
    ClockSignal,
    Const,
    Elaboratable,
    Instance,
    Module,
    Mux,
    Signal,
)
from amaranth.lib import data, io, stream, wiring
from amaranth.lib.cdc import ResetSynchronizer
from amaranth.lib.memory import Memory
from amaranth.lib.wiring import In, Out

from ..model.pipeline import Command
from ..model.tile import TileConfig
from ..model.video import VGA, VideoTiming
from .peripheral import (
    MASTER_ADDR_BITS,
    REGISTERS,
    SLAVE_ADDR_BITS,
    WORD_BITS,
    EdgePeripheral,
    bus_signature,
    command_words,
    pack_command,
)
from .pipeline import command_layout
from .tmds import TMDSEncoder

__all__ = [
    "BoardCore",
    "DisplayListPlayer",
    "FramebufferRAM",
    "PageSequence",
    "TMDSSerializer",
    "ULX3STop",
    "VideoTimer",
    "board_setup",
    "video_layout",
]

# Clocks `busy` must stay low before a page counts as drawn: a command pushed into the FIFO
# shows in its read side (and so in `busy`) 2 clocks later (`SyncFIFOBuffered`).
SETTLE_CLOCKS = 4
CLOCK_WORD = 0b0000011111  # the TMDS clock lane: one pixel clock period per 10 bits


class FramebufferRAM(wiring.Component):
    """`size` bytes of block RAM: a Wishbone B4 pipelined target taking the framebuffer
    writes (one byte lane each, never stalled, acked the next clock; a read, a write of
    several lanes or past the end is answered with ``err`` and not done), and a read port
    for the video (``data`` is the byte at ``addr`` one clock later)."""

    def __init__(self, size: int):
        self._size = size
        super().__init__(
            {
                "bus": In(bus_signature(MASTER_ADDR_BITS)),
                "addr": In(range(size)),
                "data": Out(8),
            }
        )

    def elaborate(self, platform):
        m = Module()
        m.submodules.memory = memory = Memory(shape=8, depth=self._size, init=[])
        write, read = memory.write_port(), memory.read_port(transparent_for=())
        bus = self.bus
        lane = Signal(2)
        one_hot = Signal()
        with m.Switch(bus.sel):
            for k in range(4):
                with m.Case(1 << k):
                    m.d.comb += [lane.eq(k), one_hot.eq(1)]
        byte = Cat(lane, bus.adr)
        good = bus.we & one_hot & (byte < self._size)
        taken = bus.cyc & bus.stb
        m.d.comb += [
            bus.stall.eq(0),
            write.addr.eq(byte),
            write.data.eq(bus.dat_w.word_select(lane, 8)),
            write.en.eq(taken & good),
            read.addr.eq(self.addr),
            self.data.eq(read.data),
            bus.dat_r.eq(0),
        ]
        m.d.sync += [bus.ack.eq(taken & good), bus.err.eq(taken & ~good)]
        return m


class VideoTimer(wiring.Component):
    """The counters of `timing`: ``h``, ``v`` (0, 0 the first active pixel), ``active``,
    the sync levels, and ``addr``, the active pixel's index in raster order."""

    def __init__(self, timing: VideoTiming = VGA):
        self._timing = t = timing
        super().__init__(
            {
                "h": Out(range(t.h_total)),
                "v": Out(range(t.v_total)),
                "active": Out(1),
                "hsync": Out(1),
                "vsync": Out(1),
                "addr": Out(range(t.width * t.height)),
                "frames": Out(32),
            }
        )

    def elaborate(self, platform):
        m = Module()
        t, h, v = self._timing, self.h, self.v
        line_end, frame_end = h == t.h_total - 1, v == t.v_total - 1
        m.d.sync += h.eq(h + 1)
        with m.If(line_end):
            m.d.sync += [h.eq(0), v.eq(v + 1)]
            with m.If(frame_end):
                m.d.sync += [v.eq(0), self.frames.eq(self.frames + 1)]
        h_pulse = (h >= t.width + t.h_front) & (h < t.width + t.h_front + t.h_sync)
        v_pulse = (v >= t.height + t.v_front) & (v < t.height + t.v_front + t.v_sync)
        active = (h < t.width) & (v < t.height)
        m.d.comb += [
            self.active.eq(active),
            self.hsync.eq(h_pulse ^ t.h_negative),
            self.vsync.eq(v_pulse ^ t.v_negative),
        ]
        with m.If(line_end & frame_end):
            m.d.sync += self.addr.eq(0)
        with m.Elif(active):
            m.d.sync += self.addr.eq(self.addr + 1)
        return m


def board_setup(timing: VideoTiming, origin: tuple[int, int]) -> list[tuple[str, int]]:
    """The register writes before any page: the framebuffer at byte 0, one byte a pixel, a
    row of `timing.width` bytes; `origin` the engine pixel at its (0, 0) (a plan's offset)."""
    x0, y0 = origin
    return [
        ("fb_base", 0),
        ("fb_stride", timing.width),
        ("fb_size", timing.width | timing.height << 16),
        ("fb_origin", x0 | y0 << 16),
    ]


class DisplayListPlayer(wiring.Component):
    """The display list in ROM (the commands of every page, `pack_command`'s bits), written
    into the peripheral's register window as a CPU would: first the `setup` writes, then for
    each page asked for on ``page``, each command's words (the last pushes it), one request
    at a time, each held while stalled. A page is drawn when ``busy`` (the peripheral's) has
    been low for `SETTLE_CLOCKS` after its last command; then ``drawn`` counts it and the
    next page is taken. A page number past the last is taken and ignored."""

    def __init__(self, tile: TileConfig, pages: list[list[Command]], setup):
        if not pages or not all(pages):
            raise ValueError("a display list needs at least one page of commands")
        self._tile = tile
        self._rom = [
            sum(w << WORD_BITS * k for k, w in enumerate(pack_command(tile, c)))
            for page in pages
            for c in page
        ]
        self._bounds = []
        start = 0
        for page in pages:
            self._bounds.append((start, start + len(page)))
            start += len(page)
        self._setup = [(REGISTERS[name], value) for name, value in setup]
        super().__init__(
            {
                "page": In(stream.Signature(range(max(len(pages), 2)))),
                "bus": Out(bus_signature(SLAVE_ADDR_BITS)),
                "busy": In(1),
                "drawing": Out(1),
                "drawn": Out(32),
            }
        )

    def elaborate(self, platform):
        m = Module()
        tile, bus = self._tile, self.bus
        words = command_words(tile)
        rom = Memory(shape=command_layout(tile).size, depth=len(self._rom), init=self._rom)
        m.submodules.rom = rom
        read = rom.read_port(transparent_for=())
        index = Signal(range(len(self._rom) + 1))
        end = Signal.like(index)
        word = Signal(range(words))
        setting_up = Signal(init=1)
        step = Signal(range(len(self._setup) + 1))
        settle = Signal(range(SETTLE_CLOCKS + 1))
        wide = Signal(words * WORD_BITS)
        m.d.comb += [read.addr.eq(index), wide.eq(read.data), bus.sel.eq(0xF), bus.we.eq(1)]
        with m.FSM():
            with m.State("SETUP"):
                with m.If(step == len(self._setup)):
                    m.d.sync += setting_up.eq(0)
                    m.next = "IDLE"
                with m.Else(), m.Switch(step):
                    for k, (address, value) in enumerate(self._setup):
                        with m.Case(k):
                            m.d.sync += [bus.adr.eq(address), bus.dat_w.eq(value), step.eq(k + 1)]
                            m.next = "WRITE"
            with m.State("IDLE"):
                m.d.comb += self.page.ready.eq(1)
                with m.If(self.page.valid), m.Switch(self.page.payload):
                    for k, (start, stop) in enumerate(self._bounds):
                        with m.Case(k):
                            m.d.sync += [index.eq(start), end.eq(stop)]
                            m.next = "FETCH"
            with m.State("FETCH"):  # the ROM reads `index` this clock
                m.d.comb += self.drawing.eq(1)
                m.d.sync += [word.eq(0), settle.eq(0)]
                m.next = "LOAD"
                with m.If(index == end):
                    m.next = "DRAIN"
            with m.State("LOAD"):
                m.d.comb += self.drawing.eq(1)
                m.d.sync += [
                    bus.adr.eq(REGISTERS["cmd"] + word),
                    bus.dat_w.eq(wide.word_select(word, WORD_BITS)),
                ]
                m.next = "WRITE"
            with m.State("WRITE"):
                m.d.comb += [bus.cyc.eq(1), bus.stb.eq(1), self.drawing.eq(~setting_up)]
                with m.If(~bus.stall):
                    m.next = "ACK"
            with m.State("ACK"):
                m.d.comb += [bus.cyc.eq(1), self.drawing.eq(~setting_up)]
                with m.If(bus.ack | bus.err):
                    with m.If(setting_up):
                        m.next = "SETUP"
                    with m.Elif(word != words - 1):
                        m.d.sync += word.eq(word + 1)
                        m.next = "LOAD"
                    with m.Else():
                        m.d.sync += index.eq(index + 1)
                        m.next = "FETCH"
            with m.State("DRAIN"):
                m.d.comb += self.drawing.eq(1)
                m.d.sync += settle.eq(Mux(self.busy, 0, settle + 1))
                with m.If(settle == SETTLE_CLOCKS):
                    m.d.sync += self.drawn.eq(self.drawn + 1)
                    m.next = "IDLE"
        return m


def video_layout(timing: VideoTiming) -> data.StructLayout:
    """One active pixel as the ``video`` stream shows it: where, its byte, the three TMDS
    words sent for it (blue, green, red) and whether a page was being drawn."""
    return data.StructLayout(
        {
            "x": range(timing.width),
            "y": range(timing.height),
            "value": 8,
            "tmds0": 10,
            "tmds1": 10,
            "tmds2": 10,
            "drawing": 1,
        }
    )


class BoardCore(wiring.Component):
    """The board's logic in the pixel clock domain (see the module docstring). ``video``
    has no back-pressure: its ``ready`` is not read (the display never waits)."""

    def __init__(self, tile: TileConfig, pages, origin=(0, 0), timing: VideoTiming = VGA):
        self._tile, self._timing, self._origin = tile, timing, tuple(origin)
        self.player = DisplayListPlayer(tile, pages, board_setup(timing, origin))
        # Its RAM writes one byte lane a clock: grey pixels one a write.
        self.peripheral = EdgePeripheral(tile, pack_grey=False)
        self.framebuffer = FramebufferRAM(timing.width * timing.height)
        self.timer = VideoTimer(timing)
        super().__init__(
            {
                "page": In(stream.Signature(range(max(len(pages), 2)))),
                "video": Out(stream.Signature(video_layout(timing))),
                "tmds": Out(30),
                "drawn": Out(32),
                "frames": Out(32),
                "drawing": Out(1),
            }
        )

    @property
    def tile(self) -> TileConfig:
        return self._tile

    @property
    def timing(self) -> VideoTiming:
        return self._timing

    @property
    def origin(self) -> tuple[int, int]:
        return self._origin

    def elaborate(self, platform):
        m = Module()
        player, periph, fb, timer = self.player, self.peripheral, self.framebuffer, self.timer
        m.submodules.player, m.submodules.peripheral = player, periph
        m.submodules.framebuffer, m.submodules.timer = fb, timer
        wiring.connect(m, wiring.flipped(self.page), player.page)
        wiring.connect(m, player.bus, periph.bus)
        wiring.connect(m, periph.fb, fb.bus)
        m.d.comb += [
            player.busy.eq(periph.datapath.busy),
            self.drawn.eq(player.drawn),
            self.drawing.eq(player.drawing),
            self.frames.eq(timer.frames),
            fb.addr.eq(timer.addr),
        ]
        # stage 1: the framebuffer's byte; stage 2: its TMDS words (the encoders' register)
        s1 = {n: Signal(len(getattr(timer, n)), name=f"s1_{n}") for n in _STAGED}
        m.d.sync += [s1[n].eq(getattr(timer, n)) for n in _STAGED]
        encoders = [TMDSEncoder() for _ in range(3)]
        for k, encoder in enumerate(encoders):
            m.submodules[f"tmds{k}"] = encoder
            control = Cat(s1["hsync"], s1["vsync"]) if k == 0 else Const(0, 2)
            m.d.comb += [
                encoder.data.eq(fb.data),
                encoder.de.eq(s1["active"]),
                encoder.control.eq(control),
            ]
        m.d.comb += self.tmds.eq(Cat(*(e.word for e in encoders)))
        out = self.video.payload
        m.d.sync += [
            self.video.valid.eq(s1["active"]),
            out.x.eq(s1["h"]),
            out.y.eq(s1["v"]),
            out.value.eq(fb.data),
            out.drawing.eq(player.drawing),
        ]
        m.d.comb += [getattr(out, f"tmds{k}").eq(e.word) for k, e in enumerate(encoders)]
        return m


_STAGED = ("h", "v", "active", "hsync", "vsync")


class PageSequence(wiring.Component):
    """The pages in turn for the board: page 0 once after reset, then, when there is more
    than one, the next (after the last, 0 again) once `hold_frames` frames have begun since
    the last page was taken (``frames`` is the video's frame counter)."""

    def __init__(self, pages: int, hold_frames: int):
        self._pages, self._hold = pages, hold_frames
        super().__init__({"frames": In(32), "page": Out(stream.Signature(range(max(pages, 2))))})

    def elaborate(self, platform):
        m = Module()
        page, taken = self.page, self.page.valid & self.page.ready
        shown = Signal(range(self._hold + 1))
        last = Signal(2)
        m.d.sync += last.eq(self.frames[:2])
        new_frame = last != self.frames[:2]
        with m.If(taken):
            wrap = page.payload == self._pages - 1
            m.d.sync += [page.payload.eq(Mux(wrap, 0, page.payload + 1)), shown.eq(0)]
        with m.Elif(new_frame & (shown != self._hold)):
            m.d.sync += shown.eq(shown + 1)
        first = Signal(init=1)
        with m.If(taken):
            m.d.sync += first.eq(0)
        again = (shown == self._hold) if self._pages > 1 else Const(0)
        m.d.comb += page.valid.eq(first | again)
        return m


class TMDSSerializer(wiring.Component):
    """Four lanes of 10-bit words (``words``: lane k at bits 10k..10k+9, from the pixel clock
    domain ``sync``) as 2 bits a clock of the ``shift`` domain (5 times the pixel clock, from
    the same PLL: related clocks, whose crossing nextpnr times): ``o0`` is each lane's bit
    sent first (an ODDRX1F's D0, on the rising edge), ``o1`` the next. A word is taken every
    5 shift clocks (a path of at least one shift clock from the pixel clock's register) and
    sent bit 0 first over the next 5."""

    def __init__(self, lanes: int = 4):
        self._lanes = lanes
        super().__init__({"words": In(10 * lanes), "o0": Out(lanes), "o1": Out(lanes)})

    def elaborate(self, platform):
        m = Module()
        shifters = [Signal(10, name=f"shift{k}") for k in range(self._lanes)]
        phase = Signal(range(5))
        m.d.shift += phase.eq(Mux(phase == 4, 0, phase + 1))
        for k, shifter in enumerate(shifters):
            with m.If(phase == 4):
                m.d.shift += shifter.eq(self.words.word_select(k, 10))
            with m.Else():
                m.d.shift += shifter.eq(shifter >> 2)
        m.d.comb += [
            self.o0.eq(Cat(s[0] for s in shifters)),
            self.o1.eq(Cat(s[1] for s in shifters)),
        ]
        return m


class ULX3STop(Elaboratable):
    """`BoardCore` on the ULX3S: clocks from the PLL, the pages in turn (`PageSequence`, 30
    frames apart), DVI on the GPDI connector (`TMDSSerializer` into ODDRX1F), LED 0 on while
    drawing, LED 1 once a page has been drawn, LED 7 the PLL's lock."""

    def __init__(self, core: BoardCore, pages: int, hold_frames: int = 30):
        self._core, self._pages, self._hold = core, pages, hold_frames

    def elaborate(self, platform):
        m = Module()
        m.submodules.core = core = self._core
        locked = self._clocks(m, platform)
        m.submodules.pages = pages = PageSequence(self._pages, self._hold)
        m.d.comb += pages.frames.eq(core.frames)
        wiring.connect(m, pages.page, core.page)
        self._dvi(m, platform, core.tmds)
        leds = [platform.request("led", k, dir="-") for k in (0, 1, 7)]
        for k, (port, value) in enumerate(
            zip(leds, (core.drawing, core.drawn != 0, locked), strict=True)
        ):
            m.submodules[f"led{k}"] = buffer = io.Buffer("o", port)
            m.d.comb += buffer.o.eq(value)
        return m

    def _clocks(self, m: Module, platform) -> Signal:
        """25 MHz in; CLKOP 125 MHz (VCO 625 MHz) for the serializer, CLKOS 25 MHz."""
        m.submodules.clk25 = clk25 = io.Buffer("i", platform.request("clk25", dir="-"))
        shift_clk, pixel_clk, locked = Signal(), Signal(), Signal()
        m.submodules.pll = Instance(
            "EHXPLLL",
            p_PLLRST_ENA="DISABLED", p_INTFB_WAKE="DISABLED", p_STDBY_ENABLE="DISABLED",
            p_DPHASE_SOURCE="DISABLED", p_OUTDIVIDER_MUXA="DIVA", p_OUTDIVIDER_MUXB="DIVB",
            p_OUTDIVIDER_MUXC="DIVC", p_OUTDIVIDER_MUXD="DIVD", p_CLKI_DIV=1,
            p_CLKOP_ENABLE="ENABLED", p_CLKOP_DIV=5, p_CLKOP_CPHASE=2, p_CLKOP_FPHASE=0,
            p_CLKOS_ENABLE="ENABLED", p_CLKOS_DIV=25, p_CLKOS_CPHASE=2, p_CLKOS_FPHASE=0,
            p_FEEDBK_PATH="CLKOP", p_CLKFB_DIV=5,
            i_RST=0, i_STDBY=0, i_CLKI=clk25.i, o_CLKOP=shift_clk, o_CLKOS=pixel_clk,
            i_CLKFB=shift_clk, i_PHASESEL0=0, i_PHASESEL1=0, i_PHASEDIR=1, i_PHASESTEP=1,
            i_PHASELOADREG=1, i_PLLWAKESYNC=0, i_ENCLKOP=0, o_LOCK=locked,
            a_FREQUENCY_PIN_CLKI="25", a_FREQUENCY_PIN_CLKOP="125", a_FREQUENCY_PIN_CLKOS="25",
        )  # fmt: skip
        m.domains.sync = ClockDomain()
        m.domains.shift = ClockDomain()
        m.d.comb += [ClockSignal("sync").eq(pixel_clk), ClockSignal("shift").eq(shift_clk)]
        m.submodules.sync_reset = ResetSynchronizer(~locked, domain="sync")
        m.submodules.shift_reset = ResetSynchronizer(~locked, domain="shift")
        return locked

    def _dvi(self, m: Module, platform, tmds) -> None:
        """The three TMDS lanes and the clock lane through `TMDSSerializer` and ODDRX1F onto
        the connector's pairs (the P pins, LVCMOS33D)."""
        pins = ("d", "clk", "cec", "eth", "scl", "sda")  # the rest left unconnected
        hdmi = platform.request("hdmi", 0, dir={name: "-" for name in pins})
        m.submodules.serializer = serializer = TMDSSerializer()
        m.d.comb += serializer.words.eq(Cat(tmds, Const(CLOCK_WORD, 10)))  # d0, d1, d2, clk
        m.submodules.d = data_out = io.DDRBuffer("o", hdmi.d, o_domain="shift")
        m.submodules.clk = clk_out = io.DDRBuffer("o", hdmi.clk, o_domain="shift")
        m.d.comb += [
            data_out.o[0].eq(serializer.o0[:3]),
            data_out.o[1].eq(serializer.o1[:3]),
            clk_out.o[0].eq(serializer.o0[3]),
            clk_out.o[1].eq(serializer.o1[3]),
        ]
