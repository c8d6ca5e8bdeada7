"""benchmarks/what_if.py's four-lane beat clocks (an estimate of a change not built, so only
its own logic is tested here): the built lanes are the model's, four lanes take a clock a beat
unless a bank holds two different kept cells, and never more than two lanes take."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from edgeaa.model.tile import TileConfig, beat_clocks

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from what_if import four_lane_beat_clocks  # a script in benchmarks/, not a package

TILE = TileConfig()  # 64 x 32


def _beat(*cells):
    return np.array([cells], dtype=np.int64)


def test_four_lanes_clock_by_bank():
    row = _beat((0, 0, 1), (1, 0, 2), (2, 0, 3), (3, 0, 4))  # four banks: one clock
    square = _beat((4, 5, 1), (5, 5, -1), (4, 6, 2), (5, 6, 1))  # two rows of two columns
    same_cell = _beat((7, 1, 1), (7, 1, 2), (0, 0, 0), (0, 0, 0))  # one write of their sum
    one_bank = _beat((0, 0, 1), (4, 0, 1), (8, 0, 1), (12, 0, 1))  # four writes to bank 0
    outside = _beat((0, 40, 1), (4, 40, 1), (0, 0, 0), (0, 0, 0))  # below the tile: not kept
    empty = _beat((0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0))
    got = [
        int(four_lane_beat_clocks(b, 4, TILE)[0])
        for b in (row, square, same_cell, one_bank, outside, empty)
    ]
    assert got == [1, 2, 1, 4, 1, 1]


_cell = st.tuples(st.integers(-3, 70), st.integers(-2, 34), st.integers(-2, 2))


@given(st.lists(st.tuples(_cell, _cell, _cell, _cell), min_size=1, max_size=8))
def test_four_lanes_never_slower_than_two(beats):
    cells = np.array(beats, dtype=np.int64)
    for lanes in (1, 2):
        assert (four_lane_beat_clocks(cells, lanes, TILE) == beat_clocks(cells, lanes, TILE)).all()
    assert (four_lane_beat_clocks(cells, 4, TILE) <= beat_clocks(cells, 2, TILE)).all()
