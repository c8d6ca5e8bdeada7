"""The clip window in the model: the visible columns of an edge, computed from scratch.

With the exact accumulator a clipped edge's writes are exactly the unclipped edge's columns
whose major-axis pixel lies in the window (the start state at any column is the exact value
the loop would have reached). The truncated accumulator restarts its truncation at the first
visible column, so there the check is the bound, not equality.
"""

from __future__ import annotations

import dataclasses

import pytest
from fixtures import GEOMETRY_CONFIGS, slope_edges
from hypothesis import given, settings
from hypothesis import strategies as st

from edgeaa.model import Clip, Edge, EdgeConfig, EdgeError, run_edge, setup
from edgeaa.model import timing as timing_model
from edgeaa.model.vector import run_edges

MODES = ("pw", "paper", "seg2", "seg4")


def visible(config: EdgeConfig, edge: Edge, clip: Clip):
    """The unclipped edge's columns whose primary pixel is inside the window's major axis."""
    result = run_edge(config, edge)
    lo, hi = (clip.x_min, clip.x_max) if result.setup.x_major else (clip.y_min, clip.y_max)
    major = (lambda w: w.x) if result.setup.x_major else (lambda w: w.y)
    return [column for column in result.columns if lo <= major(column[0]) <= hi]


@st.composite
def windows(draw, config: EdgeConfig) -> Clip:
    """Windows of all kinds: empty, one column wide, cutting either end, the full range."""
    top = 1 << config.coord_bits
    bound = st.one_of(st.sampled_from((0, 1, top - 1, top)), st.integers(0, top))
    x_min, x_max, y_min, y_max = (draw(bound) for _ in range(4))
    if draw(st.integers(0, 9)):  # mostly non-empty
        x_min, x_max = sorted((x_min, x_max))
        y_min, y_max = sorted((y_min, y_max))
    return Clip(x_min, y_min, x_max, y_max)


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("config_name", sorted(GEOMETRY_CONFIGS))
@settings(max_examples=150, deadline=None)
@given(data=st.data())
def test_clipped_edge_is_the_visible_part_of_the_edge(config_name, mode, data):
    config = dataclasses.replace(GEOMETRY_CONFIGS[config_name], mode=mode)
    edge = data.draw(slope_edges(config, max_pixels=40))
    clip = data.draw(windows(config))
    clipped = dataclasses.replace(edge, clip=clip)
    result = run_edge(config, clipped)
    assert result.columns == visible(config, edge, clip)
    assert result.setup.columns == len(result.columns)
    assert run_edges(config, [clipped]).writes() == result.writes


@settings(max_examples=200, deadline=None)
@given(data=st.data())
def test_clipped_start_flag_and_timing(data):
    config = EdgeConfig()
    edge = data.draw(slope_edges(config, max_pixels=40))
    clip = data.draw(windows(config))
    clipped = dataclasses.replace(edge, clip=clip)
    full, cut = setup(config, edge), setup(config, clipped)
    shown = visible(config, edge, clip)
    assert cut.columns == len(shown)
    first_column_moved = bool(shown) and shown[0][0] != run_edge(config, edge).columns[0][0]
    assert cut.clipped_start == first_column_moved
    (timing,) = timing_model.write_cycles(config, [clipped])
    if not shown:
        assert timing.beats == () and timing.load is None
        return
    latency = timing_model.setup_latency(config)
    extra = timing_model.start_clip_cycles(config) if cut.clipped_start else 0
    assert timing.beats[0] == latency + extra
    assert len(timing.beats) == cut.columns <= full.columns


def test_truncated_accumulator_restarts_at_the_first_visible_column():
    """The scaled areas differ (the clipped edge starts exact); the values stay within 1."""
    config = EdgeConfig(accumulator="truncated")
    edge = Edge.from_pixels(config, 1.25, 3.5, 1000.75, 310.0)
    clip = Clip(500, 0, 2047, 2047)
    clipped = run_edge(config, dataclasses.replace(edge, clip=clip)).writes
    whole = {(w.x, w.y): w for w in run_edge(config, edge).writes}
    assert any(whole[(w.x, w.y)].area != w.area for w in clipped)
    assert max(abs(whole[(w.x, w.y)].value - w.value) for w in clipped) <= 1


def test_empty_window_and_timing_of_an_empty_edge():
    config = EdgeConfig()
    shown = Edge.from_pixels(config, 10, 10, 50, 20)
    hidden = dataclasses.replace(shown, clip=Clip(100, 0, 200, 2048))
    assert setup(config, hidden).columns == 0 and run_edge(config, hidden).writes == []
    timings = timing_model.write_cycles(config, [hidden, shown])
    assert timings[0].beats == ()
    assert timings[1].accepted == timing_model.EMPTY_EDGE_CYCLES
    assert timings[1].beats[0] == timing_model.EMPTY_EDGE_CYCLES + timing_model.setup_latency(
        config
    )


def test_major_axis_only():
    """A shallow edge is cut in x by the x bounds; the y bounds do not cut it."""
    config = EdgeConfig()
    edge = Edge.from_pixels(config, 10, 10, 50, 20)
    result = run_edge(config, dataclasses.replace(edge, clip=Clip(20, 0, 29, 12)))
    assert [column[0].x for column in result.columns] == list(range(20, 30))
    assert max(w.y for w in result.writes) > 12  # rows outside the y bounds are still written


@pytest.mark.parametrize(
    ("clip", "message"),
    [
        ((0, 0, 2049, 10), r"clip x_max must be an integer pixel in \[0, 2048\]"),
        ((-1, 0, 10, 10), r"clip x_min must be"),
        ((0, 0, 10.5, 10), r"not 10.5"),
        ((0, 0, 10), r"clip must be \(x_min, y_min, x_max, y_max\)"),
    ],
)
def test_bad_windows_are_rejected(clip, message):
    config = EdgeConfig()
    edge = dataclasses.replace(Edge.from_pixels(config, 10, 10, 50, 20), clip=clip)
    with pytest.raises(EdgeError, match=message):
        setup(config, edge)
