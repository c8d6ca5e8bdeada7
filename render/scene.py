"""Scenes: polygons on a background, read from JSON, with SVG path data flattened to edges.

A scene is an image size, a background intensity and an ordered list of polygons. A polygon
is one or more closed contours (vertices in pixels, x right, y down, pixel (x, y) the unit
square centred on (x, y): the model's convention), one fill intensity and a fill rule
(non-zero or even-odd). Later polygons are drawn over earlier ones. The format is described
with examples in docs/scenes.md.

Curves in path data (C/c/S/s cubic, Q/q/T/t quadratic) are flattened to chords by uniform
subdivision into n pieces, n chosen so that the distance between the curve and its chord is
at most the tolerance (default 1/16 px). The bound used: on a parameter interval of length h
a curve B(t) stays within ``h**2 / 8 * max |B''|`` of its chord; ``|B''| = 2 |P0 - 2 P1 +
P2|`` for a quadratic and ``<= 6 max(|P0 - 2 P1 + P2|, |P1 - 2 P2 + P3|)`` for a cubic.

Errors are `SceneError`s (ValueError) with one-line messages naming the polygon, contour
and vertex or path position at fault.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass

DEFAULT_TOLERANCE = 1.0 / 16  # px: max distance between a curve and its chords
FILL_RULES = {"nonzero": "nonzero", "non-zero": "nonzero", "evenodd": "evenodd"}
FILL_RULES["even-odd"] = "evenodd"
SCENE_KEYS = ("width", "height", "background", "tolerance", "polygons", "name")
POLYGON_KEYS = ("points", "contours", "path", "intensity", "fill_rule", "name")

Point = tuple[float, float]
Contour = tuple[Point, ...]


class SceneError(ValueError):
    """A scene the renderer cannot draw; the message is one line naming the problem."""


@dataclass(frozen=True)
class Polygon:
    """Closed contours (each at least 3 vertices, implicitly closed), one fill intensity
    (None: full scale) and a fill rule, 'nonzero' or 'evenodd'."""

    contours: tuple[Contour, ...]
    intensity: int | None = None
    fill_rule: str = "nonzero"
    name: str = ""


@dataclass(frozen=True)
class Scene:
    width: int
    height: int
    polygons: tuple[Polygon, ...]
    background: int = 0
    name: str = "scene"
    tolerance: float = DEFAULT_TOLERANCE

    @property
    def edge_count(self) -> int:
        return sum(len(c) for p in self.polygons for c in p.contours)


# -- JSON --------------------------------------------------------------------------------------


def load_scene(path: str) -> Scene:
    """Read a scene file (JSON, see docs/scenes.md)."""
    try:
        with open(path, encoding="utf-8") as file:
            data = json.load(file)
    except OSError as error:
        raise SceneError(f"cannot read scene {path}: {error.strerror or error}") from None
    except json.JSONDecodeError as error:
        raise SceneError(
            f"{path}: not valid JSON: {error.msg} (line {error.lineno}, column {error.colno})"
        ) from None
    name = path.rsplit("/", 1)[-1].rsplit(".", 1)[0]
    return parse_scene(data, source=path, name=name)


def _number(where: str, value, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise SceneError(f"{where} must be a number, not {value!r}")
    if positive and value <= 0:
        raise SceneError(f"{where} must be positive, not {value!r}")
    return float(value)


def _integer(where: str, value, lo: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise SceneError(f"{where} must be an integer, not {value!r}")
    if lo is not None and value < lo:
        raise SceneError(f"{where} must be at least {lo}, not {value}")
    return value


def _check_keys(where: str, data: dict, allowed: tuple[str, ...]) -> None:
    for key in data:
        if key not in allowed:
            raise SceneError(f"{where}: unknown field {key!r} (allowed: {', '.join(allowed)})")


def _contour(where: str, points) -> Contour:
    if not isinstance(points, list):
        raise SceneError(f"{where} must be a list of [x, y] vertices, not {points!r}")
    out = []
    for i, point in enumerate(points):
        if not (isinstance(point, list | tuple) and len(point) == 2):
            raise SceneError(f"{where} vertex {i} must be [x, y], not {point!r}")
        out.append(
            (_number(f"{where} vertex {i} x", point[0]), _number(f"{where} vertex {i} y", point[1]))
        )
    distinct = {p for p in out}
    if len(out) < 3 or len(distinct) < 3:
        raise SceneError(
            f"{where} has {len(distinct)} distinct vertices; a contour needs at least 3"
        )
    return tuple(out)


def parse_scene(data, source: str = "scene", name: str = "scene") -> Scene:
    """Build a Scene from parsed JSON, checking every field."""
    if not isinstance(data, dict):
        raise SceneError(f"{source}: a scene is a JSON object with width, height and polygons")
    _check_keys(source, data, SCENE_KEYS)
    for key in ("width", "height", "polygons"):
        if key not in data:
            raise SceneError(f"{source}: missing field {key!r}")
    width = _integer(f"{source}: width", data["width"], 1)
    height = _integer(f"{source}: height", data["height"], 1)
    background = _integer(f"{source}: background", data.get("background", 0), 0)
    tolerance = _number(
        f"{source}: tolerance", data.get("tolerance", DEFAULT_TOLERANCE), positive=True
    )
    polygons = data["polygons"]
    if not isinstance(polygons, list):
        raise SceneError(f"{source}: polygons must be a list")
    parsed = tuple(
        parse_polygon(item, f"{source}: polygon {i}", tolerance) for i, item in enumerate(polygons)
    )
    name = data.get("name", name)
    if not isinstance(name, str):
        raise SceneError(f"{source}: name must be a string")
    return Scene(width, height, parsed, background, name, tolerance)


def parse_polygon(item, where: str, tolerance: float = DEFAULT_TOLERANCE) -> Polygon:
    if not isinstance(item, dict):
        raise SceneError(f"{where} must be an object with points, contours or path")
    _check_keys(where, item, POLYGON_KEYS)
    given = [key for key in ("points", "contours", "path") if key in item]
    if len(given) != 1:
        raise SceneError(
            f"{where} needs exactly one of points, contours or path"
            + (f", not {' and '.join(given)}" if given else "")
        )
    if "points" in item:
        contours = (_contour(f"{where}", item["points"]),)
    elif "contours" in item:
        if not isinstance(item["contours"], list) or not item["contours"]:
            raise SceneError(f"{where}: contours must be a non-empty list of vertex lists")
        contours = tuple(
            _contour(f"{where} contour {j}", c) for j, c in enumerate(item["contours"])
        )
    else:
        if not isinstance(item["path"], str):
            raise SceneError(f"{where}: path must be a string of SVG path data")
        contours = parse_path(item["path"], tolerance, where=where)
    intensity = item.get("intensity")
    if intensity is not None:
        intensity = _integer(f"{where}: intensity", intensity, 0)
    rule = item.get("fill_rule", "nonzero")
    if rule not in FILL_RULES:
        raise SceneError(
            f"{where}: unknown fill_rule {rule!r} (allowed: nonzero, evenodd; "
            "also non-zero, even-odd)"
        )
    label = item.get("name", "")
    if not isinstance(label, str):
        raise SceneError(f"{where}: name must be a string")
    return Polygon(contours, intensity, FILL_RULES[rule], label)


# -- SVG path data -----------------------------------------------------------------------------

_TOKEN = re.compile(r"[A-Za-z]|[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
_ARGS = {"M": 2, "L": 2, "H": 1, "V": 1, "C": 6, "S": 4, "Q": 4, "T": 2, "Z": 0}


def _tokens(data: str, where: str) -> list[tuple[int, str]]:
    tokens, pos = [], 0
    for match in _TOKEN.finditer(data):
        gap = data[pos : match.start()]
        if gap.strip(" \t\r\n,"):
            bad = gap.strip(" \t\r\n,")[0]
            raise SceneError(f"{where}: unexpected {bad!r} at position {pos + gap.index(bad)}")
        tokens.append((match.start(), match.group()))
        pos = match.end()
    tail = data[pos:]
    if tail.strip(" \t\r\n,"):
        bad = tail.strip(" \t\r\n,")[0]
        raise SceneError(f"{where}: unexpected {bad!r} at position {pos + tail.index(bad)}")
    return tokens


def quadratic_pieces(p0: Point, p1: Point, p2: Point, tolerance: float) -> int:
    """Chords for a quadratic: h**2/8 * 2|P0 - 2P1 + P2| <= tolerance with h = 1/n."""
    ax, ay = p0[0] - 2 * p1[0] + p2[0], p0[1] - 2 * p1[1] + p2[1]
    return max(1, math.ceil(math.sqrt(math.hypot(ax, ay) / (4 * tolerance))))


def cubic_pieces(p0: Point, p1: Point, p2: Point, p3: Point, tolerance: float) -> int:
    """Chords for a cubic: h**2/8 * 6 max(|P0 - 2P1 + P2|, |P1 - 2P2 + P3|) <= tolerance."""
    a = math.hypot(p0[0] - 2 * p1[0] + p2[0], p0[1] - 2 * p1[1] + p2[1])
    b = math.hypot(p1[0] - 2 * p2[0] + p3[0], p1[1] - 2 * p2[1] + p3[1])
    return max(1, math.ceil(math.sqrt(3 * max(a, b) / (4 * tolerance))))


def flatten_quadratic(p0: Point, p1: Point, p2: Point, tolerance: float) -> list[Point]:
    """Points at t = 1/n .. 1 (the start point excluded)."""
    n = quadratic_pieces(p0, p1, p2, tolerance)
    out = []
    for i in range(1, n + 1):
        t = i / n
        u = 1 - t
        out.append(
            (
                u * u * p0[0] + 2 * u * t * p1[0] + t * t * p2[0],
                u * u * p0[1] + 2 * u * t * p1[1] + t * t * p2[1],
            )
        )
    out[-1] = p2
    return out


def flatten_cubic(p0: Point, p1: Point, p2: Point, p3: Point, tolerance: float) -> list[Point]:
    n = cubic_pieces(p0, p1, p2, p3, tolerance)
    out = []
    for i in range(1, n + 1):
        t = i / n
        u = 1 - t
        a, b, c, d = u * u * u, 3 * u * u * t, 3 * u * t * t, t * t * t
        out.append(
            (
                a * p0[0] + b * p1[0] + c * p2[0] + d * p3[0],
                a * p0[1] + b * p1[1] + c * p2[1] + d * p3[1],
            )
        )
    out[-1] = p3
    return out


def _close(points: list[Point], contours: list[Contour]) -> None:
    """End a subpath: drop a repeated start point; keep it if it encloses anything."""
    while len(points) > 1 and points[-1] == points[0]:
        points.pop()
    deduped = [p for i, p in enumerate(points) if i == 0 or p != points[i - 1]]
    if len(set(deduped)) >= 3:
        contours.append(tuple(deduped))


def parse_path(
    data: str, tolerance: float = DEFAULT_TOLERANCE, where: str = "path"
) -> tuple[Contour, ...]:
    """SVG path data to closed contours: M/L/H/V/Z, C/S cubic and Q/T quadratic curves,
    absolute and relative; every subpath is closed for filling (as SVG fills do). Subpaths
    with fewer than 3 distinct vertices enclose nothing and are dropped."""
    tokens = _tokens(data, where)
    contours: list[Contour] = []
    points: list[Point] = []
    cur = start = (0.0, 0.0)
    command = None
    last_cubic = last_quad = None  # reflected control points for S and T
    started = False
    i = 0
    while i < len(tokens):
        pos, token = tokens[i]
        if token.isalpha():
            if token.upper() == "A":
                raise SceneError(
                    f"{where}: arc commands (A/a) are not supported (position {pos}); "
                    "convert arcs to curves"
                )
            if token.upper() not in _ARGS:
                raise SceneError(f"{where}: unknown path command {token!r} at position {pos}")
            if not started and token not in "Mm":
                raise SceneError(f"{where}: path data must start with M or m (position {pos})")
            started = True
            command = token
            i += 1
            if command in "Zz":
                _close(points, contours)
                points = []
                cur = start
                last_cubic = last_quad = None
                command = None
            continue
        if command is None:
            what = "start with M or m" if not started else "name a command before numbers"
            raise SceneError(f"{where}: path data must {what} (position {pos})")
        upper, relative = command.upper(), command.islower()
        n = _ARGS[upper]
        args = []
        for j in range(n):
            if i + j >= len(tokens) or tokens[i + j][1].isalpha():
                raise SceneError(
                    f"{where}: command {command!r} at position {pos} needs {n} numbers"
                )
            args.append(float(tokens[i + j][1]))
        i += n
        ox, oy = cur if relative else (0.0, 0.0)
        if upper == "M":
            _close(points, contours)
            cur = start = (ox + args[0], oy + args[1])
            points = [cur]
            command = "l" if relative else "L"  # further pairs are lines
            last_cubic = last_quad = None
            continue
        if not points:  # drawing after Z without M starts at the subpath's start
            points = [cur]
        if upper == "L":
            new = [(ox + args[0], oy + args[1])]
        elif upper == "H":
            new = [(ox + args[0] if relative else args[0], cur[1])]
        elif upper == "V":
            new = [(cur[0], oy + args[0] if relative else args[0])]
        elif upper in "CS":
            if upper == "C":
                c1 = (ox + args[0], oy + args[1])
                rest = args[2:]
            else:
                c1 = (2 * cur[0] - last_cubic[0], 2 * cur[1] - last_cubic[1]) if last_cubic else cur
                rest = args
            c2 = (ox + rest[0], oy + rest[1])
            end = (ox + rest[2], oy + rest[3])
            new = flatten_cubic(cur, c1, c2, end, tolerance)
        else:  # Q, T
            if upper == "Q":
                c1 = (ox + args[0], oy + args[1])
                end = (ox + args[2], oy + args[3])
            else:
                c1 = (2 * cur[0] - last_quad[0], 2 * cur[1] - last_quad[1]) if last_quad else cur
                end = (ox + args[0], oy + args[1])
            new = flatten_quadratic(cur, c1, end, tolerance)
        last_cubic = c2 if upper in "CS" else None
        last_quad = c1 if upper in "QT" else None
        points.extend(new)
        cur = new[-1]
    _close(points, contours)
    if not contours:
        raise SceneError(f"{where}: the path encloses nothing (no subpath with 3 vertices)")
    return tuple(contours)
