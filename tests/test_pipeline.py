# amaranth: UnusedElaboratable=no
"""The whole polygon pipeline (`EdgePipeline`) in Amaranth's simulator: a scene's commands
in, the renderer's image out (pixels from the hardware); bad commands dropped and counted as
the command model (`edgeaa.model.pipeline.command_ops`) says, never hanging the pipeline or
touching another polygon's pixels; the same frames under random back-pressure; the Verilog
lint-clean."""

from __future__ import annotations

import json
import re
from dataclasses import replace

import numpy as np
import pytest
from fixtures import TINY_SCENE, small_scenes
from hypothesis import given, settings
from hypothesis import strategies as st

from edgeaa.hdl.pipeline import EdgePipeline, command_layout, pipeline_verilog
from edgeaa.model import EdgeConfig
from edgeaa.model.beat import DELTAS, DELTAS_FAST
from edgeaa.model.pipeline import (
    COMMAND_VERSION,
    PIPELINES,
    Command,
    PipelineConfig,
    command_fields,
    command_ops,
)
from edgeaa.model.pipeline_timing import pipeline_cycles
from edgeaa.model.tile import TileConfig, TileModel, pack_paint
from edgeaa.render import SceneError, builtin, parse_scene, plan_scene, render_scene
from edgeaa.render.builtin import BUILTINS
from edgeaa.render.paint import Canvas, coverage_scene
from edgeaa.render.pipeline import (
    image_from_frames,
    pipeline_savings,
    render_pipeline,
    render_tiles,
    scene_commands,
    tile_jobs,
)
from edgeaa.render.render import _write_boxes
from edgeaa.sim.simulators.amaranth_sim import run_pipeline
from edgeaa.sim.simulators.pipeline_harness import PIXEL_COLUMNS, PipelineHang, expected_pixels

DEFAULT = EdgeConfig()
SMALL = EdgeConfig(coord_bits=7, subpixel_bits=2, intensity_bits=4)
TILE = TileConfig(DEFAULT)


def model_frames(tile: TileConfig, commands):
    result = command_ops(tile, commands)
    return TileModel(tile).run(result.ops), result


def test_the_command_format_and_interface():
    assert COMMAND_VERSION == 2
    tile = TileConfig(SMALL, 8, 4)
    dut = EdgePipeline(tile)
    members = {"commands", "pixels", "errors", "edge_errors", "stats"}
    assert set(dut.signature.members) == members
    assert set(command_layout(tile).members) == set(command_fields(tile))
    assert set(Command._fields) - set(command_fields(tile)) == {"paint"}
    for channels in (3, 4):  # red, green, blue and alpha, whatever the channels
        colour = command_layout(replace(tile, channels=channels))
        assert set(colour.members) == set(Command._fields)
        assert colour.members["paint"].width == 4 * SMALL.intensity_bits


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


# an alpha: often transparent, opaque or just off them (q' = 0 or q), else any
ALPHAS = st.one_of(st.sampled_from([0.0, 1.0, 0.5, 1 / 255, 254 / 255]), st.floats(0, 1))


def colour_scene(data, scene, channels: int = 3):
    """`scene` with a random paint and alpha per polygon, and a random background, opaque
    for 3 channels (a 3-channel tile's pixels are opaque), of any alpha for 4."""
    unit = st.floats(0, 1)

    def paint(alpha):
        return tuple(data.draw(unit) for _ in range(3)) + (data.draw(alpha),)

    polygons = tuple(replace(p, paint=paint(ALPHAS)) for p in scene.polygons)
    background = paint(st.just(1.0) if channels == 3 else ALPHAS)
    return replace(scene, polygons=polygons, background_paint=background)


@settings(max_examples=40, deadline=None)
@given(st.data(), st.sampled_from([(4, 2), (16, 8)]), st.sampled_from([3, 4]))
def test_a_colour_scene_through_colour_tiles_is_the_canvas(data, size, channels):
    """Each polygon's paint and alpha composited per channel in the tiles (`TileModel`, 3 or
    4 channels): the canvas's image (`edgeaa.render.paint`), bit for bit."""
    scene = colour_scene(data, data.draw(small_scenes(DEFAULT)), channels)
    full = DEFAULT.full_scale
    plan = plan_scene(coverage_scene(scene), DEFAULT)
    want = render_scene(plan, canvas=Canvas(scene, full)).image
    if channels == 3:
        assert (want[..., 3] == full).all()
    tile = TileConfig(DEFAULT, *size, channels=channels)
    got = render_tiles(plan, tile, canvas=Canvas(scene, full))
    assert np.array_equal(got, want[..., :channels])


def test_a_translucent_background_needs_four_channels():
    scene = parse_scene({**TINY_SCENE, "background_color": [1, 1, 1, 0.5]})
    scene = replace(scene, polygons=(replace(scene.polygons[0], paint=(1, 0, 0, 0.5)),))
    plan = plan_scene(coverage_scene(scene), DEFAULT)
    canvas = Canvas(scene, DEFAULT.full_scale)
    with pytest.raises(SceneError, match="background has alpha 128 of 255.*use 4 channels"):
        scene_commands(plan, TileConfig(DEFAULT, 16, 8, channels=3), canvas)
    commands = scene_commands(plan, TileConfig(DEFAULT, 16, 8, channels=4), canvas)
    begin = next(c for c in commands if c.name == "begin")
    assert begin.paint == pack_paint((255, 0, 0, 128), 8)  # straight colour, then alpha


@settings(max_examples=60, deadline=None)
@given(st.data(), st.sampled_from([(4, 2), (8, 4), (16, 8)]))
def test_the_tiles_image_is_the_renderers_with_left_edges_merged(data, size):
    """Small tiles put most edges wholly left of most tiles: sent as merged vertical edges,
    the frames are still the renderer's image bit for bit."""
    scene = data.draw(small_scenes(DEFAULT))
    plan = plan_scene(scene, DEFAULT)
    tile = TileConfig(DEFAULT, *size)
    assert np.array_equal(render_tiles(plan, tile), render_scene(plan).image)


@pytest.mark.parametrize("name", ["text", "starburst"])
def test_no_edge_is_sent_to_a_tile_it_cannot_write_in(name):
    """A tile gets the edges that can write in its columns and, for those wholly left of
    it, vertical edges on the column left of it, at most one per such edge (the text's
    glyphs left of a tile give none: a closed contour's windings cancel)."""
    plan = plan_scene(builtin(name, DEFAULT), DEFAULT)
    S, (ox, _) = DEFAULT.subpixel_scale, plan.offset
    lo_x, _, hi_x, _ = _write_boxes(plan.coords, plan.offset, S)
    columns = {tuple(c.tolist()): (a, b) for c, a, b in zip(plan.coords, lo_x, hi_x, strict=True)}
    merged = left = 0
    for job in tile_jobs(plan, TILE):
        column = (ox + job.x - 1) * S
        for edge in job.edges:
            if edge.x0 == edge.x1 == column and job.projected:
                continue
            lo, hi = columns[edge.x0, edge.y0, edge.x1, edge.y1]
            assert lo < job.x + TILE.width and hi >= job.x
        assert job.projected <= job.left
        merged, left = merged + job.projected, left + job.left
    assert left > 0 and merged < left / 4


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


# RGB's build is RGBA's less the alpha channel: it lints with -m slow
@pytest.mark.parametrize("channels", [1, pytest.param(3, marks=pytest.mark.slow), 4])
def test_the_pipeline_verilog_is_lint_clean(channels):
    from edgeaa.sim.simulators.verilator import lint

    source = pipeline_verilog(TileConfig(SMALL, 8, 4, channels=channels))
    for port in ("commands__payload__op", "pixels__payload__value", "stats__acc_stall"):
        assert port in source
    assert ("commands__payload__paint" in source) == (channels > 1)
    proc = lint(source)
    assert proc.returncode == 0, proc.stdout + proc.stderr


@pytest.mark.parametrize("scan", [1, 2])
def test_the_pipeline_verilog_of_two_pixel_lanes_is_lint_clean(scan):
    """Two pixel lanes, and one or two scan lanes (the banked accumulation memories)."""
    from edgeaa.sim.simulators.verilator import lint

    source = pipeline_verilog(PipelineConfig(TileConfig(SMALL, 8, 4), 1, 2, scan))
    assert "pixels__payload__value1" in source and "pixels__payload__value2" not in source
    assert ("cells_memory_lane1" in source) == (scan == 2)
    proc = lint(source)
    assert proc.returncode == 0, proc.stdout + proc.stderr


@pytest.mark.parametrize(("channels", "background"), [(3, "#203040"), (4, "#20304080")])
def test_a_colour_scene_in_amaranths_simulator_is_the_canvas(channels, background):
    """Translucent paints (and a translucent background in 4 channels) in the hardware."""
    polygons = [
        {**{k: v for k, v in p.items() if k != "intensity"}, "color": c}
        for p, c in zip(TINY_SCENE["polygons"], COLOURS, strict=False)
    ]
    size = {k: TINY_SCENE[k] for k in ("width", "height")}
    scene = parse_scene({**size, "background_color": background, "polygons": polygons})
    plan = plan_scene(coverage_scene(scene), DEFAULT)
    tile = TileConfig(DEFAULT, 16, 8, channels=channels)
    result = render_pipeline(plan, "amaranth", tile, canvas=Canvas(scene, DEFAULT.full_scale))
    want = render_scene(plan, canvas=Canvas(scene, DEFAULT.full_scale)).image
    assert result.mismatches == 0 and np.array_equal(result.image, want)
    assert len(set(map(tuple, want.reshape(-1, 4).tolist()))) > 10  # colour, not one grey


COLOURS = ["#ff800099", [0.1, 0.9, 0.5, 0.3], "#0000ff", "#c0c0c001"]  # with alpha


def test_edgeaa_verilog_top_pipeline(tmp_path, capsys):
    from edgeaa.cli import main

    out = tmp_path / "p.v"
    small = ["--coord-bits", "7", "--subpixel-bits", "2", "--intensity-bits", "4"]
    assert main(["verilog", "--top", "pipeline", "--tile", "8x4", *small, "-o", str(out)]) == 0
    assert "module edgeaa_pipeline" in out.read_text()
    assert main(["verilog", "--top", "pipeline", "--tile", "6x4"]) == 2
    assert "power of two" in capsys.readouterr().err
    fast = tmp_path / "fast.v"
    argv = ["verilog", "--top", "pipeline", "--tile", "8x4", *small, "--pipeline", "fast"]
    assert main([*argv, "-o", str(fast)]) == 0
    units = PIPELINES["fast"]["setup_units"]  # the fast pipeline's core has its setup array
    assert f"unit{units - 1}" in fast.read_text() and "unit1" not in out.read_text()


def test_edgeaa_verilog_channels(tmp_path, capsys):
    """`--channels 1|3|4` on `edgeaa verilog --top pipeline`: the colour pipeline's paint
    port (red, green, blue and alpha) and pixel value; refused for the core (and the
    peripheral's intensities above 8 bits), each in one line; the help says it."""
    from edgeaa.cli import main

    small = ["--coord-bits", "7", "--subpixel-bits", "2", "--intensity-bits", "4"]
    for channels in (1, 3, 4):
        out = tmp_path / f"c{channels}.v"
        argv = ["verilog", "--top", "pipeline", "--tile", "8x4", *small, "-o", str(out)]
        assert main([*argv, "--channels", str(channels)]) == 0
        text = out.read_text()
        assert ("commands__payload__paint" in text) == (channels > 1)
        assert re.search(rf"output \[{4 * channels - 1}:0\] pixels__payload__value", text)
        if channels > 1:
            assert re.search(r"input \[15:0\] commands__payload__paint", text)
    capsys.readouterr()
    for argv, message in [
        (["--top", "peripheral", "--intensity-bits", "9"], "--top peripheral writes 8-bit"),
        (["--channels", "3"], "--channels sets the polygon pipeline's pixel"),
        (["--top", "pipeline", "--channels", "2"], "invalid choice: 2 (choose from 1, 3, 4)"),
    ]:
        assert main(["verilog", *argv]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and message in err and "Traceback" not in err, err
    with pytest.raises(SystemExit):
        main(["verilog", "--help"])
    assert "--channels" in capsys.readouterr().out


def test_the_named_configurations():
    fields = ("setup_units", "pixel_lanes", "scan_lanes", "fast_core", "product_stages")
    fields += ("beat_skid",)
    want = {
        "compact": dict(zip(fields, (1, 1, 1, False, 2, False), strict=True)),
        "fast": dict(zip(fields, (4, 4, 2, True, 2, True), strict=True)),
    }
    assert want == PIPELINES
    assert PipelineConfig.named("fast", TILE) == PipelineConfig(TILE, 4, 4, 2, True, 2, True)
    assert EdgePipeline(PipelineConfig.named("fast", TILE)).skid is not None
    assert EdgePipeline(TILE).skid is None
    with pytest.raises(TypeError, match="beat_skid"):
        PipelineConfig(TILE, beat_skid=1)
    assert PipelineConfig(TILE) == PipelineConfig.named("compact", TILE)
    assert EdgePipeline(PipelineConfig(TILE, 3)).core.setup_units == 3
    assert EdgePipeline(TILE).core.setup_units == 1
    for bad, error in [(0, ValueError), (17, ValueError), (True, TypeError), (2.0, TypeError)]:
        with pytest.raises(error):
            PipelineConfig(TILE, bad)
    assert EdgePipeline(PipelineConfig(TILE, 1, 4)).res.lanes == 4
    assert EdgePipeline(TILE).res.lanes == 1
    for bad, error in [(0, ValueError), (3, ValueError), (8, ValueError), (True, TypeError)]:
        with pytest.raises(error):
            PipelineConfig(TILE, 1, bad)
    fast = EdgePipeline(PipelineConfig.named("fast", TILE))
    assert (fast.acc.lanes, fast.res.scan_lanes) == (2, 2)
    assert (EdgePipeline(TILE).acc.lanes, EdgePipeline(TILE).res.scan_lanes) == (1, 1)
    for bad, error in [(0, ValueError), (4, ValueError), (True, TypeError), (2.0, TypeError)]:
        with pytest.raises(error, match="scan_lanes"):
            PipelineConfig(TILE, 1, 2, bad)
    # two scan lanes read and write two pixel lanes (of two, or the pair of four they pick)
    with pytest.raises(ValueError, match="scan_lanes 2 needs at least 2 pixel_lanes, not 1"):
        PipelineConfig(TILE, 1, 1, 2)
    assert EdgePipeline(PipelineConfig(TILE, 1, 4, 2)).res.scan_lanes == 2
    with pytest.raises(ValueError, match="no pipeline named"):
        PipelineConfig.named("quick")
    # the fast core and compact's: both deltas steppers 4 deep, with p3
    assert fast.core.format is DELTAS_FAST and EdgePipeline(TILE).core.format is DELTAS
    assert fast.core.stepper.latency == DELTAS_FAST.pipeline_depth(TILE.config) == 4
    assert (fast.res.product_stages, EdgePipeline(TILE).res.product_stages) == (2, 2)
    for bad in (0, 3):
        with pytest.raises(ValueError, match=r"product_stages must be one of \(1, 2\), not"):
            PipelineConfig(TILE, product_stages=bad)
    assert EdgePipeline(TILE).core.stepper.latency == DELTAS.pipeline_depth(TILE.config) == 4
    for bad in (1, 0, "yes", None):
        with pytest.raises(TypeError, match="fast_core must be True or False"):
            PipelineConfig(TILE, fast_core=bad)


# -- the compiled pipeline (Verilator) -----------------------------------------------------------


@pytest.mark.parametrize("name", BUILTINS)
def test_verilator_renders_every_builtin_to_the_renderers_image(name):
    plan = plan_scene(builtin(name, DEFAULT), DEFAULT)
    result = render_pipeline(plan, "verilator", TILE)
    assert result.mismatches == 0 and result.engine == "verilator"
    assert np.array_equal(result.image, render_scene(plan).image)
    run = result.pipeline
    assert run.errors == run.edge_errors == 0
    assert len(run.pixels) == expected_pixels(TILE, scene_commands(plan, TILE))
    assert run.stats["resolve_stall"] == 0  # the harness's sink is always ready


@pytest.mark.parametrize("name", BUILTINS)
def test_the_fast_pipeline_renders_every_builtin_to_the_renderers_image(name):
    plan = plan_scene(builtin(name, DEFAULT), DEFAULT)
    result = render_pipeline(plan, "verilator", PipelineConfig.named("fast", TILE))
    assert result.mismatches == 0 and result.pipeline.errors == result.pipeline.edge_errors == 0
    assert np.array_equal(result.image, render_scene(plan).image)


# Each configuration is a Verilator build (about 15 s of CPU): the tests below share them.
# Four units with four pixel lanes and two scan lanes (fast), one unit with four pixel lanes,
# one with two pixel lanes and one scan lane.
LANE_BUILDS = [(4, 4, 2), (1, 4, 1), (1, 2, 1)]  # (setup units, pixel lanes, scan lanes)


@settings(max_examples=15, deadline=None, database=None)
@given(data=st.data(), seed=st.integers(0, 2**31))
def test_two_setup_units_under_back_pressure_give_the_renderers_image(data, seed):
    scene = data.draw(small_scenes(DEFAULT))
    pipeline = PipelineConfig(TileConfig(DEFAULT, 16, 8), 2)
    plan = plan_scene(scene, DEFAULT)
    result = render_pipeline(plan, "verilator", pipeline, seed=seed, idle=0.3, stall=0.4)
    assert result.mismatches == 0, f"seed {seed}"


@settings(max_examples=12, deadline=None, database=None)
@given(data=st.data(), seed=st.integers(0, 2**31), build=st.sampled_from(LANE_BUILDS))
def test_pixel_lanes_under_back_pressure_give_the_renderers_image(data, seed, build):
    """A flush of two or four pixels a clock (with two, a scan of one or two cells a clock),
    the sink stalling at random: every pixel in its place, the renderer's image."""
    units, lanes, scan = build
    scene = data.draw(small_scenes(DEFAULT))
    pipeline = PipelineConfig(TileConfig(DEFAULT, 16, 8), units, lanes, scan)
    plan = plan_scene(scene, DEFAULT)
    result = render_pipeline(plan, "verilator", pipeline, seed=seed, idle=0.3, stall=0.4)
    assert result.mismatches == 0, f"seed {seed}, {units} units, {lanes} lanes, {scan} scan"
    assert result.pipeline.stats["resolve_stall"] > 0


@pytest.mark.parametrize("scan", [1, 2])
@settings(max_examples=2, deadline=None, database=None)
@given(data=st.data(), seed=st.integers(0, 2**31))
def test_two_lanes_of_four_channels_under_back_pressure_are_the_canvas(scan, data, seed):
    """Two pixels of red, green, blue and alpha a beat (64 bits of values), scanned one or two
    cells a clock (each: two scenes)."""
    scene = colour_scene(data, data.draw(small_scenes(DEFAULT)))
    plan = plan_scene(coverage_scene(scene), DEFAULT)
    pipeline = PipelineConfig(TileConfig(DEFAULT, 16, 8, channels=4), 1, 2, scan)
    canvas = Canvas(scene, DEFAULT.full_scale)
    result = render_pipeline(plan, "verilator", pipeline, seed=seed, idle=0.3, stall=0.4,
                             canvas=canvas)  # fmt: skip
    want = render_scene(plan, canvas=Canvas(scene, DEFAULT.full_scale)).image
    assert result.mismatches == 0 and np.array_equal(result.image, want), f"seed {seed}"


@pytest.mark.parametrize(("build", "seed"), zip(LANE_BUILDS, [1, 2, 3], strict=True))
def test_pixel_lanes_drop_bad_commands_as_the_model_does(build, seed):
    from edgeaa.sim.simulators import pipeline_harness

    tile = TileConfig(SMALL, 8, 8)
    commands = bad_commands(SMALL.subpixel_scale)
    want, result = model_frames(tile, commands)
    pipeline = PipelineConfig(tile, *build)
    lanes = pipeline.pixel_lanes
    run = pipeline_harness.run(pipeline, commands, seed=seed, idle=0.3, stall=0.3)
    assert (run.errors, run.edge_errors) == (result.errors, result.edge_errors)
    for frame, model in zip(run.frames(tile), want, strict=True):
        assert np.array_equal(frame, model), f"{build} (units, lanes, scan), seed {seed}"
    clock, last = (run.pixels[:, PIXEL_COLUMNS.index(n)] for n in ("clock", "last"))
    assert np.flatnonzero(last).tolist() == [tile.pixels - 1, 2 * tile.pixels - 1]
    beats = clock.reshape(-1, lanes)  # a beat's pixels share its clock, each beat its own
    assert (beats == beats[:, :1]).all() and len(set(beats[:, 0])) == len(beats)


def test_a_beat_of_pixel_lanes_is_split_into_its_pixels():
    from edgeaa.sim.simulators.pipeline_harness import beat_columns, pixel_rows

    assert beat_columns(2) == ("x", "y", "value", "value1", "last")
    beats = [[5, 2, 3, 10, 11, 0], [6, 4, 3, 12, 13, 1]]  # clock, x, y, value, value1, last
    assert pixel_rows(beats, 2).tolist() == [
        [5, 2, 3, 10, 0],
        [5, 3, 3, 11, 0],
        [6, 4, 3, 12, 0],
        [6, 5, 3, 13, 1],
    ]


@pytest.mark.parametrize("seed", [1, 2])
def test_the_fast_pipeline_drops_bad_commands_as_the_model_does(seed):
    from edgeaa.sim.simulators import pipeline_harness

    tile = TileConfig(SMALL, 8, 8)
    commands = bad_commands(SMALL.subpixel_scale)
    want, result = model_frames(tile, commands)
    fast = PipelineConfig.named("fast", tile)  # the lanes test's build
    run = pipeline_harness.run(fast, commands, seed=seed, idle=0.3, stall=0.3)
    assert (run.errors, run.edge_errors) == (result.errors, result.edge_errors), f"seed {seed}"
    for frame, model in zip(run.frames(tile), want, strict=True):
        assert np.array_equal(frame, model), f"seed {seed}"


@settings(max_examples=25, deadline=None, database=None)
@given(data=st.data(), seed=st.integers(0, 2**31))
def test_verilator_under_back_pressure_gives_the_renderers_image_on_random_scenes(data, seed):
    scene = data.draw(small_scenes(DEFAULT))
    tile = TileConfig(DEFAULT, 16, 8)
    plan = plan_scene(scene, DEFAULT)
    result = render_pipeline(plan, "verilator", tile, seed=seed, idle=0.3, stall=0.4)
    assert result.mismatches == 0, f"seed {seed}"


@settings(max_examples=15, deadline=None, database=None)
@given(data=st.data(), seed=st.integers(0, 2**31))
def test_verilator_renders_random_colour_scenes_as_the_canvas_under_back_pressure(data, seed):
    """Three and four channels: each polygon's paint and alpha composited per channel in the
    hardware, the canvas's image (`edgeaa.render.paint`) bit for bit."""
    channels = data.draw(st.sampled_from([3, 4]))
    scene = colour_scene(data, data.draw(small_scenes(DEFAULT)), channels)
    plan = plan_scene(coverage_scene(scene), DEFAULT)
    tile = TileConfig(DEFAULT, 16, 8, channels=channels)
    canvas = Canvas(scene, DEFAULT.full_scale)
    result = render_pipeline(plan, "verilator", tile, seed=seed, idle=0.3, stall=0.4, canvas=canvas)
    want = render_scene(plan, canvas=Canvas(scene, DEFAULT.full_scale)).image
    assert result.mismatches == 0 and np.array_equal(result.image, want), f"seed {seed}"


@pytest.mark.parametrize("seed", [1, 2])
def test_verilator_drops_bad_commands_as_the_model_does(seed):
    from edgeaa.sim.simulators import pipeline_harness

    tile = TileConfig(SMALL, 8, 8)
    commands = bad_commands(SMALL.subpixel_scale)
    want, result = model_frames(tile, commands)
    run = pipeline_harness.run(tile, commands, seed=seed, idle=0.3, stall=0.3)
    assert (run.errors, run.edge_errors) == (result.errors, result.edge_errors), f"seed {seed}"
    for frame, model in zip(run.frames(tile), want, strict=True):
        assert np.array_equal(frame, model), f"seed {seed}"
    last = run.pixels[:, PIXEL_COLUMNS.index("last")]
    assert np.flatnonzero(last).tolist() == [tile.pixels - 1, 2 * tile.pixels - 1]


def test_a_cached_pipeline_build_is_found_without_generating_the_verilog(monkeypatch, tmp_path):
    """`edgeaa render --engine verilator` looks its build up by the sources' key: once built,
    no Verilog is generated again (it takes seconds); a changed source is a new key."""
    from edgeaa.sim.simulators import harness, pipeline_harness

    tile = TileConfig(EdgeConfig())
    exe = pipeline_harness.build(tile)
    monkeypatch.setattr(harness, "_BUILT", {})  # as a new process

    def refuse(*args, **kwargs):
        raise AssertionError("the Verilog was generated again for a cached build")

    monkeypatch.setattr(pipeline_harness, "pipeline_verilog", refuse)
    assert pipeline_harness.build(tile) == exe
    key = harness.sources_key(("pipeline", tile), harness.OPTIMIZE)
    assert harness.sources_key(("pipeline", tile), "-O3") != key
    assert (
        harness.sources_key(("pipeline", TileConfig(EdgeConfig(), 32, 32)), harness.OPTIMIZE) != key
    )
    source = tmp_path / "source.py"  # one more source folder, then a change in it
    source.write_text("A = 1\n")
    monkeypatch.setattr(harness, "SOURCE_DIRS", (*harness.SOURCE_DIRS, tmp_path))
    before = harness.sources_key(("pipeline", tile), harness.OPTIMIZE)
    source.write_text("A = 2\n")
    assert harness.sources_key(("pipeline", tile), harness.OPTIMIZE) != before


@pytest.mark.parametrize("channels", [3, 4])
def test_verilator_drops_bad_colour_commands_as_the_model_does(channels):
    """Bad commands in colour, each begin and tile with a random paint (any alpha: the
    hardware composites each channel the same way): the model's frames, per channel."""
    import random

    from edgeaa.sim.simulators import pipeline_harness

    rng = random.Random(channels)
    tile = TileConfig(SMALL, 8, 8, channels=channels)
    top = 1 << (4 * SMALL.intensity_bits)  # red, green, blue and alpha
    commands = [c._replace(paint=rng.randrange(top)) for c in bad_commands(SMALL.subpixel_scale)]
    want, result = model_frames(tile, commands)
    run = pipeline_harness.run(tile, commands, seed=channels, idle=0.3, stall=0.3)
    assert (run.errors, run.edge_errors) == (result.errors, result.edge_errors)
    for frame, model in zip(run.frames(tile), want, strict=True):
        assert frame.shape == (8, 8, channels) and np.array_equal(frame, model)
    assert len({tuple(p) for f in want for p in f.reshape(-1, channels).tolist()}) > 2


def test_a_pipeline_that_stops_moving_is_reported_not_waited_for():
    from edgeaa.sim.simulators import pipeline_harness

    plan = plan_scene(parse_scene(TINY_SCENE), DEFAULT)
    commands = scene_commands(plan, TILE)
    with pytest.raises(PipelineHang, match="pixels"):
        pipeline_harness.run(TILE, commands, max_quiet=8)  # setup alone takes longer


def test_the_amaranth_engine_renders_a_small_scene_through_the_pipeline():
    plan = plan_scene(parse_scene(TINY_SCENE), DEFAULT)
    result = render_pipeline(plan, "amaranth", TileConfig(DEFAULT, 16, 8))
    assert result.mismatches == 0 and result.pipeline.engine == "amaranth"
    assert np.array_equal(result.image, render_scene(plan).image)


def test_the_amaranth_engine_renders_through_four_pixel_lanes_under_back_pressure():
    """The Amaranth runner reads the fast pipeline's beats of four pixels (`pixel_rows`)."""
    plan = plan_scene(parse_scene(TINY_SCENE), DEFAULT)
    fast = PipelineConfig.named("fast", TileConfig(DEFAULT, 16, 8))
    assert (fast.pixel_lanes, fast.scan_lanes) == (4, 2)
    result = render_pipeline(plan, "amaranth", fast, seed=5, idle=0.2, stall=0.4)
    assert result.mismatches == 0 and result.pipeline.engine == "amaranth"
    assert np.array_equal(result.image, render_scene(plan).image)
    assert result.pipeline.stats["resolve_stall"] > 0


def test_edgeaa_render_engine_verilator_writes_the_pipelines_png(tmp_path, capsys):
    from edgeaa.cli import main

    out = tmp_path / "text.png"
    args = ["render", "--builtin", "text", "--engine", "verilator", "--tile", "16x8"]
    assert main([*args, "-o", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "pipeline (verilator)" in text and "M clocks/s" in text, text
    assert main(["render", "--builtin", "text", "--tile", "16x8"]) == 2
    assert "--engine verilator" in capsys.readouterr().err
    assert main([*args, "--pipeline", "fast", "-o", str(out), "--quiet", "--json"]) == 0
    figures = json.loads(capsys.readouterr().out)
    assert figures["pipeline_setup_units"] == PIPELINES["fast"]["setup_units"]
    assert figures["pipeline_mismatches"] == 0


def test_a_bad_tile_is_refused_before_the_scene_is_planned(capsys, monkeypatch):
    from edgeaa import render
    from edgeaa.cli import main

    def no_planning(*args, **kwargs):
        raise AssertionError("the scene was planned before --tile was checked")

    monkeypatch.setattr(render, "plan_scene", no_planning)
    args = ["render", "--builtin", "text", "--engine", "verilator", "--tile", "6x4"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "--tile: must be" in err and "'6x4'" in err and "power of two" in err, err
    assert len(err.splitlines()) == 1, err


def test_pixels_out_of_place_are_reported():
    """`PipelineRun.frames` checks every pixel's place and ``last``, not only the values."""
    from edgeaa.sim.simulators import pipeline_harness

    tile = TileConfig(SMALL, 8, 8)  # built for the bad-command tests too
    commands = [Command.tile(0, 0, 3), Command.flush(), Command.flush()]
    run = pipeline_harness.run(tile, commands, seed=2, idle=0.3, stall=0.3)
    want, _ = model_frames(tile, commands)
    assert [f.tolist() for f in run.frames(tile)] == [np.asarray(f).tolist() for f in want]
    x, last = PIXEL_COLUMNS.index("x"), PIXEL_COLUMNS.index("last")
    for column, row, value, match in [
        (x, 9, 0, r"pixel 9 is at \(0, 1\) with last 0; .* has \(1, 1\) with last 0"),
        (last, 5, 1, r"pixel 5 is at \(5, 0\) with last 1"),
        (last, 63, 0, r"pixel 63 is at \(7, 7\) with last 0; .* with last 1"),
    ]:
        pixels = run.pixels.copy()
        pixels[row, column] = value
        with pytest.raises(RuntimeError, match=match):
            replace(run, pixels=pixels).frames(tile)
    with pytest.raises(RuntimeError, match="127 pixels are not whole 8 x 8 tiles"):
        replace(run, pixels=run.pixels[:-1]).frames(tile)


@pytest.mark.parametrize("name", ["text", "starburst"])
def test_the_savings_rows_are_what_the_hardware_scanned(name):
    """The resolve takes a cell per cell scanned and one op per tile and flush, and reads a
    pixel a clock in a flush, some in the same clocks (a flush reads the other pixel memory
    while the next tile resolves): the model's cells scanned (`pipeline_savings`) are the
    cycle model's, whose busy clocks (the takes and reads, those together counted once) are
    the hardware's counter, fewer than all of them apart."""
    plan = plan_scene(builtin(name, DEFAULT), DEFAULT)
    commands = scene_commands(plan, TILE)
    run = render_pipeline(plan, "verilator", TILE).pipeline
    savings = {s.rule.split(" (")[0]: s for s in pipeline_savings(plan, TILE)}
    tiles = len(run.pixels) // TILE.pixels
    scanned = savings["clear as each cell is read"].clocks
    timing = pipeline_cycles(TILE, commands)
    assert timing.tile.cells_scanned == scanned
    busy = run.stats["resolve_busy"]
    assert busy == timing.stats["resolve_busy"] < scanned + tiles * (TILE.pixels + 2)
    assert savings["tile rows with no delta"].skipped > 0
    assert savings["columns of a touched row outside the scan span"].skipped > 0
