# amaranth: UnusedElaboratable=no
"""The tile stages in Amaranth's simulator (`TileAccumulator` into `TileResolve`) against
`edgeaa.model.tile`: with an eager source and an always-ready sink every transfer in the
clock `tile_cycles` gives and every frame equal; with random source idles and sink stalls
the same frames, a stalled pixel held. Ops from random beats (back-to-back deltas to one
cell, cells left of the tile, rows summing to zero, every fill rule, empty polygons, D = 0)
and from scenes."""

from __future__ import annotations

import random

import numpy as np
import pytest
from fixtures import TINY_SCENE
from tile_bench import StageRun, Stages, run_stages

from edgeaa.hdl.accumulator import TileAccumulator
from edgeaa.hdl.resolve import TileResolve
from edgeaa.model import EdgeConfig
from edgeaa.model.tile import (
    FLUSH_START,
    Beats,
    Flush,
    PolygonEnd,
    Scan,
    TileConfig,
    TileModel,
    TileOverflow,
    TileStart,
    resolve_latency,
    tile_cells,
    tile_cycles,
)
from edgeaa.render import parse_scene, plan_scene, render_scene
from edgeaa.render.pipeline import render_tiles, tile_jobs, tile_ops

SMALL = EdgeConfig(coord_bits=7, subpixel_bits=2, intensity_bits=4)
DEFAULT = EdgeConfig()


def test_the_interfaces():
    tile = TileConfig(SMALL, 8, 4)
    acc, res = TileAccumulator(tile), TileResolve(tile)
    assert set(acc.signature.members) == {"ops", "cells", "scanning", "busy"}
    assert set(res.signature.members) == {"cells", "pixels", "flushing"}
    assert acc.cells.signature.flip() == res.cells.signature
    assert res.latency == resolve_latency(tile) == SMALL.intensity_bits + 3
    colour = TileResolve(TileConfig(SMALL, 8, 4, channels=3))
    assert colour.latency == SMALL.intensity_bits + 4  # the alpha stage
    assert set(Stages(tile).signature.members) == {"ops", "pixels"}


def _polygon(rng: random.Random, tile: TileConfig, config: EdgeConfig, origin):
    full = config.full_scale
    intensity, i_out = rng.randint(0, full), rng.randint(0, full)
    ifix = max(abs(intensity - i_out), 1) << config.F
    anchors = [_anchor(rng, tile, origin) for _ in range(2)]
    beats = []
    for _ in range(rng.choice([0, 1, 3, 8, 14])):
        x, y = rng.choice(anchors) if rng.random() < 0.6 else _anchor(rng, tile, origin)
        shape = rng.random()
        if shape < 0.4:  # x-major: a 2 x 2 block; y-major: four cells of a row
            places = [(x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1)]
        elif shape < 0.8:
            places = [(x + k, y) for k in range(4)]
        else:  # any four cells, repeats included (back-to-back deltas to one cell)
            places = [(x + rng.randint(-1, 1), y + rng.randint(0, 1)) for _ in range(4)]
        rng.shuffle(places)
        deltas = [rng.choice([0, rng.randint(-ifix // 8, ifix // 8), ifix, -ifix]) for _ in places]
        beats.append([(px, py, d) for (px, py), d in zip(places, deltas, strict=True)])
    if rng.random() < 0.5:  # closed rows: each delta taken back further right (the scan
        shift = rng.randint(1, 2)  # may stop at the polygon's last column)
        beats += [[(px + shift, py, -d) for px, py, d in beat] for beat in beats]
    rule = rng.choice(["nonzero", "evenodd"])
    return Beats(np.array(beats, dtype=np.int64).reshape(-1, 4, 3)), PolygonEnd(
        intensity, i_out, rule
    )


def _anchor(rng: random.Random, tile: TileConfig, origin) -> tuple[int, int]:
    return origin[0] + rng.randint(-5, tile.width), origin[1] + rng.randint(-2, tile.height)


def random_ops(tile: TileConfig, config: EdgeConfig, seed: int) -> list:
    """Tiles of random polygons (each within the cells' exact range), each flushed."""
    rng = random.Random(seed)
    ops = []
    for _ in range(2):
        origin = (rng.randint(0, 5), rng.randint(0, 3))
        ops.append(TileStart(*origin, rng.randint(0, config.full_scale)))
        for _ in range(rng.randint(1, 4)):
            while True:
                beats, end = _polygon(rng, tile, config, origin)
                polygon = [beats, end] if rng.random() < 0.9 else [beats, beats, end]
                try:  # keep polygons whose sums fit the cells
                    TileModel(tile).run([TileStart(*origin, 0), *polygon])
                    break
                except TileOverflow:
                    continue
            ops += polygon
        ops.append(Flush())
    return ops


def check_exact(tile: TileConfig, ops, lanes: int = 1, product_stages: int = 1) -> StageRun:
    run = run_stages(tile, ops, lanes=lanes, product_stages=product_stages)
    want = tile_cycles(tile, ops, lanes, product_stages)
    assert run.accepts == want.accepts, "op clocks differ from tile_cycles"
    assert run.cells == want.cells, "cell clocks differ from tile_cycles"
    assert [p[0] for p in run.pixels] == want.pixels, "pixel clocks differ from tile_cycles"
    got = run.frames(tile)
    assert len(got) == len(want.frames)
    for k, (frame, model) in enumerate(zip(got, want.frames, strict=True)):
        assert np.array_equal(frame, model), f"frame {k}:\n{frame}\nmodel:\n{model}"
    coords = [(p[1], p[2]) for p in run.pixels[: tile.pixels]]
    assert coords == [(x, y) for y in range(tile.height) for x in range(tile.width)]
    assert [p[4] for p in run.pixels].count(1) == len(want.frames)
    return run


CASES = [
    (TileConfig(SMALL, 8, 4), 1),
    (TileConfig(SMALL, 4, 2), 2),
    (TileConfig(SMALL, 16, 4, headroom_bits=0), 3),
    (TileConfig(DEFAULT, 8, 4), 4),
]


@pytest.mark.parametrize(
    ("tile", "seed"),
    CASES,
    ids=lambda v: (
        str(v)
        if isinstance(v, int)
        else f"{v.width}x{v.height}h{v.headroom_bits}i{v.config.intensity_bits}"
    ),
)
def test_random_beats_clock_for_clock(tile, seed):
    for k in range(3):
        check_exact(tile, random_ops(tile, tile.config, 10 * seed + k))


@pytest.mark.parametrize("tile", [TileConfig(SMALL, 8, 4), TileConfig(DEFAULT, 8, 4)])
def test_the_product_over_two_clocks_gives_the_same_pixels_a_clock_later(tile):
    """`product_stages` 2 (the fast pipeline's resolve: its I x I products' rows split over
    two clocks): every pixel the model's and every transfer in `tile_cycles`' clocks, which
    the one-clock product's latency does not match."""
    ops = random_ops(tile, tile.config, 21)
    run = check_exact(tile, ops, product_stages=2)
    assert [p[0] for p in run.pixels] != tile_cycles(tile, ops).pixels


@pytest.mark.parametrize("seed", [7, 8])
def test_two_lanes_take_a_pair_of_cells_a_clock_clock_for_clock(seed):
    """Two lanes (a memory bank per column parity): a beat's cells go in by pairs, a clash
    (two cells of one bank) in two clocks, two cells of one cell added; random beats of any
    four cells (repeats, cells left of the tile, odd origins) as `tile_cycles` says."""
    tile = TileConfig(SMALL, 8, 4)
    seen = {"clash": 0, "one cell": 0}
    for k in range(3):
        ops = random_ops(tile, SMALL, 10 * seed + k)
        check_exact(tile, ops, lanes=2, product_stages=2)  # the fast pipeline's stages
        for kind in _pair_kinds(tile, ops):
            seen[kind] = seen.get(kind, 0) + 1
    assert seen["clash"] and seen["one cell"], seen  # both cases were driven


@pytest.mark.parametrize("seed", [7, pytest.param(8, marks=pytest.mark.slow)])
def test_four_lanes_take_a_cell_a_bank_a_clock_clock_for_clock(seed):
    """Four lanes (a memory bank per column modulo 4): every bank takes a cell a clock, the
    cells at one cell added, as many clocks as the busiest bank's cells; random beats of any
    four cells as `tile_cycles` says, the cells and pixels bit for bit."""
    tile = TileConfig(SMALL, 8, 4)
    busiest = set()
    for k in range(3):
        ops = random_ops(tile, SMALL, 10 * seed + k)
        check_exact(tile, ops, lanes=4, product_stages=2)
        model = TileModel(tile, 4)
        for op in ops:
            if isinstance(op, Beats):
                busiest.update(model.beat_clocks(op.cells).tolist())
            model.feed(op)
    assert {1, 2} <= busiest, busiest  # a beat in one clock and a bank with two cells driven


def _pair_kinds(tile: TileConfig, ops):
    """Per pair of nonzero kept cells of every beat: "clash" (one bank, two cells), "one
    cell" (both at one cell) or "two banks"."""
    origin = (0, 0)
    for op in ops:
        if isinstance(op, TileStart):
            origin = (op.x0, op.y0)
        for beat in op.cells.tolist() if isinstance(op, Beats) else []:
            for a, b in ((0, 1), (2, 3)):
                placed = [tile_cells(tile, origin, *([v] for v in beat[j])) for j in (a, b)]
                if all(len(tx) for tx, _, _ in placed):  # both nonzero and kept
                    (xa, ya), (xb, yb) = ((int(tx[0]), int(ty[0])) for tx, ty, _ in placed)
                    same = (xa, ya) == (xb, yb)
                    yield "one cell" if same else "clash" if xa % 2 == xb % 2 else "two banks"


def test_back_to_back_polygons_with_no_gap_wait_for_the_pixels_below():
    tile = TileConfig(SMALL, 4, 2)
    ifix = 15 << SMALL.F
    one = Beats(np.array([[[0, 0, ifix], [1, 0, -ifix], [0, 1, ifix // 2], [1, 1, -ifix // 2]]]))
    ops = [TileStart(0, 0, 0), one, PolygonEnd(15, 0), one, PolygonEnd(7, 0), PolygonEnd(3, 9)]
    ops += [one, PolygonEnd(9, 9), Flush(), TileStart(1, 0, 5), Flush()]
    check_exact(tile, ops)


def test_a_flush_goes_out_while_the_next_tile_resolves():
    """Two pixel memories: the next tile's start and its polygon's cells are taken while the
    flush sends the last tile's pixels, which stay the last tile's; the next flush waits
    for the last pixel."""
    tile = TileConfig(SMALL, 8, 4)
    ifix = 15 << SMALL.F
    one = Beats(np.array([[[1, 0, ifix], [2, 0, -ifix], [1, 1, ifix], [2, 1, -ifix]]]))
    ops = [TileStart(0, 0, 0), one, PolygonEnd(15, 0), Flush(), TileStart(8, 0, 6)]
    ops += [Beats(one.cells + [8, 0, 0]), PolygonEnd(9, 6), Flush()]
    check_exact(tile, ops)
    timing = tile_cycles(tile, ops)
    first, second = timing.pixels[: tile.pixels], timing.pixels[tile.pixels :]
    resolved = [c for c in timing.cells if first[0] <= c <= first[-1]]
    # the second polygon's two rows over its span (columns 1 and 2), within the flush
    assert len(resolved) == 2 * 2
    assert second[0] == first[-1] + FLUSH_START
    assert timing.frames[0][0, 1] == 15 and timing.frames[1][0, 1] == 9


def _block(x, y, deltas):
    """A beat of a 2 x 2 block at (x, y): deltas of (x, y), (x + 1, y), (x, y + 1), (x + 1,
    y + 1)."""
    places = [(x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1)]
    return [(px, py, d) for (px, py), d in zip(places, deltas, strict=True)]


def test_the_scan_stops_at_the_polygons_last_column_on_a_zero_sum():
    """Touched rows read from lo to hi, on to the last column when the sum through hi is
    nonzero (a tile's first scan of a row too: the pixels hold their written flags): a stop
    in a middle row, on the last row (a clock later), at lo == hi, cells left of the tile,
    after a flush."""
    tile = TileConfig(SMALL, 8, 4)
    a, b = 15 << SMALL.F, 7 << SMALL.F
    closed = Beats(np.array([_block(3, 0, [a, -a, b, -b])]))
    ops = [TileStart(2, 0, 3), closed, PolygonEnd(15, 0), closed, PolygonEnd(9, 0)]
    ops += [Beats(np.array([_block(4, 1, [a, a, b, -b])])), PolygonEnd(12, 2, "evenodd")]
    once = [Beats(np.array([_block(6, 0, [a, 0, 0, 0]), _block(6, 0, [-a, 0, 0, 0])]))]
    ops += [*once, PolygonEnd(15, 0), Beats(np.array([_block(0, 1, [a, -a, b, -b])]))]
    ops += [PolygonEnd(5, 11), closed, PolygonEnd(4, 4), Flush(), closed, PolygonEnd(15, 0)]
    ops += [closed, PolygonEnd(0, 15), Flush()]
    check_exact(tile, ops)
    model = TileModel(tile)
    scans = [model.feed(op) for op in ops]
    stop, on = (2, True), (6, False)  # columns 1 and 2, stopping; columns 2 to 7
    assert [s.runs for s in scans if isinstance(s, Scan)] == [
        *[(stop, stop)] * 2,
        (on, stop),
        ((1, True),),
        ((1, True),) * 2,
        *[(stop, stop)] * 3,
    ]


def test_a_scene_through_the_stages_is_the_renderers_image():
    plan = plan_scene(parse_scene(TINY_SCENE), DEFAULT)
    tile = TileConfig(DEFAULT, 16, 8)
    image = np.full((14, 20), 40, dtype=np.int64)
    for job in tile_jobs(plan, tile):
        ops = tile_ops(plan, tile, job)
        run = run_stages(tile, ops)
        assert run.accepts == tile_cycles(tile, ops).accepts
        (frame,) = run.frames(tile)
        h, w = min(8, 14 - job.y), min(16, 20 - job.x)
        image[job.y : job.y + h, job.x : job.x + w] = frame[:h, :w]
    assert np.array_equal(image, render_scene(plan, engine="model").image)
    assert np.array_equal(image, render_tiles(plan, tile))


@pytest.mark.parametrize(
    ("seed", "lanes"),
    [(5, 1), (6, 1), (5, 2), (6, 2), (5, 4), pytest.param(6, 4, marks=pytest.mark.slow)],
)
def test_random_back_pressure_gives_the_same_frames(seed, lanes):
    tile = TileConfig(SMALL, 8, 4)
    ops = random_ops(tile, SMALL, seed)
    run = run_stages(tile, ops, seed=seed, idle=0.3, stall=0.4, lanes=lanes)
    want = tile_cycles(tile, ops, lanes)
    for frame, model in zip(run.frames(tile), want.frames, strict=True):
        assert np.array_equal(frame, model)
    assert len(run.pixels) == len(want.pixels)


def test_the_scans_carry_free_stop_test_is_the_sum_exhaustively():
    """`_sum_is` (the two-lane scan's ``total == 0`` as ``a + b == -base``, no carry chain):
    equal to the modular sum's compare for every a, b and t of 4 bits."""
    import itertools

    from amaranth.hdl import Module, Signal, signed
    from amaranth.sim import Simulator

    from edgeaa.hdl.accumulator import _sum_is

    a, b, t, out = Signal(signed(4)), Signal(signed(4)), Signal(4), Signal()
    m = Module()
    m.d.comb += out.eq(_sum_is(a, b, t))
    wrong = []

    async def bench(ctx):
        for x, y, z in itertools.product(range(-8, 8), range(-8, 8), range(16)):
            ctx.set(a, x)
            ctx.set(b, y)
            ctx.set(t, z)
            if ctx.get(out) != ((x + y - z) % 16 == 0):
                wrong.append((x, y, z))

    sim = Simulator(m)
    sim.add_testbench(bench)
    sim.run()
    assert not wrong, wrong[:5]


def test_four_lanes_stop_test_is_the_sum():
    """`_carry_save` then `_sum_is` (the four-lane scan's ``total == 0``: four cells and the
    base, no carry chain): equal to the modular sum's compare on 4,096 random operands of 4
    bits (seeded), and on every operand with a, b, c and d equal."""
    from amaranth.hdl import Module, Signal, signed
    from amaranth.sim import Simulator

    from edgeaa.hdl.accumulator import _carry_save, _sum_is

    values, t, out = [Signal(signed(4), name=f"v{k}") for k in range(4)], Signal(4), Signal()
    m = Module()
    m.d.comb += out.eq(_sum_is(*_carry_save(values), t))
    rng = random.Random(4)
    cases = [[rng.randrange(-8, 8) for _ in range(4)] + [rng.randrange(16)] for _ in range(4096)]
    cases += [[v] * 4 + [z] for v in range(-8, 8) for z in range(16)]
    wrong = []

    async def bench(ctx):
        for *vs, z in cases:
            for signal, v in zip(values, vs, strict=True):
                ctx.set(signal, v)
            ctx.set(t, z)
            if ctx.get(out) != ((sum(vs) - z) % 16 == 0):
                wrong.append((vs, z))

    sim = Simulator(m)
    sim.add_testbench(bench)
    sim.run()
    assert not wrong, f"seed 4: {wrong[:5]}"
