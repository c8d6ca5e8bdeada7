# amaranth: UnusedElaboratable=no
"""The clip window: directed and random windows, the start offset of the longest edges
and the clocks of clipped and empty edges.
"""

from __future__ import annotations

import random
from dataclasses import replace

import pytest
from core_bench import (
    corpus,
    is_good,
    longest_edges,
    run_and_check,
    run_of,
    sim_settings,
    with_window,
)
from fixtures import CORE_CONFIGS, core_config_params, edge_commands, random_edge_commands
from hypothesis import given
from hypothesis import strategies as st

from edgeaa.model import Clip, Edge, EdgeConfig, setup
from edgeaa.model import timing as timing_model

# -- (5b) the clip window ---------------------------------------------------------------------


def clipped_corpus(config: EdgeConfig) -> list[Edge]:
    """Corner-case edges of at least three columns under directed windows: the start cut, the
    end cut, both, one column, wider than the edge, beyond either end, min > max, the minor
    axis only (which clips nothing); and one-column windows at both image borders."""
    top, S, hi = 1 << config.coord_bits, config.subpixel_scale, config.max_vertex
    names = ("octant", "vertical", "45deg", "225deg", "subpixel")
    edges = []
    for name, edge in corpus(config, longest=False):
        if not name.startswith(names) or not is_good(config, edge):
            continue
        columns = setup(config, edge).columns
        if columns < 3:
            continue
        mid = columns // 2
        for start, end in (
            (1, columns - 1),
            (0, columns - 2),
            (1, columns - 2),
            (columns - 1, columns - 1),
            (mid, mid),
            (-3, columns + 2),
            (columns, columns + 2),
            (-3, -1),
            (mid + 1, mid),
        ):
            edges.append(with_window(config, edge, start, end))
        edges.append(with_window(config, edge, -1, columns, minor=(1, 0)))
    reach = min(5 * S, hi)
    edges += [
        Edge(0, 0, reach, S // 2, clip=Clip(0, 0, 0, top)),  # column 0 only
        Edge(hi, hi, hi - reach, hi - S // 2, clip=Clip(top, 0, top, top)),  # column 2**W only
        Edge(hi, 0, hi - reach, 0, clip=Clip(top, 0, 0, top)),  # min > max at the extremes
        Edge(0, hi, S // 2, hi - reach, inside="right", clip=Clip(0, top, top, top)),
    ]
    return edges


def clip_classes(config: EdgeConfig, edges: list[Edge]) -> dict[str, int]:
    """How many good edges are start-clipped, end-clipped only, empty or not clipped."""
    out = {"start": 0, "end": 0, "empty": 0, "none": 0}
    for edge in edges:
        if not is_good(config, edge):
            continue
        clipped = setup(config, edge)
        full = setup(config, replace(edge, clip=None))
        if not clipped.columns:
            out["empty"] += 1
        elif clipped.clipped_start:
            out["start"] += 1
        elif clipped.columns < full.columns:
            out["end"] += 1
        else:
            out["none"] += 1
    return out


@pytest.mark.parametrize("name", ["default", "small", "lowfrac", "seg4", "wide"])
def test_clip_corpus(name):
    """Directed windows, back to back (each edge's window differs from the last): writes, bank,
    trace and beat clocks against the model and the timing model."""
    config = CORE_CONFIGS[name]
    edges = clipped_corpus(config)
    assert min(clip_classes(config, edges).values()) >= 4, clip_classes(config, edges)
    run_and_check(config, edges, label=f"clip corpus {name}")


# Lane A's first pass of a start-clipped edge needs a quotient of W + s + 2 bits: wider
# than the accumulator (I + F = 10 bits) in this configuration.
NARROW = EdgeConfig(coord_bits=4, subpixel_bits=8, intensity_bits=1)


@pytest.mark.parametrize("name", core_config_params("narrow"))
def test_clip_hypothesis(name):
    config = NARROW if name == "narrow" else CORE_CONFIGS[name]

    @sim_settings(5)
    @given(st.lists(edge_commands(config, 8, clip=True), min_size=5, max_size=12))
    def check(edges):
        run_and_check(config, edges, label=f"clip hypothesis {name}")

    check()


@pytest.mark.parametrize(("name", "seed"), [("default", 31), ("small", 32), ("seg2", 33)])
def test_clip_backpressure(name, seed):
    """Random windows, random source idle clocks and sink stalls, and a random value on the
    ``clip`` port whenever no edge is offered (the window is sampled with the edge only)."""
    config = CORE_CONFIGS[name]
    rng = random.Random(seed)
    edges = random_edge_commands(config, rng, 16, 12, clip=True) + clipped_corpus(config)[::7]
    edges.insert(3, Edge(4, 4, 4, 4, clip=Clip(0, 0, 0, 0)))  # bad: an error, not "empty"
    classes = clip_classes(config, edges)
    assert min(classes.values()) >= 2, classes
    run_and_check(config, edges, seed=seed, idle=0.4, stall=0.5, label=f"clip stalls {name}")


def start_quotient(config: EdgeConfig, edge: Edge) -> int:
    """Lane A's first-pass quotient ``floor(2 |e| dv / du)`` for a visible edge, with
    ``e = first S - u0`` the offset of its first column's centre from P0 (folded)."""
    st_ = setup(config, edge)
    major, p0 = (st_.x, edge.x0) if st_.x_major else (st_.y, edge.y0)
    step = st_.col_dx or st_.col_dy
    e = step * major * config.subpixel_scale - step * p0
    return 2 * abs(e) * st_.dv // st_.du


@pytest.mark.parametrize("name", ["default", "narrow", "small", "wide"])
def test_clip_longest_start_offset(name):
    """Windows that keep only the last columns of the longest edges (diagonals, a row, a
    column; both directions): the start offset is almost the edge's length, so lane A's
    first-pass quotient is near its largest, about 2 dv < 2**(W + s + 2) (beyond the
    accumulator's width in the narrow configuration)."""
    config = NARROW if name == "narrow" else CORE_CONFIGS[name]
    W, s = config.coord_bits, config.subpixel_bits
    edges = []
    for edge in longest_edges(config):
        edges += [edge, replace(edge, x0=edge.x1, y0=edge.y1, x1=edge.x0, y1=edge.y0)]
    clipped = []
    for edge in edges:
        columns = setup(config, edge).columns
        for first, last in ((columns - 1, columns - 1), (columns - 3, columns - 1), (2, 4)):
            clipped.append(with_window(config, edge, first, last))
    quotients = [start_quotient(config, edge) for edge in clipped]
    assert max(quotients) >= 1 << (W + s), quotients
    if name == "narrow":
        assert max(quotients) >= 1 << (config.intensity_bits + config.F)
    run_and_check(config, clipped, label=f"longest start offset {name}")


def test_clip_latency():
    """Exact clocks: a start-clipped edge on an idle core has its first beat W + 1 clocks later
    than L; an end-clipped one at L; an edge with no column in its window occupies the setup
    for 5 clocks (the next command is accepted 5 clocks after it) and pulses no error."""
    config = CORE_CONFIGS["default"]
    W = config.coord_bits
    latency = timing_model.setup_latency(config)
    edge = run_of(config, 10, 20, 6)
    start_cut, end_cut = with_window(config, edge, 2, 5), with_window(config, edge, 0, 3)
    empty = with_window(config, edge, 7, 9)
    assert [setup(config, e).columns for e in (start_cut, end_cut, empty)] == [4, 4, 0]
    assert setup(config, start_cut).clipped_start and not setup(config, end_cut).clipped_start

    run = run_and_check(config, [start_cut], label="start-clipped latency")
    assert [clock for clock, _ in run.beats] == list(range(latency + W + 1, latency + W + 5))
    assert run.banks[0][1]["x"] == 12 and run.banks[0][1]["remaining"] == 3
    run = run_and_check(config, [end_cut], label="end-clipped latency")
    assert [clock for clock, _ in run.beats] == list(range(latency, latency + 4))

    bad = Edge(7, 7, 7, 7)
    run = run_and_check(
        config, [empty, bad, empty, edge], label="empty edge occupancy", setup_units=1
    )
    assert run.accepts == [0, 5, 7, 12] and run.error_pulses == [7], run.accepts
    assert [clock for clock, _ in run.beats] == list(range(12 + latency, 12 + latency + 6))
    assert len(run.banks) == 1
    # Several units: the next command goes to the next unit in the next clock.
    run = run_and_check(config, [empty, bad, empty, edge], label="empty edge, units", setup_units=9)
    assert run.accepts == [0, 1, 2, 3] and run.error_pulses == [3], run.accepts
