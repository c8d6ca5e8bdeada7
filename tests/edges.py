"""Shared helpers of the bound tests: configurations, edge strategies and the error budget.

`fixed_point_term` is the model's fixed-point allowance of one write (docs/algorithm.md).
"""

from __future__ import annotations

from fractions import Fraction

from hypothesis import strategies as st

from edgeaa.model import Edge, EdgeConfig, EdgeResult, EdgeSetup, Write, error_bound, reference

# The configurations every bound test runs on (mode and accumulator are set per test).
CONFIGS = {
    "default": EdgeConfig(),
    "wide": EdgeConfig(coord_bits=15, subpixel_bits=8),
    "tiny": EdgeConfig(coord_bits=5, subpixel_bits=0, intensity_bits=4),
}
TWO_PIXEL_MODES = ("paper", "seg2", "seg4")


def fixed_point_term(config: EdgeConfig, setup: EdgeSetup, column: int) -> Fraction:
    """The model's fixed-point allowance of a write in `column` (derived in docs/algorithm.md)."""
    return reference.fixed_point_term(config.mode, config.accumulator, setup.ifix, column)


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
