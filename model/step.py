"""The step-by-step model: the inner loop one column at a time, every register width-checked.

This is the golden reference the hardware is matched against. The loop body uses only adds,
subtracts, compares and fixed shifts; every value is checked against the width table of
`EdgeConfig.register_widths` as it is assigned.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from .config import EdgeConfig
from .edge import Edge, EdgeSetup, setup


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


class WidthError(AssertionError):
    """A register value outside its declared width: a bug in the model or the width table."""


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


class _Checked:
    """Assigns register values, raising WidthError when one does not fit its declared width."""

    def __init__(self, config: EdgeConfig):
        self.widths = config.register_widths()

    def __call__(self, name: str, value: int) -> int:
        width = self.widths[name]
        if not width.holds(value):
            raise WidthError(
                f"register {name} = {value} does not fit {width.bits} bits "
                f"({'signed' if width.signed else 'unsigned'})"
            )
        return value


def exit_depth_above(st: EdgeSetup, jq: int, jr: int, reg: _Checked) -> tuple[int, bool]:
    """d = J + K/2 - ifix: how far the edge passes the row's far boundary at the column's end.

    Returns the quotient (the floor of d) and whether d > 0, decided exactly with remainders.
    """
    rsum = jr + st.khr
    carry = int(rsum >= st.du)
    dq = reg("dq", jq + st.khq + carry - st.ifix)
    dr = reg("dr", rsum - carry * st.du)
    return dq, dq > 0 or (dq == 0 and dr > 0)


def exit_depth_below(st: EdgeSetup, jq: int, jr: int, reg: _Checked) -> tuple[int, bool]:
    """d = K/2 - J: how far the edge passes the row's near boundary at the column's start."""
    borrow = int(st.khr < jr)
    dq = reg("dq", st.khq - jq - borrow)
    dr = reg("dr", st.khr - jr + borrow * st.du)
    return dq, dq > 0 or (dq == 0 and dr > 0)


def triangle_estimate(config: EdgeConfig, st: EdgeSetup, dq: int, reg: _Checked) -> int:
    """Add-only estimate of the cut-off triangle d^2/(2k), scaled like the accumulator.

    N segments: on segment j (d >= j*K/(2N)) the minimax line (2j+1)/(4N) d - intercept_j.
    The slope multiply is by a small odd constant: shifts and adds in hardware.
    """
    n = config.segments
    j = sum(1 for threshold in st.seg_thresholds if dq >= threshold)
    log2n = n.bit_length() - 1
    t = reg("t", (((2 * j + 1) * dq) >> (2 + log2n)) - st.seg_intercepts[j])
    return max(t, 0)


def column_areas(
    config: EdgeConfig, st: EdgeSetup, jq: int, jr: int, reg: _Checked
) -> list[tuple[int, int]]:
    """The (row offset, scaled A-side area) writes of one column: the primary pixel first."""
    if config.segments == 0:  # pw: formula (1), one pixel per column
        return [(0, reg("area", jq))]
    dq, above = exit_depth_above(st, jq, jr, reg)
    if above:  # the edge leaves through the far boundary into row + 1
        t = triangle_estimate(config, st, dq, reg)
        return [(0, reg("area", jq - t)), (1, reg("area", t))]
    dq, below = exit_depth_below(st, jq, jr, reg)
    if below:  # the edge enters from row - 1 through the near boundary
        t = triangle_estimate(config, st, dq, reg)
        return [(0, reg("area", jq + t)), (-1, reg("area", st.ifix - t))]
    return [(0, reg("area", jq))]


def output_value(config: EdgeConfig, st: EdgeSetup, area: int, reg: _Checked) -> int:
    """Intensity I_B + sign * round(area / 2**F): the scaled area is the intensity offset."""
    F = config.F
    return reg("value", st.value_base + st.value_sign * ((area + (1 << (F - 1))) >> F))


def run_edge(config: EdgeConfig, edge: Edge) -> EdgeResult:
    """Run one edge through the step-by-step model: its ordered writes and per-column trace."""
    st = setup(config, edge)
    reg = _Checked(config)
    for name, value in (("du", st.du), ("ifix", st.ifix), ("kq", st.kq), ("kr", st.kr)):
        reg(name, value)
    reg("khq", st.khq), reg("khr", st.khr)
    for constant in st.seg_thresholds + st.seg_intercepts:
        reg("seg_const", constant)

    x, y, jq, jr = reg("x", st.x), reg("y", st.y), reg("jq", st.jq), reg("jr", st.jr)
    columns: list[tuple[Write, ...]] = []
    trace: list[StepState] = []
    for column in range(st.columns):
        reg("remaining", st.columns - 1 - column)
        trace.append(StepState(column, x, y, jq, jr))
        column_writes = []
        for row_offset, area in column_areas(config, st, jq, jr, reg):
            wx = reg("x", x + row_offset * st.row_dx)
            wy = reg("y", y + row_offset * st.row_dy)
            column_writes.append(Write(wx, wy, output_value(config, st, area, reg), area))
        columns.append(tuple(column_writes))
        # Advance one column: J += K with the remainder carried; step a row when J >= 1.
        rsum = jr + st.kr
        carry = int(rsum >= st.du)
        jr = reg("jr", rsum - carry * st.du)
        jsum = reg("jsum", jq + st.kq + carry)
        row_step = jsum >= st.ifix
        jq = reg("jq", jsum - st.ifix if row_step else jsum)
        x = reg("x", x + st.col_dx + (st.row_dx if row_step else 0))
        y = reg("y", y + st.col_dy + (st.row_dy if row_step else 0))
    return EdgeResult(st, columns, trace)
