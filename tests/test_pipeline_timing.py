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
from dataclasses import dataclass, replace

import pytest
from amaranth.sim import Simulator
from fixtures import TINY_SCENE, small_scenes
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from edgeaa.hdl.pipeline import STATS, EdgePipeline, command_const
from edgeaa.model import EdgeConfig, pipeline_timing, timing
from edgeaa.model import tile as tile_model
from edgeaa.model.beat import DELTAS
from edgeaa.model.pipeline import Command, PipelineConfig
from edgeaa.model.pipeline_timing import pipeline_cycles
from edgeaa.model.tile import OPS, RESOLVE_OPS, TileConfig
from edgeaa.render import parse_scene, plan_scene
from edgeaa.render.paint import Canvas, coverage_scene
from edgeaa.render.pipeline import scene_commands
from edgeaa.sim.simulators.pipeline_harness import expected_pixels, pixel_drain_clocks

SMALL = EdgeConfig(coord_bits=7, subpixel_bits=2, intensity_bits=4)
DEFAULT = EdgeConfig()


@dataclass
class Transfers:
    commands: list[int]
    beats: list[int]  # into the accumulator
    cells: list[int]  # into the resolve (cell ops)
    pixels: list[int]
    stats: dict
    clocks: int  # clock 0 to the last transfer, inclusive


def run_transfers(tile: TileConfig | PipelineConfig, commands: list[Command]) -> Transfers:
    """`EdgePipeline` in Amaranth's simulator, commands back to back, the sink always ready:
    the clock of every command taken, delta beat into the accumulator, cell into the resolve
    and pixel out; after the last, the harness's drain (nothing more may move)."""
    dut = EdgePipeline(tile)
    tile, lanes = dut.tile, dut.pipeline.pixel_lanes
    payloads = [command_const(tile, c) for c in commands]
    expected = expected_pixels(tile, commands)
    out = Transfers([], [], [], [], {}, 0)
    beats, cells = dut.acc.ops, dut.acc.cells  # beats: the accumulator's beat ops
    logs = [out.commands, out.pixels, out.beats, out.cells]

    async def bench(ctx):
        ctx.set(dut.pixels.ready, 1)
        clock = quiet = 0
        while len(out.commands) < len(payloads) or len(out.pixels) < expected or quiet < drain:
            assert clock < 200_000, "the pipeline hangs"
            index = len(out.commands)
            offer = index < len(payloads)
            ctx.set(dut.commands.valid, offer)
            if offer:
                ctx.set(dut.commands.payload, payloads[index])
            _, _, taken, pixel, *handshakes = await ctx.tick().sample(
                dut.commands.ready,
                dut.pixels.valid,
                beats.valid,
                beats.ready,
                beats.payload.op,
                cells.valid,
                cells.ready,
                cells.payload.op,
            )
            b_valid, b_ready, b_op, c_valid, c_ready, op = handshakes
            beat = b_valid and b_ready and b_op == OPS.index("beat")
            cell = c_valid and c_ready and op == RESOLVE_OPS.index("cell")
            moved = [offer and taken, pixel, beat, cell]
            for hit, log in zip(moved, logs, strict=True):
                if hit:  # a pixel beat: its lanes' pixels, each in the beat's clock
                    log.extend([clock] * (lanes if log is out.pixels else 1))
            quiet = 0 if any(moved) or len(out.pixels) < expected else quiet + 1
            clock += 1
        out.stats = {name: ctx.get(dut.stats[name]) for name in STATS}
        out.clocks = max([-1, *out.commands, *out.beats, *out.cells, *out.pixels]) + 1

    drain = pixel_drain_clocks(tile)
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


def check_clock_for_clock(
    tile: TileConfig | PipelineConfig, commands, hw: Transfers, label: str
) -> None:
    model = pipeline_cycles(tile, commands)
    for name, got, want in (
        ("command", hw.commands, model.commands),
        ("beat", hw.beats, model.beats),
        ("cell", hw.cells, model.tile.cells),
        ("pixel", hw.pixels, model.pixels),
    ):
        assert list(got) == list(want), f"{label}: {first_difference(name, got, want)}"
    assert hw.stats == model.stats, f"{label}: counters {hw.stats} != model {model.stats}"
    assert hw.clocks == model.clocks, label


# A tile of 16 x 8 at 7.2 bits: scenes of a few tiles, each a few hundred clocks.
SMALL_TILE = TileConfig(SMALL, 16, 8)


def _slow(*values):
    """A parameter set run with ``-m slow`` only (the default run's time: README, "Tests")."""
    return pytest.param(*values, marks=pytest.mark.slow)


# pixel lanes with one or two scan lanes: the default run keeps one of each lane count
SLOW_LANES = [_slow(4, 2, 1, 7), _slow(1, 2, 2, 2), _slow(2, 2, 2, 10)]


def check_scene(scene) -> None:
    commands = scene_commands(plan_scene(scene, SMALL), SMALL_TILE)
    hw = run_transfers(SMALL_TILE, commands)
    check_clock_for_clock(SMALL_TILE, commands, hw, f"scene {scene}")


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scene=small_scenes(SMALL))
def test_random_scenes_go_through_the_hardware_as_the_model_says(scene):
    check_scene(scene)


@pytest.mark.slow
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scene=small_scenes(SMALL))
def test_many_random_scenes_go_through_the_hardware_as_the_model_says(scene):
    check_scene(scene)


def random_commands(rng: random.Random, tile: TileConfig, count: int = 60) -> list[Command]:
    """A stream of tiles, polygons and flushes with every kind of bad command among them:
    unknown codes (in and out of polygons), zero-length edges and I_in == I_out polygons
    (the core's errors), edges with no column in the tile or cut at their start, empty
    polygons, polygons with no end, edges and ends outside a polygon, tiles past 2**W,
    flushes and tiles back to back (an op waiting behind a flush)."""
    config = tile.config
    scale, top = config.subpixel_scale, 1 << config.coord_bits
    limit = (top << config.subpixel_bits) - 1
    origin = (0, 0)
    out: list[Command] = []

    def point():
        x = origin[0] + rng.uniform(-3, tile.width + 3)
        y = origin[1] + rng.uniform(-3, tile.height + 3)
        return [min(max(round(v * scale), 0), limit) for v in (x, y)]

    while len(out) < count:
        kind = rng.choices(["tile", "polygon", "flush", "junk"], [2, 6, 2, 1])[0]
        if kind == "tile":
            bad = rng.random() < 0.15
            origin = (rng.randrange(top - tile.width), rng.randrange(top - tile.height))
            out.append(Command.tile(top + 1 if bad else origin[0], origin[1], rng.randrange(16)))
        elif kind == "flush":
            out.append(Command.flush())
        elif kind == "junk":
            out.append(
                rng.choice([Command(rng.randrange(5, 8)), Command.end(), Command.edge(1, 2, 3, 4)])
            )
        else:
            i_in = rng.randrange(16)
            i_out = i_in if rng.random() < 0.1 else rng.randrange(16)
            out.append(Command.begin(i_in, i_out, rng.choice(["nonzero", "evenodd"])))
            for _ in range(rng.randrange(6)):
                if rng.random() < 0.1:
                    out.append(Command(rng.randrange(5, 8)))
                p0 = point()
                p1 = p0 if rng.random() < 0.1 else point()
                out.append(Command.edge(*p0, *p1, rng.choice(["left", "right"])))
            if rng.random() < 0.85:
                out.append(Command.end())
    return out


@pytest.mark.parametrize("seed", [2, 3, 10])
def test_random_command_streams_with_bad_commands_in_the_models_clocks(seed):
    commands = random_commands(random.Random(seed), SMALL_TILE)
    hw = run_transfers(SMALL_TILE, commands)
    check_clock_for_clock(SMALL_TILE, commands, hw, f"seed {seed}")


COLOUR_TILE = TileConfig(SMALL, 16, 8, channels=3)


@settings(max_examples=2, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_random_colour_scenes_go_through_the_hardware_as_the_model_says(data):
    """Translucent paints in three channels: the channels run side by side, the alpha stage
    is one clock more of the resolve's latency (`resolve_latency`)."""
    unit = st.floats(0, 1)
    scene = data.draw(small_scenes(SMALL))
    polygons = tuple(
        replace(p, paint=tuple(data.draw(unit) for _ in range(4))) for p in scene.polygons
    )
    scene = replace(scene, polygons=polygons, background_paint=(0.2, 0.4, 0.6, 1.0))
    plan = plan_scene(coverage_scene(scene), SMALL)
    commands = scene_commands(plan, COLOUR_TILE, Canvas(scene, SMALL.full_scale))
    hw = run_transfers(COLOUR_TILE, commands)
    check_clock_for_clock(COLOUR_TILE, commands, hw, f"colour scene {scene}")


def test_a_random_colour_command_stream_with_bad_commands_in_the_models_clocks(monkeypatch):
    """Paints of any colour and alpha; the grey latency (no alpha stage) is caught."""
    rng = random.Random(4)
    colours = 1 << (4 * SMALL.intensity_bits)  # red, green, blue and alpha
    commands = [c._replace(paint=rng.randrange(colours)) for c in random_commands(rng, COLOUR_TILE)]
    hw = run_transfers(COLOUR_TILE, commands)
    check_clock_for_clock(COLOUR_TILE, commands, hw, "colour seed 4")
    fast = PipelineConfig.named("fast", COLOUR_TILE)  # lanes, alpha stage and products
    check_clock_for_clock(fast, commands, run_transfers(fast, commands), "fast colour seed 4")
    assert tile_model.resolve_latency(COLOUR_TILE) == SMALL.intensity_bits + 4
    monkeypatch.setattr(
        tile_model, "resolve_latency", lambda tile, stages=1: tile.config.intensity_bits + 3
    )
    with pytest.raises(AssertionError):
        check_clock_for_clock(COLOUR_TILE, commands, hw, "the grey latency in colour")


@pytest.mark.parametrize(("units", "seed"), [(2, 2), _slow(3, 10), (4, 7)])
def test_several_setup_units_in_the_models_clocks(units, seed):
    """The fast pipeline's array of setup units, with the bad commands and the stalls."""
    pipeline = PipelineConfig(SMALL_TILE, units)
    commands = random_commands(random.Random(seed), SMALL_TILE)
    hw = run_transfers(pipeline, commands)
    check_clock_for_clock(pipeline, commands, hw, f"{units} units, seed {seed}")
    assert hw.stats["core_stall"] > 0 and hw.stats["acc_stall"] > 0  # the stall is exercised
    # the single unit's model does not fit the array's clocks
    with pytest.raises(AssertionError):
        check_clock_for_clock(SMALL_TILE, commands, hw, "one unit's model")


@pytest.mark.parametrize(
    ("units", "lanes", "scan", "seed"),
    [(1, 2, 1, 2), (2, 4, 1, 10), (4, 4, 2, 7), (4, 4, 4, 3)] + SLOW_LANES,
)
def test_pixel_lanes_in_the_models_clocks(monkeypatch, units, lanes, scan, seed):
    """A flush of `lanes` pixels a clock and a scan of `scan` cells a clock (the fast
    pipeline's four and two; two scan lanes also take a beat's cells into the accumulator by
    pairs, four a cell a bank), with the bad commands and the stalls: each pixel in its
    beat's clock, each beat of cells in its clock."""
    pipeline = PipelineConfig(SMALL_TILE, units, lanes, scan)
    commands = random_commands(random.Random(seed), SMALL_TILE)
    hw = run_transfers(pipeline, commands)
    label = f"{units} units, {lanes} lanes, {scan} scan lanes, seed {seed}"
    check_clock_for_clock(pipeline, commands, hw, label)
    assert hw.stats["acc_stall"] > 0  # the stall is exercised
    # the model of a flush of one pixel a clock, or of a scan of one cell a clock, does not fit
    other_scan = {1: 2, 2: 1, 4: 2}[scan]
    wrongs = [{"pixel_lanes": 1, "scan_lanes": 1}] + [{"scan_lanes": other_scan}] * (lanes > 1)
    wrongs += [{"pixel_lanes": 2}] * (lanes == 4 and scan == 2)
    for wrong in wrongs:
        with pytest.raises(AssertionError):
            check_clock_for_clock(replace(pipeline, **wrong), commands, hw, f"{wrong}")
    if scan > 1:  # nor does the scan lanes' model with a cell a clock into the accumulator
        one = tile_model.beat_clocks
        monkeypatch.setattr(tile_model.TileModel, "beat_clocks", lambda self, cells: one(cells))
        with pytest.raises(AssertionError):
            check_clock_for_clock(pipeline, commands, hw, "a cell a clock in")


@pytest.mark.parametrize(
    ("units", "lanes", "scan", "seed"),
    [(1, 1, 1, 3), (4, 4, 2, 3), _slow(2, 2, 2, 10), _slow(4, 4, 4, 3)],
)
def test_a_skid_buffer_before_the_accumulator_in_the_models_clocks(units, lanes, scan, seed):
    """The core's beats through a skid buffer (`beat_skid`, the fast pipeline's), with the
    bad commands and the stalls: the stepper hands each beat to the buffer while the
    accumulator takes the one before, and waits only while the buffer holds one. The model of
    the beats straight into the accumulator does not fit."""
    pipeline = PipelineConfig(SMALL_TILE, units, lanes, scan, beat_skid=True)
    commands = random_commands(random.Random(seed), SMALL_TILE)
    hw = run_transfers(pipeline, commands)
    label = f"a skid buffer, {units} units, {lanes} lanes, {scan} scan lanes, seed {seed}"
    check_clock_for_clock(pipeline, commands, hw, label)
    assert hw.stats["core_stall"] > 0 and hw.stats["acc_stall"] > 0  # the stall is exercised
    with pytest.raises(AssertionError):
        check_clock_for_clock(replace(pipeline, beat_skid=False), commands, hw, "no buffer")


@pytest.mark.parametrize("seed", [4, 11])
def test_two_scan_lanes_in_colour_in_the_models_clocks(seed):
    """Two cells a clock through the resolve's colour datapath (an alpha stage per lane)."""
    rng = random.Random(seed)
    colours = 1 << (4 * SMALL.intensity_bits)  # red, green, blue and alpha
    commands = [c._replace(paint=rng.randrange(colours)) for c in random_commands(rng, COLOUR_TILE)]
    pipeline = PipelineConfig(COLOUR_TILE, 2, 2, 2)
    hw = run_transfers(pipeline, commands)
    check_clock_for_clock(pipeline, commands, hw, f"colour, two scan lanes, seed {seed}")
    with pytest.raises(AssertionError):
        check_clock_for_clock(replace(pipeline, scan_lanes=1), commands, hw, "one scan lane")


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scene=small_scenes(SMALL))
def test_random_scenes_in_the_fast_pipeline_as_the_model_says(scene):
    pipeline = PipelineConfig.named("fast", SMALL_TILE)
    commands = scene_commands(plan_scene(scene, SMALL), SMALL_TILE)
    check_clock_for_clock(pipeline, commands, run_transfers(pipeline, commands), f"{scene}")


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scene=small_scenes(SMALL))
def test_random_scenes_with_two_setup_units_as_the_model_says(scene):
    pipeline = PipelineConfig(SMALL_TILE, 2)
    commands = scene_commands(plan_scene(scene, SMALL), SMALL_TILE)
    check_clock_for_clock(pipeline, commands, run_transfers(pipeline, commands), f"{scene}")


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(100, 140))
def test_many_random_command_streams_in_the_models_clocks(seed):
    commands = random_commands(random.Random(seed), SMALL_TILE, count=150)
    hw = run_transfers(SMALL_TILE, commands)
    check_clock_for_clock(SMALL_TILE, commands, hw, f"seed {seed}")


def test_the_tiny_scene_at_the_default_configuration():
    tile = TileConfig(DEFAULT, 16, 8)
    commands = scene_commands(plan_scene(parse_scene(TINY_SCENE), DEFAULT), tile)
    hw = run_transfers(tile, commands)
    check_clock_for_clock(tile, commands, hw, "tiny scene")
    assert hw.stats["core_stall"] > 0 and hw.stats["acc_stall"] > 0  # the stall is exercised


WRONG_SEED = 5  # a stream where every wrong model below shows


@pytest.fixture(scope="module")
def wrong_model_run():
    commands = random_commands(random.Random(WRONG_SEED), SMALL_TILE)
    return commands, run_transfers(SMALL_TILE, commands)


WRONG_WAITS = {
    "no_wait": lambda valid, sink_ready, hold: 0,  # beats before the accumulator is ready
    "beat_a_clock": lambda valid, sink_ready, hold: max(0, sink_ready - valid),  # no cell a clock
}


# A constant one clock off, or the stall not modelled (beats before the accumulator is ready,
# or taken a beat a clock, not a nonzero cell a clock).
WRONG = ["SCAN_START", "EMPTY_END", "FLUSH_START", "pipeline_depth", "BAD_COMMAND_CYCLES"]
WRONG += ["EMPTY_EDGE_CYCLES"]


@pytest.mark.parametrize("wrong", [*WRONG, "resolve_latency", *WRONG_WAITS])
def test_a_wrong_model_is_caught(wrong_model_run, monkeypatch, wrong):
    commands, hw = wrong_model_run
    check_clock_for_clock(SMALL_TILE, commands, hw, "the right model")
    stages = PipelineConfig(SMALL_TILE).product_stages  # the pipeline `run_transfers` builds
    latency = tile_model.resolve_latency(SMALL_TILE, stages) + 1
    for module in (timing, tile_model, pipeline_timing):
        if wrong in WRONG_WAITS and hasattr(module, "beat_wait"):
            monkeypatch.setattr(module, "beat_wait", WRONG_WAITS[wrong])
        elif wrong == "resolve_latency" and hasattr(module, wrong):
            monkeypatch.setattr(module, wrong, lambda tile, stages=1: latency)
        elif wrong == "pipeline_depth" and hasattr(module, wrong):  # the deltas core's, + 1
            depth = getattr(module, wrong)
            monkeypatch.setattr(
                module, wrong, lambda config, fmt, depth=depth: depth(config, fmt) + 1
            )
        elif hasattr(module, wrong):
            monkeypatch.setattr(module, wrong, getattr(module, wrong) + 1)
    with pytest.raises(AssertionError):
        check_clock_for_clock(SMALL_TILE, commands, hw, f"{wrong} one off")


@pytest.mark.parametrize(
    ("name", "pipeline", "scan_lanes"),
    [
        ("text", "compact", 1),
        ("text", "fast", 2),
        ("starburst", "compact", 1),
        pytest.param("starburst", "fast", 2, marks=pytest.mark.slow),
        pytest.param("hatch", "compact", 1, marks=pytest.mark.slow),
        pytest.param("hatch", "fast", 2, marks=pytest.mark.slow),
        pytest.param("text", "fast", 4, marks=pytest.mark.slow),
        pytest.param("starburst", "fast", 4, marks=pytest.mark.slow),
    ],
)
def test_verilator_runs_the_builtins_in_the_models_clocks(name, pipeline, scan_lanes):
    from edgeaa.render import builtin
    from edgeaa.sim.simulators import pipeline_harness

    tile = TileConfig(DEFAULT)
    commands = scene_commands(plan_scene(builtin(name, DEFAULT), DEFAULT), tile)
    tile = replace(PipelineConfig.named(pipeline, tile), scan_lanes=scan_lanes)
    run = pipeline_harness.run(tile, commands)
    model = pipeline_cycles(tile, commands)
    got = run.pixels[:, 0]
    assert list(run.commands) == model.commands, first_difference(
        "command", run.commands, model.commands
    )
    assert list(got) == model.pixels, first_difference("pixel", got, model.pixels)
    assert run.stats == model.stats
    assert run.clocks == model.clocks + pixel_drain_clocks(tile.tile)


def test_schedule_without_idles_or_a_stall_is_the_back_to_back_one():
    rng = random.Random(5)
    for _ in range(50):
        shapes = [
            None if rng.random() < 0.1 else (rng.choice([0, 1, 3, 40]), rng.random() < 0.3)
            for _ in range(rng.randrange(1, 8))
        ]
        plain = timing.schedule(SMALL, shapes, fmt=DELTAS)
        zero = timing.schedule(SMALL, shapes, fmt=DELTAS, idle=[0] * len(shapes))
        assert plain == zero == timing.schedule(SMALL, shapes, fmt=DELTAS, sink_ready=0)
        late = plain[-1].accepted + 1000  # after every beat would be valid
        stalled = timing.schedule(SMALL, shapes, fmt=DELTAS, sink_ready=late)
        beats = [b for t in stalled for b in t.beats]
        assert beats == sorted(set(beats)) and all(b >= late for b in beats), shapes
        # the setup runs on while the stepper waits until it holds an edge the stall keeps
        # from finishing (the deltas stepper takes the bank when it steps the last column):
        # the first good edge, or the next when the first has at most D columns (stepped
        # before the stall); the commands up to that one are accepted as with a ready sink
        good = [k for k, shape in enumerate(shapes) if shape and shape[0]]
        short = good and shapes[good[0]][0] <= timing.pipeline_depth(SMALL, DELTAS)
        held = (good[1:2] if short else good[:1]) or [len(shapes)]
        same = held[0] + 1
        assert [t.accepted for t in stalled[:same]] == [t.accepted for t in plain[:same]]
        if same < len(shapes):
            assert stalled[same].accepted >= late, shapes
