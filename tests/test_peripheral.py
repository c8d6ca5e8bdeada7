# amaranth: UnusedElaboratable=no
"""The bus peripheral (`EdgePeripheral`) in Amaranth's simulator: a scene's commands written
into its register window by a CPU model, the tiles written by its framebuffer master into a
memory model, both buses with random idle clocks, stalls and ack latencies; the framebuffer
equals the renderer's image bit for bit, every pixel written exactly once; the counters,
errors and interrupt as the model says; the Verilog lint-clean."""

from __future__ import annotations

import random
import re

import numpy as np
import pytest
from fixtures import TINY_SCENE

from edgeaa.hdl.peripheral import (
    REGISTERS,
    EdgePeripheral,
    command_words,
    pack_command,
    peripheral_verilog,
    register_map,
)
from edgeaa.hdl.pipeline import command_layout
from edgeaa.model import EdgeConfig
from edgeaa.model.framebuffer import (
    FORMATS,
    default_format,
    format_codes,
    framebuffer_bytes,
    scale_channel,
    scale_steps,
)
from edgeaa.model.pipeline import Command, command_ops
from edgeaa.model.tile import TileConfig
from edgeaa.render import parse_scene, plan_scene, render_scene
from edgeaa.render.paint import Canvas, coverage_scene
from edgeaa.render.pipeline import scene_commands
from edgeaa.sim.simulators.wishbone import Framebuffer, run_peripheral

DEFAULT = EdgeConfig()
TILE = TileConfig(DEFAULT, 16, 8)


def test_a_command_is_its_layouts_bits_in_32_bit_words():
    layout = command_layout(TILE)
    assert command_words(TILE) == -(-layout.size // 32) == 3
    command = Command.edge(5, 1 << 14, (1 << 15) - 1, 3, "right")
    words = pack_command(TILE, command)
    value = sum(word << 32 * k for k, word in enumerate(words))
    for name, field in layout:
        assert (value >> field.offset) & ((1 << field.width) - 1) == getattr(command, name)
    assert value >> layout.size == 0
    with pytest.raises(ValueError, match="x0"):
        pack_command(TILE, Command.edge(1 << 15, 0, 0, 0))


def test_the_register_map_has_no_overlap():
    regs = register_map(TILE)
    assert len(set(regs.values())) == len(regs)
    assert max(regs.values()) < 1 << len(EdgePeripheral(TILE).bus.adr)


def test_the_docs_register_map_is_registers():
    """docs/hardware.md's register map table names every register of `REGISTERS` at its
    offset, and no other (``stats.*`` and ``cmd0`` .. stand for the first of their range)."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "hardware.md").read_text()
    table = text.split("**Register map**", 1)[1].split("\n\n", 2)[1]
    rows = re.findall(r"^\| (\d+)(?: to [^|]*)? \| `([a-z_]+)", table, re.M)
    documented = {name: int(word) for word, name in rows}
    assert documented == REGISTERS


@pytest.mark.parametrize(
    "seed, idle, stall, latency", [(0, 0.0, 0.0, 0), (11, 0.3, 0.5, 3), (23, 0.1, 0.8, 6)]
)
def test_a_scene_written_as_a_cpu_would_lands_in_the_framebuffer_bit_for_bit(
    seed, idle, stall, latency
):
    plan = plan_scene(parse_scene(TINY_SCENE), DEFAULT)
    commands = scene_commands(plan, TILE)
    ox, oy = plan.offset
    width, height = plan.scene.width, plan.scene.height
    fb = Framebuffer(base=0x1000 + 3, stride=width + 5, width=width, height=height, x0=ox, y0=oy)
    run = run_peripheral(TILE, commands, fb, seed=seed, idle=idle, stall=stall, latency=latency)
    tag = f"seed {seed}"
    image = np.array(fb.image(run.memory))
    want = render_scene(plan, engine="model").image
    assert np.array_equal(image, want), f"{tag}\n{image}\nmodel:\n{want}"
    inside = {fb.base + y * fb.stride + x for y in range(height) for x in range(width)}
    assert set(run.writes) == inside, f"{tag}: a write outside the framebuffer"
    assert set(run.writes.values()) == {1}, f"{tag}: a pixel written twice"
    regs = run.registers
    tiles = sum(c.op == Command.flush().op for c in commands)
    assert regs["tiles"] == tiles and regs["errors"] == 0 and regs["status"] & 0b11 == 0
    assert regs["irq_status"] == 1 and regs["irq"] == 1 and regs["irq_after_clear"] == 0
    assert regs["stats.core_busy"] > 0 and regs["stats.resolve_busy"] >= tiles * TILE.pixels
    if stall:
        assert regs["stats.resolve_stall"] > 0, f"{tag}: the memory never held the pipeline"
    assert run.cpu_stalls > 0, f"{tag}: the command FIFO was never full"
    assert run.aborted == 0, f"{tag}: cyc dropped with writes unanswered"


def test_the_reset_bit_drops_what_was_running_and_the_next_scene_is_whole():
    plan = plan_scene(parse_scene(TINY_SCENE), DEFAULT)
    commands = scene_commands(plan, TILE)
    fb = Framebuffer(base=64, stride=20, width=20, height=14)
    first = commands[: len(commands) // 2]  # a tile's flush: the reset comes during its writes
    run = run_peripheral(TILE, commands, fb, seed=3, stall=0.7, latency=6, before_reset=first)
    assert run.aborted > 0, "no framebuffer write was in flight at the reset"
    image = np.array(fb.image(run.memory))
    assert np.array_equal(image, render_scene(plan, engine="model").image), "seed 3"
    clean = run_peripheral(TILE, commands, fb, seed=3, stall=0.7, latency=6)
    for name in ("tiles", "errors", "stats.core_busy", "stats.acc_busy"):
        assert run.registers[name] == clean.registers[name], f"the reset left {name}"


def test_bad_commands_are_counted_in_the_errors_register():
    tile = TileConfig(EdgeConfig(coord_bits=7, subpixel_bits=2, intensity_bits=4), 8, 4)
    commands = [Command.end(), Command(6), Command.begin(9, 3), Command.edge(4, 4, 4, 4)]
    commands += [Command.end(), Command.flush()]
    result = command_ops(tile, commands)
    fb = Framebuffer(base=0, stride=8, width=8, height=4)
    run = run_peripheral(tile, commands, fb, seed=5, idle=0.2, stall=0.3, latency=2)
    assert run.registers["errors"] == result.errors | result.edge_errors << 16
    assert (result.errors, result.edge_errors) == (2, 1)
    assert np.array_equal(np.array(fb.image(run.memory)), np.zeros((4, 8)))


@pytest.mark.parametrize("channels", [1, 3])
def test_the_peripheral_verilog_is_lint_clean(channels):
    from edgeaa.sim.simulators.verilator import lint

    source = peripheral_verilog(TileConfig(EdgeConfig(7, 2, 4), 8, 4, channels=channels))
    header = re.search(r"module edgeaa_peripheral\((.*?)\);", source, re.S).group(1)
    names = ("cyc", "stb", "we", "adr", "dat_w", "sel", "dat_r", "ack", "stall", "err")
    want = {"clk", "rst", "irq"} | {f"{bus}__{n}" for bus in ("bus", "fb", "dl") for n in names}
    assert {port.strip() for port in header.split(",")} == want
    proc = lint(source)
    assert proc.returncode == 0, proc.stdout + proc.stderr


SMALL = EdgeConfig(coord_bits=7, subpixel_bits=2, intensity_bits=4)


def _empty_tiles(tile: TileConfig, across: int, down: int) -> tuple[list[Command], np.ndarray]:
    """A tile start and a flush per tile (its background its number), and the image."""
    commands, image = [], np.zeros((down * tile.height, across * tile.width), np.int64)
    for k in range(across * down):
        x, y = k % across * tile.width, k // across * tile.height
        commands += [Command.tile(x, y, k % 15 + 1), Command.flush()]
        image[y : y + tile.height, x : x + tile.width] = k % 15 + 1
    return commands, image


def test_flushes_back_to_back_against_a_slow_memory_keep_their_origins():
    tile = TileConfig(SMALL, 8, 4)
    commands, want = _empty_tiles(tile, 4, 4)
    fb = Framebuffer(base=0, stride=32, width=32, height=16)
    run = run_peripheral(tile, commands, fb, seed=9, stall=0.9, latency=8, fifo_depth=16)
    assert np.array_equal(np.array(fb.image(run.memory)), want), "seed 9"
    assert set(run.writes.values()) == {1} and run.registers["tiles"] == 16


def test_a_bus_error_is_reported_in_status_and_interrupt():
    tile = TileConfig(SMALL, 8, 4)
    commands, want = _empty_tiles(tile, 2, 1)
    fb = Framebuffer(base=0, stride=16, width=16, height=4)
    run = run_peripheral(tile, commands, fb, seed=4, stall=0.3, latency=2, errors={5})
    regs = run.registers
    assert regs["status"] & 0b10 and regs["irq_status"] == 0b11 and regs["tiles"] == 2
    # The err answers the write of byte 5 and of the grey pixels joined to it (its word).
    lost = {y * 16 + x for y in range(4) for x in range(16)} - set(run.writes)
    assert 5 in lost and lost <= {4, 5, 6, 7} and set(run.writes.values()) == {1}
    assert not lost & set(run.memory)


@pytest.mark.parametrize("seed, stall, latency", [(0, 0.0, 0), (6, 0.5, 3)])
def test_grey_pixels_of_one_word_go_in_one_write(seed, stall, latency):
    """Back-to-back grey 8 pixels of one word are one write with their byte lanes: a whole
    tile at an aligned base and stride is a write a word when the memory never stalls (4
    pixels a write), fewer than a write a pixel under stalls (a write offered under a
    stall takes no more pixels), and bit for bit either way."""
    tile = TileConfig(SMALL, 8, 4)
    commands, want = _empty_tiles(tile, 2, 2)
    fb = Framebuffer(base=0x100, stride=16, width=16, height=8)
    run = run_peripheral(tile, commands, fb, seed=seed, stall=stall, latency=latency)
    assert np.array_equal(np.array(fb.image(run.memory)), want), f"seed {seed}"
    assert set(run.writes.values()) == {1}, f"seed {seed}: a pixel written twice"
    pixels = 16 * 8
    if stall:
        assert run.requests < pixels, f"seed {seed}: {run.requests} writes"
    else:
        assert run.requests == pixels // 4, f"seed {seed}: {run.requests} writes"


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_writer_joins_grey_pixels_that_come_with_gaps_and_stalls(seed):
    """The writer alone, its pixels with random gaps (a pixel may arrive while a write waits
    under a stall: it must not join it, the memory model checks that a stalled request is
    offered again unchanged), the memory stalling and waiting at random: every byte once,
    the tile's values, fewer writes than pixels."""
    from types import SimpleNamespace

    from amaranth.sim import Simulator

    from edgeaa.hdl.peripheral import FramebufferWriter
    from edgeaa.sim.simulators.wishbone import _Memory

    tile = TileConfig(SMALL, 8, 4)
    dut = FramebufferWriter(tile)
    rng = random.Random(seed)
    values = [rng.randrange(16) for _ in range(tile.pixels)]
    shim = SimpleNamespace(fb=dut.bus, irq=dut.done, datapath=SimpleNamespace(writer=dut))
    memory = _Memory(shim, random.Random(seed + 100), 0.5, 3, f"seed {seed}")
    finished = []

    async def feed(ctx):
        ctx.set(dut.fb_base, 0x203)
        ctx.set(dut.fb_stride, 11)
        ctx.set(dut.fb_size, {"x": 8, "y": 4})
        ctx.set(dut.origins.valid, 1)
        for k, value in enumerate(values):
            while rng.random() < 0.4:  # a gap
                ctx.set(dut.pixels.valid, 0)
                await ctx.tick()
            pixel = {"x": k % 8, "y": k // 8, "value": value, "last": k == len(values) - 1}
            ctx.set(dut.pixels.payload, pixel)
            ctx.set(dut.pixels.valid, 1)
            await ctx.tick().until(dut.pixels.ready)
        ctx.set(dut.pixels.valid, 0)
        for _ in range(500):
            if ctx.get(dut.done):
                finished.append(True)
                break
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(memory.run, background=True)
    sim.add_testbench(feed)
    sim.run()
    assert finished, f"seed {seed}: the tile never done"
    fb = Framebuffer(base=0x203, stride=11, width=8, height=4)
    assert fb.image(memory.memory).ravel().tolist() == values, f"seed {seed}"
    assert set(memory.writes.values()) == {1}, f"seed {seed}: a byte written twice"
    assert memory.requests < len(values), f"seed {seed}: {memory.requests} writes"


def test_edgeaa_verilog_top_peripheral(tmp_path, capsys):
    from edgeaa.cli import main

    out = tmp_path / "p.v"
    small = ["--coord-bits", "7", "--subpixel-bits", "2", "--intensity-bits", "4"]
    assert main(["verilog", "--top", "peripheral", "--tile", "8x4", *small, "-o", str(out)]) == 0
    assert "module edgeaa_peripheral" in out.read_text() and out.with_suffix(".vlt").exists()
    colour = tmp_path / "c.v"
    assert (
        main(
            [
                "verilog",
                "--top",
                "peripheral",
                "--tile",
                "8x4",
                *small,
                "--channels",
                "3",
                "-o",
                str(colour),
            ]
        )
        == 0
    )
    assert "tile 8x4, 3 channels" in colour.read_text() and "fb_format" in colour.read_text()
    capsys.readouterr()
    assert main(["verilog", "--top", "peripheral", "--intensity-bits", "10"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "8-bit channels" in err and "Traceback" not in err
    assert main(["verilog", "--top", "peripheral", "--core", "deltas"]) == 2
    assert "--top peripheral has its own" in capsys.readouterr().err


@pytest.mark.formal
@pytest.mark.parametrize("channels, fault", [(1, None), (3, None), (3, "drop_stb")])
def test_the_framebuffer_writer_keeps_the_wishbone_initiator_rules(channels, fault):
    """In every format (``fb_format`` free), a pixel's two writes across a word included."""
    from edgeaa.sim.verification.formal.wishbone import run_writer_proof

    result = run_writer_proof(fault=fault, channels=channels, timeout=300)
    if fault is None:
        assert result.status == "PASS", result.log_tail
    else:  # the check can fail: a request dropped under stall is caught
        assert result.status == "FAIL" and "stream: a held request stays valid" in " ".join(
            result.failed
        )


def test_a_channels_rounding_to_565_is_exact_and_needs_no_divider():
    """`scale_channel` is round(c (2**n - 1) / (2**I - 1)) half up for every c at I = 1 to
    8 (by fractions), and `scale_steps` (the hardware's, no divider) equals it for every c
    at every I from n to 16."""
    from fractions import Fraction

    for n in (5, 6):
        for bits in range(1, 9):
            full = (1 << bits) - 1
            for c in range(full + 1):
                want = int(Fraction(c * ((1 << n) - 1), full) + Fraction(1, 2))
                assert scale_channel(c, bits, n) == want, (c, bits, n)
        for bits in range(n, 17):
            c = np.arange(1 << bits, dtype=np.int64)
            assert np.array_equal(scale_steps(c, bits, n), scale_channel(c, bits, n)), bits
    assert scale_channel(128, 8, 6) == 32 and scale_channel(9, 4, 5) == 19
    with pytest.raises(ValueError, match="narrows"):
        scale_steps(3, 4, 5)


def test_framebuffer_bytes_lay_out_each_format():
    pixel = np.array([[[255, 128, 0, 200]]])  # red 255, green 128, blue 0, alpha 200
    rgb = pixel[..., :3]
    assert framebuffer_bytes(rgb, FORMATS["rgb565"], 8).tolist() == [[[0x00, 0xFC]]]
    assert framebuffer_bytes(rgb, FORMATS["rgb888"], 8).tolist() == [[[255, 128, 0]]]
    assert framebuffer_bytes(rgb, FORMATS["rgba8888"], 8).tolist() == [[[255, 128, 0, 255]]]
    assert framebuffer_bytes(pixel, FORMATS["rgba8888"], 8).tolist() == [[[255, 128, 0, 200]]]
    small = np.array([[[7, 15, 0]]])  # 4-bit channels: 565 widens them (14, 63, 0)
    assert framebuffer_bytes(small, FORMATS["rgb565"], 4).tolist() == [[[0xE0, 0x77]]]
    assert framebuffer_bytes(np.array([[7]]), FORMATS["grey8"], 4).tolist() == [[[7]]]
    with pytest.raises(ValueError, match="no grey8"):
        framebuffer_bytes(rgb, FORMATS["grey8"], 8)
    with pytest.raises(ValueError, match="no rgb565"):
        framebuffer_bytes(np.array([[7]]), FORMATS["rgb565"], 8)


COLOURS = ["#ff800099", [0.1, 0.9, 0.5, 0.3], "#0000ff", "#c0c0c001"]  # with alpha


def _colour_plan(config: EdgeConfig, background: str):
    polygons = [
        {**{k: v for k, v in p.items() if k != "intensity"}, "color": c}
        for p, c in zip(TINY_SCENE["polygons"], COLOURS, strict=False)
    ]
    size = {k: TINY_SCENE[k] for k in ("width", "height")}
    scene = parse_scene({**size, "background_color": background, "polygons": polygons})
    return plan_scene(coverage_scene(scene), config), Canvas(scene, config.full_scale)


@pytest.mark.parametrize(
    "channels, fmt, bits, seed, idle, stall, latency",
    [
        (3, "rgb565", 8, 11, 0.3, 0.5, 3),
        pytest.param(3, "rgb888", 8, 23, 0.1, 0.8, 6, marks=pytest.mark.slow),
        (4, "rgba8888", 8, 5, 0.2, 0.6, 4),
        (4, "rgb565", 4, 7, 0.2, 0.5, 2),  # fields wider than the channels: the table
        # opaque: alpha full scale
        pytest.param(3, "rgba8888", 8, 13, 0.1, 0.5, 3, marks=pytest.mark.slow),
    ],
)
def test_a_colour_scene_lands_in_the_framebuffer_in_its_format_bit_for_bit(
    channels, fmt, bits, seed, idle, stall, latency
):
    """A scene written as a CPU would, the framebuffer in `fmt` at an odd base and stride (so
    pixels of 2 or 3 bytes cross words): its bytes are the model's image converted
    (`framebuffer_bytes`), every byte written once, none outside, under random idle clocks,
    stalls and ack latencies."""
    config = EdgeConfig(coord_bits=7, subpixel_bits=2, intensity_bits=4) if bits == 4 else DEFAULT
    tile = TileConfig(config, 16, 8, channels=channels)
    plan, canvas = _colour_plan(config, "#203040" if channels == 3 else "#20304080")
    want = render_scene(plan, canvas=canvas).image[..., :channels]
    commands = scene_commands(plan, tile, canvas)
    ox, oy = plan.offset
    width, height, fmt = plan.scene.width, plan.scene.height, FORMATS[fmt]
    stride = width * fmt.bytes + 5
    fb = Framebuffer(0x1000 + 3, stride, width, height, x0=ox, y0=oy, format=fmt)
    run = run_peripheral(tile, commands, fb, seed=seed, idle=idle, stall=stall, latency=latency)
    tag = f"seed {seed}"
    image = fb.image(run.memory)
    expected = framebuffer_bytes(want, fmt, bits)
    assert np.array_equal(image, expected), f"{tag}\n{image}\nmodel:\n{expected}"
    inside = {a for y in range(height) for x in range(width) for a in fb.addresses(y, x)}
    assert set(run.writes) == inside, f"{tag}: a write outside the framebuffer"
    assert set(run.writes.values()) == {1}, f"{tag}: a byte written twice"
    assert len({tuple(p) for p in expected.reshape(-1, fmt.bytes).tolist()}) > 4, tag
    assert run.registers["fb_format"] & 3 == fmt.code and run.aborted == 0, tag


@pytest.mark.parametrize("channels", [1, 3, 4])
def test_the_format_register_keeps_only_formats_the_build_writes(channels):
    """Writing a format the build does not write into ``fb_format`` (grey8 into a colour
    peripheral, RGB565 into a grey one) is ignored: it keeps its reset format and writes in
    it; bits 7:4 read the codes it writes."""
    tile = TileConfig(SMALL, 8, 4, channels=channels)
    commands, grey = _empty_tiles(tile, 1, 1) if channels == 1 else ([], None)
    if channels > 1:
        commands = [Command.tile(0, 0, 0, paint=3 | 5 << 4 | 9 << 8 | 15 << 12), Command.flush()]
    other = FORMATS["rgb565" if channels == 1 else "grey8"]
    asked = Framebuffer(0, 32, 8, 4, format=other)
    run = run_peripheral(tile, commands, asked, seed=1, stall=0.3, latency=2)
    kept = default_format(channels)
    mask = sum(1 << f.code for f in format_codes(channels))
    assert run.registers["fb_format"] == kept.code | mask << 4
    got = Framebuffer(0, 32, 8, 4, format=kept).image(run.memory)
    want = grey if channels == 1 else np.tile([3, 5, 9, 15][:channels], (4, 8, 1))
    assert np.array_equal(got, framebuffer_bytes(want, kept, 4).reshape(got.shape))


@pytest.mark.parametrize("fault", [None, "ack_stalled"])
def test_the_register_window_keeps_the_wishbone_target_rules(fault):
    """k-induction, about 1 s: one ack a taken request the next clock, none without one, err
    never, stall only for the last command word on a full FIFO, no ack and irq low after a
    reset, info reads its word; for any initiator keeping the B4 rules and any datapath."""
    from edgeaa.sim.verification.formal.wishbone import run_window_proof

    result = run_window_proof(fault=fault, timeout=300)
    if fault is None:
        assert result.status == "PASS", result.log_tail
    else:  # an ack for a stalled request is caught
        failed = " ".join(result.failed)
        assert result.status == "FAIL" and "one ack a taken request" in failed, failed
