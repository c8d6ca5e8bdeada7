# amaranth: UnusedElaboratable=no
"""The pipeline as a bus peripheral (`EdgePeripheral`): a Wishbone B4 pipelined slave with a
register window (commands in through a FIFO, status, counters, interrupt), a Wishbone B4
pipelined master that writes each flushed tile's pixels into a linear framebuffer
(`FramebufferWriter`: grey 8, RGB565, RGB888 or RGBA8888, the ``fb_format`` register) and
one that reads a display list of commands from memory into the same FIFO
(`DisplayListReader`). docs/hardware.md, "Integrating edgeaa", has the register map.

Amaranth 0.5 has no Wishbone library, so the bus is declared here (`bus_signature`): 32-bit
data, byte granularity, word addresses, the B4 pipelined handshake (a request is taken on a
clock with ``cyc & stb & ~stall``; each taken request gets one ``ack`` or ``err``, in order).

A command is written as `command_words` 32-bit words (`pack_command`): the bits of
`edgeaa.hdl.pipeline.command_layout`, word 0 the lowest; writing the last word pushes the
command into the FIFO (the write stalls while the FIFO is full).
"""

from __future__ import annotations

from amaranth.hdl import Cat, Const, Module, Mux, ResetInserter, Signal, unsigned
from amaranth.lib import data, fifo, stream, wiring
from amaranth.lib.wiring import In, Out

from ..model.framebuffer import (
    FORMAT_BITS,
    default_format,
    format_codes,
    scale_channel,
    scale_steps,
)
from ..model.pipeline import CODE, COMMAND_VERSION, Command
from ..model.tile import TileConfig
from .core import ERRORS_BITS, flat_verilog
from .layouts import tile_pixel_layout
from .pipeline import STATS, EdgePipeline, command_layout

__all__ = [
    "REGISTERS",
    "DisplayListReader",
    "EdgePeripheral",
    "FramebufferWriter",
    "bus_signature",
    "command_words",
    "pack_command",
    "peripheral_verilog",
    "register_map",
]

WORD_BITS = 32
SLAVE_ADDR_BITS = 6  # 64 words of register window
MASTER_ADDR_BITS = 30  # word address: a 4 GiB byte space
FB_BITS = 16  # stride, size and origin fields
FB_PIXEL_BITS = 8  # a channel is at most a byte
INFO_MAGIC = 0xEA
MAX_OUTSTANDING = 7  # framebuffer writes in flight (acks not yet in)
DL_LENGTH_BITS = 24  # a display list's length in commands
# Flushed tiles between the command stage and the writer; a flush waits for room (at 2, the
# back-to-back flush test makes one wait; 4 never filled).
ORIGIN_DEPTH = 2

# The register window, word offsets (the byte offset is 4 times). "cmd" is the first of
# `command_words` words; writing the last pushes the command.
REGISTERS = {
    "info": 0,  # RO: magic, command version, words per command, tile size
    "ctrl": 1,  # WO: bit 0 resets the datapath (FIFO, pipeline, writer, counters), bit 1
    # starts the display list
    "status": 2,  # RO: bit 0 busy, bit 1 bus error (sticky), bit 2 FIFO full, bit 3 the
    # display list running; level 31:16
    "irq_enable": 3,  # RW: bit 0 tile written, bit 1 bus error, bit 2 display list done
    "irq_status": 4,  # R, write 1 to clear: the same bits, set on the event
    "fb_base": 5,  # RW: byte address of framebuffer pixel (0, 0)
    "fb_stride": 6,  # RW: bytes per framebuffer row (15:0)
    "fb_size": 7,  # RW: width 15:0, height 31:16 (pixels outside are not written)
    "fb_origin": 8,  # RW: the engine pixel at framebuffer (0, 0): x 15:0, y 31:16
    "errors": 9,  # RO: bad commands 15:0, bad edges 31:16 (saturating)
    "tiles": 10,  # RO: tiles written to the framebuffer (wrapping)
    "fb_format": 11,  # RW 1:0: the pixel format's code; RO 7:4: the codes this build writes
    "dl_base": 12,  # RW 31:2: byte address of the display list's first word (1:0 read 0)
    "dl_length": 13,  # RW 23:0: the display list's length in commands
    "stats": 16,  # RO: the pipeline's counters, in `STATS` order
    "cmd": 32,  # WO: command words
}


def bus_signature(addr_width: int) -> wiring.Signature:
    """A Wishbone B4 pipelined bus, from the initiator's side: 32-bit data, byte lanes
    (``sel``), ``adr`` a word address, ``stall`` and ``err`` from the target."""
    return wiring.Signature(
        {
            "cyc": Out(1),
            "stb": Out(1),
            "we": Out(1),
            "adr": Out(addr_width),
            "dat_w": Out(WORD_BITS),
            "sel": Out(WORD_BITS // 8),
            "dat_r": In(WORD_BITS),
            "ack": In(1),
            "stall": In(1),
            "err": In(1),
        }
    )


def command_words(tile: TileConfig) -> int:
    return -(-command_layout(tile).size // WORD_BITS)


def pack_command(tile: TileConfig, command: Command) -> list[int]:
    """The words a CPU writes for `command` (each field at its `command_layout` offset)."""
    value = 0
    for name, field in command_layout(tile):
        v = getattr(command, name)
        if not 0 <= v < 1 << field.width:
            raise ValueError(f"command field {name}={v} does not fit in {field.width} bits")
        value |= v << field.offset
    mask = (1 << WORD_BITS) - 1
    return [(value >> (WORD_BITS * k)) & mask for k in range(command_words(tile))]


def register_map(tile: TileConfig) -> dict[str, int]:
    """Every register's word offset (the stats and command words each their own)."""
    regs = {k: v for k, v in REGISTERS.items() if k not in ("stats", "cmd")}
    regs |= {f"stats.{name}": REGISTERS["stats"] + i for i, name in enumerate(STATS)}
    regs |= {f"cmd{k}": REGISTERS["cmd"] + k for k in range(command_words(tile))}
    return regs


def info_word(tile: TileConfig) -> int:
    """The ``info`` register: magic 31:24, command version 23:16, command words 15:12,
    log2 tile width 11:8, log2 tile height 7:4, intensity bits 3:0."""
    fields = (INFO_MAGIC, 24), (COMMAND_VERSION, 16), (command_words(tile), 12)
    fields += (tile.x_bits, 8), (tile.y_bits, 4), (tile.config.intensity_bits, 0)
    return sum(value << shift for value, shift in fields)


class FramebufferWriter(wiring.Component):
    """Each tile's pixels (``pixels``, raster order of one flush, ``last`` on the last) to
    ``base + Y * stride + X * bytes`` in the format ``fb_format`` (a code of
    `edgeaa.model.framebuffer.format_codes`, else the default format; ``bytes`` its bytes per
    pixel), where (X, Y) is the pixel's engine position (the tile's origin from ``origins``,
    one per tile, plus its x, y) less ``fb_origin``; pixels outside ``fb_size`` are not
    written. A pixel is one write with its byte lanes in ``sel``, or two when its bytes cross
    a 32-bit word (the second to the next word); in a grey build the next pixel of a row
    that comes before the write is offered joins it (`_join_grey`: up to 4 a write), unless
    ``pack_grey`` is False (one lane a write, for a target that takes no more).
    ``done`` pulses when every write of a tile is acknowledged (the next tile's writes start
    after it); ``bus_error`` pulses on an ``err`` (the write counts as answered)."""

    def __init__(self, tile: TileConfig, pack_grey: bool = True):
        if tile.config.intensity_bits > FB_PIXEL_BITS:
            raise ValueError(
                f"the framebuffer's channels are bytes: at most {FB_PIXEL_BITS} intensity "
                f"bits, not {tile.config.intensity_bits}"
            )
        self._tile, self._pack = tile, pack_grey and tile.channels == 1
        origin = data.StructLayout({"x": unsigned(FB_BITS), "y": unsigned(FB_BITS)})
        super().__init__(
            {
                "pixels": In(stream.Signature(tile_pixel_layout(tile))),
                "origins": In(stream.Signature(origin)),
                "fb_base": In(WORD_BITS),
                "fb_stride": In(FB_BITS),
                "fb_size": In(origin),
                "fb_origin": In(origin),
                "fb_format": In(FORMAT_BITS),
                "bus": Out(bus_signature(MASTER_ADDR_BITS)),
                "done": Out(1),
                "bus_error": Out(1),
            }
        )

    def elaborate(self, platform):
        m = Module()
        px, origin, bus = self.pixels.payload, self.origins.payload, self.bus
        wide = FB_BITS + 2  # signed X, Y before the window check
        X, Y = Signal(range(-(1 << wide), 1 << wide)), Signal(range(-(1 << wide), 1 << wide))
        m.d.comb += [
            X.eq(origin.x + px.x - self.fb_origin.x),
            Y.eq(origin.y + px.y - self.fb_origin.y),
        ]
        # stage 1: the pixel's framebuffer position; stage 2: the bus request (and the
        # second word's part of a pixel that crosses a word, `s2_hi_*`)
        s1 = {n: Signal(w, name=f"s1_{n}") for n, w in (("x", FB_BITS), ("y", FB_BITS))}
        s1_value, s1_valid = Signal(len(px.value)), Signal()
        s1_inside, s1_last = Signal(), Signal()
        s2_valid, draining = Signal(), Signal()
        s2_hi_sel, s2_hi_dat = Signal(4), Signal(WORD_BITS)
        sel = Signal(4, init=1)  # a run of lanes from reset on (the formal proof's invariant)
        self.hi_sel = s2_hi_sel  # observed by the formal harness
        outstanding = Signal(range(MAX_OUTSTANDING + 1))
        self.outstanding = outstanding  # observed by the formal harness
        issued, joins = Signal(), Signal()  # joins: grey only (`_join_grey`)
        m.d.comb += [
            bus.sel.eq(sel),
            bus.cyc.eq(s2_valid | (outstanding != 0)),
            bus.stb.eq(s2_valid & ~joins & (outstanding != MAX_OUTSTANDING)),
            bus.we.eq(1),
            issued.eq(bus.stb & ~bus.stall),
        ]
        answered = bus.cyc & (bus.ack | bus.err)
        m.d.sync += outstanding.eq(outstanding + issued - answered)
        m.d.comb += self.bus_error.eq(bus.cyc & bus.err)
        byte, lanes, packed = self._pixel_bytes(m, s1["x"], s1["y"], s1_value)
        wide_sel, wide_dat = Signal(8), Signal(2 * WORD_BITS)
        with m.Switch(byte[:2]):  # the bytes moved to their lanes
            for k in range(4):
                with m.Case(k):
                    m.d.comb += wide_sel.eq(Cat(Const(0, k), lanes))
                    m.d.comb += wide_dat.eq(Cat(Const(0, 8 * k), packed))
        s2_free = ~s2_valid | (issued & (s2_hi_sel == 0))
        if self._pack:
            self._join_grey(m, s1, s1_valid & s1_inside, s2_valid, s2_free, packed, sel, joins)
        s1_move = s1_valid & (~s1_inside | s2_free | joins)
        with m.If(s1_move & s1_inside & ~joins):
            m.d.sync += [
                s2_valid.eq(1),
                bus.adr.eq(byte[2:]),
                sel.eq(wide_sel[:4]),
                bus.dat_w.eq(wide_dat[:WORD_BITS]),
                s2_hi_sel.eq(wide_sel[4:]),
                s2_hi_dat.eq(wide_dat[WORD_BITS:]),
            ]
        with m.Elif(issued & (s2_hi_sel != 0)):  # the pixel's bytes in the next word
            m.d.sync += [
                bus.adr.eq(bus.adr + 1),
                sel.eq(s2_hi_sel),
                bus.dat_w.eq(s2_hi_dat),
                s2_hi_sel.eq(0),
            ]
        with m.Elif(issued):
            m.d.sync += s2_valid.eq(0)
        take = Signal()
        blocked = draining | (s1_valid & s1_last)
        m.d.comb += [
            self.pixels.ready.eq(self.origins.valid & ~blocked & (~s1_valid | s1_move)),
            take.eq(self.pixels.valid & self.pixels.ready),
        ]
        inside = (X >= 0) & (self.fb_size.x > X) & (Y >= 0) & (self.fb_size.y > Y)
        with m.If(take):
            m.d.sync += [s1["x"].eq(X), s1["y"].eq(Y), s1_inside.eq(inside)]
            m.d.sync += [s1_value.eq(px.value), s1_last.eq(px.last), s1_valid.eq(1)]
        with m.Elif(s1_move):
            m.d.sync += s1_valid.eq(0)
        with m.If(s1_move & s1_last):
            m.d.sync += draining.eq(1)
        # Done once the tile's last write is answered: nothing in either stage or in flight.
        finished = draining & ~s2_valid & (outstanding == 0)
        m.d.comb += [self.done.eq(finished), self.origins.ready.eq(finished)]
        with m.If(finished):
            m.d.sync += draining.eq(0)
        return m

    def _join_grey(self, m, s1, inside, s2_valid, s2_free, packed, sel, joins):
        """A grey 8 pixel is one byte, so a row's pixels are neighbouring bytes: the pixel in
        stage 1 ``joins`` the write waiting in stage 2 (its byte in the lane above the
        write's last) when it is the next pixel of the same row and that lane is in the
        word (the last is not lane 3), and the write has not been offered under a stall (a
        stalled request is offered again unchanged): up to 4 pixels a write when they come
        back to back. The lane follows from the last, not from the address, so ``sel``
        stays a run of lanes whatever the ``fb_*`` registers do, and ``stb`` waits on no
        multiplier (only this compare)."""
        last_x, last_y, offered = Signal(FB_BITS), Signal(FB_BITS), Signal()
        bus = self.bus
        m.d.comb += joins.eq(
            inside & s2_valid & ~offered & ~sel[3] & (s1["y"] == last_y) & (s1["x"] == last_x + 1)
        )
        with m.If(inside & (joins | s2_free)):  # the pixel joins or loads
            m.d.sync += [last_x.eq(s1["x"]), last_y.eq(s1["y"])]
        with m.If(bus.stb & bus.stall):
            m.d.sync += offered.eq(1)
        with m.If(bus.stb & ~bus.stall):
            m.d.sync += offered.eq(0)
        above = (sel << 1)[:4] & ~sel  # the lane above the last (sel is a run of lanes)
        with m.If(joins):
            lanes = (Mux(above[k], packed[:8], bus.dat_w[8 * k : 8 * k + 8]) for k in range(4))
            m.d.sync += [sel.eq(sel | above), bus.dat_w.eq(Cat(*lanes))]

    def _pixel_bytes(self, m, x, y, value):
        """The pixel's byte address, its byte lanes from bit 0 and its bytes (format
        ``fb_format``, `edgeaa.model.framebuffer.framebuffer_bytes`)."""
        tile = self._tile
        bits = tile.config.intensity_bits
        channels = [value[k * bits : (k + 1) * bits] for k in range(tile.channels)]
        packed, lanes, step = Signal(WORD_BITS), Signal(4), Signal(FB_BITS + 2)
        byte = Signal(WORD_BITS)

        def byte8(c):
            return Cat(c, Const(0, FB_PIXEL_BITS - bits))

        def fields(fmt):
            if fmt.name == "grey8":
                return [byte8(channels[0])]
            if fmt.name == "rgb565":
                widths = zip(channels[:3], (5, 6, 5), strict=True)
                r5, g6, b5 = (_scaled(m, c, bits, n) for c, n in widths)
                return [Cat(b5, g6, r5)]
            alpha = channels[3] if tile.channels == 4 else Const((1 << bits) - 1, bits)
            return [byte8(c) for c in channels[:3]] + [byte8(alpha)] * (fmt.name == "rgba8888")

        default = default_format(tile.channels)
        others = [f for f in format_codes(tile.channels) if f != default]
        with m.Switch(self.fb_format):  # a code this pipeline does not write: its default
            for fmt in [*others, default]:
                with m.Case(fmt.code) if fmt != default else m.Default():
                    m.d.comb += [
                        packed.eq(Cat(*fields(fmt))),
                        lanes.eq((1 << fmt.bytes) - 1),
                        step.eq(x * fmt.bytes),
                    ]
        m.d.comb += byte.eq(self.fb_base + y * self.fb_stride + step)
        return byte, lanes, packed


def _scaled(m, c, bits: int, n: int):
    """`edgeaa.model.framebuffer.scale_channel` in hardware: without a divider when the
    field is no wider than the channel (`scale_steps`), else a table of its 2**bits values."""
    out = Signal(n)
    if n <= bits:
        m.d.comb += out.eq(scale_steps(c, bits, n))
        return out
    with m.Switch(c):
        for v in range(1 << bits):
            with m.Case(v):
                m.d.comb += out.eq(scale_channel(v, bits, n))
    return out


class DisplayListReader(wiring.Component):
    """A display list's commands from memory into ``commands``: on ``start`` (ignored while
    ``running``), ``length`` commands of `command_words` words each, read from word address
    ``base`` up through ``bus`` (a Wishbone B4 pipelined initiator that only reads); a
    command is pushed when its last word is in. One command's reads are in flight at a time
    (its words back to back), so the words in need no buffer beyond the command's. An
    ``err`` pulses ``bus_error`` and ends the list once that command's reads are answered
    (it and the rest are not pushed). ``running`` is high from the clock after ``start``
    until every command is pushed and ``idle`` (the datapath has taken them and written its
    tiles); ``done`` pulses in its last clock."""

    def __init__(self, tile: TileConfig):
        self._words = command_words(tile)
        super().__init__(
            {
                "start": In(1),
                "base": In(MASTER_ADDR_BITS),
                "length": In(DL_LENGTH_BITS),
                "idle": In(1),
                "commands": Out(stream.Signature(command_layout(tile).size)),
                "bus": Out(bus_signature(MASTER_ADDR_BITS)),
                "running": Out(1),
                "done": Out(1),
                "bus_error": Out(1),
            }
        )

    def elaborate(self, platform):
        m = Module()
        words, bus, out = self._words, self.bus, self.commands
        left = Signal(DL_LENGTH_BITS)  # commands not yet pushed, the one being read included
        issued, answered = Signal(range(words + 1)), Signal(range(words + 1))
        staged = Signal(words * WORD_BITS)  # word 0 ends lowest: each new word enters on top
        failed = Signal()
        self.issued, self.answered = issued, answered  # observed by the formal harness
        m.d.comb += [
            bus.stb.eq(self.running & (left != 0) & (issued != words)),
            bus.cyc.eq(bus.stb | (issued != answered)),
            bus.we.eq(0),
            bus.sel.eq(0xF),
            bus.dat_w.eq(0),
            self.bus_error.eq(bus.cyc & bus.err),
        ]
        with m.If(bus.stb & ~bus.stall):
            m.d.sync += [bus.adr.eq(bus.adr + 1), issued.eq(issued + 1)]
        with m.If(bus.cyc & (bus.ack | bus.err)):
            m.d.sync += answered.eq(answered + 1)
        with m.If(bus.cyc & bus.ack):
            m.d.sync += staged.eq(Cat(staged[WORD_BITS:], bus.dat_r))
        with m.If(bus.cyc & bus.err):
            m.d.sync += failed.eq(1)
        # All the command's reads answered (so nothing is in flight): push it, or end the list.
        complete = answered == words
        m.d.comb += [out.payload.eq(staged), out.valid.eq(complete & ~failed)]
        with m.If(complete & (failed | out.ready)):
            m.d.sync += [issued.eq(0), answered.eq(0), failed.eq(0)]
            m.d.sync += left.eq(Mux(failed, 0, left - 1))
        ending = self.running & (left == 0) & self.idle
        m.d.comb += self.done.eq(ending)
        with m.If(ending):
            m.d.sync += self.running.eq(0)
        with m.If(self.start & ~self.running):
            m.d.sync += [self.running.eq(1), bus.adr.eq(self.base), left.eq(self.length)]
        return m


class _Datapath(wiring.Component):
    """Command FIFO, pipeline, tile origins, framebuffer writer and display-list reader: what
    the control register's reset bit resets. The FIFO takes the window's commands (``push``)
    first and the reader's when the window pushes none (the window's stall rule stays "only
    on a full FIFO")."""

    def __init__(self, tile: TileConfig, fifo_depth: int, pack_grey: bool):
        self._tile = tile
        self.fifo = fifo.SyncFIFOBuffered(width=command_layout(tile).size, depth=fifo_depth)
        self.pipeline = EdgePipeline(tile)
        self.writer = FramebufferWriter(tile, pack_grey)
        self.reader = DisplayListReader(tile)
        stats = data.StructLayout({name: unsigned(32) for name in STATS})
        super().__init__(
            {
                "push": In(stream.Signature(command_layout(tile).size)),
                "level": Out(range(fifo_depth + 1)),
                "busy": Out(1),
                "tiles": Out(32),
                "errors": Out(ERRORS_BITS),
                "edge_errors": Out(ERRORS_BITS),
                "stats": Out(stats),
                "fb": Out(self.writer.signature.members["bus"].signature),
                "fb_regs": In(
                    wiring.Signature(
                        {n: Out(self.writer.signature.members[n].shape) for n in _FB_REGS}
                    )
                ),
                "done": Out(1),
                "bus_error": Out(1),
                "dl": Out(bus_signature(MASTER_ADDR_BITS)),
                "dl_start": In(1),
                "dl_base": In(MASTER_ADDR_BITS),
                "dl_length": In(DL_LENGTH_BITS),
                "dl_running": Out(1),
                "dl_done": Out(1),
            }
        )

    def elaborate(self, platform):
        m = Module()
        q, pipe, writer, reader = self.fifo, self.pipeline, self.writer, self.reader
        m.submodules.fifo, m.submodules.pipeline, m.submodules.writer = q, pipe, writer
        m.submodules.reader = reader
        tile = self._tile
        origins = fifo.SyncFIFO(width=2 * FB_BITS, depth=ORIGIN_DEPTH)
        m.submodules.origins = origins
        window, listed = self.push.valid, reader.commands
        m.d.comb += [
            q.w_data.eq(Mux(window, self.push.payload, listed.payload)),
            q.w_en.eq(window | listed.valid),
            self.push.ready.eq(q.w_rdy),
            listed.ready.eq(q.w_rdy & ~window),
            self.level.eq(q.level),
        ]
        wiring.connect(m, wiring.flipped(self.dl), reader.bus)
        m.d.comb += [
            reader.start.eq(self.dl_start),
            reader.base.eq(self.dl_base),
            reader.length.eq(self.dl_length),
            reader.idle.eq(~self.busy),
            self.dl_running.eq(reader.running),
            self.dl_done.eq(reader.done),
        ]
        cmd = pipe.commands.payload
        m.d.comb += cmd.eq(q.r_data)
        is_flush = cmd.op == CODE["flush"]
        # A flush waits for room for its tile's origin.
        m.d.comb += pipe.commands.valid.eq(q.r_rdy & (~is_flush | origins.w_rdy))
        taken = pipe.commands.valid & pipe.commands.ready
        m.d.comb += q.r_en.eq(taken)
        # The tile origin the pipeline keeps (its rule: an origin past 2**W is dropped).
        top = 1 << tile.config.coord_bits
        current = Signal(self.writer.origins.payload.shape())
        good_tile = (cmd.op == CODE["tile"]) & (cmd.x0 <= top) & (cmd.y0 <= top)
        with m.If(taken & good_tile):
            m.d.sync += [current.x.eq(cmd.x0), current.y.eq(cmd.y0)]
        m.d.comb += [origins.w_data.eq(current), origins.w_en.eq(taken & is_flush)]
        wiring.connect(m, pipe.pixels, writer.pixels)
        m.d.comb += [
            writer.origins.payload.eq(origins.r_data),
            writer.origins.valid.eq(origins.r_rdy),
            origins.r_en.eq(writer.origins.ready),
        ]
        for name in _FB_REGS:
            m.d.comb += getattr(writer, name).eq(getattr(self.fb_regs, name))
        wiring.connect(m, wiring.flipped(self.fb), writer.bus)
        pending = Signal(range(ORIGIN_DEPTH + 2))  # flushes taken, tiles not yet written
        m.d.sync += pending.eq(pending + (taken & is_flush) - writer.done)
        with m.If(writer.done):
            m.d.sync += self.tiles.eq(self.tiles + 1)
        m.d.comb += [
            self.busy.eq((q.level != 0) | (pending != 0)),  # level: from the push clock on
            self.errors.eq(pipe.errors),
            self.edge_errors.eq(pipe.edge_errors),
            self.stats.eq(pipe.stats),
            self.done.eq(writer.done),
            self.bus_error.eq(writer.bus_error | reader.bus_error),
        ]
        return m


# The framebuffer registers; all but fb_format take any value written (a format code this
# build does not write is ignored, and its read shows the codes it writes).
_FB_PLAIN = ("fb_base", "fb_stride", "fb_size", "fb_origin")
_FB_REGS = (*_FB_PLAIN, "fb_format")


class EdgePeripheral(wiring.Component):
    """The pipeline behind a register window (``bus``, a Wishbone B4 pipelined target,
    `REGISTERS`), writing its tiles into a framebuffer through ``fb`` (an initiator) and
    reading display lists through ``dl`` (another); ``irq`` is high while an enabled
    interrupt is pending. ``pack_grey``: `FramebufferWriter`'s."""

    top_kind = "peripheral"  # `edgeaa verilog`'s header (`edgeaa.hdl.integration`)

    def __init__(self, tile: TileConfig, fifo_depth: int = 16, pack_grey: bool = True):
        if not isinstance(tile, TileConfig):
            raise TypeError(f"tile must be a TileConfig, not {tile!r}")
        self._tile = tile
        self.datapath = _Datapath(tile, fifo_depth, pack_grey)
        super().__init__(
            {
                "bus": In(bus_signature(SLAVE_ADDR_BITS)),
                "fb": Out(bus_signature(MASTER_ADDR_BITS)),
                "dl": Out(bus_signature(MASTER_ADDR_BITS)),
                "irq": Out(1),
            }
        )

    @property
    def tile(self) -> TileConfig:
        return self._tile

    def elaborate(self, platform):
        m = Module()
        tile, bus = self._tile, self.bus
        soft_reset = Signal()
        dp = self.datapath
        m.submodules.datapath = ResetInserter(soft_reset)(dp)
        wiring.connect(m, wiring.flipped(self.fb), dp.fb)
        wiring.connect(m, wiring.flipped(self.dl), dp.dl)
        words = command_words(tile)
        staged = [Signal(WORD_BITS, name=f"cmd{k}") for k in range(words - 1)]
        fb = {
            name: Signal(dp.fb_regs.signature.members[name].shape, name=name) for name in _FB_REGS
        }
        formats = format_codes(tile.channels)
        fb["fb_format"] = Signal(
            FORMAT_BITS, name="fb_format", init=default_format(tile.channels).code
        )
        for name in _FB_REGS:
            m.d.comb += getattr(dp.fb_regs, name).eq(fb[name])
        dl_base, dl_length = Signal(MASTER_ADDR_BITS), Signal(DL_LENGTH_BITS)
        m.d.comb += [dp.dl_base.eq(dl_base), dp.dl_length.eq(dl_length)]
        irq_enable, irq_status, bus_error = Signal(3), Signal(3), Signal()
        request = bus.cyc & bus.stb
        writing = request & bus.we
        push = writing & (bus.adr == REGISTERS["cmd"] + words - 1)
        m.d.comb += [
            dp.push.payload.eq(Cat(*staged, bus.dat_w)),
            dp.push.valid.eq(push),
            bus.stall.eq(push & ~dp.push.ready),
            bus.err.eq(0),
        ]
        taken = request & ~bus.stall
        # One ack a clock after each taken request; reads answer from the clock they are taken.
        m.d.sync += bus.ack.eq(taken)
        reads = self._read_values(tile, dp, fb, irq_enable, irq_status, bus_error)
        reads[REGISTERS["dl_base"]] = Cat(Const(0, 2), dl_base)
        reads[REGISTERS["dl_length"]] = dl_length
        with m.If(taken & ~bus.we), m.Switch(bus.adr):
            for address, value in reads.items():
                with m.Case(address):
                    m.d.sync += bus.dat_r.eq(value)
            with m.Default():
                m.d.sync += bus.dat_r.eq(0)
        events = Cat(dp.done, dp.bus_error, dp.dl_done)
        cleared = Signal(3)
        with m.If(taken & bus.we), m.Switch(bus.adr):
            for k, stage in enumerate(staged):
                with m.Case(REGISTERS["cmd"] + k):
                    m.d.sync += stage.eq(bus.dat_w)
            for name in _FB_PLAIN:
                with m.Case(REGISTERS[name]):
                    m.d.sync += fb[name].eq(bus.dat_w)
            with m.Case(REGISTERS["fb_format"]):  # a format this build does not write: ignored
                code = bus.dat_w[:FORMAT_BITS]
                with m.If(Cat(code == f.code for f in formats).any()):
                    m.d.sync += fb["fb_format"].eq(code)
            with m.Case(REGISTERS["dl_base"]):
                m.d.sync += dl_base.eq(bus.dat_w[2:])
            with m.Case(REGISTERS["dl_length"]):
                m.d.sync += dl_length.eq(bus.dat_w)
            with m.Case(REGISTERS["irq_enable"]):
                m.d.sync += irq_enable.eq(bus.dat_w)
            with m.Case(REGISTERS["irq_status"]):
                m.d.comb += cleared.eq(bus.dat_w)
            with m.Case(REGISTERS["ctrl"]):
                m.d.comb += [soft_reset.eq(bus.dat_w[0]), dp.dl_start.eq(bus.dat_w[1])]
        m.d.sync += irq_status.eq((irq_status & ~cleared) | events)
        with m.If(soft_reset):
            m.d.sync += bus_error.eq(0)
        with m.Elif(dp.bus_error):
            m.d.sync += bus_error.eq(1)
        m.d.comb += self.irq.eq((irq_status & irq_enable) != 0)
        return m

    def _read_values(self, tile, dp, fb, irq_enable, irq_status, bus_error) -> dict:
        full = dp.level == dp.fifo.depth
        values = {
            REGISTERS["info"]: info_word(tile),
            REGISTERS["status"]: Cat(
                dp.busy | dp.dl_running, bus_error, full, dp.dl_running, Const(0, 12), dp.level
            ),
            REGISTERS["irq_enable"]: irq_enable,
            REGISTERS["irq_status"]: irq_status,
            REGISTERS["errors"]: Cat(dp.errors, dp.edge_errors),
            REGISTERS["tiles"]: dp.tiles,
        }
        values |= {REGISTERS[name]: fb[name] for name in _FB_PLAIN}
        mask = sum(1 << f.code for f in format_codes(tile.channels))
        values[REGISTERS["fb_format"]] = Cat(
            fb["fb_format"], Const(0, 4 - FORMAT_BITS), Const(mask, 4)
        )
        for i, name in enumerate(STATS):
            values[REGISTERS["stats"] + i] = dp.stats[name]
        return values


def peripheral_verilog(tile: TileConfig, *, name: str = "edgeaa_peripheral") -> str:
    """The peripheral as Verilog: ports clk, rst, ``bus__*`` (the register window, a
    Wishbone target), ``fb__*`` (the framebuffer initiator), ``dl__*`` (the display-list
    initiator) and ``irq``."""
    return flat_verilog(EdgePeripheral(tile), name)
