"""The exact reference (model/reference.py) against an independent computation.

The closed form is checked against clipping the pixel square by the inside half-plane
(Sutherland-Hodgman, in Fractions) and taking the shoelace area; the inside half-plane is
decided here from the edge's direction on the image (y down), not through the model's folding.
"""

from __future__ import annotations

import math
from fractions import Fraction

import pytest
from fixtures import GEOMETRY_CONFIGS, slope_edges
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from edgeaa.model import Edge, EdgeConfig, EdgeError, exact_coverage, exact_coverage_array

SETTINGS = settings(deadline=None, max_examples=150, suppress_health_check=[HealthCheck.too_slow])
HALF = Fraction(1, 2)


def points(config: EdgeConfig, edge: Edge):
    """The endpoints in pixels, as Fractions."""
    s = config.subpixel_scale
    return (Fraction(v, s) for v in (edge.x0, edge.y0, edge.x1, edge.y1))


def side(config: EdgeConfig, edge: Edge):
    """g(P) <= 0 on the inside: the sign of the cross product of travel and P - P0.

    On the image (y down) the left of travel is where dx (Py - y0) - dy (Px - x0) < 0: going
    right (dx > 0, dy = 0) the left is up, at smaller y.
    """
    x0, y0, x1, y1 = points(config, edge)
    dx, dy = x1 - x0, y1 - y0
    sign = 1 if edge.inside == "left" else -1

    def g(px, py):
        return sign * (dx * (py - y0) - dy * (px - x0))

    return g


def clipped_area(config: EdgeConfig, edge: Edge, x: int, y: int) -> Fraction:
    """Area of pixel (x, y) on the inside: Sutherland-Hodgman clip, then the shoelace."""
    g = side(config, edge)
    square = [
        (x - HALF, y - HALF),
        (x + HALF, y - HALF),
        (x + HALF, y + HALF),
        (x - HALF, y + HALF),
    ]
    clipped = []
    for i, p in enumerate(square):
        q = square[(i + 1) % len(square)]
        gp, gq = g(*p), g(*q)
        if gp <= 0:
            clipped.append(p)
        if (gp < 0 < gq) or (gq < 0 < gp):
            t = gp / (gp - gq)
            clipped.append((p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])))
    twice = sum(
        a[0] * b[1] - b[0] * a[1] for a, b in zip(clipped, clipped[1:] + clipped[:1], strict=True)
    )
    return abs(twice) / 2


def line_point(config: EdgeConfig, edge: Edge, t: Fraction):
    x0, y0, x1, y1 = points(config, edge)
    return x0 + t * (x1 - x0), y0 + t * (y1 - y0)


config_names = st.sampled_from(sorted(GEOMETRY_CONFIGS))


@st.composite
def edge_and_pixel(draw, max_pixels=None):
    """An edge and a pixel within two pixels of a point of its supporting line."""
    config = GEOMETRY_CONFIGS[draw(config_names)]
    edge = draw(slope_edges(config, max_pixels=max_pixels))
    # A point of the supporting line, also beyond the endpoints.
    t = Fraction(draw(st.integers(-64, 64 + 64)), 64)
    px, py = line_point(config, edge, t)
    x = math.floor(px + HALF) + draw(st.integers(-2, 2))
    y = math.floor(py + HALF) + draw(st.integers(-2, 2))
    return config, edge, x, y


@SETTINGS
@given(edge_and_pixel())
def test_closed_form_equals_clipped_polygon(case):
    config, edge, x, y = case
    exact = exact_coverage(config, edge, x, y)
    clipped = clipped_area(config, edge, x, y)
    assert exact == clipped, (edge, x, y, exact, clipped)
    assert 0 <= exact <= 1


@SETTINGS
@given(edge_and_pixel())
def test_inside_left_and_right_are_complementary(case):
    config, edge, x, y = case
    left = exact_coverage(config, Edge(**{**vars(edge), "inside": "left"}), x, y)
    right = exact_coverage(config, Edge(**{**vars(edge), "inside": "right"}), x, y)
    assert left + right == 1
    # Reversing the direction with the other inside side is the same half-plane.
    reverse = Edge(edge.x1, edge.y1, edge.x0, edge.y0, inside="right")
    assert exact_coverage(config, reverse, x, y) == left


def float_tolerance(config: EdgeConfig) -> float:
    """Rounding of the float closed form: a few ulps of the coordinates, whatever the slope.

    The height a at the pixel is a difference of coordinates up to 2**coord_bits; each case of
    the clamped mean is written without cancellation, so its error stays that of a.
    """
    return 4 * 2.0**-52 * (2**config.coord_bits + 2)


@SETTINGS
@given(edge_and_pixel())
def test_float_matches_fraction(case):
    config, edge, x, y = case
    exact = exact_coverage(config, edge, x, y)
    value = exact_coverage_array(config, edge, [x], [y])[0]
    tol = float_tolerance(config)
    assert abs(value - float(exact)) <= tol, (edge, x, y, float(exact), value, tol)


@SETTINGS
@given(slope_edges(GEOMETRY_CONFIGS["default"]), st.integers(0, 64))
def test_float_matches_fraction_to_1e_12(edge, t64):
    """At coordinates below 2**11, at every slope: agreement to 1e-12."""
    config = GEOMETRY_CONFIGS["default"]
    px, py = line_point(config, edge, Fraction(t64, 64))
    pixels = [
        (math.floor(px + HALF) + dx, math.floor(py + HALF) + dy)
        for dx in (-1, 0, 1)
        for dy in (-1, 0, 1)
    ]
    values = exact_coverage_array(config, edge, *zip(*pixels, strict=True))
    for (x, y), value in zip(pixels, values, strict=True):
        exact = exact_coverage(config, edge, x, y)
        assert abs(value - float(exact)) <= 1e-12, (edge, x, y, float(exact), value)


@SETTINGS
@given(edge_and_pixel(max_pixels=64), st.data())
def test_column_sums_to_trapezoid(case, data):
    """Inside coverages of a whole column add up to the trapezoid under (or over) the line.

    The line is linear across a column, so the column's inside area between the outermost
    rows is the distance from the line at the column centre to the far edge of the last row
    on the inside.
    """
    config, edge, _, _ = case
    x0, y0, x1, y1 = points(config, edge)
    x_major = abs(x1 - x0) >= abs(y1 - y0)
    (p0, q0, p1, q1) = (x0, y0, x1, y1) if x_major else (y0, x0, y1, x1)
    k = (q1 - q0) / (p1 - p0)
    # A column beyond the edge's ends too: the reference is of the supporting line.
    c = data.draw(st.integers(math.floor(min(p0, p1)) - 2, math.ceil(max(p0, p1)) + 2))
    centre = q0 + k * (c - p0)  # the line's minor coordinate at the column centre
    lo = math.floor(centre) - 3
    hi = math.ceil(centre) + 3
    g = side(config, edge)
    # Is the side of smaller minor coordinate inside? Test a point far on that side.
    probe = (c, centre - 10) if x_major else (centre - 10, c)
    low_inside = g(*probe) < 0
    total = 0
    for r in range(lo, hi + 1):
        px, py = (c, r) if x_major else (r, c)
        total += exact_coverage(config, edge, px, py)
    expected = centre - (lo - HALF) if low_inside else (hi + HALF) - centre
    assert total == expected, (edge, c, total, expected)


@pytest.mark.parametrize(
    "coords, inside, x, y, expected",
    [
        # Horizontal edge through pixel centres at y = 2, going right: left is up (smaller y).
        ((0, 2, 4, 2), "left", 1, 2, HALF),
        ((0, 2, 4, 2), "left", 1, 1, 1),
        ((0, 2, 4, 2), "left", 1, 3, 0),
        ((0, 2, 4, 2), "right", 1, 3, 1),
        # On a pixel boundary (y = 2.5): pixel 2 is wholly on the left, pixel 3 wholly right.
        ((0, "2.5", 4, "2.5"), "left", 1, 2, 1),
        ((0, "2.5", 4, "2.5"), "left", 1, 3, 0),
        # The diagonal through pixel centres halves the pixels it crosses.
        ((0, 0, 4, 4), "left", 2, 2, HALF),
        ((0, 0, 4, 4), "left", 2, 1, 1),  # above the diagonal (y < x) is the left of travel
        ((0, 0, 4, 4), "left", 1, 2, 0),
        # A diagonal through pixel corners cuts a corner triangle of 1/8 from its neighbours.
        # (going down-right, the right of travel is below the line: larger y - x).
        ((0, "0.5", 4, "4.5"), "right", 2, 2, Fraction(1, 8)),
        ((0, "0.5", 4, "4.5"), "right", 2, 3, Fraction(7, 8)),
        # Vertical edge going down: the left of travel is towards larger x.
        (("2.25", 0, "2.25", 4), "left", 2, 1, Fraction(1, 4)),
        (("2.25", 0, "2.25", 4), "right", 2, 1, Fraction(3, 4)),
    ],
)
def test_named_values(coords, inside, x, y, expected):
    config = GEOMETRY_CONFIGS["default"]
    edge = Edge.from_pixels(config, *coords, inside=inside)
    assert exact_coverage(config, edge, x, y) == expected
    assert clipped_area(config, edge, x, y) == expected
    assert exact_coverage_array(config, edge, [x], [y])[0] == pytest.approx(float(expected))


@pytest.mark.parametrize("text", ["1e1000000000", "1e-999", "1e100", "9" * 65, "inf", "nan"])
def test_from_pixels_refuses_numbers_it_cannot_read_cheaply(text):
    """Huge exponents and long text are refused at once (Fraction would build the power)."""
    with pytest.raises(EdgeError, match=r"^X0 (must be a decimal number|= .* out of range)"):
        Edge.from_pixels(GEOMETRY_CONFIGS["default"], text, 0, 1, 1)


def test_from_pixels_reads_plain_decimals_and_small_exponents():
    config = GEOMETRY_CONFIGS["default"]
    edge = Edge.from_pixels(config, "2.5e1", "0e1000000000", "5e-001", 1)
    assert (edge.x0, edge.y0, edge.x1) == tuple(
        int(v * config.subpixel_scale) for v in (25, 0, Fraction(1, 2))
    )
