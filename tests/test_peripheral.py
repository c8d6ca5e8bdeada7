# amaranth: UnusedElaboratable=no
"""The bus peripheral (`EdgePeripheral`) in Amaranth's simulator: a scene's commands written
into its register window by a CPU model, the tiles written by its framebuffer master into a
memory model, both buses with random idle clocks, stalls and ack latencies; the framebuffer
equals the renderer's image bit for bit, every pixel written exactly once; the counters,
errors and interrupt as the model says; the Verilog lint-clean."""

from __future__ import annotations

import re

import numpy as np
import pytest
from fixtures import TINY_SCENE

from edgeaa.hdl.peripheral import (
    EdgePeripheral,
    command_words,
    pack_command,
    peripheral_verilog,
    register_map,
)
from edgeaa.hdl.pipeline import command_layout
from edgeaa.model import EdgeConfig
from edgeaa.model.pipeline import Command, command_ops
from edgeaa.model.tile import TileConfig
from edgeaa.render import parse_scene, plan_scene, render_scene
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
    first = commands[: len(commands) // 2]  # a tile's flush in flight when the reset comes
    run = run_peripheral(TILE, commands, fb, seed=3, stall=0.5, latency=4, before_reset=first)
    assert run.aborted > 0, "no framebuffer write was in flight at the reset"
    image = np.array(fb.image(run.memory))
    assert np.array_equal(image, render_scene(plan, engine="model").image), "seed 3"
    clean = run_peripheral(TILE, commands, fb, seed=3, stall=0.5, latency=4)
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


def test_the_peripheral_verilog_is_lint_clean():
    from edgeaa.sim.simulators.verilator import lint

    source = peripheral_verilog(TileConfig(EdgeConfig(7, 2, 4), 8, 4))
    header = re.search(r"module edgeaa_peripheral\((.*?)\);", source, re.S).group(1)
    names = ("cyc", "stb", "we", "adr", "dat_w", "sel", "dat_r", "ack", "stall", "err")
    want = {"clk", "rst", "irq"} | {f"{bus}__{n}" for bus in ("bus", "fb") for n in names}
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
    assert 5 not in run.memory and len(run.writes) == 16 * 4 - 1


def test_edgeaa_verilog_top_peripheral(tmp_path, capsys):
    from edgeaa.cli import main

    out = tmp_path / "p.v"
    small = ["--coord-bits", "7", "--subpixel-bits", "2", "--intensity-bits", "4"]
    assert main(["verilog", "--top", "peripheral", "--tile", "8x4", *small, "-o", str(out)]) == 0
    assert "module edgeaa_peripheral" in out.read_text() and out.with_suffix(".vlt").exists()
    capsys.readouterr()
    assert main(["verilog", "--top", "peripheral", "--intensity-bits", "10"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "8-bit grey" in err and "Traceback" not in err
    assert main(["verilog", "--top", "peripheral", "--core", "deltas"]) == 2
    assert "--top peripheral has its own" in capsys.readouterr().err


@pytest.mark.formal
@pytest.mark.parametrize("fault", [None, "drop_stb"])
def test_the_framebuffer_writer_keeps_the_wishbone_initiator_rules(fault):
    from edgeaa.sim.verification.formal.wishbone import run_writer_proof

    result = run_writer_proof(fault=fault, timeout=300)
    if fault is None:
        assert result.status == "PASS", result.log_tail
    else:  # the check can fail: a request dropped under stall is caught
        assert result.status == "FAIL" and "stream: a held request stays valid" in " ".join(
            result.failed
        )
