"""Strokes (render/stroke.py) against an independent stroked area, shapely's (GEOS) buffer
with the same caps and joins, and through the renderer: non-zero, so overlaps count once.
The tolerance of the comparison is derived in docs/scenes.md, "Strokes"."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from shapely import unary_union
from shapely.geometry import LineString, Point
from shapely.geometry import Polygon as ShapelyPolygon
from shapely.ops import substring

from edgeaa.model import EdgeConfig
from edgeaa.render import plan_scene, render_scene
from edgeaa.render.exact import error_rows, exact_image
from edgeaa.render.scene import Polygon, Scene
from edgeaa.render.stroke import CAPS, JOINS, StrokeStyle, Subpath, dash, stroke_outline

TOL = 1 / 16  # px, the scene tolerance
QUAD_SEGS = 64  # GEOS's chords per quarter circle in the reference
GEOS_CAP = {"butt": "flat", "round": "round", "square": "square"}
GEOS_JOIN = {"miter": "mitre", "round": "round", "bevel": "bevel"}
# Overlays snap-round to this grid: GEOS's floating overlay can drop a whole face where edges
# nearly coincide (seen: a union of four dashes lost one, 4.3 px^2; a symmetric difference of
# two equal areas gave 22.5). Snapping moves each vertex at most GRID, so an area by at most
# perimeter x GRID, far inside every bound below.
GRID = 1e-9


def outline(points, closed: bool, style: StrokeStyle):
    path = Subpath(tuple(points), closed, (True,) * len(points))
    return stroke_outline([path], style, TOL, 10**6)


def union(pieces):
    return unary_union([ShapelyPolygon(p) for p in pieces], grid_size=GRID)


def reference(points, closed: bool, style: StrokeStyle, join: str | None = None):
    """GEOS's buffer of the path, with the parts every such stroke certainly covers: each
    segment's body (width w, flat ends) and, for round joins or caps, the disc of radius
    w/2 at each joint or end (the segments are at least w long). GEOS's buffer of a
    self-crossing path with short segments can lose a face inside them: points=[(0, 0.5),
    (1.75, 5.25), (0, 0), (1.75, 1)], closed, width 2, bevels lost 0.78 of a body;
    [(0, 0.25), (0.25, 2), (0, 0), (1, 1.25)], closed, width 1.5, round joins lost 0.78 of
    the loop it closes, every point of which lies within w/2 of the path."""
    ring = [*points, points[0]] if closed else list(points)
    r, join = style.width / 2, join or style.join
    buffer = LineString(ring).buffer(
        r, quad_segs=QUAD_SEGS, cap_style=GEOS_CAP[style.cap], join_style=GEOS_JOIN[join],
        mitre_limit=style.miter_limit,
    )  # fmt: skip
    parts = [
        LineString(pair).buffer(r, cap_style="flat") for pair in zip(ring, ring[1:], strict=False)
    ]
    joints = ring if closed else ring[1:-1]
    discs = (joints if join == "round" else []) + (
        [ring[0], ring[-1]] if style.cap == "round" and not closed else []
    )
    parts += [Point(p).buffer(r, quad_segs=QUAD_SEGS) for p in discs]
    return unary_union([buffer, *parts], grid_size=GRID)


def miter_ratios(points, closed: bool) -> list[float]:
    """1 / sin(theta / 2) at every corner (theta the angle between the segments)."""
    pts = list(points)
    corners = range(len(pts)) if closed else range(1, len(pts) - 1)
    out = []
    for k in corners:
        a, b, c = pts[k - 1], pts[k], pts[(k + 1) % len(pts)]
        u = (a[0] - b[0], a[1] - b[1])
        v = (c[0] - b[0], c[1] - b[1])
        cos = (u[0] * v[0] + u[1] * v[1]) / (math.hypot(*u) * math.hypot(*v))
        half = math.sqrt(max(0.0, (1 - cos) / 2))
        out.append(math.inf if half == 0 else 1 / half)
    return out


def retraced(points, closed: bool) -> bool:
    """Whether two segments overlap along a length (GEOS's buffer then fills the ring they
    close, which the stroke does not cover)."""
    pts = [*points, points[0]] if closed else list(points)
    segments = [LineString(pair) for pair in zip(pts, pts[1:], strict=False)]
    return any(
        a.intersection(b).length > 0 for i, a in enumerate(segments) for b in segments[i + 1 :]
    )


def round_bound(style: StrokeStyle, corners: int) -> float:
    """Area both round approximations may miss: chords inscribed in the circle of radius
    r = w/2 leave lenses no thicker than their sagitta (ours <= TOL, GEOS's
    r (1 - cos(pi / (4 QUAD_SEGS)))), over at most half a turn per corner and cap."""
    r = style.width / 2
    sagitta = TOL + r * (1 - math.cos(math.pi / (4 * QUAD_SEGS)))
    return sagitta * math.pi * r * (corners + 2)


points_st = st.lists(
    st.tuples(st.integers(0, 160), st.integers(0, 160)).map(lambda p: (p[0] / 4, p[1] / 4)),
    min_size=2, max_size=6,
).filter(lambda p: all(a != b for a, b in zip(p, p[1:], strict=False)))  # fmt: skip


@settings(max_examples=150, deadline=None)
@given(
    points=points_st, closed=st.booleans(), width=st.sampled_from([0.25, 0.5, 1, 1.5, 2, 5, 8]),
    cap=st.sampled_from(CAPS), join=st.sampled_from(JOINS), limit=st.sampled_from([1.0, 4.0, 50.0]),
)  # fmt: skip
@example(  # GEOS's floating overlay lost a face here (GRID above)
    points=[(0.75, 32.75), (0.0, 0.25), (38.5, 0.0), (0.25, 34.0), (1.75, 0.25), (3.5, 0.0)],
    closed=True, width=0.5, cap="butt", join="miter", limit=1.0,
)  # fmt: skip
@example(  # GEOS's buffer lost a face inside a segment's body here (`reference`)
    points=[(0.0, 0.5), (1.75, 5.25), (0.0, 0.0), (1.75, 1.0)],
    closed=True, width=2, cap="butt", join="miter", limit=1.0,
)  # fmt: skip
@example(  # GEOS's buffer lost the loop the path closes here (`reference`)
    points=[(0.0, 0.25), (0.25, 2.0), (0.0, 0.0), (1.0, 1.25)],
    closed=True, width=1.5, cap="butt", join="round", limit=4.0,
)  # fmt: skip
def test_the_stroke_is_shapelys_buffer_within_the_round_parts_bound(
    points, closed, width, cap, join, limit
):
    # GEOS buffers a line whose ends meet as a ring (a join there): SVG caps an open one
    assume(points[0] != points[-1])
    closed = closed and len(points) > 2
    ratios = miter_ratios(points, closed)
    assume(all(r != math.inf for r in ratios))  # a full reversal: GEOS and SVG differ in kind
    assume(not retraced(points, closed))  # GEOS fills a ring a retraced segment closes
    # GEOS's offset curve simplifies segments shorter than the buffer's width (it loses a
    # part of the true stroke there): keep them longer
    assume(min(map(math.dist, points, points[1:])) >= width)
    style = StrokeStyle(width, cap, join, limit)
    geos_join = join
    if join == "miter":  # SVG bevels past the limit, GEOS clips the miter: keep clear of it
        assume(all(r < 0.99 * limit or r > 1.01 * limit for r in ratios))
        geos_join = "miter" if all(r < limit for r in ratios) else None
        assume(geos_join or all(r > limit for r in ratios))
        geos_join = geos_join or "bevel"
    mine = union(outline(points, closed, style))
    theirs = reference(points, closed, style, geos_join)
    bound = round_bound(style, len(points)) + 1e-7 * (1 + theirs.length)
    difference = mine.symmetric_difference(theirs, grid_size=GRID).area
    assert difference <= bound, (difference, bound)


@settings(max_examples=60, deadline=None)
@given(
    points=points_st, width=st.sampled_from([0.5, 1, 2]),
    dashes=st.lists(st.integers(1, 40).map(lambda v: v / 4), min_size=1, max_size=4),
    offset=st.integers(-20, 20).map(lambda v: v / 4),
)  # fmt: skip
@example(  # a dash ending on a corner; GEOS's floating union lost a dash (GRID above)
    points=[(7.25, 18.75), (0.25, 13.5), (11.25, 30.75), (5.5, 0.0)],
    width=0.5,
    dashes=[8.5],
    offset=-0.25,
)
def test_dashes_are_the_line_cut_at_the_dash_lengths(points, width, dashes, offset):
    """The dashed stroke is the union of shapely's buffers of the pieces shapely cuts from
    the line at the pattern's lengths (round caps and joins: GEOS's buffer is exact in kind
    there, a disc swept along each piece, where its flat caps lose area on pieces shorter
    than the width)."""
    style = StrokeStyle(width, "round", "round", 4.0, tuple(dashes), offset)
    line = LineString(points)
    pattern = list(dashes) * (2 if len(dashes) % 2 else 1)
    period = sum(pattern)
    pieces, at, k = [], -(offset % period), 0
    while at < line.length:
        if k % 2 == 0 and at + pattern[k] > 0:
            piece = substring(line, max(at, 0.0), min(at + pattern[k], line.length))
            if piece.length > 0:
                pieces.append(piece.buffer(width / 2, quad_segs=QUAD_SEGS))
        at += pattern[k]
        k = (k + 1) % len(pattern)
    mine = union(outline(points, False, style))
    theirs = unary_union(pieces, grid_size=GRID) if pieces else ShapelyPolygon()
    corners = len(pieces) * (len(points) + 2)  # caps and joins of every dash, at most
    bound = round_bound(style, corners) + 1e-6 * (1 + line.length)
    assert mine.symmetric_difference(theirs, grid_size=GRID).area <= bound, dashes


def test_dash_cuts_and_zero_length_dashes():
    path = Subpath(((0.0, 0.0), (10.0, 0.0)), False, (True, True))
    parts = dash(path, (2.0, 3.0), 1.0)
    assert [p.points for p in parts] == [
        ((0.0, 0.0), (1.0, 0.0)), ((4.0, 0.0), (6.0, 0.0)), ((9.0, 0.0), (10.0, 0.0)),
    ]  # fmt: skip
    dots = dash(path, (0.0, 5.0), 0.0)  # zero-length dashes: dots with round caps
    # (none at the very end: that dash would begin where the path ends)
    assert [p.points for p in dots] == [((0.0, 0.0),), ((5.0, 0.0),)]
    disc = union(outline([(3.0, 3.0)], False, StrokeStyle(2.0, "round")))
    assert abs(disc.area - math.pi) < 2 * math.pi * TOL
    assert outline([(3.0, 3.0)], False, StrokeStyle(2.0, "butt")) == []  # SVG: nothing


def test_miter_becomes_bevel_exactly_past_the_limit():
    """A 60 degree corner has the miter ratio 1 / sin(30 deg) = 2."""
    corner = [(0.0, 0.0), (10.0, 0.0), (5.0, 5 * math.sqrt(3))]
    miter = union(outline(corner, False, StrokeStyle(2.0, "butt", "miter", 2.0001))).area
    bevel = union(outline(corner, False, StrokeStyle(2.0, "butt", "miter", 1.9999))).area
    assert math.isclose(
        bevel, union(outline(corner, False, StrokeStyle(2.0, "butt", "bevel"))).area
    )
    # the kite b, o1, tip, o2 against the triangle b, o1, o2, turn phi = 120 deg, r = 1:
    # r^2 tan(phi / 2) - r^2 sin(phi) / 2
    phi = math.radians(120)
    assert math.isclose(miter - bevel, math.tan(phi / 2) - math.sin(phi) / 2, rel_tol=1e-9)


@pytest.mark.parametrize("mode", ["paper", "seg4"])
def test_a_self_overlapping_stroke_counts_its_overlaps_once(mode):
    """A loop crossing itself, round joins, wide: the rendered ink is the union's area (the
    pieces' areas summed would count the overlaps twice and more), and every pixel is within
    the model's bound of the exact area of the outline."""
    config = EdgeConfig(mode=mode)
    loop = [(6.3, 30.2), (34.1, 6.7), (40.2, 30.9), (10.6, 8.1), (30.4, 36.3)]
    pieces = outline(loop, False, StrokeStyle(5.0, "round", "round"))
    scene = Scene(48, 48, (Polygon(tuple(pieces), None, "nonzero", "loop"),))
    result = render_scene(scene, config)
    ink = result.image.astype(np.float64).sum() / config.full_scale
    area = union(pieces).area
    summed = sum(ShapelyPolygon(p).area for p in pieces)
    assert summed > 1.15 * area  # the overlaps are many: counted twice, the ink would be more
    assert abs(ink - area) < 0.01 * area
    rows = error_rows(result, exact_image(plan_scene(scene, config)))
    assert rows[0].max_abs <= (2.0 if mode == "seg4" else 255 / 16), rows[0]


@pytest.mark.parametrize("join", JOINS)
def test_a_cusp_between_curves_reverses_beyond_the_point(join):
    """A cubic arriving straight up at (3, 11) and an arc leaving straight down: their true
    tangents are opposite up to float noise (the arc's cos(pi) is 1e-16 off), which must not
    pick the side of the reversal. Round: the half disc beyond the cusp (above y = 11), area
    pi r^2 / 2 less its chords' lenses (<= tol * pi r); miter and bevel: nothing there (SVG's
    miter at a full reversal passes every limit and bevels to nothing). Tabler's `pepper`
    icon lost that half disc (255 LSB against resvg) when the side was picked by the noise."""
    from shapely.geometry import box

    from edgeaa.render.scene import read_path

    path = read_path("M3 15 C3 14 3 12 3 11 A8 8 0 1 0 19 11", TOL)
    pieces = stroke_outline(path.subpaths, StrokeStyle(2.0, "butt", join), TOL, 10**6)
    above = union(pieces).intersection(box(-10, -10, 30, 11)).area
    if join == "round":
        assert math.pi / 2 - TOL * math.pi <= above <= math.pi / 2
    else:
        assert above <= 1e-9
