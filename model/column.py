"""The per-column arithmetic, written once and run on three kinds of number.

One column of the stepping loop: the exit depths above and below (`exit_depths`), the
N-segment triangle estimate (`triangle_estimate`), the column's scaled areas
(`column_areas`), the output value (`output_value`) and the advance to the next column
(`advance`). Each function takes an *arithmetic* that says how to select, negate a
condition, take a magnitude or a minimum (`abs`, `min`) and check a register's width:

* `IntArith` on Python ints: the step model (`step.run_edge`), raising `WidthError` as soon
  as a value does not fit its register;
* `ArrayArith` on numpy arrays (int64 or object arrays of Python ints), one element per
  column: the vectorized model (`vector.run_edges`);
* an Amaranth arithmetic (`edgeaa.sim.verification.formal.spec`) on Amaranth values: the
  formal specification that the hand-optimised core is proven against.

A `check(name, value, where)` applies where `where` holds: a register the step model assigns
only on one branch (the exit depth below, the neighbour's area) is checked only there.
The fields of `st` are `EdgeSetup`'s, each an int, an array (per column) or a value.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .config import EdgeConfig, RegisterWidth


class WidthError(AssertionError):
    """A register value outside its declared width: a bug in the model or the width table."""


def width_error(name: str, value: int, width: RegisterWidth) -> WidthError:
    return WidthError(
        f"register {name} = {value} does not fit {width.bits} bits "
        f"({'signed' if width.signed else 'unsigned'})"
    )


def pick_by_select(select, index, values):
    """``values[index]`` for an index that is an int, or (with `select`) an array or a value:
    a chain of selects on ``index == j``."""
    if isinstance(index, int):
        return values[index]
    out = values[0]
    for j in range(1, len(values)):
        out = select(index == j, values[j], out)
    return out


class IntArith:
    """Python ints and bools; `check` raises `WidthError` for a value that does not fit."""

    def __init__(self, config: EdgeConfig | None = None):
        # Without a config there are no registers to check: selects only (the setup's fold,
        # once per edge, where building the width table would cost more than the fold).
        self.widths = {} if config is None else config.register_widths()
        # (min, max) per register: the check runs a dozen times per column.
        self.bounds = {name: (w.min, w.max) for name, w in self.widths.items()}

    @staticmethod
    def select(cond, a, b):
        return a if cond else b

    @staticmethod
    def not_(cond) -> bool:
        return not cond

    @staticmethod
    def pick(index: int, values):
        return values[index]

    abs = staticmethod(abs)
    min = staticmethod(min)

    def check(self, name: str, value: int, where: bool = True) -> int:
        if where:
            lo, hi = self.bounds[name]
            if not lo <= value <= hi:
                raise width_error(name, value, self.widths[name])
        return value


class ArrayArith:
    """numpy arrays, one element per column, in `dtype` (np.int64, or object for Python ints
    where int64 could overflow); `check` raises `WidthError` for the first register whose
    smallest or largest element (where `where` holds) does not fit."""

    def __init__(self, config: EdgeConfig, dtype):
        self.widths = config.register_widths()
        self.dtype = dtype

    @staticmethod
    def select(cond, a, b):
        return np.where(cond, a, b)

    @staticmethod
    def not_(cond):
        return ~np.asarray(cond, dtype=bool)

    @staticmethod
    def pick(index, values):
        return pick_by_select(np.where, index, values)

    # one numpy call each where a select would be two (the fill rule on whole buffers)
    abs = staticmethod(np.abs)
    min = staticmethod(np.minimum)

    def check(self, name: str, values, where=True):
        picked = values if where is True else np.asarray(values)[where]
        picked = np.asarray(picked)
        if picked.size:
            width = self.widths[name]
            lo, hi = int(picked.min()), int(picked.max())
            if lo < width.min:
                raise width_error(name, lo, width)
            if hi > width.max:
                raise width_error(name, hi, width)
        return values


@dataclass(slots=True)
class ColumnAreas:
    """One column's exit tests and scaled A-side areas (units of 2**-F intensity LSB).

    ``area0`` is the primary pixel's; ``area1`` the neighbour's when ``two``: row + 1 when the
    edge leaves through the far boundary (``above``), row - 1 when it enters through the near
    one (``below``). The exit depths and the clamped estimate ``t`` are kept for observers.
    """

    area0: Any
    area1: Any
    above: Any
    below: Any
    two: Any
    dq_above: Any = 0  # exit depth above, quotient (d = J + K/2 - ifix)
    dr_above: Any = 0
    dq_below: Any = 0  # exit depth below, quotient (d = K/2 - J)
    dr_below: Any = 0
    borrow: Any = 0  # the below depth's borrow from the remainder
    below_raw: Any = 0  # the below test alone (before "and not above")
    dq: Any = 0  # the depth the estimate uses (above's, else below's)
    t: Any = 0  # the estimate before clamping


def exit_depths(a, st, jq, jr) -> dict[str, Any]:
    """d = J + K/2 - ifix (how far the edge passes the row's far boundary at the column's end)
    and d = K/2 - J (its near boundary at the column's start), each as a floor quotient and a
    remainder over du, with the test d > 0 decided exactly. The depth below is the step
    model's register only when the edge does not leave above."""
    rsum = jr + st.khr
    carry = rsum >= st.du
    dq_above = a.check("dq", jq + st.khq + carry - st.ifix)
    dr_above = a.check("dr", rsum - a.select(carry, st.du, 0))
    above = (dq_above > 0) | ((dq_above == 0) & (dr_above > 0))
    borrow = st.khr < jr
    not_above = a.not_(above)
    dq_below = a.check("dq", st.khq - jq - borrow, not_above)
    dr_below = a.check("dr", st.khr - jr + a.select(borrow, st.du, 0), not_above)
    below_raw = (dq_below > 0) | ((dq_below == 0) & (dr_below > 0))
    return dict(
        dq_above=dq_above,
        dr_above=dr_above,
        above=above,
        dq_below=dq_below,
        dr_below=dr_below,
        borrow=borrow,
        below_raw=below_raw,
        below=not_above & below_raw,
    )


def triangle_estimate(a, config: EdgeConfig, st, dq, where=True):
    """Add-only estimate of the cut-off triangle d^2/(2k), scaled like the accumulator, before
    clamping at 0: on segment j (d >= j K/(2N)) the minimax line (2j+1)/(4N) d - intercept_j.
    The slope multiply is by a small odd constant: shifts and adds in hardware."""
    shift = 2 + config.segments.bit_length() - 1
    thresholds = st.seg_thresholds if config.segments > 1 else ()  # (a bank has none for N = 1)
    segment = sum(dq >= threshold for threshold in thresholds)
    lines = [
        (_times(dq, 2 * j + 1) >> shift) - intercept
        for j, intercept in enumerate(st.seg_intercepts)
    ]
    return a.check("t", a.pick(segment, lines), where)


def _times(value, k: int):
    """`value` times a small odd constant (no multiply at all for 1)."""
    return value if k == 1 else k * value


def column_areas(a, config: EdgeConfig, st, jq, jr) -> ColumnAreas:
    """The scaled A-side areas of one column (formula (1) and the paper's split)."""
    if config.segments == 0:  # pw: one pixel per column, its area the accumulator
        return ColumnAreas(a.check("area", jq), 0, False, False, False)
    d = exit_depths(a, st, jq, jr)
    two = d["above"] | d["below"]
    dq = a.select(d["above"], d["dq_above"], d["dq_below"])
    t = triangle_estimate(a, config, st, dq, two)
    clamped = a.select(t > 0, t, 0)
    area0 = a.select(d["above"], jq - clamped, a.select(d["below"], jq + clamped, jq))
    area1 = a.select(d["above"], clamped, st.ifix - clamped)
    return ColumnAreas(
        area0=a.check("area", area0),
        area1=a.check("area", area1, two),
        two=two,
        dq=dq,
        t=t,
        **d,
    )


def output_value(a, config: EdgeConfig, st, area, where=True):
    """Intensity I_B + sign * round(area / 2**F): the scaled area is the intensity offset."""
    F = config.F
    rounded = (area + (1 << (F - 1))) >> F
    value = a.select(st.value_sign < 0, st.value_base - rounded, st.value_base + rounded)
    return a.check("value", value, where)


def neighbour_offset(a, areas: ColumnAreas):
    """The neighbour's row offset along the stepping direction: -1 below, else +1."""
    return a.select(areas.below, -1, 1)


@dataclass(slots=True)
class Advance:
    """The loop registers after one column, and what the step decided."""

    x: Any
    y: Any
    jq: Any
    jr: Any
    jsum: Any  # jq + kq + carry, before the row step
    row_step: Any  # J reached 1: the next column is one row further


def advance(a, st, x, y, jq, jr) -> Advance:
    """J += K with the remainder carried; step a row when J >= 1 (quotient and remainder
    over du, so the accumulator does not drift)."""
    rsum = jr + st.kr
    carry = rsum >= st.du
    jr_next = a.check("jr", rsum - a.select(carry, st.du, 0))
    jsum = a.check("jsum", jq + st.kq + carry)
    row_step = jsum >= st.ifix
    jq_next = a.check("jq", a.select(row_step, jsum - st.ifix, jsum))
    x_next = a.check("x", x + st.col_dx + a.select(row_step, st.row_dx, 0))
    y_next = a.check("y", y + st.col_dy + a.select(row_step, st.row_dy, 0))
    return Advance(x_next, y_next, jq_next, jr_next, jsum, row_step)


# -- accumulation deltas (docs/algorithm.md section 13) -----------------------------------------


@dataclass(slots=True)
class ColumnDeltas:
    """One column's signed-area deltas before the winding sign, in the folded frame.

    The edge's piece in the column runs from height ``hs`` to ``he`` (units of ifix per
    pixel, from the top of the loop's row r). ``up`` says it starts above row r: its two
    rows are then r - 1 and r, else r and r + 1. x-major: ``cells`` are (R_a, cov_a - R_a,
    R_b, cov_b - R_b): the piece's area on the +u side of the line in column c of the upper
    and the lower row, and the rest of each row's cover, which the next column along +u
    gets. y-major: (band - P0, P0 - P1, P1, 0) along +v from row r - up: differences of
    P0, P1, the piece's areas on the smaller-v side in those two cells."""

    up: Any
    cells: tuple[Any, Any, Any, Any]
    he: Any  # where the piece ends: the next column starts there (one row less on a step)
    t: Any = 0  # the clamped triangle estimate used


def piece_end(a, st, last, jq, jr, row):
    """The height where a column's piece ends: floor(J + K/2), or P1's height in the last
    partial column (P1's row is within one of the loop's row r)."""
    p = st.pieces
    carry = (jr + st.khr) >= st.du
    full = jq + st.khq + carry
    adj = p.end_row - row  # -1, 0 or +1
    at_end = p.end_height + a.select(adj > 0, st.ifix, a.select(adj < 0, -st.ifix, 0))
    return a.check("height", a.select(last, at_end, full)), adj


def _clamp(a, value, hi):
    """value clamped to [0, hi]."""
    return a.select(value < 0, 0, a.select(value > hi, hi, value))


def column_deltas(a, config: EdgeConfig, st, first, last, hs, he, adj, jq) -> ColumnDeltas:
    """The signed-area deltas of one column's piece from hs to he (docs/algorithm.md s. 13).

    first / last: the column is the edge's partial first / last column (it holds a vertex);
    adj: P1's row minus the loop's row. Adds, compares and selects of per-edge constants,
    and the add-only triangle estimate of the crossing part's depth."""
    p, ifix = st.pieces, st.ifix
    up, low = hs < 0, he > ifix
    depth = a.check("height", a.select(low, he - ifix, -hs))
    if config.segments:
        t = triangle_estimate(a, config, st, depth, up | low)
        t = a.select(t > 0, t, 0)
    else:  # pw: no estimate of the split
        t = 0
    x_major = st.x_major
    interior_total = a.select(x_major, st.khq, jq)
    band1 = a.select(adj > 0, p.band1, a.select(adj < 0, -p.band1, 0))
    total = a.select(first, p.total0, a.select(last, p.total1 + band1, interior_total))
    band = a.select(first, p.band0, a.select(last, p.band1, ifix))
    cells_x = _deltas_x_major(a, p, first, last, hs, he, ifix, t, total)
    cells_y = _deltas_y_major(a, hs, he, ifix, t, total, band)
    cells = tuple(
        a.check("delta", a.select(x_major, cx, cy)) for cx, cy in zip(cells_x, cells_y, strict=True)
    )
    return ColumnDeltas(up, cells, he, t)


def _deltas_x_major(a, p, first, last, hs, he, ifix, t, total):
    """Areas on the +u side of the line, row by row (the upper row r - 1 only when up)."""
    cov_up = a.select(he < 0, he, 0) - a.select(hs < 0, hs, 0)
    cov_mid = _clamp(a, he, ifix) - _clamp(a, hs, ifix)
    cov_low = a.select(he > ifix, he, ifix) - a.select(hs > ifix, hs, ifix)
    rect_up = a.select(first, p.rect0, 0)
    rect_low = a.select(last, p.rect1, 0)
    r_low = a.select(hs >= ifix, total, a.select(he > ifix, _clamp(a, t + rect_low, cov_low), 0))
    r_up = a.select(he <= 0, total, a.select(hs < 0, _clamp(a, cov_up - t - rect_up, cov_up), 0))
    r_mid = _clamp(a, total - r_low - r_up, cov_mid)
    up = hs < 0
    r_a, cov_a = a.select(up, r_up, r_mid), a.select(up, cov_up, cov_mid)
    r_b, cov_b = a.select(up, r_mid, r_low), a.select(up, cov_mid, cov_low)
    return r_a, cov_a - r_a, r_b, cov_b - r_b


def _deltas_y_major(a, hs, he, ifix, t, total, band):
    """Areas on the smaller-v side in cells r - 1, r, r + 1, differenced along +v."""
    a_low = a.select(hs >= ifix, total - band, a.select(he > ifix, t, 0))
    a_up = a.select(he <= 0, total + band, a.select(hs < 0, band - t, band))
    a_low, a_up = _clamp(a, a_low, band), _clamp(a, a_up, band)
    a_mid = _clamp(a, total + band - a_up - a_low, band)
    up = hs < 0
    p0, p1 = a.select(up, a_up, a_mid), a.select(up, a_mid, a_low)
    return band - p0, p0 - p1, p1, 0 * p1


def delta_cells(a, st, x, y, d: ColumnDeltas):
    """The four cells of a column's deltas in screen pixels, signed by the winding: a list of
    (x, y, delta). (x, y) is the loop's pixel of column c, row r (docs/algorithm.md s. 13).

    x-major: a 2 x 2 block, columns x and x + 1 (screen), rows r - up and r - up + 1 (each
    folded row one ``row_dy`` on screen); the column pair's values swap when the major axis
    steps down (u = -x). y-major: three cells along the row, v = r - up .. r - up + 2 on
    +v; along -v (the minor axis steps down) the same values one cell lower in v."""
    sigma = st.pieces.sigma
    up = a.select(d.up, 1, 0)
    ra, rest_a, rb, rest_b = d.cells
    neg = st.major_neg_x  # x-major edge stepping left
    xm = st.x_major
    cells = []
    # x-major: (x, row a), (x + 1, row a), (x, row b), (x + 1, row b)
    for k, (left, right) in enumerate(((ra, rest_a), (rb, rest_b))):
        yk = y + (k - up) * st.row_dy
        cells.append((x, yk, a.select(neg, right, left)))
        cells.append((x + 1, yk, a.select(neg, left, right)))
    # y-major: v offsets (0, 1, 2) - up, one less along -v
    shift = a.select(st.row_dx < 0, 1, 0)
    out = []
    for k in range(4):
        xx_y = x + (k - up - shift) * st.row_dx
        cx, cy, cv = cells[k]
        out.append(
            (
                a.select(xm, cx, xx_y),
                a.select(xm, cy, y),
                sigma * a.select(xm, cv, d.cells[k]),
            )
        )
    return out
