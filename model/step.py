"""The step-by-step model: the inner loop one column at a time, every register width-checked.

This is the golden reference the hardware is matched against. The loop body uses only adds,
subtracts, compares and fixed shifts (`edgeaa.model.column`, the one description of a
column's arithmetic); every value is checked against the width table of
`EdgeConfig.register_widths` as it is assigned.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from .column import (
    IntArith,
    WidthError,
    advance,
    column_areas,
    column_deltas,
    delta_cells,
    neighbour_offset,
    output_value,
    piece_end,
)
from .config import EdgeConfig
from .edge import Edge, EdgeSetup, setup

__all__ = ["Delta", "EdgeResult", "StepState", "WidthError", "Write", "column_writes", "run_edge"]


class Write(NamedTuple):
    x: int
    y: int
    value: int  # output intensity
    area: int  # scaled A-side area before rounding, in units of 2**-F intensity LSB


class StepState(NamedTuple):
    """The loop registers at the start of one column (what the hardware is matched against)."""

    column: int
    x: int
    y: int
    jq: int
    jr: int


@dataclass
class EdgeResult:
    setup: EdgeSetup
    columns: list[tuple[Write, ...]]  # the writes of each column, primary first
    trace: list[StepState]  # the loop registers at the start of each column

    @property
    def writes(self) -> list[Write]:
        """All writes in order: column by column, the primary pixel before its neighbour."""
        return [write for column in self.columns for write in column]

    def coverage(self, write: Write) -> float:
        """The inside coverage the model computed for a write, before output rounding."""
        area_a = write.area / self.setup.ifix
        return area_a if self.setup.inside_is_a else 1.0 - area_a


def run_edge(config: EdgeConfig, edge: Edge) -> EdgeResult:
    """Run one edge through the step-by-step model: its ordered writes and per-column trace."""
    st = setup(config, edge)
    a = IntArith(config)
    for name, value in (("du", st.du), ("ifix", st.ifix), ("kq", st.kq), ("kr", st.kr)):
        a.check(name, value)
    a.check("khq", st.khq), a.check("khr", st.khr)
    for constant in st.seg_thresholds + st.seg_intercepts:
        a.check("seg_const", constant)

    x, y, jq, jr = (
        a.check("x", st.x),
        a.check("y", st.y),
        a.check("jq", st.jq),
        a.check("jr", st.jr),
    )
    columns: list[tuple[Write, ...]] = []
    trace: list[StepState] = []
    for column in range(st.columns):
        a.check("remaining", st.columns - 1 - column)
        trace.append(StepState(column, x, y, jq, jr))
        columns.append(column_writes(a, config, st, x, y, jq, jr))
        step = advance(a, st, x, y, jq, jr)
        x, y, jq, jr = step.x, step.y, step.jq, step.jr
    return EdgeResult(st, columns, trace)


def column_writes(
    a: IntArith, config: EdgeConfig, st: EdgeSetup, x, y, jq, jr
) -> tuple[Write, ...]:
    """The writes of one column: the primary pixel, then its neighbour if it has one."""
    areas = column_areas(a, config, st, jq, jr)
    pixels = [(0, areas.area0)]
    if areas.two:
        pixels.append((neighbour_offset(a, areas), areas.area1))
    writes = []
    for row_offset, area in pixels:
        wx = a.check("x", x + row_offset * st.row_dx)
        wy = a.check("y", y + row_offset * st.row_dy)
        writes.append(Write(wx, wy, output_value(a, config, st, area), area))
    return tuple(writes)


class Delta(NamedTuple):
    """One cell's signed-area delta: the accumulation buffer's cell (x, y) gains `delta`
    (units of 2**-F intensity LSB times the winding sign)."""

    x: int
    y: int
    delta: int


def run_edge_deltas(config: EdgeConfig, edge: Edge) -> list[tuple[Delta, ...]]:
    """The accumulation deltas of one edge, column by column (four cells each, zeros
    included): the stepping loop of `run_edge` with `column_deltas` in place of the
    two-pixel writes. Each column's cells add up to the edge's signed cover of that column."""
    st = setup(config, edge)
    p = st.pieces
    a = IntArith(config)
    for name in ("hs0", "end_height", "total0", "total1", "rect0", "rect1", "band0", "band1"):
        a.check("height", getattr(p, name))
    x, y, jq, jr, row = st.x, st.y, st.jq, st.jr, p.row0
    hs = p.hs0
    columns = []
    for column in range(st.columns):
        first = column == 0 and p.first_partial
        last = column == st.columns - 1 and p.last_partial
        he, adj = piece_end(a, st, last, jq, jr, row)
        d = column_deltas(a, config, st, first, last, hs, he, adj, jq)
        columns.append(tuple(Delta(*cell) for cell in delta_cells(a, st, x, y, d)))
        step = advance(a, st, x, y, jq, jr)
        hs = a.check("height", he - (st.ifix if step.row_step else 0))
        row += 1 if step.row_step else 0
        x, y, jq, jr = step.x, step.y, step.jq, step.jr
    return columns
