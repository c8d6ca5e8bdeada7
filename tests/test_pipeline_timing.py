# amaranth: UnusedElaboratable=no
"""The whole pipeline's cycle model (`edgeaa.model.pipeline_timing.pipeline_cycles`) against
the hardware (`EdgePipeline`), clock for clock, with commands offered back to back and an
always-ready pixel sink: in Amaranth's simulator every command taken, every delta beat into
the accumulator, every pixel out and the six stage counters, on random scenes (several
tiles, polygons whose first beats wait behind the previous scan or a flush) and on command
streams with bad commands; through Verilator the built-in scenes' every command and pixel
clock, the total clocks and the counters. A model one clock off is caught."""

from __future__ import annotations

import random
from dataclasses import dataclass

import numpy as np
import pytest
from amaranth.sim import Simulator
from fixtures import TINY_SCENE, small_scenes
from hypothesis import HealthCheck, given, settings

from edgeaa.hdl.pipeline import STATS, EdgePipeline, command_layout
from edgeaa.model import EdgeConfig
from edgeaa.model import tile as tile_model
from edgeaa.model.pipeline import CODE, Command
from edgeaa.model.pipeline_timing import pipeline_cycles
from edgeaa.model.tile import TileConfig
from edgeaa.render import parse_scene, plan_scene
from edgeaa.render.pipeline import scene_commands
from edgeaa.sim.simulators.pipeline_harness import expected_pixels, pixel_drain_clocks

SMALL = EdgeConfig(coord_bits=7, subpixel_bits=2, intensity_bits=4)
DEFAULT = EdgeConfig()


@dataclass
class Transfers:
    commands: list[int]
    beats: list[int]
    pixels: list[int]
    stats: dict
    clocks: int  # clock 0 to the last transfer, inclusive


def run_transfers(tile: TileConfig, commands: list[Command]) -> Transfers:
    """`EdgePipeline` in Amaranth's simulator, commands back to back, the sink always ready:
    the clock of every command taken, delta beat into the accumulator and pixel out."""
    dut = EdgePipeline(tile)
    layout = command_layout(tile)
    payloads = [layout.const(c._asdict()) for c in commands]
    expected = expected_pixels(tile, commands)
    out = Transfers([], [], [], {}, 0)

    async def bench(ctx):
        ctx.set(dut.pixels.ready, 1)
        clock = 0
        while len(out.commands) < len(payloads) or len(out.pixels) < expected:
            assert clock < 200_000, "the pipeline hangs"
            index = len(out.commands)
            offer = index < len(payloads)
            ctx.set(dut.commands.valid, offer)
            if offer:
                ctx.set(dut.commands.payload, payloads[index])
            *_, taken, beat, beat_ready, pixel = await ctx.tick().sample(
                dut.commands.ready, dut.core.deltas.valid, dut.core.deltas.ready, dut.pixels.valid
            )
            for hit, log in ((offer and taken, out.commands), (beat and beat_ready, out.beats)):
                if hit:
                    log.append(clock)
            if pixel:
                out.pixels.append(clock)
            clock += 1
        # a few quiet clocks: nothing more may move
        for _ in range(2 * tile_model.resolve_latency(tile.config) + 8):
            ctx.set(dut.commands.valid, 0)
            *_, beat, pixel = await ctx.tick().sample(dut.core.deltas.valid, dut.pixels.valid)
            assert not (beat or pixel), "a transfer after the last expected one"
        out.stats = {name: ctx.get(dut.stats[name]) for name in STATS}
        out.clocks = max([-1, *out.commands, *out.beats, *out.pixels]) + 1

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    return out


def first_difference(name: str, got, want) -> str:
    got, want = list(got), list(want)
    for k, (g, w) in enumerate(zip(got, want, strict=False)):
        if g != w:
            return f"{name} {k}: hardware clock {g}, model {w}"
    return f"{name}: {len(got)} in the hardware, {len(want)} in the model"


def check_clock_for_clock(tile: TileConfig, commands, hw: Transfers, label: str) -> None:
    model = pipeline_cycles(tile, commands)
    for name, got, want in (
        ("command", hw.commands, model.commands),
        ("beat", hw.beats, model.beats),
        ("pixel", hw.pixels, model.pixels),
    ):
        assert list(got) == list(want), f"{label}: {first_difference(name, got, want)}"
    assert hw.stats == model.stats, f"{label}: counters {hw.stats} != model {model.stats}"
    assert hw.clocks == model.clocks, label


# A tile of 16 x 8 at 7.2 bits: scenes of a few tiles, each a few hundred clocks.
SMALL_TILE = TileConfig(SMALL, 16, 8)


def scene_for(scene, config):
    plan = plan_scene(scene, config)
    return plan


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scene=small_scenes(SMALL))
def test_random_scenes_go_through_the_hardware_as_the_model_says(scene):
    commands = scene_commands(plan_scene(scene, SMALL), SMALL_TILE)
    hw = run_transfers(SMALL_TILE, commands)
    check_clock_for_clock(SMALL_TILE, commands, hw, f"scene {scene}")


def test_the_tiny_scene_at_the_default_configuration():
    tile = TileConfig(DEFAULT, 16, 8)
    commands = scene_commands(plan_scene(parse_scene(TINY_SCENE), DEFAULT), tile)
    hw = run_transfers(tile, commands)
    check_clock_for_clock(tile, commands, hw, "tiny scene")
    assert hw.stats["core_stall"] > 0 and hw.stats["acc_stall"] > 0  # the stall is exercised


@pytest.mark.parametrize("name", ["text", "starburst"])
def test_verilator_runs_the_builtins_in_the_models_clocks(name):
    from edgeaa.render import builtin
    from edgeaa.sim.simulators import pipeline_harness

    tile = TileConfig(DEFAULT)
    commands = scene_commands(plan_scene(builtin(name, DEFAULT), DEFAULT), tile)
    run = pipeline_harness.run(tile, commands)
    model = pipeline_cycles(tile, commands)
    got = run.pixels[:, 0]
    assert list(run.commands) == model.commands, first_difference(
        "command", run.commands, model.commands
    )
    assert list(got) == model.pixels, first_difference("pixel", got, model.pixels)
    assert run.stats == model.stats
    assert run.clocks == model.clocks + pixel_drain_clocks(tile)
