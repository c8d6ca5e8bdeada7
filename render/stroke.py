"""Strokes expanded into outlines, filled non-zero (docs/scenes.md, "Strokes").

A stroke of width w along a flattened subpath is the union of simple convex pieces, each
wound the same way (counter-clockwise in the y-down plane, positive shoelace area): one
rectangle per segment (the segment swept by a w-long normal), one join piece per corner on
the outer side of the turn (miter kite, bevel triangle or a round wedge), and at the ends of
an open subpath its caps (butt: none; square: a w/2 extension; round: a half disc). Their
non-zero fill is the union, so where pieces overlap (the inner side of every turn, a path
crossing itself) the area counts once, the SVG stroke's area.

Straight parts are exact: the corners are the true offset points. Round parts (round joins
and caps, and the turn between two chords of a flattened curve, which the curve's own offset
rounds) are chords of the circle of radius w/2 whose sagitta is at most the tolerance: an arc
step of 2 acos(1 - tol / r). Dashes cut the flattened subpath at the lengths of the dash
array (lengths measured along the chords), each dash an open subpath with its caps.
"""

from __future__ import annotations

import math
import operator
from dataclasses import dataclass

Point = tuple[float, float]
CAPS = ("butt", "round", "square")
JOINS = ("miter", "round", "bevel")


Tangent = Point | None  # a curve's direction where it ends or starts (None: the chord's)


@dataclass(frozen=True)
class Subpath:
    """Flattened points (no two consecutive equal), whether the subpath is closed, and per
    point whether it is a corner between two path segments (a join applies) rather than a
    vertex inside a flattened curve (its offset is round); and per point the true tangents
    of the curves that end and start there (empty: the chords' directions everywhere)."""

    points: tuple[Point, ...]
    closed: bool
    corners: tuple[bool, ...]
    tangents: tuple[tuple[Tangent, Tangent], ...] = ()


def subpath_of(points, corners, tangents, closed: bool, same=operator.eq) -> Subpath:
    """A subpath from a path's points as read (with their corners and [end, start] tangents):
    a point the `same` as the one before merged into it (keeping its end tangent and taking
    the start tangent that follows), and a closed subpath's closing point dropped (the
    tangent arriving there moved to the start)."""
    pts, flags, tans = [], [], []
    for i, (p, corner, (tin, tout)) in enumerate(zip(points, corners, tangents, strict=True)):
        if i and same(p, points[i - 1]):
            tans[-1] = (tans[-1][0], tout or tans[-1][1])
            continue
        pts.append(p)
        flags.append(corner)
        tans.append((tin, tout))
    if closed and len(pts) > 1 and same(pts[-1], pts[0]):
        pts.pop()
        flags.pop()
        tans[0] = (tans.pop()[0], tans[0][1])
    return Subpath(tuple(pts), closed, tuple(flags), tuple(tans))


@dataclass(frozen=True)
class StrokeStyle:
    width: float
    cap: str = "butt"
    join: str = "miter"
    miter_limit: float = 4.0
    dashes: tuple[float, ...] = ()  # empty: solid
    dash_offset: float = 0.0


def arc_step(radius: float, tolerance: float) -> float:
    """The largest angle whose chord on a circle of `radius` stays within `tolerance`
    (sagitta r (1 - cos(step / 2)) <= tol), at most a quarter turn."""
    if radius <= tolerance:
        return math.pi / 2
    return min(math.pi / 2, 2 * math.acos(1 - tolerance / radius))


def area(points) -> float:
    """The shoelace area (positive counter-clockwise in the y-down plane's x-y axes)."""
    return 0.5 * sum(
        x0 * y1 - x1 * y0
        for (x0, y0), (x1, y1) in zip(points, [*points[1:], points[0]], strict=True)
    )


def _ccw(points: list[Point]) -> tuple[Point, ...]:
    """The piece wound with positive area (the same sense for every piece)."""
    return tuple(points if area(points) > 0 else points[::-1])


def _arc(center: Point, radius: float, a0: float, a1: float, tolerance: float) -> list[Point]:
    """Points on the circle from angle a0 to a1 (both included), chords within tolerance."""
    n = max(1, math.ceil(abs(a1 - a0) / arc_step(radius, tolerance)))
    cx, cy = center
    return [
        (
            cx + radius * math.cos(a0 + (a1 - a0) * i / n),
            cy + radius * math.sin(a0 + (a1 - a0) * i / n),
        )
        for i in range(n + 1)
    ]


def _normal(p: Point, q: Point, half: float) -> Point:
    dx, dy = q[0] - p[0], q[1] - p[1]
    length = math.hypot(dx, dy)
    return (-dy / length * half, dx / length * half)


PARALLEL = 1e-9  # rad: directions this close to parallel are (a curve's tangent at a cusp)


def _join(a: Point, b: Point, c: Point, join: str, style: StrokeStyle, tol: float):
    """The piece filling the outer side of the turn at b (segments a-b, b-c), or None."""
    half = style.width / 2
    n1, n2 = _normal(a, b, half), _normal(b, c, half)
    cross = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
    if abs(cross) <= PARALLEL * math.dist(a, b) * math.dist(b, c):
        cross = 0.0  # parallel: a tangent's float noise must not pick the side of a reversal
    if cross == 0 and n1[0] * n2[0] + n1[1] * n2[1] > 0:
        return None  # straight on: the rectangles meet edge to edge
    sign = -1.0 if cross > 0 else 1.0  # the outer side is away from the turn
    o1 = (b[0] + sign * n1[0], b[1] + sign * n1[1])
    o2 = (b[0] + sign * n2[0], b[1] + sign * n2[1])
    if join == "round":
        a1 = math.atan2(o1[1] - b[1], o1[0] - b[0])
        a2 = math.atan2(o2[1] - b[1], o2[0] - b[0])
        turn = (a2 - a1 + math.pi) % (2 * math.pi) - math.pi  # the short way round
        if cross == 0:
            turn = -math.pi  # a full reversal: the half disc beyond b, from o1 = b + n1
        return _ccw([b, *_arc(b, half, a1, a1 + turn, tol)])
    # cos of the angle between the segments' directions; the miter length ratio is
    # 1 / sin(theta / 2) with theta the angle between the segments (SVG's miterlimit).
    cos_turn = (n1[0] * n2[0] + n1[1] * n2[1]) / (half * half)
    sin_half = math.sqrt(max(0.0, (1 + cos_turn) / 2))  # sin(theta / 2): theta = pi - turn
    if join == "miter" and sin_half > 0 and 1 / sin_half <= style.miter_limit:
        mx, my = (o1[0] + o2[0]) / 2 - b[0], (o1[1] + o2[1]) / 2 - b[1]
        scale = (half / sin_half) / math.hypot(mx, my)
        tip = (b[0] + mx * scale, b[1] + my * scale)
        return _ccw([b, o1, tip, o2])
    return _ccw([b, o1, o2])


def _cap(end: Point, before: Point, style: StrokeStyle, tol: float):
    """The cap beyond `end` of the segment before-end, or None (butt)."""
    half = style.width / 2
    nx, ny = _normal(before, end, half)
    dx, dy = ny, -nx  # along the segment, length half
    if style.cap == "square":
        return _ccw(
            [
                (end[0] + nx, end[1] + ny),
                (end[0] + nx + dx, end[1] + ny + dy),
                (end[0] - nx + dx, end[1] - ny + dy),
                (end[0] - nx, end[1] - ny),
            ]
        )
    if style.cap == "round":
        a0 = math.atan2(ny, nx)
        return _ccw(_arc(end, half, a0, a0 - math.pi, tol))
    return None


def _dot(p: Point, style: StrokeStyle, tol: float) -> list[tuple[Point, ...]]:
    """A zero-length subpath: a disc for round caps, a square along x for square, else
    nothing (SVG's rule)."""
    half = style.width / 2
    if style.cap == "round":
        return [_ccw(_arc(p, half, 0.0, 2 * math.pi, tol)[:-1])]
    if style.cap == "square":
        x, y = p
        return [
            _ccw(
                [
                    (x - half, y - half),
                    (x + half, y - half),
                    (x + half, y + half),
                    (x - half, y + half),
                ]
            )
        ]
    return []


def _convex(points: list[Point]) -> bool:
    turns = [
        (q[0] - p[0]) * (r[1] - q[1]) - (q[1] - p[1]) * (r[0] - q[0])
        for p, q, r in zip(points, points[1:] + points[:1], points[2:] + points[:2], strict=True)
    ]
    return not (min(turns) < 0 < max(turns))


def _chord(p: Point, q: Point, start: Tangent, end: Tangent, style: StrokeStyle, tol: float):
    """The pieces of one chord: the chord swept by its normal; where a curve starts at p or
    ends at q, the normal of its tangent there instead, so the cap or join beyond meets the
    curve's true offset (a quadrilateral, convex unless the stroke is wider than the curve's
    radius of curvature; then the rectangle and round wedges from the chord's normal to the
    tangent's)."""
    half = style.width / 2
    chord = _normal(p, q, half)
    n0 = _normal((0.0, 0.0), start, half) if start else chord
    n1 = _normal((0.0, 0.0), end, half) if end else chord
    quad = [
        (p[0] + n0[0], p[1] + n0[1]),
        (q[0] + n1[0], q[1] + n1[1]),
        (q[0] - n1[0], q[1] - n1[1]),
        (p[0] - n0[0], p[1] - n0[1]),
    ]
    if _convex(quad):
        return [_ccw(quad)]
    nx, ny = chord
    pieces = [_ccw([(p[0] + nx, p[1] + ny), (q[0] + nx, q[1] + ny),
                    (q[0] - nx, q[1] - ny), (p[0] - nx, p[1] - ny)])]  # fmt: skip
    if start:
        pieces.append(_join(_minus(p, start), p, q, "round", style, tol))
    if end:
        pieces.append(_join(p, q, _plus(q, end), "round", style, tol))
    return [piece for piece in pieces if piece]


def _plus(p: Point, d: Point) -> Point:
    return (p[0] + d[0], p[1] + d[1])


def _minus(p: Point, d: Point) -> Point:
    return (p[0] - d[0], p[1] - d[1])


def stroke_subpath(path: Subpath, style: StrokeStyle, tol: float) -> list[tuple[Point, ...]]:
    """The pieces of one subpath's stroke (no dashes). Joins and caps take the directions of
    the curves' true tangents where they have them (`Subpath.tangents`), else the chords'."""
    pts, corners = list(path.points), list(path.corners)
    tangents = list(path.tangents) or [(None, None)] * len(pts)
    if len(pts) == 1:
        return _dot(pts[0], style, tol)
    closed = path.closed and len(pts) > 2
    if closed:
        pts.append(pts[0])
        corners.append(corners[0])
        tangents.append(tangents[0])
    pieces = []
    for k in range(len(pts) - 1):
        pieces += _chord(pts[k], pts[k + 1], tangents[k][1], tangents[k + 1][0], style, tol)
    inner = range(len(pts) - 1) if closed else range(1, len(pts) - 1)
    for k in inner:
        a, b, c = pts[k - 1] if k else pts[-2], pts[k], pts[k + 1]
        tin, tout = tangents[k]
        join = style.join if corners[k] else "round"
        a, c = _minus(b, tin) if tin else a, _plus(b, tout) if tout else c
        piece = _join(a, b, c, join, style, tol)
        if piece:
            pieces.append(piece)
    if not closed:
        last, first = tangents[-1][0], tangents[0][1]
        for end, before in (
            (pts[-1], _minus(pts[-1], last) if last else pts[-2]),
            (pts[0], _plus(pts[0], first) if first else pts[1]),
        ):
            piece = _cap(end, before, style, tol)
            if piece:
                pieces.append(piece)
    return pieces


def dash(path: Subpath, dashes: tuple[float, ...], offset: float) -> list[Subpath]:
    """The dashes of a subpath: on for dashes[0], off for dashes[1], ... (an odd list is
    repeated once, as SVG says), starting `offset` into the pattern; lengths along the
    chords. A dash of length zero is a one-point subpath (a dot with round or square caps).
    A cut inside a curve's chord takes the direction between those at the chord's ends (the
    curve's, `_direction`), so its cap is square to the curve."""
    if len(dashes) % 2:
        dashes = dashes * 2
    pts = list(path.points) + ([path.points[0]] if path.closed else [])
    corners = list(path.corners) + ([path.corners[0]] if path.closed else [])
    tangents = list(path.tangents) or [(None, None)] * len(path.points)
    tangents += [tangents[0]] if path.closed else []
    k, left = 0, offset % sum(dashes)
    while left > dashes[k] or 0 < left == dashes[k]:  # a zero-length dash at 0 stays
        left -= dashes[k]
        k = (k + 1) % len(dashes)
    left = dashes[k] - left  # what remains of dash or gap k
    out, current = [], [(pts[0], False, tangents[0])] if k % 2 == 0 else []
    for i in range(1, len(pts)):
        p, q = pts[i - 1], pts[i]
        length, done = math.hypot(q[0] - p[0], q[1] - p[1]), 0.0
        while length - done > left:
            done += left
            t = done / length
            along = _blend(_direction(pts, corners, tangents, i - 1, True),
                           _direction(pts, corners, tangents, i, False), t)  # fmt: skip
            cut = ((p[0] + (q[0] - p[0]) * t, p[1] + (q[1] - p[1]) * t), False, (along, along))
            if k % 2 == 0:
                out.append([*current, cut])
                current = []
            else:
                current = [cut]
            k = (k + 1) % len(dashes)
            left = dashes[k]
        left -= length - done
        if k % 2 == 0:
            current.append((q, corners[i], tangents[i]))
    if current:
        out.append(current)
    return [_subpath(part) for part in out]


def _unit(d: Point) -> Point:
    length = math.hypot(*d)
    return (d[0] / length, d[1] / length)


def _direction(pts, corners, tangents, i: int, leaving: bool) -> Point:
    """The path's direction at point i on the chord leaving it (or arriving): the curve's
    tangent where one starts (ends) there, the bisector of the two chords at a vertex inside
    a flattened curve (the tangent there of a circle's chords), else the chord's."""
    j = i + 1 if leaving else i - 1
    chord = _unit(_minus(pts[j], pts[i]) if leaving else _minus(pts[i], pts[j]))
    given = tangents[i][1 if leaving else 0]
    if given:
        return _unit(given)
    if not corners[i] and 0 < i < len(pts) - 1:
        a, b = _unit(_minus(pts[i], pts[i - 1])), _unit(_minus(pts[i + 1], pts[i]))
        if a[0] + b[0] or a[1] + b[1]:
            return _unit((a[0] + b[0], a[1] + b[1]))
    return chord


def _blend(a: Point, b: Point, t: float) -> Point | None:
    """The direction a fraction t of the way from direction a to b (None if they cancel)."""
    d = (a[0] * (1 - t) + b[0] * t, a[1] * (1 - t) + b[1] * t)
    return d if d != (0.0, 0.0) else None


def _subpath(marked: list[tuple[Point, bool, tuple]]) -> Subpath:
    """An open subpath from (point, corner, tangents) triples, repeated points merged."""
    points, corners, tangents = zip(*marked, strict=True)
    return subpath_of(points, corners, tangents, False)


def stroke_outline(
    paths: list[Subpath], style: StrokeStyle, tol: float, limit: int
) -> list[tuple[Point, ...]]:
    """The stroke of every subpath as pieces to fill together non-zero (pieces of no area
    dropped). ValueError when the pieces' vertices would pass `limit`."""
    if style.width <= 0:
        return []
    dashed = bool(style.dashes) and sum(style.dashes) > 0
    pieces, count = [], 0
    for path in paths:
        if dashed:
            # each dash has at least 4 vertices: refuse before cutting millions
            length = sum(map(math.dist, path.points, path.points[1:]))
            if (length / sum(style.dashes) + 1) * (len(style.dashes) + 1) // 2 * 4 > limit:
                raise ValueError(f"its dashes need more than the limit of {limit:,} edges")
        for part in dash(path, style.dashes, style.dash_offset) if dashed else [path]:
            for piece in stroke_subpath(part, style, tol):
                count += len(piece)
                if count > limit:
                    raise ValueError(f"its stroke needs more than the limit of {limit:,} edges")
                if abs(area(piece)) > 0:
                    pieces.append(piece)
    return pieces
