"""Shared helpers of the bound tests: configurations, edge strategies and the error budget.

`fixed_point_term` is the fixed-point part of the error budget of one write; its derivation
from the loop in model/step.py is written out in its docstring.
"""

from __future__ import annotations

from fractions import Fraction

from hypothesis import strategies as st

from edgeaa.model import Edge, EdgeConfig, EdgeResult, EdgeSetup, Write, error_bound

# The configurations every bound test runs on (mode and accumulator are set per test).
CONFIGS = {
    "default": EdgeConfig(),
    "wide": EdgeConfig(coord_bits=15, subpixel_bits=8),
    "tiny": EdgeConfig(coord_bits=5, subpixel_bits=0, intensity_bits=4),
}
TWO_PIXEL_MODES = ("paper", "seg2", "seg4")

# Fixed-point budget of one write with the exact accumulator, in units of 2**-F intensity LSB:
# strict upper bounds of |written area - the estimate's exact value|, derived in
# `fixed_point_term`. The truncated accumulator adds one unit per column (its drift).
FIXED_POINT_UNITS = {
    "pw": Fraction(1),
    "paper": Fraction(2),
    "seg2": Fraction(41, 16),
    "seg4": Fraction(185, 64),
}


def fixed_point_term(config: EdgeConfig, setup: EdgeSetup, column: int) -> Fraction:
    """The fixed-point part of the error bound of a write in `column` (0 = the first column).

    The bound of a write is error_bound(mode, k) + fixed_point_term: c / ifix, where c is in
    units of the accumulator (2**-F intensity LSB) and ifix = |I_d| << F units make a whole
    pixel. c = FIXED_POINT_UNITS[mode] for the exact accumulator, plus `column` for the
    truncated one. Derivation from model/step.py, with J, K and K/2 the exact rationals the
    exact accumulator holds as quotient and remainder over du, N the segments, j the segment
    and s = (2j+1)/(4N) its slope (s <= (2N-1)/(4N)), c_j = 8j(j+1)+1:

    pw: the write is jq = floor(J): in (-1, 0] units of the exact J. c = 1.

    Two pixels: whether the edge leaves the row is decided exactly (quotient and remainder),
    and the exit depth's quotient dq = floor(d) is exact. The estimate
    t = ((2j+1) dq >> (2 + log2 N)) - (c_j kq >> (6 + 2 log2 N)) against s d - c_j K/(64 N^2):
    - s (dq - d) in (-s, 0]; the >> floor in [-(4N-1)/(4N), 0];
    - the intercept comes from kq = floor(K) (short of K by < 1, so by < c_j / (64 N^2) after
      scaling) and is floored (by <= 1 - 1/(64 N^2)): t is high by < 1 + (c_j - 1)/(64 N^2),
      i.e. < 1 (N = 1), < 1.0625 (N = 2), < 1.094 (N = 4);
    - the segment: dq >= floor(j kq / (2N)) picks j for d down to 1 + j/(2N) units below the
      exact boundary j K / (2N), never a lower segment. The minimax lines of adjacent
      segments meet on the boundary and their slopes differ by 1/(2N), so each wrongly passed
      boundary (at most N - 1 of them) lowers t by < (1 + (N-1)/(2N)) / (2N): < 0.3125 in
      all for N = 2, < 0.516 for N = 4;
    - max(t, 0) only moves t towards the exact triangle, which is >= 0.
    So t is low by < 1 (N = 1), 1.5625 (N = 2), 1.890625 (N = 4), high by the amounts above.
    The primary pixel writes jq - t (edge leaves through the far boundary) or jq + t (through
    the near one), jq being low by < 1: the worst is jq + t, low by < 1 + 1, 1 + 1.5625 and
    1 + 1.890625. The neighbour writes t or ifix - t: within the bounds of t. Hence c = 2
    (paper), 41/16 (seg2), 185/64 (seg4), all strict.

    Truncated accumulator: the remainders are dropped, so in column n, jq = J - delta with
    delta in [0, n + 1) (floor of the initial value, then kq = floor(K) per column) and khq =
    floor(K/2) = K/2 - e, e in [0, 1). dq is then exact for the truncated d, so the s (dq - d)
    and the floor of J above drop out, and the drift enters the primary pixel as
    -(1 - sigma) delta +- sigma e and the neighbour as -sigma (delta +- e), sigma in [0, 7/16]
    the estimate's mean slope between the two depths: < n + 1 either way, which is less than
    the dropped terms plus n. So c = FIXED_POINT_UNITS[mode] + n. (Where the truncated and
    the exact depths disagree on the exit, the missed or extra triangle is < (n + 2)/4.)
    """
    units = FIXED_POINT_UNITS[config.mode]
    if config.accumulator == "truncated":
        units += column
    return units / setup.ifix


def write_column(setup: EdgeSetup, write: Write) -> int:
    """Index (0 = first) of the column a write belongs to."""
    return (write.x - setup.x) * setup.col_dx + (write.y - setup.y) * setup.col_dy


def slope(setup: EdgeSetup) -> Fraction:
    """k = |minor delta| / |major delta| of the folded edge."""
    return Fraction(setup.dv, setup.du)


def bound(config: EdgeConfig, setup: EdgeSetup) -> Fraction:
    """The estimate's own bound k/8, k/64, k/256 or k/1024 as an exact rational."""
    per_k = {"pw": 8, "paper": 64, "seg2": 256, "seg4": 1024}[config.mode]
    value = slope(setup) / per_k
    assert abs(float(value) - error_bound(config.mode, float(slope(setup)))) < 1e-15
    return value


def model_coverage(result: EdgeResult, write: Write) -> Fraction:
    """EdgeResult.coverage as an exact rational (the float it returns is this, rounded)."""
    area_a = Fraction(write.area, result.setup.ifix)
    cov = area_a if result.setup.inside_is_a else 1 - area_a
    assert abs(float(cov) - result.coverage(write)) <= 1e-15
    return cov


def output_coverage(config: EdgeConfig, edge: Edge, write: Write) -> Fraction:
    """(value - I_out) / (I_in - I_out): the coverage the rounded output intensity stands for."""
    i_in, i_out = edge.intensities(config)
    return Fraction(write.value - i_out, i_in - i_out)


def column_pixels(setup: EdgeSetup, column: int, x: int, y: int, reach: int = 2):
    """The pixels of a column around its primary pixel (x, y), rows -reach .. +reach."""
    return [(x + r * setup.row_dx, y + r * setup.row_dy) for r in range(-reach, reach + 1)]


# -- hypothesis strategies ------------------------------------------------------------------


def _anchor(lo: int, hi: int):
    """Integers in [lo, hi], with the ends drawn often."""
    return st.one_of(st.sampled_from((lo, hi)), st.integers(lo, hi))


@st.composite
def edges(draw, config: EdgeConfig, max_pixels: int | None = None) -> Edge:
    """Edges of `config` in all eight octants, both inside sides and any intensities.

    The major delta is at most max_pixels pixels (default: the whole coordinate range); short
    deltas and the special slopes 0 and 1 are drawn often.
    """
    scale = config.subpixel_scale
    hi = config.max_vertex
    limit = hi if max_pixels is None else min(hi, max_pixels * scale)
    major = draw(
        st.one_of(
            st.integers(1, min(limit, 3 * scale)),
            st.integers(1, limit),
            st.just(limit),
        )
    )
    minor = draw(st.one_of(st.sampled_from((0, major)), st.integers(0, major)))
    swap = draw(st.booleans())
    du = draw(st.sampled_from((1, -1))) * major
    dv = draw(st.sampled_from((1, -1))) * minor
    dx, dy = (dv, du) if swap else (du, dv)
    x0 = draw(_anchor(max(0, -dx), min(hi, hi - dx)))
    y0 = draw(_anchor(max(0, -dy), min(hi, hi - dy)))
    inside = draw(st.sampled_from(("left", "right")))
    full = config.full_scale
    i_in = draw(st.one_of(st.none(), st.integers(0, full)))
    i_out = draw(st.integers(0, full).filter(lambda v: v != (full if i_in is None else i_in)))
    return Edge(x0, y0, x0 + dx, y0 + dy, inside=inside, i_in=i_in, i_out=i_out)
