# amaranth: UnusedElaboratable=no
"""The tile's resolve (`TileResolve`): cell sums in, composited pixels into the tile's pixel
memory, the tile out on a flush. `edgeaa.model.tile` is the model and the cycle model.

One beat of cells per clock through a fixed pipeline, `resolve_latency` = I + 3 clocks (I + 4
in colour, one more with ``product_stages`` 2) from taking a beat to writing its pixels. A
beat is one cell, or with ``scan_lanes`` 2 (`PipelineConfig.scan_lanes`, the fast
pipeline's) two, the columns ``x`` and ``x + 1``:
every stage below is then a lane per cell (the registers of lane 1 named ``_l1``; one
prefix sum register, the second cell's sum the first's plus its own), and each lane reads
and writes its own pixel lane's memory (with more pixel lanes than scan lanes, of the group
of lanes the beat's column picks: the fast pipeline's four and two):

* take (clock r): the pixel's read is issued;
* s1: the row's prefix sum (restarting at the row's first cell, ``start``) and D =
  ``|I - I_out|``, formed as the cell is taken (the pixel's word carries its own written
  flag: a pixel not written since the tile started reads as the background);
* s2: the fill rule (`edgeaa.model.accumulate.fill`; even-odd by h + 1 compare-subtract
  steps, exact within the cells' range) and the pixel below;
* colour only, sa: the intensity offset q (a shift; 0 when I_in == I_out) times the paint's
  alpha over full scale, rounded half up (`_alpha`, `edgeaa.model.tile.alpha_steps`: one
  product and two additions, no divider), with the pixel below, the paint and D;
* s3: the intensity offset q (grey; colour: sa's q') and the unsigned numerator of
  `edgeaa.model.tile.composite_steps` (one I x I product per channel; the alpha channel's
  paint is full scale);
* with ``product_stages`` 2 (`PipelineConfig.product_stages`, the fast pipeline's), sp before
  s3: each product's shift-and-add rows of the low half of the difference's bits, q, the
  high half and the sign; s3 adds the high half's rows (a clock's chain of carry chains
  halved: the critical path of the one-clock form on the ECP5);
* the I stages after s3: one quotient bit each, restoring division by 2 D (one register:
  every cell in flight is one polygon's), the partial remainder shifted left with the
  dividend's next bit, the quotient's bits shifting into the dividend's low bits as they
  go; the last stage writes ``below +- quotient`` (or ``below`` when q = 0).

The values a cell only carries go through two delay lines, not registers: x and y from the
take to the last stage, the pixel below, q = 0 and the sign from s3 to it (the stages keep
``valid``, which has a reset, and the fields that change each stage). As the pipeline never
stalls (every stage loads every clock) a carried value is a fixed delay: each line is a
`Memory` (a block RAM on an FPGA) written every clock at a free-running address and read by
a synchronous read port at the address written that many clocks before, so the value is the
read port's data in the clock the last stage writes. Its depth is the power of two above the
longest delay (16 words at I = 8; the word read is never the one written). Why (a flip-flop
loaded from a register costs an iCE40 logic cell; block RAMs were free) and what it saved:
docs/hardware.md, "Polygon pipeline", Resolve.

The pipeline never stalls: nothing leaves it but the write. A polygon's first cell, a tile op
and a flush are taken only when no cell is in flight (the pixels they read must be written
first). Two pixel memories (ping-pong): the resolve reads and writes one (``bank``); a flush
hands it, with its background, to the flush side and the resolve goes on with the other,
the tile the background again (no pixel's flag set). The flush side reads its
memory row by row, ``lanes`` pixels a clock while the ``pixels`` stream advances (its read
ports' enable is the advance, so a stalled beat stays in the memories' output registers):
a beat of the stream is lane k the pixel at column ``x + k`` (`PipelineConfig.pixel_lanes`;
1 in the compact pipeline, 4 in the fast one). Each pixel memory is a memory per lane,
banked by column modulo the lanes (a pixel's word is its address without the low bits), so
a beat is one word of each lane's memory; the resolve reads and writes the memory of its
pixel's lane (its read data chosen by the lane read a clock before). The flush goes on
while the resolve takes the next tile's ops and cells; its first beat is offered two
clocks after the flush is taken, and the next flush waits until the last beat has gone
(its memory is then the resolve's again). A memory's ports are the resolve's or the
flush's as ``bank`` says; each memory is one block RAM port pair, so the second memory
costs the pixel memory's block RAMs again and a multiplexer per port. The flush side
clears each word's flag the clock after reading it, through the write port the resolve
is not using; so a flushed memory is clean with no pass of its own. A memory written since
its last flush (``dirty``, a bit each kept through reset) is swept, read and cleared with
nothing sent (``silent``), when a tile op finds the resolve's memory dirty (it flips the
bank as a flush does) and after a reset (`TileResolve._sweeps`).

Observation points for the formal harness (``observe``, a namespace set when the resolve is
elaborated; no logic of their own): ``memories`` the two pixel memories (each a list of a
`Memory` per lane), ``reads`` their read ports (likewise), ``bank`` the one the resolve
writes, ``dirty``, ``recover`` (a reset's sweeps due), ``clear`` (``addr``, ``en``: the
flush side's clear of the beat read a clock before), ``fbackground`` the flushed tile's
background, ``silent`` (the flush side sweeps),
``stages`` the pipeline's stages (s1 first; namespaces
of registers, each with ``valid``; the values a stage carries are in the delay lines,
``delays`` (their `Memory` by name, ``"xy"`` and ``"carry"``), at the address its
``delayed`` names per line (a value, no logic); the last stage's are its fields ``x``,
``y``, ``below``, ``zero`` and ``neg``, with two scan lanes lane 1's ``below_l1``,
``zero_l1`` and ``neg_l1`` too, the read ports' data), ``acc`` the row's prefix
sum, ``d2``, ``background``, ``p_valid`` and ``p`` the output register (``x``, ``y``,
``last``), ``fx`` and ``fy`` the flush position (the flush side reads
while ``flushing``).
"""

from __future__ import annotations

import itertools
import types

from amaranth.hdl import Array, Cat, Const, Module, Mux, Signal, Value, unsigned
from amaranth.lib import data, memory, stream, wiring
from amaranth.lib.wiring import In, Out

from ..model.pipeline import PIXEL_LANES, SCAN_LANES
from ..model.tile import PRODUCT_STAGES, RESOLVE_OPS, TileConfig, resolve_latency
from .layouts import cell_sum_fields, pixel_value_fields, tile_cell_layout, tile_pixel_layout

__all__ = ["TileResolve"]

OP = {name: code for code, name in enumerate(RESOLVE_OPS)}


class TileResolve(wiring.Component):
    """Resolve and pixel memory of a `TileConfig` tile. ``cells`` (in, `tile_cell_layout`),
    ``pixels`` (out, `tile_pixel_layout`); ``flushing`` is high while a tile goes out."""

    def __init__(
        self, tile: TileConfig, lanes: int = 1, scan_lanes: int = 1, product_stages: int = 1
    ):
        if not isinstance(tile, TileConfig):
            raise TypeError(f"tile must be a TileConfig, not {tile!r}")
        if lanes not in PIXEL_LANES:
            raise ValueError(f"lanes must be one of {PIXEL_LANES}, not {lanes!r}")
        if scan_lanes not in SCAN_LANES or scan_lanes > lanes:
            raise ValueError(
                f"scan_lanes must be one of {SCAN_LANES} and at most the lanes ({lanes}), "
                f"not {scan_lanes!r}"
            )
        if product_stages not in PRODUCT_STAGES:
            raise ValueError(
                f"product_stages must be one of {PRODUCT_STAGES}, not {product_stages!r}"
            )
        self._tile, self._lanes, self._scan_lanes = tile, lanes, scan_lanes
        self._product_stages = product_stages
        super().__init__(
            {
                "cells": In(stream.Signature(tile_cell_layout(tile, scan_lanes))),
                "pixels": Out(stream.Signature(tile_pixel_layout(tile, lanes))),
                "flushing": Out(1),
            }
        )

    @property
    def tile(self) -> TileConfig:
        return self._tile

    @property
    def lanes(self) -> int:
        """Pixels a flush sends a clock (`PipelineConfig.pixel_lanes`)."""
        return self._lanes

    @property
    def scan_lanes(self) -> int:
        """Cells it takes a clock (`PipelineConfig.scan_lanes`)."""
        return self._scan_lanes

    @property
    def product_stages(self) -> int:
        """Clocks the composite's I x I products take (`PipelineConfig.product_stages`)."""
        return self._product_stages

    @property
    def latency(self) -> int:
        """Clocks from taking a cell to writing its pixel (`resolve_latency`)."""
        return resolve_latency(self._tile, self._product_stages)

    def elaborate(self, platform):
        m = Module()
        tile, lanes = self._tile, self._lanes
        # two pixel memories: the resolve writes one (``bank``) while a flush reads the other;
        # each is a memory per lane, banked by column modulo the lanes (word: the pixel's
        # address without its low bits), so a flush reads a beat's pixels in one clock. A
        # word is the pixel and its flag, written since the tile started (its top bit): a
        # pixel not written reads as the background, and the flush clears the flags
        value = unsigned(tile.config.intensity_bits * tile.channels)  # a value per channel
        word = unsigned(value.width + 1)
        depth, lane_bits = tile.pixels // lanes, lanes.bit_length() - 1
        mems = [
            [memory.Memory(shape=word, depth=depth, init=[]) for _ in range(lanes)]
            for _ in range(2)
        ]
        for k, j in itertools.product(range(2), range(lanes)):
            m.submodules[f"pixels{k}" + (f"_lane{j}" if lanes > 1 else "")] = mems[k][j]
        reads = [[mem.read_port() for mem in bank_mems] for bank_mems in mems]
        writes = [[mem.write_port() for mem in bank_mems] for bank_mems in mems]
        bank = Signal()
        # each memory written since its last flush or sweep, through reset (a reset then
        # sweeps it: `_sweeps`)
        dirty = [Signal(name=f"dirty{k}", reset_less=True) for k in range(2)]
        self.observe = types.SimpleNamespace(memories=mems, reads=reads, bank=bank, dirty=dirty)
        # the flush side's clear: the words it read a clock before, written back with no flag
        clear = types.SimpleNamespace(addr=Signal(range(tile.pixels), name="clear_addr"))
        clear.en = Signal(name="clear_en")
        self.observe.clear = clear
        background = Signal(value)
        p_valid = Signal()
        advance = ~p_valid | self.pixels.ready
        # the resolve's side: the read port of ``bank``, always enabled (it never stalls),
        # and its write port; the flush's: the other read port, enabled as the pixels advance
        rd = types.SimpleNamespace(
            addr=Signal(range(tile.pixels)), data=Mux(bank, reads[1][0].data, reads[0][0].data)
        )
        frd = types.SimpleNamespace(
            addr=Signal(range(tile.pixels)), data=Mux(bank, reads[0][0].data, reads[1][0].data)
        )
        # the flush's read: a beat's pixels, a lane each
        pairs = list(zip(*reads, strict=True))  # (bank 0's, bank 1's) read port of each lane
        frd.lanes = [frd.data, *(Mux(bank, r0.data, r1.data) for r0, r1 in pairs[1:])]
        wr = types.SimpleNamespace(addr=Signal(range(tile.pixels)), data=Signal(value), en=Signal())
        # a beat of `scan` cells: a pixel of each of `scan` lanes' memories, the group of
        # lanes its column picks (all of them when the scan is as wide as the flush)
        scan = self._scan_lanes
        scan_bits = scan.bit_length() - 1
        wr.lanes = [wr.data, *(Signal(value, name=f"wr_data_l{j}") for j in range(1, scan))]
        resolve_reads = [Mux(bank, r1.data, r0.data) for r0, r1 in pairs]
        if scan == lanes:
            rd.lanes = resolve_reads
        else:  # the resolve's read: the group of the column it read a clock ago
            read_group = Signal(lane_bits - scan_bits, name="read_lane")
            m.d.sync += read_group.eq(rd.addr[scan_bits:lane_bits])
            groups = [resolve_reads[g : g + scan] for g in range(0, lanes, scan)]
            rd.lanes = [Array(group[k] for group in groups)[read_group] for k in range(scan)]
        rd.data = rd.lanes[0]
        for k, j in itertools.product(range(2), range(lanes)):
            mine = bank == k
            write = wr.en & mine
            if scan < lanes:
                write = write & (wr.addr[scan_bits:lane_bits] == j >> scan_bits)
            m.d.comb += [
                reads[k][j].addr.eq(Mux(mine, rd.addr, frd.addr)[lane_bits:]),
                reads[k][j].en.eq(mine | advance),
                writes[k][j].addr.eq(Mux(mine, wr.addr, clear.addr)[lane_bits:]),
                writes[k][j].data.eq(Mux(mine, Cat(wr.lanes[j % scan], 1), 0)),
                writes[k][j].en.eq(Mux(mine, write, clear.en)),
            ]
            with m.If(write):
                m.d.sync += dirty[k].eq(1)
        stages = self._pipeline(m, rd, wr, background)
        busy = Cat(*(s.valid for s in stages)).any()  # an OR, not a sum's carry chain (Fmax)
        self.observe.__dict__.update(stages=stages, background=background, p_valid=p_valid)
        self._control(m, rd, frd, bank, dirty, clear, background, p_valid, advance, busy)
        return m

    def _pipeline(self, m, rd, wr, background) -> list:
        """s1 .. s(I + 3) (module docstring); returns the stages (each with ``valid``)."""
        tile, c = self._tile, self.cells.payload
        F, bits = tile.config.F, tile.config.intensity_bits
        take = self.cells.valid & self.cells.ready & (c.op == OP["cell"])
        self._take_cell = take
        # the delay lines' free-running address (its value never matters: only differences)
        ptr = Signal((self.latency - 1).bit_length(), name="delay_ptr", reset_less=True)
        m.d.sync += ptr.eq(ptr + 1)
        self.observe.delays = {}
        # x and y from the take to the last stage
        xy = _delay_line(m, self.observe, "xy", ptr, self.latency - 1, x=c.x, y=c.y)
        acc = Signal.like(c.sum)  # the row's prefix sum, wrapping like the cells
        # a beat's cells, lane k the column x + k: lane n's names end in n ("" for lane 0)
        lanes = [""] + [f"_l{k}" for k in range(1, self._scan_lanes)]
        totals, total = [], Mux(c.start, 0, acc)
        for name in cell_sum_fields(len(lanes)):  # each lane's prefix sum, one adder each
            total = (total + c[name])[: tile.cell_bits].as_signed()
            totals.append(total)
        # D = |I - I_out|, the polygon's: formed from the cell as it is taken, so that s1's
        # register cuts its carry chain from the fill rule's (an Fmax path in s2)
        scale = c.intensity if tile.channels == 1 else c.intensity[:bits]
        s1 = _stage(
            m,
            "s1",
            valid=take,
            **{f"sum{n}": t for n, t in zip(lanes, totals, strict=True)},
            intensity=c.intensity,
            d=Mux(scale >= c.i_out, scale - c.i_out, c.i_out - scale)[:bits],
            evenodd=c.evenodd,
        )
        with m.If(take):
            m.d.sync += acc.eq(total)
        self.observe.acc = acc
        d = s1.d
        ifix = d << F
        s2 = _stage(
            m,
            "s2",
            valid=s1.valid,
            **{f"cov{n}": self._fill(getattr(s1, f"sum{n}"), ifix, s1.evenodd) for n in lanes},
            **{  # the word's flag: written since the tile started
                f"below{n}": Mux(data[-1], data[:-1], background)
                for n, data in zip(lanes, rd.lanes, strict=True)
            },
            intensity=s1.intensity,
            d=d,
        )
        qs = [Mux(s2.d == 0, 0, (getattr(s2, f"cov{n}") + (1 << (F - 1))) >> F) for n in lanes]
        qs = [q[: bits + 1] for q in qs]
        # each channel: its paint (the intensity, grey) against the pixel below, one numerator
        pre, stages = s2, [s1, s2]  # the stage before s3
        if tile.channels == 1:
            paints, belows = [s2.intensity], [[getattr(s2, f"below{n}")] for n in lanes]
        else:  # colour: the alpha stage
            pre, paints, belows = self._alpha_stage(m, s2, qs, lanes)
            qs, stages = [getattr(pre, f"q{n}") for n in lanes], [s1, s2, pre]
        negs, factors, names = [[] for _ in lanes], [], []  # names: each lane's channels
        for j, (lane, q) in enumerate(zip(lanes, qs, strict=True)):
            for k, (paint, below) in enumerate(zip(paints, belows[j], strict=True)):
                if paint is None:  # towards full scale: never below, and full - below is ~below
                    neg, diff = Const(0, 1), ~below
                else:
                    neg = paint < below
                    diff = Mux(neg, below - paint, paint - below)[:bits]
                names.append(lane + ("" if k == 0 else f"_c{k}"))
                negs[j].append(neg)
                factors.append((q, diff, neg))
        carried = len(stages)  # the stages up to `pre` (the carry line starts there)
        nums = [  # >= 0 unless q = 0
            ((product << 1) + d - neg)[: 2 * bits + 2]
            for product, d, neg in self._products(m, pre, factors, names, stages)
        ]
        # 2 D: one register, as every cell in flight is one polygon's (its first cell waits
        # for the pipeline to empty)
        d2 = Signal(bits + 1, name="d2")
        with m.If(s2.valid):
            m.d.sync += d2.eq(s2.d << 1)
        self.observe.d2 = d2
        # each lane's pixel below, q = 0 and signs from s3 to the last stage
        carried_values = {}
        for lane, q, lane_negs in zip(lanes, qs, negs, strict=True):
            carried_values[f"below{lane}"] = getattr(pre, f"below{lane}")
            carried_values[f"zero{lane}"] = q == 0
            carried_values[f"neg{lane}"] = Cat(*lane_negs)
        delay = bits + self._product_stages - 1
        carry = _delay_line(m, self.observe, "carry", ptr, delay, **carried_values)
        stages += _divide(m, dict(zip(names, nums, strict=True)), stages[-1].valid, d2, bits)
        for k, st in enumerate(stages[:-1], start=1):  # where stage k's values are now
            st.delayed = {"xy": ptr - k} | ({"carry": ptr - (k - carried)} if k > carried else {})
        last = stages[-1]
        last.__dict__.update(x=xy.x, y=xy.y, **{name: carry[name] for name in carried_values})
        writes, colour = [], tile.channels > 1
        for lane in lanes:
            news = []
            for k in range(tile.channels):
                n = lane + ("" if k == 0 else f"_c{k}")
                lane_neg = getattr(last, f"neg{lane}")
                quot, neg = getattr(last, f"low{n}"), lane_neg[k] if colour else lane_neg
                below = getattr(last, f"below{lane}")
                below = below[bits * k :][:bits] if colour else below
                # below - quot as below + ~quot + 1: one adder
                signed_quot = quot ^ neg.replicate(bits)
                news.append(
                    Mux(getattr(last, f"zero{lane}"), below, below + signed_quot + neg)[:bits]
                )
            writes.append(news[0] if len(news) == 1 else Cat(*news))
        m.d.comb += [
            wr.addr.eq(Cat(last.x, last.y)),
            wr.data.eq(writes[0]),
            wr.en.eq(last.valid),
            *(port.eq(data) for port, data in zip(wr.lanes[1:], writes[1:], strict=True)),
        ]
        assert len(stages) == self.latency, (len(stages), self.latency)
        return stages

    def _products(self, m, pre, factors, names, stages):
        """Each channel's ``q * diff``, with the D and sign it is read with (`factors`: q, diff
        and the sign per channel of each lane, from stage `pre`; `names` their suffixes). With
        two product stages, stage sp registers each product's rows of diff's low half (and
        what the rest needs; appended to `stages`), and the high half's rows add to it after:
        each clock's carry chains half as many (docs/hardware.md, "The resolve's product in
        two clocks")."""
        pairs = list(zip(factors, names, strict=True))
        if self._product_stages == 1:
            return [(_product(m, q, diff, n), pre.d, neg) for (q, diff, neg), n in pairs]
        half = self._tile.config.intensity_bits // 2
        fields = {}
        for (q, diff, neg), n in pairs:
            fields |= {f"part{n}": _product(m, q, diff[:half], n), f"q{n}": q}
            fields |= {f"high{n}": diff[half:], f"neg{n}": neg}
        sp = _stage(m, "sp", valid=pre.valid, d=pre.d, **fields)
        stages.append(sp)
        return [
            (
                _product(m, getattr(sp, f"q{n}"), getattr(sp, f"high{n}"), n,
                         total=getattr(sp, f"part{n}"), shift=half),
                sp.d,
                getattr(sp, f"neg{n}"),
            )
            for n in names
        ]  # fmt: skip

    def _alpha_stage(self, m, s2, qs, lanes):
        """Colour's stage sa: each lane's q' = round(q A / full) (`_alpha`; `qs` a q per
        lane, `lanes` their names' suffixes), and its pixel below, the paint's three colours
        and D carried to s3; returns it, each channel's paint (None: the alpha channel's,
        full scale) and each lane's pixel below per channel."""
        bits, channels = self._tile.config.intensity_bits, self._tile.channels
        colour = s2.intensity[bits:]  # red, green, blue, alpha (`PAINT`)
        alpha = colour[bits * 3 :][:bits]
        sa = _stage(
            m,
            "sa",
            valid=s2.valid,
            **{f"q{n}": _alpha(m, q, alpha, bits, n) for n, q in zip(lanes, qs, strict=True)},
            **{f"below{n}": getattr(s2, f"below{n}") for n in lanes},
            paint=colour[: bits * 3],
            d=s2.d,
        )
        paints = [sa.paint[bits * k :][:bits] for k in range(3)] + [None]
        belows = [
            [getattr(sa, f"below{n}")[bits * k :][:bits] for k in range(channels)] for n in lanes
        ]
        return sa, paints[:channels], belows

    def _fill(self, s, ifix, evenodd):
        """`fill` on a prefix sum within the cells' range: non-zero min(|s|, ifix); even-odd
        s folded with period 2 ifix (a multiple of it added when negative, then h
        compare-subtract steps, then 2 ifix - r above ifix). The two rules share the last
        compare with ifix."""
        h = self._tile.headroom_bits
        width = self._tile.cell_bits + 1
        mag = Mux(s < 0, -s, s)
        r = Mux(s < 0, s + ((ifix << 1) << h), s)[:width]
        for j in reversed(range(h)):
            step = (ifix << 1) << j
            r = Mux(r >= step, r - step, r)[:width]
        x = Mux(evenodd, r, mag)
        return Mux(x > ifix, Mux(evenodd, (ifix << 1) - r, ifix), x)[:width]

    def _control(self, m, rd, frd, bank, dirty, clear, background, p_valid, advance, busy):
        """Taking cells and ops, and the flush (of the other memory: the bank flips as a
        flush is taken, which waits until the last flush's last pixel goes). A sweep is a
        flush that sends nothing (``silent``): it clears the flags of a memory written since
        its last flush, handed over by a tile op (`_sweeps`)."""
        tile, c = self._tile, self.cells.payload
        out = self.pixels.payload
        fx, fy = Signal(tile.x_bits), Signal(tile.y_bits)
        px, py, plast = Signal.like(out.x), Signal.like(out.y), Signal()
        fbackground = Signal.like(background)  # the flushed tile's
        silent = Signal()
        gate = (c.op != OP["cell"]) | c.first  # waits for no cell in flight
        is_flush = c.op == OP["flush"]
        mine_dirty, other_dirty = Mux(bank, dirty[1], dirty[0]), Mux(bank, dirty[0], dirty[1])
        # the ops that hand the resolve's memory to the flush side: a flush, and a tile op
        # on written pixels (a sweep: `edgeaa.model.tile.TileClock.take`)
        flips = is_flush | ((c.op == OP["tile"]) & mine_dirty)
        sweep_starts = Signal()  # a sweep after a reset starts this clock (`_sweeps`)
        self.observe.p = types.SimpleNamespace(x=px, y=py, last=plast)
        self.observe.__dict__.update(fx=fx, fy=fy, fbackground=fbackground, silent=silent)
        take = self.cells.valid & self.cells.ready
        dirties = (dirty, mine_dirty, other_dirty)
        stuck = self._sweeps(m, bank, dirties, fx, fy, silent, advance, sweep_starts)
        m.d.comb += [
            self.cells.ready.eq(
                ~stuck & ~(gate & busy) & ~(flips & (self.flushing | sweep_starts | ~advance))
            ),
            rd.addr.eq(Cat(c.x, c.y)),
            frd.addr.eq(Cat(fx, fy)),
        ]
        with m.If(take & (c.op == OP["tile"])):
            m.d.sync += background.eq(c.background)
        with m.If(take & flips):
            m.d.sync += [
                fx.eq(0),
                fy.eq(0),
                fbackground.eq(background),
                bank.eq(~bank),
                self.flushing.eq(1),
                silent.eq(~is_flush),
            ]
        with m.If(advance):
            m.d.sync += p_valid.eq(0)
        m.d.sync += [clear.en.eq(self.flushing & advance), clear.addr.eq(Cat(fx, fy))]
        with m.If(self.flushing & advance):
            end = (fx == tile.width - self._lanes) & (fy == tile.height - 1)
            m.d.sync += [
                p_valid.eq(~silent),
                px.eq(fx),
                py.eq(fy),
                plast.eq(end),
                Cat(fx, fy).eq(Cat(fx, fy) + self._lanes),
            ]
            with m.If(end):  # the flushed memory is clean (its last clear the next clock)
                m.d.sync += self.flushing.eq(0)
                for k in range(2):
                    with m.If(bank != k):
                        m.d.sync += dirty[k].eq(0)
        m.d.comb += [
            self.pixels.valid.eq(p_valid),
            out.x.eq(px),
            out.y.eq(py),
            out.last.eq(plast),
            *(
                out[name].eq(Mux(data[-1], data[:-1], fbackground))
                for name, data in zip(pixel_value_fields(self._lanes), frd.lanes, strict=True)
            ),
        ]

    def _sweeps(self, m, bank, dirties, fx, fy, silent, advance, starts) -> Value:
        """After a reset the registers no longer know what the memories hold: each memory
        written since its last flush (``dirty``, kept through reset) is swept before the
        resolve takes anything (returns that wait), the flush side's first, then the
        resolve's, handed over. At power-on neither is dirty: no clock is lost. `starts` is
        high in the clock a sweep starts; `dirties` the two memories' ``dirty``, then the
        resolve's and the flush side's (as ``bank`` picks them)."""
        dirty, mine_dirty, other_dirty = dirties
        recover = Signal(init=1)  # since the last reset, until both memories are clean
        self.observe.recover = recover
        stuck = recover & (dirty[0] | dirty[1])
        m.d.sync += recover.eq(stuck)
        # (with the output free, as a flush: the bank picks the waiting beat's memory)
        m.d.comb += starts.eq(~self.flushing & advance & (other_dirty | (stuck & mine_dirty)))
        with m.If(starts):
            m.d.sync += [fx.eq(0), fy.eq(0), self.flushing.eq(1), silent.eq(1)]
            with m.If(~other_dirty):  # the resolve's memory: handed to the flush side
                m.d.sync += bank.eq(~bank)
        return stuck


def _divide(m, nums: dict, valid, d2, bits: int) -> list:
    """s3 and the quotient's stages q(I - 1) .. q0: each numerator of `nums` (by its lane's and
    channel's name) over the divisor `d2` = 2 D, a restoring step a stage. s3 holds the
    partial remainder (num's top bits: below 2 D, as the quotient has I bits) and the
    dividend's low bits, which the quotient's bits replace one a stage (lane 0's channel 0
    named rem and low)."""
    stages = [
        _stage(
            m,
            "s3",
            valid=valid,
            **{f"rem{n}": num[bits:][: bits + 1] for n, num in nums.items()},
            **{f"low{n}": num[:bits] for n, num in nums.items()},
        )
    ]
    for j in reversed(range(bits)):  # quotient bit j
        prev, fields = stages[-1], {}
        for n in nums:
            rem, low = getattr(prev, f"rem{n}"), getattr(prev, f"low{n}")
            trial = Cat(low[-1], rem)  # rem << 1 | the dividend's next bit
            fits = trial >= d2
            fields[f"rem{n}"] = Mux(fits, trial - d2, trial)[: bits + 1]
            fields[f"low{n}"] = Cat(fits, low[:-1])
        stages.append(_stage(m, f"q{j}", valid=prev.valid, **fields))
    return stages


def _alpha(m, q, alpha, bits: int, suffix: str = ""):
    """``round(q * alpha / full)`` half up, full = 2**bits - 1, with no divider
    (`edgeaa.model.tile.alpha_steps`): y = q alpha + 2**(bits - 1) - 1, then
    (y + (y >> bits) + 1) >> bits; q and alpha at most full (`suffix`: the lane's)."""
    y = _product(m, q, alpha, "_alpha" + suffix) + ((1 << (bits - 1)) - 1)
    return ((y + (y >> bits) + 1) >> bits)[: bits + 1]


def _product(m, a, b, suffix: str = "", total=None, shift: int = 0):
    """``total + a * (b << shift)`` (unsigned; no `total`: ``a * b << shift``) as shift-and-add
    rows, each row's sum a kept signal: so Yosys maps each row to a carry chain rather than
    the whole product to a full-adder tree in LUT4s (for the resolve's I x I product: 41 LUT4
    fewer, 51 carries more)."""
    for j in range(len(b)):
        term = Mux(b[j], a, 0)
        term = term << (j + shift) if j + shift else term
        if total is None:
            total = term
            continue
        width = len(a) + j + shift + 1
        row = Signal(width, name=f"product_row{j + shift}{suffix}", attrs={"keep": 1})
        m.d.comb += row.eq(total + term)
        total = row
    return total


def _stage(m, prefix: str, **values) -> types.SimpleNamespace:
    """One pipeline stage's registers, each shaped like its value, loaded every clock."""
    regs = {}
    for name, value in values.items():
        value = Value.cast(value)
        regs[name] = Signal(value.shape(), name=f"{prefix}_{name}")
        m.d.sync += regs[name].eq(value)
    return types.SimpleNamespace(**regs)


def _delay_line(m, observe, name: str, ptr, delay: int, **values) -> data.View:
    """`values` `delay` clocks later, through a `Memory` (block RAM on an FPGA) written every
    clock at ``ptr`` and read (synchronous read port) at ``ptr - delay``; returns the read
    data (a view with a field per value). Its depth, ``2**len(ptr)``, is above `delay`: the
    word read is never the one being written. In ``observe.delays[name]``."""
    shapes = {k: Value.cast(v).shape() for k, v in values.items()}
    assert delay < 1 << len(ptr), (delay, len(ptr))
    mem = memory.Memory(shape=data.StructLayout(shapes), depth=1 << len(ptr), init=[])
    m.submodules[f"delay_{name}"] = mem
    wr, rd = mem.write_port(), mem.read_port()
    m.d.comb += [
        wr.addr.eq(ptr),
        wr.data.eq(Cat(*(values[k] for k in shapes))),
        wr.en.eq(1),
        rd.addr.eq(ptr - delay),
    ]
    observe.delays[name] = mem
    return rd.data
