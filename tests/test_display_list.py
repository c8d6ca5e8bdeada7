# amaranth: UnusedElaboratable=no
"""The peripheral's display-list reader (`DisplayListReader`, the ``dl_*`` registers and the
``dl`` bus) in Amaranth's simulator: a scene's commands put in a memory model as a display
list, started with a base, a length and the start bit; the framebuffer equals the
renderer's image bit for bit under random wait states on the register window, the
framebuffer and the list's bus; every list word read once; a start while the list runs, a
zero-length list, a bus error while reading and a list between window commands."""

from __future__ import annotations

import random
from itertools import pairwise

import numpy as np
import pytest
from fixtures import TINY_SCENE

from edgeaa.hdl.peripheral import DisplayListReader, command_words
from edgeaa.model import EdgeConfig
from edgeaa.model.pipeline import Command
from edgeaa.model.tile import TileConfig
from edgeaa.render import parse_scene, plan_scene, render_scene
from edgeaa.render.pipeline import scene_commands
from edgeaa.sim.simulators.wishbone import DisplayList, Framebuffer, run_peripheral

DEFAULT = EdgeConfig()
TILE = TileConfig(DEFAULT, 16, 8)
SMALL = TileConfig(EdgeConfig(coord_bits=7, subpixel_bits=2, intensity_bits=4), 8, 4)
LIST_DONE, BUS_ERROR, TILE_WRITTEN, RUNNING = 0b100, 0b10, 0b1, 0b1000


def _tiny(width_pad: int = 5):
    plan = plan_scene(parse_scene(TINY_SCENE), DEFAULT)
    ox, oy = plan.offset
    width, height = plan.scene.width, plan.scene.height
    fb = Framebuffer(0x1000 + 3, width + width_pad, width, height, x0=ox, y0=oy)
    return plan, scene_commands(plan, TILE), fb


def _tile_runs(commands) -> list[list[Command]]:
    """`commands` cut after each flush: one run a tile."""
    runs, run = [], []
    for command in commands:
        run.append(command)
        if command.op == Command.flush().op:
            runs.append(run)
            run = []
    assert not run, "commands after the last flush"
    return runs


def _check_image(run, fb, want, tag):
    image = np.array(fb.image(run.memory))
    assert np.array_equal(image, want), f"{tag}\n{image}\nmodel:\n{want}"
    inside = {a for y in range(fb.height) for x in range(fb.width) for a in fb.addresses(y, x)}
    assert set(run.writes) == inside, f"{tag}: a write outside the framebuffer"
    assert set(run.writes.values()) == {1}, f"{tag}: a pixel written twice"


def _check_list_read_once(run, dl: DisplayList, tile: TileConfig, tag):
    assert run.reads == dict.fromkeys(dl.words(tile), 1), f"{tag}: a list word not read once"


def _empty_tiles(tile: TileConfig, across: int) -> tuple[list[Command], np.ndarray]:
    """A tile start and a flush per tile in a row (its background its number + 1)."""
    commands, image = [], np.zeros((tile.height, across * tile.width), np.int64)
    for k in range(across):
        commands += [Command.tile(k * tile.width, 0, k + 1), Command.flush()]
        image[:, k * tile.width : (k + 1) * tile.width] = k + 1
    return commands, image


@pytest.mark.parametrize(
    "seed, idle, stall, latency, dl_stall, dl_latency",
    [(31, 0.3, 0.5, 3, 0.6, 5), pytest.param(0, 0.0, 0.0, 0, 0.0, 0, marks=pytest.mark.slow)],
)
def test_a_scene_drawn_from_a_display_list_is_the_models_bit_for_bit(
    seed, idle, stall, latency, dl_stall, dl_latency
):
    plan, commands, fb = _tiny()
    dl = DisplayList(tuple(commands), base=0x8000, stall=dl_stall, latency=dl_latency)
    run = run_peripheral(
        TILE, [], fb, seed=seed, idle=idle, stall=stall, latency=latency, display_list=dl
    )
    tag = f"seed {seed}"
    _check_image(run, fb, render_scene(plan, engine="model").image, tag)
    _check_list_read_once(run, dl, TILE, tag)
    regs = run.registers
    tiles = sum(c.op == Command.flush().op for c in commands)
    assert regs["tiles"] == tiles and regs["errors"] == 0 and regs["status"] & 0xFFFF == 0, tag
    assert regs["irq_status"] == LIST_DONE | TILE_WRITTEN and regs["irq_at_list_done"] == 1, tag
    assert regs["irq_after_clear"] == 0 and run.aborted == 0, tag
    assert regs["dl_base"] == 0x8000 and regs["dl_length"] == len(commands), tag
    assert regs["tiles_at_list_done"] == tiles, f"{tag}: the list done before its tiles"


def test_a_start_while_the_list_runs_is_ignored():
    """The second start comes with ``dl_base`` moved past the list: were it taken, the
    reader would read outside the list (the memory model fails the run) or draw twice."""
    commands, want = _empty_tiles(SMALL, 4)
    fb = Framebuffer(base=0x101, stride=37, width=32, height=4)
    dl = DisplayList(tuple(commands), stall=0.5, latency=3, restart=True)
    run = run_peripheral(SMALL, [], fb, seed=7, idle=0.2, stall=0.5, latency=2, display_list=dl)
    assert run.registers["status_at_restart"] & RUNNING, "the list was not running any more"
    _check_image(run, fb, want, "seed 7")
    _check_list_read_once(run, dl, SMALL, "seed 7")
    assert run.registers["tiles"] == 4 and run.registers["irq_status"] & LIST_DONE


def test_a_zero_length_list_reads_nothing_and_is_done():
    commands = (Command.tile(0, 0, 9), Command.flush())  # in memory, but not in the list
    fb = Framebuffer(base=0, stride=8, width=8, height=4)
    dl = DisplayList(commands, length=0, latency=3)  # no stall: a first read would be taken
    run = run_peripheral(SMALL, [], fb, seed=2, stall=0.3, latency=2, display_list=dl)
    assert not run.reads and not run.writes
    regs = run.registers
    assert regs["irq_status"] == LIST_DONE and regs["irq_at_list_done"] == 1
    assert regs["tiles"] == 0 and regs["status"] & 0xFFFF == 0


def test_a_bus_error_reading_the_list_ends_it_and_the_window_still_works():
    """An err on a word of the third tile's first command: the two tiles before it are
    drawn, that command and the rest of the list are not pushed, the error bit and both
    interrupts are set, the list is done; then the fourth tile written through the window
    is drawn."""
    words = command_words(SMALL)
    commands, want = _empty_tiles(SMALL, 4)
    base = 0x200
    bad = base + 4 * (4 * words + 1) + 2  # a byte of command 4's word 1
    errors, after = frozenset({bad}), tuple(commands[6:])
    dl = DisplayList(tuple(commands), base, stall=0.4, latency=3, errors=errors, after=after)
    fb = Framebuffer(base=0, stride=32, width=32, height=4)
    run = run_peripheral(SMALL, [], fb, seed=5, stall=0.3, latency=2, display_list=dl)
    regs = run.registers
    assert regs["status"] & BUS_ERROR, "the read's err did not set the error bit"
    assert regs["irq_status"] == LIST_DONE | BUS_ERROR | TILE_WRITTEN
    assert regs["tiles"] == 3 and regs["irq_at_list_done"] == 1
    read = set(dl.words(SMALL)) & set(run.reads)
    assert read == {base // 4 + k for k in range(5 * words)}, "reads past the failed command"
    want[:, 16:24] = -1  # the third tile: its command was not pushed
    assert np.array_equal(fb.image(run.memory), want), "seed 5"
    assert set(run.writes.values()) == {1}, "seed 5: a pixel written twice"


def test_a_list_between_window_commands_keeps_their_order():
    """The first tile written through the window (still in the FIFO when the list starts),
    the next two from the list, the last through the window once the list is done; while
    the list runs the window pushes bad commands (dropped and counted, whichever tile they
    land in), so both push into the FIFO in the same clocks: none is lost or doubled."""
    plan, commands, fb = _tiny()
    runs = _tile_runs(commands)
    assert len(runs) == 4
    middle = tuple(runs[1] + runs[2])
    bad = (Command(6),) * 12
    dl = DisplayList(middle, stall=0.3, latency=2, during=bad, after=tuple(runs[3]))
    run = run_peripheral(TILE, runs[0], fb, seed=13, stall=0.6, latency=3, display_list=dl)
    _check_image(run, fb, render_scene(plan, engine="model").image, "seed 13")
    _check_list_read_once(run, dl, TILE, "seed 13")
    assert run.registers["tiles"] == 4 and run.registers["errors"] == len(bad), "seed 13"


def test_the_reader_takes_a_command_every_words_plus_two_clocks():
    """The documented rate: with a memory that never stalls and acks the next clock, and the
    FIFO always ready, one command every ``command_words + 2`` clocks (its words back to
    back, the last ack, the push)."""
    from amaranth.sim import Simulator

    tile, n = SMALL, 6
    words = command_words(tile)
    rng = random.Random(3)
    memory = {k: rng.getrandbits(32) for k in range(100, 100 + n * words)}
    dut = DisplayListReader(tile)
    got, clocks = [], []

    async def bench(ctx):
        bus = dut.bus
        ctx.set(dut.base, 100)
        ctx.set(dut.length, n)
        ctx.set(dut.start, 1)
        ctx.set(dut.idle, 1)
        ctx.set(dut.commands.ready, 1)
        await ctx.tick()
        ctx.set(dut.start, 0)
        pending = []
        for clock in range(200):
            ack = bool(pending)
            ctx.set(bus.ack, ack)
            ctx.set(bus.dat_r, memory[pending.pop(0)] if ack else 0)
            if ctx.get(bus.cyc) and ctx.get(bus.stb):
                pending.append(ctx.get(bus.adr))
            if ctx.get(dut.commands.valid):
                got.append(ctx.get(dut.commands.payload))
                clocks.append(clock)
            if ctx.get(dut.done):
                break
            await ctx.tick()

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    size = len(dut.commands.payload)
    want = [
        sum(memory[100 + c * words + k] << 32 * k for k in range(words)) & ((1 << size) - 1)
        for c in range(n)
    ]
    assert got == want
    assert [b - a for a, b in pairwise(clocks)] == [words + 2] * (n - 1)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [41, 42])
def test_a_bigger_scene_from_a_display_list_under_heavy_wait_states(seed):
    """A 48 x 40 scene of many tiles: the list's memory stalls 80 % of clocks."""
    scene = {
        **TINY_SCENE,
        "width": 48,
        "height": 40,
        "polygons": [
            *TINY_SCENE["polygons"],
            {"points": [[40, 2], [46.5, 37], [3, 30.25], [25, 20]], "intensity": 170},
        ],
    }
    plan = plan_scene(parse_scene(scene), DEFAULT)
    commands = scene_commands(plan, TILE)
    ox, oy = plan.offset
    fb = Framebuffer(0x2001, 53, 48, 40, x0=ox, y0=oy)
    dl = DisplayList(tuple(commands), stall=0.8, latency=6)
    run = run_peripheral(
        TILE, [], fb, seed=seed, idle=0.2, stall=0.5, latency=4, display_list=dl,
        max_clocks=400_000,
    )  # fmt: skip
    _check_image(run, fb, render_scene(plan, engine="model").image, f"seed {seed}")
    _check_list_read_once(run, dl, TILE, f"seed {seed}")


@pytest.mark.parametrize("fault", [None, "drop_stb"])
def test_the_reader_keeps_the_wishbone_initiator_rules(fault):
    """k-induction, a few seconds: ``stb`` within ``cyc``, ``cyc`` held while a read is
    unanswered, a stalled read offered again unchanged, at most a command's words in flight,
    reads of whole words, a command not taken held; for any start, length, FIFO, reset and
    target."""
    from edgeaa.sim.verification.formal.wishbone import run_reader_proof

    result = run_reader_proof(fault=fault, timeout=300)
    if fault is None:
        assert result.status == "PASS", result.log_tail
    else:  # a request dropped under stall is caught
        failed = " ".join(result.failed)
        assert result.status == "FAIL" and "a held request stays valid" in failed, failed
