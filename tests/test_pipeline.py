# amaranth: UnusedElaboratable=no
"""The whole polygon pipeline (`EdgePipeline`) in Amaranth's simulator: a scene's commands
in, the renderer's image out (pixels from the hardware); bad commands dropped and counted as
the command model (`edgeaa.model.pipeline.command_ops`) says, never hanging the pipeline or
touching another polygon's pixels; the same frames under random back-pressure; the Verilog
lint-clean."""

from __future__ import annotations

import random
from dataclasses import dataclass, field

import numpy as np
import pytest
from amaranth.sim import Simulator
from fixtures import TINY_SCENE

from edgeaa.hdl.pipeline import STATS, EdgePipeline, command_layout, pipeline_verilog
from edgeaa.model import EdgeConfig
from edgeaa.model.pipeline import COMMAND_VERSION, Command, command_ops
from edgeaa.model.tile import TileConfig, TileModel
from edgeaa.render import parse_scene, plan_scene, render_scene
from edgeaa.render.pipeline import image_from_frames, render_tiles, scene_commands

DEFAULT = EdgeConfig()
SMALL = EdgeConfig(coord_bits=7, subpixel_bits=2, intensity_bits=4)


@dataclass
class PipelineRun:
    pixels: list = field(default_factory=list)  # (x, y, value, last)
    errors: int = 0
    edge_errors: int = 0
    stats: dict = field(default_factory=dict)
    clocks: int = 0

    def frames(self, tile: TileConfig) -> list[np.ndarray]:
        values = np.array([p[2] for p in self.pixels], dtype=np.int64)
        return list(values.reshape(-1, tile.height, tile.width))


def run_pipeline(tile: TileConfig, commands, *, seed=None, idle=0.0, stall=0.0) -> PipelineRun:
    dut = EdgePipeline(tile)
    layout = command_layout(tile)
    payloads = [layout.const(c._asdict()) for c in commands]
    rng = random.Random(seed) if seed is not None else None
    run = PipelineRun()

    async def bench(ctx):
        index, quiet = 0, 0
        while quiet < 200 and run.clocks < 500_000:
            offer = index < len(payloads) and (rng is None or rng.random() >= idle)
            ctx.set(dut.commands.valid, offer)
            if offer:
                ctx.set(dut.commands.payload, payloads[index])
            ready = rng is None or rng.random() >= stall
            ctx.set(dut.pixels.ready, ready)
            *_, taken, valid, pixel = await ctx.tick().sample(
                dut.commands.ready, dut.pixels.valid, dut.pixels.payload
            )
            index += bool(offer and taken)
            if valid and ready:
                run.pixels.append((int(pixel.x), int(pixel.y), int(pixel.value), int(pixel.last)))
            run.clocks += 1
            quiet = quiet + 1 if index == len(payloads) and not valid else 0
        run.errors, run.edge_errors = ctx.get(dut.errors), ctx.get(dut.edge_errors)
        run.stats = {name: ctx.get(dut.stats[name]) for name in STATS}

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()
    return run


def model_frames(tile: TileConfig, commands):
    result = command_ops(tile, commands)
    return TileModel(tile).run(result.ops), result


def test_the_command_format_and_interface():
    assert COMMAND_VERSION == 1
    tile = TileConfig(SMALL, 8, 4)
    dut = EdgePipeline(tile)
    members = {"commands", "pixels", "errors", "edge_errors", "stats"}
    assert set(dut.signature.members) == members
    assert set(command_layout(tile).members) == set(Command._fields)


def test_a_scene_goes_through_the_pipeline_to_the_renderers_image():
    plan = plan_scene(parse_scene(TINY_SCENE), DEFAULT)
    tile = TileConfig(DEFAULT, 16, 8)
    commands = scene_commands(plan, tile)
    run = run_pipeline(tile, commands)
    want, result = model_frames(tile, commands)
    assert run.errors == result.errors == 0 and run.edge_errors == 0
    image = image_from_frames(plan, tile, run.frames(tile))
    assert np.array_equal(image, render_scene(plan, engine="model").image)
    assert np.array_equal(image, image_from_frames(plan, tile, want))
    assert np.array_equal(image, render_tiles(plan, tile))
    assert run.stats["core_busy"] > 0 and run.stats["resolve_busy"] >= 4 * tile.pixels
    assert run.stats["resolve_stall"] == 0


def _square(x: int, y: int, size: int, scale: int) -> list[Command]:
    p = [(x, y), (x + size, y), (x + size, y + size), (x, y + size)]
    return [
        Command.edge(a[0] * scale, a[1] * scale, b[0] * scale, b[1] * scale, "right")
        for a, b in zip(p, p[1:] + p[:1], strict=True)
    ]


def bad_commands(scale: int) -> list[Command]:
    """Good polygons around every kind of bad command."""
    top = 1 << SMALL.coord_bits
    return [
        Command.tile(2, 1, 3),
        Command.edge(0, 0, 4 * scale, 4 * scale),  # an edge outside a polygon
        Command.end(),  # an end outside a polygon
        Command(6),  # unknown
        Command.begin(15, 3),
        *_square(3, 2, 3, scale),
        Command(7, 1, 2, 3, 4),  # unknown inside a polygon
        Command.edge(scale, scale, scale, scale),  # zero length: the core's error
        Command.end(),
        Command.tile(top + 1, 0, 9),  # origin out of range: dropped
        Command.begin(9, 3, "evenodd"),
        *_square(4, 3, 4, scale),
        Command.begin(1, 15),  # the previous polygon has no end: ended here
        *_square(2, 1, 2, scale),
        Command.flush(),  # ... and this one too
        Command.begin(12, 0),
        Command.flush(),  # and this one (empty)
    ]


@pytest.mark.parametrize("seed", [None, 7])
def test_bad_commands_are_dropped_and_counted_and_hurt_no_other_polygon(seed):
    tile = TileConfig(SMALL, 8, 8)
    commands = bad_commands(SMALL.subpixel_scale)
    want, result = model_frames(tile, commands)
    assert result.errors == 8 and result.edge_errors == 1
    run = run_pipeline(tile, commands, seed=seed, idle=0.3, stall=0.3)
    assert (run.errors, run.edge_errors) == (result.errors, result.edge_errors)
    got = run.frames(tile)
    assert len(got) == len(want) == 2
    for frame, model in zip(got, want, strict=True):
        assert np.array_equal(frame, model), f"\n{frame}\nmodel:\n{model}"
    scale = SMALL.subpixel_scale
    good = [Command.tile(2, 1, 3), Command.begin(15, 3), *_square(3, 2, 3, scale)]
    good += [Command.end(), Command.begin(9, 3, "evenodd"), *_square(4, 3, 4, scale)]
    good += [Command.end(), Command.begin(1, 15), *_square(2, 1, 2, scale), Command.end()]
    (clean,) = TileModel(tile).run(command_ops(tile, [*good, Command.flush()]).ops)
    assert np.array_equal(clean, want[0]), "a bad command changed a good polygon's pixels"


def test_random_back_pressure_gives_the_same_image():
    plan = plan_scene(parse_scene(TINY_SCENE), DEFAULT)
    tile = TileConfig(DEFAULT, 32, 16)
    run = run_pipeline(tile, scene_commands(plan, tile), seed=3, idle=0.2, stall=0.5)
    image = image_from_frames(plan, tile, run.frames(tile))
    assert np.array_equal(image, render_scene(plan, engine="model").image)
    assert run.stats["resolve_stall"] > 0


def test_the_pipeline_verilog_is_lint_clean():
    from edgeaa.sim.simulators.verilator import lint

    source = pipeline_verilog(TileConfig(SMALL, 8, 4))
    for port in ("commands__payload__op", "pixels__payload__value", "stats__acc_stall"):
        assert port in source
    proc = lint(source)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def test_edgeaa_verilog_top_pipeline(tmp_path, capsys):
    from edgeaa.cli import main

    out = tmp_path / "p.v"
    small = ["--coord-bits", "7", "--subpixel-bits", "2", "--intensity-bits", "4"]
    assert main(["verilog", "--top", "pipeline", "--tile", "8x4", *small, "-o", str(out)]) == 0
    assert "module edgeaa_pipeline" in out.read_text()
    assert main(["verilog", "--top", "pipeline", "--tile", "6x4"]) == 2
    assert "power of two" in capsys.readouterr().err
