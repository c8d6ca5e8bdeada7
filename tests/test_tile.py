"""The tile model (`edgeaa.model.tile`): the renderer's image through tiles of every size on
the built-ins and on hypothesis scenes, the resolve's integer composite against the
renderer's operator, a zero prefix sum leaving a pixel (the scan span), the cells' exact
range."""

from __future__ import annotations

import itertools
import random

import numpy as np
import pytest
from fixtures import small_scenes
from hypothesis import given, settings
from hypothesis import strategies as st

from edgeaa.model import EdgeConfig
from edgeaa.model.accumulate import (
    FILL_RULES,
    alpha_coverage,
    composite,
    fill,
    intensity_offset,
)
from edgeaa.model.pipeline import command_ops
from edgeaa.model.tile import (
    Beats,
    Flush,
    PolygonEnd,
    TileConfig,
    TileModel,
    TileOverflow,
    TileStart,
    alpha_steps,
    beat_clocks,
    composite_steps,
)
from edgeaa.render import builtin, plan_scene, render_scene
from edgeaa.render.builtin import BUILTINS
from edgeaa.render.pipeline import render_tiles, scene_commands

DEFAULT = EdgeConfig()
SMALL = EdgeConfig(coord_bits=7, subpixel_bits=2, intensity_bits=4)


@pytest.mark.parametrize("name", ["starburst", "text"])
@pytest.mark.parametrize("size", [(64, 32), (16, 8), (512, 256)])
def test_the_tiles_give_the_renderers_image_on_the_builtins(name, size):
    plan = plan_scene(builtin(name, DEFAULT), DEFAULT)
    want = render_scene(plan, engine="model").image
    got = render_tiles(plan, TileConfig(DEFAULT, *size))
    assert np.array_equal(got, want)


@pytest.mark.parametrize("config", [DEFAULT, SMALL], ids=["default", "small"])
@settings(max_examples=60, deadline=None, database=None)
@given(data=st.data())
def test_the_tiles_give_the_renderers_image_on_random_scenes(config, data):
    scene = data.draw(small_scenes(config))
    tile = TileConfig(
        config, data.draw(st.sampled_from([4, 8, 64])), data.draw(st.sampled_from([2, 4, 32]))
    )
    plan = plan_scene(scene, config)
    assert np.array_equal(render_tiles(plan, tile), render_scene(plan, engine="model").image)


def test_the_resolves_division_is_the_renderers_composite_everywhere_at_4_bits():
    full = 15
    for below, intensity, i_out in itertools.product(range(full + 1), repeat=3):
        d = abs(intensity - i_out)
        for q in range(1, d + 1):
            want = int(composite(below, q, intensity, d))
            assert composite_steps(below, q, intensity, d, 4) == want, (below, q, intensity, d)


def test_the_resolves_division_is_the_renderers_composite_at_8_and_16_bits():
    rng = random.Random(3)
    for bits in (8, 16):
        full = (1 << bits) - 1
        for _ in range(20000):
            below, intensity, i_out = (rng.randint(0, full) for _ in range(3))
            d = abs(intensity - i_out) or 1
            q = rng.choice([1, d, rng.randint(1, d)])
            want = int(composite(below, q, intensity, d))
            assert composite_steps(below, q, intensity, d, bits) == want


@pytest.mark.parametrize("bits", range(1, 13))
def test_the_resolves_alpha_stage_is_the_canvass_rounding_everywhere(bits):
    """round(q A / full) half up with no divider (`alpha_steps`), every q and A in [0,
    full], up to 12 bits; wider at random below."""
    full = (1 << bits) - 1
    q, alpha = np.meshgrid(np.arange(full + 1), np.arange(full + 1))
    want = alpha_coverage(q, alpha, full)
    assert np.array_equal(alpha_steps(q, alpha, bits), want), bits
    assert want.max() == full and (want <= q).all()


@pytest.mark.parametrize("bits", [13, 14, 15, 16])
def test_the_resolves_alpha_stage_at_random_up_to_16_bits(bits):
    rng = np.random.default_rng(bits)
    full = (1 << bits) - 1
    q, alpha = rng.integers(0, full + 1, (2, 200_000))
    q[:100], alpha[:100] = full, rng.integers(0, full + 1, 100)  # the largest products
    want = alpha_coverage(q, alpha, full)
    assert np.array_equal(alpha_steps(q, alpha, bits), want), f"seed {bits}"


def _ops(tile: TileConfig, cells, end: PolygonEnd):
    return [
        TileStart(0, 0, 0),
        Beats(np.array(cells, dtype=np.int64).reshape(-1, 4, 3)),
        end,
        Flush(),
    ]


@pytest.mark.parametrize("rule", FILL_RULES)
def test_a_zero_prefix_sum_leaves_every_pixel_as_it_is(rule):
    """What the scan span relies on: the columns it does not read (prefix sum 0) would have
    been composited with coverage 0, which changes no pixel."""
    for config in (SMALL, DEFAULT):
        full, F = config.full_scale, config.F
        for d in range(1, full + 1):
            q = int(intensity_offset(fill(np.zeros(1, np.int64), rule, d << F), F)[0])
            assert q == 0
            below = np.arange(full + 1)
            for intensity in {0, d, full - d, full}:
                assert np.array_equal(composite(below, q, intensity, d), below)


def test_a_cell_left_of_the_tile_goes_into_the_first_column_and_others_are_dropped():
    tile = TileConfig(SMALL, 4, 2)
    ifix = 15 << SMALL.F
    cells = [(-3, 0, ifix), (-2, 0, 0), (-1, 0, 0), (0, 0, 0)]  # a row's four cells
    cells += [(9, 1, -ifix), (10, 1, -ifix), (9, 2, -ifix), (10, 2, -ifix)]  # right, below
    cells += [(1, -1, ifix), (2, -1, ifix), (1, 0, 0), (2, 0, 0)]  # above
    (frame,) = TileModel(tile).run(_ops(tile, cells, PolygonEnd(15, 0)))
    assert frame.tolist() == [[15, 15, 15, 15], [0, 0, 0, 0]]


def test_a_prefix_sum_past_the_cells_range_is_refused():
    tile = TileConfig(SMALL, 4, 2, headroom_bits=0)
    ifix = 15 << SMALL.F
    fits = [(0, 0, ifix), (1, 0, ifix - 1), (2, 0, 1 - 2 * ifix), (3, 0, -2 * ifix)]
    TileModel(tile).run(_ops(tile, fits, PolygonEnd(15, 0)))  # 2 ifix - 1, then -2 ifix
    for bad in ((1, 0, ifix), (3, 0, -2 * ifix - 1)):
        cells = [bad if cell[0] == bad[0] else cell for cell in fits]
        with pytest.raises(TileOverflow, match="exact range"):
            TileModel(tile).run(_ops(tile, cells, PolygonEnd(15, 0)))


@settings(max_examples=30, deadline=None, database=None)
@given(data=st.data())
def test_two_scan_lanes_read_whole_beats_and_leave_the_frames(data):
    """A scan of two cells a clock (`PipelineConfig.scan_lanes`) reads each row's one-lane
    span widened to whole beats, stops at ``hi``'s beat unless it is the row's last, and
    gives the same frames."""
    scene = data.draw(small_scenes(SMALL))
    tile = TileConfig(SMALL, 8, 4)
    ops = command_ops(tile, scene_commands(plan_scene(scene, SMALL), tile)).ops
    one, two = TileModel(tile), TileModel(tile, 2)
    last = tile.width - 1
    for op in ops:
        rows = np.flatnonzero(one.touched) if isinstance(op, PolygonEnd) else []
        spans = [(one.span(row), two.span(row)) for row in rows]
        a, b = one.feed(op), two.feed(op)
        if isinstance(op, Flush):
            assert np.array_equal(a, b)
        for (f1, l1, s1), (f2, l2, s2) in spans:
            assert (f2, l2, s2) == (f1 - f1 % 2, l1 | 1, s1 and (l1 | 1) != last), scene
        if isinstance(op, PolygonEnd):
            assert b.cells == 2 * b.beats == sum(l2 - f2 + 1 for _, (f2, l2, _) in spans)
    for bad in (0, 3, 16, 2.0):
        with pytest.raises(ValueError, match="scan_lanes"):
            TileModel(tile, bad)


def test_two_lanes_take_a_beats_cells_by_pairs():
    """`beat_clocks` with two lanes: a clock per pair (0, 1), (2, 3) with a nonzero cell, two
    for a pair that clashes (both kept, one bank, two cells); cells moved into the first
    column, dropped or zero do not clash."""
    tile, d = TileConfig(SMALL, 8, 4), 5
    beats = [
        [(2, 0, d), (3, 0, d), (2, 1, d), (3, 1, d)],  # x-major block: a clock a pair
        [(4, 1, d), (5, 1, d), (6, 1, 0), (7, 1, 0)],  # the second pair all zero: skipped
        [(4, 1, 0), (5, 1, 0), (6, 1, 0), (7, 1, 0)],  # no nonzero cell: one clock
        [(2, 0, d), (4, 0, d), (3, 1, d), (3, 2, d)],  # both pairs clash
        [(-3, 2, d), (-1, 2, d), (-1, 2, d), (0, 2, d)],  # all into column 0 of row 2
        [(-1, 1, d), (-1, 2, d), (2, 0, d), (2, 9, d)],  # column 0, two rows; one dropped
        [(1, 0, d), (3, 0, 0), (1, 0, d), (9, 0, d)],  # a zero and one right of the tile
    ]
    cells = np.array(beats)
    assert beat_clocks(cells).tolist() == [4, 2, 1, 4, 4, 4, 3]
    assert beat_clocks(cells, 2, tile).tolist() == [2, 1, 1, 4, 2, 3, 2]
    # the bank is the tile's column: moved into column 0 the cell's parity is the origin's
    moved = np.array([[(-1, 0, d), (1, 0, d), (0, 0, 0), (0, 0, 0)]])
    assert [beat_clocks(moved, 2, tile, (x, 0)).tolist() for x in (0, -1, -2)] == [[1], [2], [2]]
    with pytest.raises(ValueError, match="2 or 4 with the tile"):
        beat_clocks(cells, 2)


def test_four_lanes_take_a_cell_a_bank_a_clock():
    """`beat_clocks` with four lanes (a bank per column modulo 4): a clock for a beat with a
    nonzero cell, or as many as its busiest bank's different kept cells; cells at one cell
    add into one write; cells dropped or zero take none of their own."""
    tile, d = TileConfig(SMALL, 8, 4), 5
    beats = [
        [(0, 0, d), (1, 0, d), (2, 0, d), (3, 0, d)],  # four banks: one clock
        [(4, 1, d), (5, 1, d), (4, 2, d), (5, 2, d)],  # two rows of two columns: two
        [(7, 1, d), (7, 1, d), (0, 0, 0), (0, 0, 0)],  # one cell twice: one write
        [(0, 0, d), (4, 0, d), (0, 1, d), (4, 1, d)],  # four cells of bank 0: four
        [(-1, 1, d), (-2, 1, d), (0, 2, d), (1, 9, d)],  # column 0 twice, row 2; one dropped
        [(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0)],  # no nonzero cell: one clock
        [(9, 0, d), (1, 9, d), (0, 0, 0), (0, 0, 0)],  # both dropped: one clock
    ]
    cells = np.array(beats)
    assert beat_clocks(cells, 4, tile).tolist() == [1, 2, 1, 4, 2, 1, 1]
    # the bank is the tile's column: moved into column 0 a cell is in bank 0 wherever it was
    moved = np.array([[(-1, 0, d), (3, 0, d), (0, 0, 0), (0, 0, 0)]])
    assert [beat_clocks(moved, 4, tile, (x, 0)).tolist() for x in (0, -1)] == [[1], [2]]
    with pytest.raises(ValueError, match="4 with the tile"):
        beat_clocks(cells, 4)


@settings(max_examples=50, deadline=None)
@given(
    st.lists(
        st.tuples(*[st.tuples(st.integers(-3, 10), st.integers(-2, 5), st.integers(-2, 2))] * 4),
        min_size=1,
        max_size=8,
    )
)
def test_four_lanes_never_take_more_clocks_than_two(beats):
    tile = TileConfig(SMALL, 8, 4)
    cells = np.array(beats, dtype=np.int64)
    assert (beat_clocks(cells, 4, tile) <= beat_clocks(cells, 2, tile)).all()


def _pair_clocks(tile: TileConfig, plan):
    """Check that every beat the stepper makes for `plan` takes, with two lanes, a clock per
    pair with a nonzero cell (none clashes); returns (beats, clocks)."""
    model, beats, clocks = TileModel(tile, 2), 0, 0
    for op in command_ops(tile, scene_commands(plan, tile)).ops:
        if isinstance(op, Beats):
            nonzero = op.cells[:, :, 2] != 0
            want = np.maximum(nonzero[:, :2].any(1) * 1 + nonzero[:, 2:].any(1), 1)
            assert model.beat_clocks(op.cells).tolist() == want.tolist()
            beats, clocks = beats + len(op.cells), clocks + int(want.sum())
        model.feed(op)
    return beats, clocks


@pytest.mark.parametrize("name", BUILTINS)
def test_the_steppers_beats_never_clash(name):
    """A stepper's beat is two neighbouring columns of a row a pair, or both moved into the
    tile's first column: with two lanes, a clock per pair with a nonzero cell."""
    plan = plan_scene(builtin(name, DEFAULT), DEFAULT)
    beats, clocks = _pair_clocks(TileConfig(DEFAULT, 16, 8), plan)
    assert beats < clocks < 2 * beats, name  # some beats take two clocks, not all


@settings(max_examples=30, deadline=None, database=None)
@given(data=st.data())
def test_the_steppers_beats_never_clash_on_random_scenes(data):
    scene = data.draw(small_scenes(SMALL))
    _pair_clocks(TileConfig(SMALL, 8, 4), plan_scene(scene, SMALL))


def test_bad_tile_sizes_are_refused():
    for kwargs in ({"width": 6}, {"width": 2}, {"height": 1}, {"headroom_bits": -1}):
        with pytest.raises(ValueError, match="must be"):
            TileConfig(DEFAULT, **kwargs)
