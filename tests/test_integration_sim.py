# amaranth: UnusedElaboratable=no
"""The core and the pipeline as an integrator drives them (docs/hardware.md, "Integration"),
in the Amaranth simulator.

Reset: while ``rst`` is high the input stream's ready is low, so a command offered during
reset is not taken; one clock of reset drops every edge in flight and clears the error
counter (and the pipeline's counters); from the clock after the first reset clock no output
is valid; after reset the block works.

Clip port values past the model's range (bounds up to ``2**(W + 1) - 1``): the core steps
the window `Clip.from_port` gives, checked against the model's `window` on the raw bounds
and against the core's beats."""

from __future__ import annotations

import random
from dataclasses import replace

import pytest
from amaranth.hdl import ClockDomain, Module
from amaranth.sim import Simulator
from core_bench import observed_beat
from fixtures import CORE_CONFIGS

from edgeaa.hdl import LineCore
from edgeaa.hdl.layouts import pixel_value_fields
from edgeaa.hdl.pipeline import STATS, EdgePipeline, command_const
from edgeaa.model import Clip, Edge, EdgeConfig, EdgeError, run_edge
from edgeaa.model.column import IntArith
from edgeaa.model.edge import fold, window
from edgeaa.model.pipeline import CODE, Command, PipelineConfig, command_ops
from edgeaa.model.tile import TileConfig, TileModel
from edgeaa.sim.simulators.amaranth_runner import decoder
from edgeaa.sim.simulators.commands import edge_command
from edgeaa.sim.verification.scoreboard import edge_beats

CONFIG = CORE_CONFIGS["small"]  # W 4, s 0, I 4: 17 x 17 pixels
RESET_CLOCKS = 4


def _with_domain(dut):
    """`dut` in a module with an explicit sync domain, so a testbench can drive its rst."""
    m = Module()
    m.domains.sync = domain = ClockDomain()
    m.submodules.dut = dut
    return m, domain


class _Core:
    """One clock at a time of the core: offer a command, take beats, log what happened."""

    def __init__(self, ctx, dut, domain):
        self.ctx, self.dut, self.domain = ctx, dut, domain
        self.decode = decoder(dut.writes.payload.shape())
        self.beats, self.log = [], []

    async def clock(self, edge: Edge | None, *, rst: int = 0, clip: dict | None = None) -> bool:
        """One clock with `edge` offered (None: nothing) with its window, or the raw port
        values `clip`, and an always-ready sink; returns whether the edge was taken."""
        ctx, dut = self.ctx, self.dut
        ctx.set(self.domain.rst, rst)
        ctx.set(dut.edges.valid, edge is not None)
        ctx.set(dut.writes.ready, 1)
        if edge is not None:
            command = edge_command(dut.config, edge)
            ctx.set(dut.edges.payload, command.payload)
            ctx.set(dut.clip, command.clip if clip is None else clip)
        taken = edge is not None and bool(ctx.get(dut.edges.ready))
        valid = bool(ctx.get(dut.writes.valid))
        if valid:
            self.beats.append(observed_beat(self.decode(ctx.get(dut.writes.payload.as_value()))))
        self.log.append((rst, taken, valid, ctx.get(dut.errors)))
        await ctx.tick()
        return taken

    async def send(self, edge: Edge, clip: dict | None = None) -> None:
        while not await self.clock(edge, clip=clip):
            pass


def test_core_reset_takes_nothing_drops_edges_in_flight_and_clears_errors():
    dut = LineCore(CONFIG)
    top, domain = _with_domain(dut)
    long_edge = Edge(0, 0, 15, 7, i_out=0)  # 16 columns
    bad = Edge(3, 3, 3, 3, i_in=5, i_out=0)  # zero length: dropped and counted
    after = Edge(2, 9, 14, 1, inside="right", i_in=9, i_out=2)
    result = {}

    async def bench(ctx):
        core = _Core(ctx, dut, domain)
        await core.send(bad)
        await core.send(long_edge)
        while len(core.beats) < 3:  # the long edge is stepping
            await core.clock(None)
        result["before"] = (len(core.beats), ctx.get(dut.errors))
        mark = len(core.log)
        for _ in range(RESET_CLOCKS):
            await core.clock(after, rst=1)
        result["reset"] = core.log[mark:]
        result["kept"] = len(core.beats)
        await core.send(after)
        for _ in range(60):
            await core.clock(None)
        result["after"] = core.beats[result["kept"] :]
        result["errors"] = ctx.get(dut.errors)

    sim = Simulator(top)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    assert result["before"][1] == 1, "the bad command was counted before the reset"
    reset = result["reset"]
    assert not any(taken for _, taken, _, _ in reset), f"a command was taken in reset: {reset}"
    assert not any(valid for _, _, valid, _ in reset[1:]), f"a beat after reset's first: {reset}"
    assert all(errors == 0 for *_, errors in reset[1:]), reset
    # The long edge's remaining columns are gone: after the reset only `after`'s beats.
    assert result["after"] == edge_beats(run_edge(CONFIG, after))
    assert result["errors"] == 0


def _pipeline_bench(dut, domain, tile, result):

    async def clock(ctx, command, rst=0):
        ctx.set(domain.rst, rst)
        ctx.set(dut.commands.valid, command is not None)
        ctx.set(dut.pixels.ready, 1)
        if command is not None:
            ctx.set(dut.commands.payload, command_const(tile, command))
        taken = command is not None and bool(ctx.get(dut.commands.ready))
        pixel = ctx.get(dut.pixels.payload) if ctx.get(dut.pixels.valid) else None
        counters = (ctx.get(dut.errors), *(ctx.get(dut.stats[name]) for name in STATS))
        await ctx.tick()
        return taken, pixel, counters

    async def bench(ctx):
        junk = Command(CODE["end"])  # an end outside a polygon: dropped and counted
        while not (await clock(ctx, junk))[0]:
            pass
        for _ in range(3):
            await clock(ctx, None)
        result["before"] = ctx.get(dut.errors)
        flush = Command(CODE["flush"])
        result["reset"] = [await clock(ctx, flush, rst=1) for _ in range(RESET_CLOCKS)]
        for command in (Command(CODE["tile"], 0, 0, i_in=6), flush):
            while not (await clock(ctx, command))[0]:
                pass
        pixels = []
        for _ in range(4 * tile.width * tile.height):
            _, pixel, counters = await clock(ctx, None)
            if pixel is not None:
                pixels.append(pixel.value)
        result["pixels"], result["errors"] = pixels, counters[0]

    return bench


def test_pipeline_reset_takes_nothing_and_clears_the_counters():
    tile = TileConfig(CONFIG, 8, 4)
    dut = EdgePipeline(tile)
    top, domain = _with_domain(dut)
    result = {}
    sim = Simulator(top)
    sim.add_clock(1e-6)
    sim.add_testbench(_pipeline_bench(dut, domain, tile, result))
    sim.run()
    assert result["before"] == 1
    reset = result["reset"]
    assert not any(taken for taken, _, _ in reset), "a command was taken in reset"
    assert all(pixel is None for _, pixel, _ in reset), "a pixel came out in reset"
    assert all(not any(counters) for *_, counters in reset[1:]), [c for *_, c in reset]
    # After the reset the pipeline works: a flushed tile is its background.
    assert result["pixels"] == [6] * (tile.width * tile.height)
    assert result["errors"] == 0


def _reset_mid_polygon_bench(dut, domain, tile, first, wait, second, result):
    """Offer `first`, wait `wait` clocks, reset for RESET_CLOCKS, then offer `second`;
    collect the pixels after the reset (each beat's lanes)."""
    fields = pixel_value_fields(dut.pipeline.pixel_lanes)

    async def offer(ctx, commands):
        for command in commands:
            ctx.set(dut.commands.valid, 1)
            ctx.set(dut.commands.payload, command_const(tile, command))
            while True:
                *_, taken, valid, pixel = await ctx.tick().sample(
                    dut.commands.ready, dut.pixels.valid, dut.pixels.payload
                )
                if valid:
                    result["pixels"].extend(int(pixel[name]) for name in fields)
                if taken:
                    break
        ctx.set(dut.commands.valid, 0)

    async def bench(ctx):
        ctx.set(dut.pixels.ready, 1)
        await offer(ctx, first)
        await ctx.tick().repeat(wait)
        ctx.set(domain.rst, 1)
        for _ in range(RESET_CLOCKS):  # (`repeat` would raise DomainReset)
            await ctx.tick()
        ctx.set(domain.rst, 0)
        result["pixels"] = []
        await offer(ctx, second)
        for _ in range(6 * tile.pixels + 300):
            *_, valid, pixel = await ctx.tick().sample(
                dut.commands.ready, dut.pixels.valid, dut.pixels.payload
            )
            if valid:
                result["pixels"].extend(int(pixel[name]) for name in fields)

    return bench


@pytest.mark.parametrize("scan", [1, 2], ids=["one scan lane", "two scan lanes"])
@pytest.mark.parametrize(
    "tail, wait",
    [([], 200), (["end"], 6), (["end"], 200), (["end", "flush"], 12), (["end", "flush"], 200)],
    ids=[
        "open polygon, its beats in the memory",
        "in the end's scan",
        "resolved, its pixels in the memory",
        "in the flush",
        "resolved in both pixel memories",
    ],
)
def test_pipeline_reset_mid_polygon_leaves_no_delta_behind(tail, wait, scan):
    """A reset while a polygon's deltas are in the accumulation memory (the polygon open, or
    its scan under way): they are cleared (with two scan lanes, a beat of the banked
    memory a clock); while its pixels are in a pixel memory (resolved, or being flushed):
    none of them shows in the next scene, whose first tile starts with no tile command (the
    reset's tile, background 0): their written flags are swept. So the next scene is the
    model's image of that scene alone (its polygons cover fewer pixels than the first's)."""
    tile = TileConfig(CONFIG, 8, 4)
    tri = [(1, 0, 7, 3), (7, 3, 0, 3), (0, 3, 1, 0)]
    first = [Command.tile(0, 0, 3), Command.begin(15, 3)]
    first += [Command.edge(*e) for e in tri] + [getattr(Command, op)() for op in tail]
    if tail == ["end", "flush"] and wait > 100:  # the other memory written too
        first += [Command.tile(0, 0, 4), Command.begin(9, 4)]
        first += [Command.edge(*e) for e in tri] + [Command.end()]
    # two tiles: the first with no tile command (the reset's: background 0), the second in
    # the memory the first scene's flush side had
    second = []
    for background, box in [(0, (2, 0, 6, 3)), (5, (3, 1, 5, 2))]:
        x0, y0, x1, y1 = box
        second += [Command.tile(0, 0, background)] * (background > 0)
        second += [Command.begin(12, background)]
        second += [Command.edge(x0, y0, x1, y1), Command.edge(x1, y1, x0, y1)]
        second += [Command.edge(x0, y1, x0, y0), Command.end(), Command.flush()]
    frames = TileModel(tile).run(command_ops(tile, second).ops)
    dut = EdgePipeline(PipelineConfig(tile, 1, scan, scan))
    top, domain = _with_domain(dut)
    result = {"pixels": []}
    sim = Simulator(top)
    sim.add_clock(1e-6)
    sim.add_testbench(_reset_mid_polygon_bench(dut, domain, tile, first, wait, second, result))
    sim.run()
    assert result["pixels"] == [int(v) for frame in frames for v in frame.ravel()]


# -- clip port values past 2**W --------------------------------------------------------------

# Sub-pixel bits, so that an edge can have a column at 2**W (a vertex past 2**W - 1/2).
CLIP_CONFIG = EdgeConfig(coord_bits=4, subpixel_bits=2, intensity_bits=4)
PORT_MAX = (1 << (CLIP_CONFIG.coord_bits + 1)) - 1  # 31: the clip ports are W + 1 = 5 bits


def _raw_windows(rng: random.Random, count: int) -> list[tuple[int, int, int, int]]:
    """Windows with at least one bound past 2**W, biased to the interesting values."""
    top = 1 << CLIP_CONFIG.coord_bits
    picks = [0, 1, top - 1, top, top + 1, PORT_MAX, None, None]
    windows = []
    while len(windows) < count:
        bounds = tuple(
            rng.randrange(PORT_MAX + 1) if (p := rng.choice(picks)) is None else p for _ in range(4)
        )
        if max(bounds) > top:
            windows.append(bounds)
    return windows


def _edges(rng: random.Random, count: int) -> list[Edge]:
    hi = CLIP_CONFIG.max_vertex
    edges = []
    while len(edges) < count:
        x0, y0, x1, y1 = (rng.choice((0, 1, hi - 1, hi, rng.randint(0, hi))) for _ in range(4))
        if (x0, y0) != (x1, y1):
            side = rng.choice(("left", "right"))
            edges.append(Edge(x0, y0, x1, y1, inside=side, i_in=rng.randint(1, 15), i_out=0))
    return edges


def _columns(edge: Edge, clip: Clip) -> tuple:
    """The model's columns of `edge` in window `clip` (any bounds: `window` on raw ints)."""
    f = fold(
        IntArith(), CLIP_CONFIG, edge.x0, edge.y0, edge.x1, edge.y1, 1, 0, edge.inside == "left"
    )
    w = window(IntArith(), f, clip)
    return (w.first, w.last, w.start_clip) if w.first <= w.last else ()


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_clip_from_port_is_the_models_window_on_the_raw_bounds(seed):
    rng = random.Random(seed)
    for edge, bounds in zip(_edges(rng, 400), _raw_windows(rng, 400), strict=True):
        port = Clip.from_port(CLIP_CONFIG, *bounds)
        assert max(port) <= 1 << CLIP_CONFIG.coord_bits, (seed, bounds)
        assert _columns(edge, Clip(*bounds)) == _columns(edge, port), (seed, edge, bounds)


def test_clip_from_port_keeps_bounds_in_range_and_refuses_what_a_port_cannot_carry():
    assert Clip.from_port(CLIP_CONFIG, 0, 3, 16, 9) == Clip(0, 3, 16, 9)
    assert Clip.from_port(CLIP_CONFIG, 2, 17, 31, 20) == Clip(2, 1, 16, 0)
    with pytest.raises(EdgeError, match=r"clip port y_max must be an integer in \[0, 31\]"):
        Clip.from_port(CLIP_CONFIG, 0, 0, 0, 32)


def test_the_core_steps_clip_from_port_for_bounds_past_2_to_the_w():
    seed = 7
    rng = random.Random(seed)
    cases = list(zip(_edges(rng, 40), _raw_windows(rng, 40), strict=True))
    dut = LineCore(CLIP_CONFIG)
    top, domain = _with_domain(dut)
    got = []

    async def bench(ctx):
        core = _Core(ctx, dut, domain)
        for edge, bounds in cases:
            mark = len(core.beats)
            await core.send(edge, dict(zip(Clip._fields, bounds, strict=True)))
            for _ in range(80):  # longer than a start-clipped setup and 17 columns
                await core.clock(None)
            got.append(core.beats[mark:])

    sim = Simulator(top)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    for (edge, bounds), beats in zip(cases, got, strict=True):
        model = replace(edge, clip=Clip.from_port(CLIP_CONFIG, *bounds))
        assert beats == edge_beats(run_edge(CLIP_CONFIG, model)), f"seed {seed}: {edge} {bounds}"
    assert sum(map(len, got)) > 40, "most windows cut nothing away: the test sees beats"
