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
and vertex or path position at fault. Limits (docs/scenes.md, "Errors and limits") are
checked as the scene is read, before anything is allocated for it: file size, pixels,
edges per scene and per polygon (flattened curve pieces included), coordinate magnitude and
the smallest tolerance.
"""

from __future__ import annotations

import gc
import json
import math
import re
from contextlib import contextmanager
from dataclasses import dataclass

from ..model.numbers import shown

DEFAULT_TOLERANCE = 1.0 / 16  # px: max distance between a curve and its chords
MIN_TOLERANCE = 1.0 / 1024  # px: finer than the finest sub-pixel grid (1/256 px)
MAX_FILE_BYTES = 32 << 20  # a scene file; the text built-in as JSON is about 60 kB
MAX_PIXELS = 1 << 24  # width x height: 16,777,216 (4096 x 4096); the image is int64
MAX_EDGES = 400_000  # edges of a scene, curves flattened
MAX_POLYGON_EDGES = 20_000  # edges of one polygon as written (curve pieces included)
MAX_NODED_EDGES = 100_000  # edges of one polygon after splitting at crossings (docs/scenes.md)
MAX_STEPPED_COLUMNS = 4_000_000  # columns the engine steps in a scene: about 1.7 GB at peak
MAX_COORD = float(1 << 20)  # px, |x| and |y|: 16 times the widest coordinate range
FILL_RULES = {"nonzero": "nonzero", "non-zero": "nonzero", "evenodd": "evenodd"}
FILL_RULES["even-odd"] = "evenodd"
SCENE_KEYS = ("width", "height", "background", "background_color", "tolerance", "polygons", "name")
GEOMETRY_KEYS = ("points", "contours", "path", "rect", "circle", "ellipse")
POLYGON_KEYS = (
    *GEOMETRY_KEYS, "intensity", "color", "fill_rule", "stroke", "transform", "name",
)  # fmt: skip
STROKE_KEYS = ("width", "cap", "join", "miter_limit", "dash", "dash_offset")

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
    # A colour instead of the intensity: red, green, blue and alpha in [0, 1] (sRGB values),
    # composited per channel (`edgeaa.render.paint`).
    paint: tuple[float, float, float, float] | None = None
    # The groups (indices into `Scene.layers`, outermost first) this polygon is drawn inside:
    # each composited as a layer with its opacity (SVG's group opacity, `edgeaa.render.paint`).
    layers: tuple[int, ...] = ()


@dataclass(frozen=True)
class Scene:
    width: int
    height: int
    polygons: tuple[Polygon, ...]
    background: int = 0
    name: str = "scene"
    tolerance: float = DEFAULT_TOLERANCE
    # A colour background (red, green, blue, alpha in [0, 1]) instead of `background`; SVG
    # files start transparent.
    background_paint: tuple[float, float, float, float] | None = None
    # Each layer's opacity in [0, 1] (`Polygon.layers`); a colour scene's.
    layers: tuple[float, ...] = ()
    # Colours composited in linear light (sRGB decoded before, encoded after: `paint`).
    linear_light: bool = False

    @property
    def colour(self) -> bool:
        """Whether any paint is a colour: rendered per channel (`edgeaa.render.paint`)."""
        return self.background_paint is not None or any(p.paint for p in self.polygons)

    @property
    def edge_count(self) -> int:
        return sum(len(c) for p in self.polygons for c in p.contours)


# -- JSON --------------------------------------------------------------------------------------


def read_text(path: str) -> str:
    """The file's text: UTF-8 (a byte-order mark allowed), at most MAX_FILE_BYTES."""
    try:
        with open(path, "rb") as file:
            raw = file.read(MAX_FILE_BYTES + 1)
    except OSError as error:
        raise SceneError(f"cannot read scene {path}: {error.strerror or error}") from None
    if len(raw) > MAX_FILE_BYTES:
        raise SceneError(f"{path}: larger than the limit of {MAX_FILE_BYTES >> 20} MiB")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise SceneError(
            f"{path}: not UTF-8 text (byte {raw[error.start]:#04x} at offset {error.start})"
        ) from None


class _BadJson(ValueError):
    """Raised from the JSON decoder's hooks; its message is the whole complaint."""


def _no_duplicates(pairs: list) -> dict:
    keys = set()
    for key, _ in pairs:
        if key in keys:
            raise _BadJson(f"key {shown(key)} appears twice in one object; give each key once")
        keys.add(key)
    return dict(pairs)


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise _BadJson(f"number {shown(text)} is beyond the range of a double")
    return value


def _short_int(text: str) -> int:
    if len(text.lstrip("-")) > 30:  # int() of thousands of digits is slow, then refused
        raise _BadJson(f"integer {shown(text)} has more than 30 digits")
    return int(text)


def _no_constant(text: str):
    raise _BadJson(f"{text} is not allowed: numbers must be finite")


def parse_json(text: str, source: str = "scene"):
    """JSON with finite numbers of sane length and no duplicate keys; SceneError otherwise."""
    try:
        return json.loads(
            text,
            object_pairs_hook=_no_duplicates,
            parse_float=_finite_float,
            parse_int=_short_int,
            parse_constant=_no_constant,
        )
    except json.JSONDecodeError as error:
        raise SceneError(
            f"{source}: not valid JSON: {error.msg} (line {error.lineno}, column {error.colno})"
        ) from None
    except _BadJson as error:
        raise SceneError(f"{source}: {error}") from None
    except RecursionError:
        raise SceneError(f"{source}: JSON nested too deeply (a scene needs 5 levels)") from None


def load_scene(path: str) -> Scene:
    """Read a scene file (JSON, see docs/scenes.md)."""
    name = path.rsplit("/", 1)[-1].rsplit(".", 1)[0]
    with _collector_paused():
        data = parse_json(read_text(path), path)  # the text is freed once parsed
        return parse_scene(data, path, name, items=_emptying)


def scene_from_json(text: str, source: str = "scene", name: str = "scene") -> Scene:
    """A scene from a JSON scene file's text."""
    with _collector_paused():
        return parse_scene(parse_json(text, source), source, name, items=_emptying)


@contextmanager
def _collector_paused():
    """Python's cyclic garbage collector paused, as it was found after: the parse makes a
    few objects a vertex and no reference cycles, and the collector's passes over them made
    it superlinear (the 1,000 to 4,000-glyph pages' parse slope 1.19 with it, 0.91
    without, docs/results.md section 7)."""
    paused = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if paused:
            gc.enable()


def _number(where: str, value, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise SceneError(f"{where} must be a number, not {shown(value)}")
    if positive and value <= 0:
        raise SceneError(f"{where} must be positive, not {shown(value)}")
    return float(value)


def _coordinate(where: str, value) -> float:
    value = _number(where, value)
    if abs(value) > MAX_COORD:
        raise SceneError(f"{where} = {value:g} px is beyond the limit of +-{MAX_COORD:,.0f} px")
    return value


def _integer(where: str, value, lo: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise SceneError(f"{where} must be an integer, not {shown(value)}")
    if lo is not None and value < lo:
        raise SceneError(f"{where} must be at least {lo}, not {value}")
    return value


def _check_keys(where: str, data: dict, allowed: tuple[str, ...]) -> None:
    for key in data:
        if key not in allowed:
            raise SceneError(f"{where}: unknown field {key!r} (allowed: {', '.join(allowed)})")


def _emptying(items: list):
    """Each item of `items`, its place in the list emptied as it is handed out: a scene's
    own JSON is freed polygon by polygon as its tuples are built (the JSON and the tuples
    both whole were the load's peak, 27 of the 4,000-glyph page's 117 MB)."""
    for i, item in enumerate(items):
        items[i] = None
        yield item


def _contour(where: str, points) -> Contour:
    if not isinstance(points, list):
        raise SceneError(f"{where} must be a list of [x, y] vertices, not {shown(points)}")
    if len(points) > MAX_POLYGON_EDGES:
        raise SceneError(
            f"{where} has {len(points):,} vertices, more than the limit of "
            f"{MAX_POLYGON_EDGES:,} edges per polygon"
        )
    out = []
    for i, point in enumerate(points):
        if not (isinstance(point, list | tuple) and len(point) == 2):
            raise SceneError(f"{where} vertex {i} must be [x, y], not {shown(point)}")
        x = _coordinate(f"{where} vertex {i} x", point[0])
        out.append((x, _coordinate(f"{where} vertex {i} y", point[1])))
    distinct = {p for p in out}
    if len(out) < 3 or len(distinct) < 3:
        raise SceneError(
            f"{where} has {len(distinct)} distinct vertices; a contour needs at least 3"
        )
    return tuple(out)


def parse_scene(data, source: str = "scene", name: str = "scene", items=iter) -> Scene:
    """Build a Scene from parsed JSON, checking every field and every limit. `items` goes
    through the polygons' list (`_emptying` for JSON no one else holds)."""
    if not isinstance(data, dict):
        raise SceneError(f"{source}: a scene is a JSON object with width, height and polygons")
    _check_keys(source, data, SCENE_KEYS)
    for key in ("width", "height", "polygons"):
        if key not in data:
            raise SceneError(f"{source}: missing field {key!r}")
    width = _integer(f"{source}: width", data["width"], 1)
    height = _integer(f"{source}: height", data["height"], 1)
    check_pixels(source, width, height)
    background = _integer(f"{source}: background", data.get("background", 0), 0)
    backdrop = data.get("background_color")
    if backdrop is not None:
        backdrop = color(f"{source}: background_color", backdrop)
    tolerance = _number(
        f"{source}: tolerance", data.get("tolerance", DEFAULT_TOLERANCE), positive=True
    )
    if tolerance < MIN_TOLERANCE:
        raise SceneError(
            f"{source}: tolerance {tolerance:g} px is below the limit of "
            f"1/{1 / MIN_TOLERANCE:.0f} px"
        )
    polygons = data["polygons"]
    if not isinstance(polygons, list):
        raise SceneError(f"{source}: polygons must be a list")
    parsed, edges = [], 0
    for i, item in enumerate(items(polygons)):
        polygon = parse_polygon(item, f"{source}: polygon {i}", tolerance)
        edges += sum(len(c) for c in polygon.contours)
        if edges > MAX_EDGES:
            raise SceneError(
                f"{source}: more than the limit of {MAX_EDGES:,} edges per scene "
                f"(reached at polygon {i})"
            )
        parsed.append(polygon)
    name = data.get("name", name)
    if not isinstance(name, str):
        raise SceneError(f"{source}: name must be a string")
    return Scene(width, height, tuple(parsed), background, name, tolerance, backdrop)


def check_pixels(source: str, width: int, height: int, limit: int = MAX_PIXELS) -> None:
    """Refuse an image of more than `limit` pixels before anything is allocated for it."""
    if width * height > limit:
        side = math.isqrt(limit)
        raise SceneError(
            f"{source}: the image is {width} x {height} = {width * height:,} pixels, more than "
            f"the limit of {limit:,} ({side} x {side})"
        )


def parse_polygon(item, where: str, tolerance: float = DEFAULT_TOLERANCE) -> Polygon:
    if not isinstance(item, dict):
        raise SceneError(f"{where} must be an object with points, contours or path")
    _check_keys(where, item, POLYGON_KEYS)
    given = [key for key in GEOMETRY_KEYS if key in item]
    if len(given) != 1:
        raise SceneError(
            f"{where} needs exactly one of {', '.join(GEOMETRY_KEYS)}"
            + (f", not {' and '.join(given)}" if given else "")
        )
    if given[0] in ("rect", "circle", "ellipse"):  # SVG's shapes, as SVG's path data
        item = {**item, "path": shape_path(where, given[0], item[given[0]])}
    matrix = _matrix(where, item.get("transform"))
    stretch = _stretch(matrix)
    local = tolerance / stretch if stretch > 0 else tolerance  # chords within tol in pixels
    if "points" in item:
        contours = (_contour(f"{where}", item["points"]),)
    elif "contours" in item:
        contours = _contours(where, item["contours"])
    else:  # path, or a shape made path
        if not isinstance(item["path"], str):
            raise SceneError(f"{where}: path must be a string of SVG path data")
        reader = read_path(item["path"], local, where=where)
        contours = tuple(reader.contours)
    rule = item.get("fill_rule", "nonzero")
    if not isinstance(rule, str) or rule not in FILL_RULES:
        raise SceneError(
            f"{where}: unknown fill_rule {shown(rule)} (allowed: nonzero, evenodd; "
            "also non-zero, even-odd)"
        )
    if "stroke" in item:
        if "fill_rule" in item:
            raise SceneError(f"{where}: fill_rule does not apply to a stroke (filled non-zero)")
        subpaths = reader.subpaths if "path" in item else _closed_subpaths(contours)
        contours, rule = _stroked(where, item["stroke"], subpaths, local), "nonzero"
    if stretch == 0:
        contours = ()  # a transform that scales to nothing draws nothing, as in SVG
    contours = tuple(_transformed(where, matrix, c) for c in contours)
    intensity, paint = _paint(where, item)
    label = item.get("name", "")
    if not isinstance(label, str):
        raise SceneError(f"{where}: name must be a string")
    return Polygon(contours, intensity, FILL_RULES[rule], label, paint)


def shape_path(where: str, shape: str, value) -> str:
    """SVG's rect [x, y, width, height(, rx(, ry))], circle [cx, cy, r] and ellipse [cx, cy,
    rx, ry] as the path data SVG defines for them (rx, ry clamped to half the sides, one
    given for both); a zero size draws nothing, as in SVG."""
    sizes = {"rect": (4, 6), "circle": (3, 3), "ellipse": (4, 4)}[shape]
    if not isinstance(value, list) or not sizes[0] <= len(value) <= sizes[1]:
        raise SceneError(
            f"{where}: {shape} must be a list of {' to '.join(map(str, sorted(set(sizes))))} "
            f"numbers, not {shown(value)}"
        )
    v = [_coordinate(f"{where}: {shape} {i}", n) for i, n in enumerate(value)]
    if min(v[2:]) < 0:
        raise SceneError(f"{where}: {shape} sizes and radii must not be negative")
    if shape == "rect":
        x, y, w, h = v[:4]
        rx = v[4] if len(v) > 4 else None
        ry = v[5] if len(v) > 5 else rx
        rx = ry if rx is None else rx
        rx, ry = min(rx or 0.0, w / 2), min(ry or 0.0, h / 2)
        if rx == 0 or ry == 0:
            return f"M {x!r} {y!r} h {w!r} v {h!r} h {-w!r} Z" if w and h else ""
        arc = f"A {rx!r} {ry!r} 0 0 1"
        return (
            f"M {x + rx!r} {y!r} H {x + w - rx!r} {arc} {x + w!r} {y + ry!r} "
            f"V {y + h - ry!r} {arc} {x + w - rx!r} {y + h!r} H {x + rx!r} "
            f"{arc} {x!r} {y + h - ry!r} V {y + ry!r} {arc} {x + rx!r} {y!r} Z"
        )
    cx, cy, rx = v[:3]
    ry = v[3] if shape == "ellipse" else rx
    if rx == 0 or ry == 0:
        return ""
    arc = f"A {rx!r} {ry!r} 0 0 1"
    return (
        f"M {cx + rx!r} {cy!r} {arc} {cx!r} {cy + ry!r} {arc} {cx - rx!r} {cy!r} "
        f"{arc} {cx!r} {cy - ry!r} {arc} {cx + rx!r} {cy!r} Z"
    )


def _paint(where: str, item: dict) -> tuple[int | None, tuple | None]:
    """The polygon's intensity or colour (not both)."""
    if "intensity" in item and "color" in item:
        raise SceneError(f"{where}: give intensity or color, not both")
    intensity = item.get("intensity")
    if intensity is not None:
        intensity = _integer(f"{where}: intensity", intensity, 0)
    paint = color(f"{where}: color", item["color"]) if "color" in item else None
    return intensity, paint


def color(where: str, value) -> tuple[float, float, float, float]:
    """A colour: "#rgb", "#rrggbb", "#rrggbbaa", or [r, g, b] / [r, g, b, a] in [0, 1]."""
    if isinstance(value, str) and re.fullmatch(r"#(?:[0-9a-fA-F]{3}|[0-9a-fA-F]{6,8})", value):
        digits = value[1:] if len(value) != 4 else "".join(c * 2 for c in value[1:])
        if len(digits) in (6, 8):
            channels = [int(digits[i : i + 2], 16) / 255 for i in range(0, len(digits), 2)]
            return tuple(channels + [1.0] * (4 - len(channels)))
    if isinstance(value, list) and len(value) in (3, 4):
        numbers = [_number(f"{where} channel {i}", v) for i, v in enumerate(value)]
        if all(0 <= v <= 1 for v in numbers):
            return tuple(numbers + [1.0] * (4 - len(numbers)))
    raise SceneError(
        f'{where} must be "#rrggbb", "#rgb", "#rrggbbaa" or [r, g, b(, a)] in [0, 1], '
        f"not {shown(value)}"
    )


def _matrix(where: str, value) -> tuple[float, ...]:
    """`transform`: [a, b, c, d, e, f], SVG's matrix(a b c d e f): x' = a x + c y + e,
    y' = b x + d y + f."""
    if value is None:
        return (1.0, 0.0, 0.0, 1.0, 0.0, 0.0)
    if not isinstance(value, list) or len(value) != 6:
        raise SceneError(f"{where}: transform must be [a, b, c, d, e, f], not {shown(value)}")
    numbers = tuple(_number(f"{where}: transform {i}", v) for i, v in enumerate(value))
    if max(abs(v) for v in numbers) > MAX_COORD:
        raise SceneError(f"{where}: transform numbers must be within +-{MAX_COORD:,.0f}")
    return numbers


def _stretch(m: tuple[float, ...]) -> float:
    """The largest singular value of the matrix's linear part: how far it moves a chord."""
    a, b, c, d = m[:4]
    half = (a * a + b * b + c * c + d * d) / 2
    det = a * d - b * c
    return math.sqrt(half + math.sqrt(max(0.0, half * half - det * det)))


def _transformed(where: str, m: tuple[float, ...], contour: Contour) -> Contour:
    a, b, c, d, e, f = m
    if m == (1.0, 0.0, 0.0, 1.0, 0.0, 0.0):
        return contour
    out = tuple((a * x + c * y + e, b * x + d * y + f) for x, y in contour)
    for x, y in out:
        if not (abs(x) <= MAX_COORD and abs(y) <= MAX_COORD):
            raise SceneError(
                f"{where}: its transform takes a vertex to ({x:g}, {y:g}) px, beyond the limit "
                f"of +-{MAX_COORD:,.0f} px"
            )
    return out


def _closed_subpaths(contours: tuple[Contour, ...]) -> list:
    from .stroke import Subpath

    return [Subpath(tuple(c), True, (True,) * len(c)) for c in contours]


def _stroked(where: str, data, subpaths: list, tolerance: float) -> tuple[Contour, ...]:
    """`stroke`: {"width", "cap", "join", "miter_limit", "dash", "dash_offset"}, the
    outline's pieces (`edgeaa.render.stroke`)."""
    from .stroke import CAPS, JOINS, StrokeStyle, stroke_outline

    if not isinstance(data, dict) or "width" not in data:
        raise SceneError(f"{where}: stroke must be an object with at least a width")
    _check_keys(f"{where}: stroke", data, STROKE_KEYS)
    width = _number(f"{where}: stroke width", data["width"])
    limit = _number(f"{where}: stroke miter_limit", data.get("miter_limit", 4))
    offset = _number(f"{where}: stroke dash_offset", data.get("dash_offset", 0))
    if not 0 <= width <= MAX_COORD or limit < 1:
        raise SceneError(
            f"{where}: stroke width must be in [0, {MAX_COORD:,.0f}] and miter_limit at least 1"
        )
    cap, join = data.get("cap", "butt"), data.get("join", "miter")
    for name, value, allowed in (("cap", cap, CAPS), ("join", join, JOINS)):
        if value not in allowed:
            raise SceneError(
                f"{where}: stroke {name} {shown(value)} (allowed: {', '.join(allowed)})"
            )
    dashes = data.get("dash", [])
    if not isinstance(dashes, list) or len(dashes) > 64:
        raise SceneError(f"{where}: stroke dash must be a list of at most 64 lengths")
    dashes = tuple(_number(f"{where}: stroke dash {i}", v) for i, v in enumerate(dashes))
    if any(v < 0 for v in dashes):
        raise SceneError(f"{where}: stroke dash lengths must not be negative")
    style = StrokeStyle(width, cap, join, limit, dashes if sum(dashes) > 0 else (), offset)
    try:
        return tuple(stroke_outline(subpaths, style, tolerance, MAX_POLYGON_EDGES))
    except ValueError as error:
        raise SceneError(f"{where}: {error}") from None


def _contours(where: str, data) -> tuple[Contour, ...]:
    if not isinstance(data, list) or not data:
        raise SceneError(f"{where}: contours must be a non-empty list of vertex lists")
    contours, edges = [], 0
    for j, points in enumerate(data):
        contours.append(_contour(f"{where} contour {j}", points))
        edges += len(contours[-1])
        if edges > MAX_POLYGON_EDGES:
            raise SceneError(
                f"{where}: more than the limit of {MAX_POLYGON_EDGES:,} edges per polygon "
                f"(reached at contour {j})"
            )
    return tuple(contours)


# -- SVG path data -----------------------------------------------------------------------------

_TOKEN = re.compile(r"[A-Za-z]|[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
_ARGS = {"M": 2, "L": 2, "H": 1, "V": 1, "C": 6, "S": 4, "Q": 4, "T": 2, "A": 7, "Z": 0}


SEPARATORS = " \t\n\f\r,"  # SVG's whitespace (space, tab, LF, FF, CR) and the comma


def _tokens(data: str, where: str) -> list[tuple[int, str]]:
    tokens, pos = [], 0
    for match in _TOKEN.finditer(data):
        _check_gap(data, pos, match.start(), where)
        tokens.append((match.start(), match.group()))
        pos = match.end()
    _check_gap(data, pos, len(data), where)
    return tokens


def _check_gap(data: str, start: int, stop: int, where: str) -> None:
    gap = data[start:stop]
    if gap.strip(SEPARATORS):
        bad = gap.strip(SEPARATORS)[0]
        raise SceneError(f"{where}: unexpected {bad!r} at position {start + gap.index(bad)}")


def quadratic_pieces(p0: Point, p1: Point, p2: Point, tolerance: float) -> int:
    """Chords for a quadratic: h**2/8 * 2|P0 - 2P1 + P2| <= tolerance with h = 1/n."""
    ax, ay = p0[0] - 2 * p1[0] + p2[0], p0[1] - 2 * p1[1] + p2[1]
    return max(1, math.ceil(math.sqrt(math.hypot(ax, ay) / (4 * tolerance))))


def cubic_pieces(p0: Point, p1: Point, p2: Point, p3: Point, tolerance: float) -> int:
    """Chords for a cubic: h**2/8 * 6 max(|P0 - 2P1 + P2|, |P1 - 2P2 + P3|) <= tolerance."""
    a = math.hypot(p0[0] - 2 * p1[0] + p2[0], p0[1] - 2 * p1[1] + p2[1])
    b = math.hypot(p1[0] - 2 * p2[0] + p3[0], p1[1] - 2 * p2[1] + p3[1])
    return max(1, math.ceil(math.sqrt(3 * max(a, b) / (4 * tolerance))))


Tangents = tuple["Point | None", "Point | None"]  # a curve's directions at its start and end


def _first_direction(*vectors: Point) -> Point | None:
    """The first non-zero vector (a curve's tangent where its derivative vanishes is the
    direction to its next distinct control point)."""
    return next((v for v in vectors if v != (0.0, 0.0) and v != (0, 0)), None)


def _minus(p: Point, q: Point) -> Point:
    return (p[0] - q[0], p[1] - q[1])


def quadratic_tangents(p0: Point, p1: Point, p2: Point) -> Tangents:
    return (
        _first_direction(_minus(p1, p0), _minus(p2, p0)),
        _first_direction(_minus(p2, p1), _minus(p2, p0)),
    )


def cubic_tangents(p0: Point, p1: Point, p2: Point, p3: Point) -> Tangents:
    return (
        _first_direction(_minus(p1, p0), _minus(p2, p0), _minus(p3, p0)),
        _first_direction(_minus(p3, p2), _minus(p3, p1), _minus(p3, p0)),
    )


def arc_tangents(u: Point, v: Point, t0: float, sweep: float) -> Tangents:
    """P'(t) = -u sin t + v cos t at both ends, in the direction of travel."""
    sign = 1.0 if sweep > 0 else -1.0
    ends = []
    for t in (t0, t0 + sweep):
        d = (sign * (v[0] * math.cos(t) - u[0] * math.sin(t)),
             sign * (v[1] * math.cos(t) - u[1] * math.sin(t)))  # fmt: skip
        ends.append(_first_direction(d))
    return ends[0], ends[1]


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


def flatten_arc(
    center: Point,
    u: Point,
    v: Point,
    t0: float,
    sweep: float,
    end: Point,
    tolerance: float,
    limit: int = MAX_POLYGON_EDGES,
) -> list[Point]:
    """An elliptical arc P(t) = c + u cos t + v sin t, t from t0 over `sweep`, as the points
    after its start (the last is `end`): |P''| <= sqrt(|u|^2 + |v|^2) = R, so n = ceil(|sweep|
    sqrt(R / (8 tol))) chords keep it within tol (h**2 / 8 R with h = sweep / n). A zero
    radius or sweep is a line (SVG's rule). SceneError when n passes `limit`."""
    radius = math.sqrt(u[0] ** 2 + u[1] ** 2 + v[0] ** 2 + v[1] ** 2)
    if radius == 0 or sweep == 0 or math.hypot(*u) == 0 or math.hypot(*v) == 0:
        return [end]
    n = max(1, math.ceil(abs(sweep) * math.sqrt(radius / (8 * tolerance))))
    if n > limit:
        raise SceneError(
            f"an arc needs {n:,} pieces at tolerance {tolerance:g}, more than the limit of "
            f"{limit:,} edges per polygon"
        )
    out = []
    for i in range(1, n):
        t = t0 + sweep * i / n
        ct, st = math.cos(t), math.sin(t)
        out.append((center[0] + u[0] * ct + v[0] * st, center[1] + u[1] * ct + v[1] * st))
    return [*out, end]


def arc_points(start: Point, params: list[float], end: Point, tolerance: float, limit: int):
    """SVG's arc from `start` (rx, ry, rotation in degrees, large-arc flag, sweep flag) to
    `end`, flattened, and its tangents at both ends (None, None for a line): svgelements
    converts the endpoints to the centre form with its radius correction (the same reading as
    an SVG file's), `flatten_arc` cuts it."""
    import svgelements as se

    rx, ry, rotation, large, sweep = params
    data = f"M {start[0]!r} {start[1]!r} A {rx!r} {ry!r} {rotation!r} {int(large)} {int(sweep)} "
    arc = se.Path(data + f"{end[0]!r} {end[1]!r}").segments()[-1]
    if not isinstance(arc, se.Arc):
        return [end], (None, None)
    return centre_arc(arc, end, tolerance, limit)


def centre_arc(arc, end: Point, tolerance: float, limit: int = MAX_POLYGON_EDGES):
    """svgelements' arc (centre, semi-axis end points, start angle, sweep) flattened, and its
    tangents (None, None where it is a line)."""
    c, u, v = arc.center, arc.prx, arc.pry
    c, u, v = (c[0], c[1]), (u[0] - c[0], u[1] - c[1]), (v[0] - c[0], v[1] - c[1])
    t0, sweep = float(arc.get_start_t()), float(arc.sweep)
    points = flatten_arc(c, u, v, t0, sweep, end, tolerance, limit)
    line = len(points) == 1 and (math.hypot(*u) == 0 or math.hypot(*v) == 0 or sweep == 0)
    return points, (None, None) if line else arc_tangents(u, v, t0, sweep)


def close_subpath(points: list[Point], contours: list[Contour]) -> None:
    """End a subpath: drop a repeated start point; keep it if it encloses anything."""
    while len(points) > 1 and points[-1] == points[0]:
        points.pop()
    deduped = [p for i, p in enumerate(points) if i == 0 or p != points[i - 1]]
    if len(set(deduped)) >= 3:
        contours.append(tuple(deduped))


def parse_path(
    data: str,
    tolerance: float = DEFAULT_TOLERANCE,
    where: str = "path",
    limit: int = MAX_POLYGON_EDGES,
) -> tuple[Contour, ...]:
    """The path's contours for filling (`read_path`)."""
    return tuple(read_path(data, tolerance, where, limit).contours)


def read_path(
    data: str,
    tolerance: float = DEFAULT_TOLERANCE,
    where: str = "path",
    limit: int = MAX_POLYGON_EDGES,
):
    """SVG path data read: closed contours for filling and the subpaths as written (for
    strokes; `_PathReader`): M/L/H/V/Z, C/S cubic and Q/T quadratic curves, A arcs,
    absolute and relative; every subpath is closed for filling (as SVG fills do). Subpaths
    with fewer than 3 distinct vertices enclose nothing and are dropped (a path of only such
    subpaths draws nothing, as in SVG). A command without
    its numbers is an error; so is a path whose points (curve pieces included) would pass
    `limit`, refused before a curve is flattened."""
    path = _PathReader(where, tolerance, limit)
    tokens = _tokens(data, where)
    i = 0
    while i < len(tokens):
        pos, token = tokens[i]
        if token.isalpha():
            path.command(token, pos)
            i += 1
            continue
        n = path.arguments(pos)
        if i + n > len(tokens) or any(t.isalpha() for _, t in tokens[i : i + n]):
            raise SceneError(
                f"{where}: command {path.name!r} at position {path.name_pos} needs {n} numbers"
            )
        path.draw([_path_number(where, p, t) for p, t in tokens[i : i + n]])
        i += n
    path.finish()
    return path


def _path_number(where: str, pos: int, token: str) -> float:
    value = float(token)
    if not abs(value) <= MAX_COORD:
        raise SceneError(
            f"{where}: number {shown(token)} at position {pos} is beyond the limit of "
            f"+-{MAX_COORD:,.0f} px"
        )
    return value


class _PathReader:
    """The state of path data being read: the current point, the subpath, the contours."""

    def __init__(self, where: str, tolerance: float, limit: int):
        self.where, self.tolerance, self.limit = where, tolerance, limit
        self.contours: list[Contour] = []
        self.points: list[Point] = []
        self.corners: list[bool] = []  # per point: a corner between segments (not in a curve)
        self.tangents: list[list] = []  # per point: a curve's [end, start] tangent there
        self.subpaths: list = []  # every subpath as written (`stroke.Subpath`), for strokes
        self.count = 0  # points so far, every subpath: the limit counts them
        self.cur = self.start = (0.0, 0.0)
        self.name = self.name_pos = None  # the current command and where it was named
        self.waiting = False  # the command has not had its numbers yet
        self.last_cubic = self.last_quad = None  # reflected control points for S and T

    def command(self, token: str, pos: int) -> None:
        where = self.where
        if token.upper() not in _ARGS:
            raise SceneError(f"{where}: unknown path command {token!r} at position {pos}")
        if self.name_pos is None and token not in "Mm":
            raise SceneError(f"{where}: path data must start with M or m (position {pos})")
        self._check_waiting()
        self.name, self.name_pos = token, pos
        self.waiting = token not in "Zz"
        if not self.waiting:
            self._end(closed=True)
            self.points, self.corners, self.tangents, self.cur = [], [], [], self.start
            self.last_cubic = self.last_quad = None

    def _check_waiting(self) -> None:
        if self.waiting:
            n = _ARGS[self.name.upper()]
            raise SceneError(
                f"{self.where}: command {self.name!r} at position {self.name_pos} needs {n} numbers"
            )

    def arguments(self, pos: int) -> int:
        """How many numbers the current command takes (SceneError if numbers may not come)."""
        if self.name is None or self.name in "Zz":
            what = "start with M or m" if self.name is None else "name a command before numbers"
            raise SceneError(f"{self.where}: path data must {what} (position {pos})")
        return _ARGS[self.name.upper()]

    def draw(self, args: list[float]) -> None:
        self.waiting = False
        upper, relative = self.name.upper(), self.name.islower()
        ox, oy = self.cur if relative else (0.0, 0.0)
        if upper == "M":
            self._end(closed=False)
            self.cur = self.start = self._point(ox + args[0], oy + args[1])
            self.points, self.corners, self.tangents = [self.cur], [True], [[None, None]]
            self.name = "l" if relative else "L"  # further pairs are lines
            self.last_cubic = self.last_quad = None
            return
        if not self.points:  # drawing after Z without M starts at the subpath's start
            self.points, self.corners, self.tangents = [self.cur], [True], [[None, None]]
        tangents = (None, None)
        if upper in "LHV":
            new = [self._line(upper, relative, args)]
        elif upper in "CS":
            new, tangents = self._cubic(upper, (ox, oy), args)
        elif upper == "A":
            new, tangents = self._arc((ox, oy), args)
        else:
            new, tangents = self._quadratic(upper, (ox, oy), args)
        if upper not in "CSQT":
            self.last_cubic = self.last_quad = None
        self.points.extend(new)
        self.corners += [False] * (len(new) - 1) + [True]
        self.tangents[-1][1] = tangents[0] or self.tangents[-1][1]
        self.tangents += [[None, None] for _ in new]
        self.tangents[-1][0] = tangents[1]
        self.cur = new[-1]

    def _point(self, x: float, y: float, count: bool = True) -> Point:
        """A new point (or a control point: not counted), checked against the limits."""
        if not (abs(x) <= MAX_COORD and abs(y) <= MAX_COORD):
            raise SceneError(
                f"{self.where}: the path reaches ({x:g}, {y:g}) px (command {self.name!r} at "
                f"position {self.name_pos}), beyond the limit of +-{MAX_COORD:,.0f} px"
            )
        if count:
            self._count(1)
        return (x, y)

    def _count(self, n: int) -> None:
        self.count += n
        if self.count > self.limit:
            raise SceneError(
                f"{self.where}: the path needs more than the limit of {self.limit:,} edges per "
                f"polygon (at command {self.name!r}, position {self.name_pos}; curves count "
                f"their pieces at tolerance {self.tolerance:g} px)"
            )

    def _line(self, upper: str, relative: bool, args: list[float]) -> Point:
        x, y = self.cur
        dx, dy = (x, y) if relative else (0.0, 0.0)
        if upper == "L":
            return self._point(dx + args[0], dy + args[1])
        if upper == "H":
            return self._point(dx + args[0], y)
        return self._point(x, dy + args[0])

    def _cubic(self, upper: str, origin: Point, args: list[float]) -> list[Point]:
        ox, oy = origin
        cur, last = self.cur, self.last_cubic
        if upper == "C":
            c1, rest = self._point(ox + args[0], oy + args[1], count=False), args[2:]
        else:
            c1 = (2 * cur[0] - last[0], 2 * cur[1] - last[1]) if last else cur
            rest = args
        c2 = self._point(ox + rest[0], oy + rest[1], count=False)
        end = self._point(ox + rest[2], oy + rest[3], count=False)  # counted in the pieces
        self._count(cubic_pieces(cur, c1, c2, end, self.tolerance))
        self.last_cubic, self.last_quad = c2, None
        return flatten_cubic(cur, c1, c2, end, self.tolerance), cubic_tangents(cur, c1, c2, end)

    def _quadratic(self, upper: str, origin: Point, args: list[float]) -> list[Point]:
        ox, oy = origin
        cur, last = self.cur, self.last_quad
        if upper == "Q":
            c1 = self._point(ox + args[0], oy + args[1], count=False)
            end = self._point(ox + args[2], oy + args[3], count=False)  # counted in the pieces
        else:
            c1 = (2 * cur[0] - last[0], 2 * cur[1] - last[1]) if last else cur
            end = self._point(ox + args[0], oy + args[1], count=False)
        self._count(quadratic_pieces(cur, c1, end, self.tolerance))
        self.last_cubic, self.last_quad = None, c1
        return flatten_quadratic(cur, c1, end, self.tolerance), quadratic_tangents(cur, c1, end)

    def _arc(self, origin: Point, args: list[float]) -> list[Point]:
        """An elliptical arc (rx ry rotation large-arc sweep x y), SVG's out-of-range radius
        and flag rules, flattened within the tolerance (`arc_points`)."""
        ox, oy = origin
        for flag in args[3:5]:
            if flag not in (0.0, 1.0):
                raise SceneError(
                    f"{self.where}: arc flag {flag:g} at command {self.name!r} (position "
                    f"{self.name_pos}) must be 0 or 1"
                )
        end = self._point(ox + args[5], oy + args[6], count=False)  # counted in the pieces
        limit = self.limit - self.count
        points, tangents = arc_points(self.cur, args[:5], end, self.tolerance, limit)
        self._count(len(points))
        return points, tangents

    def _end(self, closed: bool) -> None:
        """End a subpath: its contour for filling, and the subpath as written for strokes."""
        from .stroke import subpath_of

        if self.points:
            self.subpaths.append(subpath_of(self.points, self.corners, self.tangents, closed))
        close_subpath(self.points, self.contours)

    def finish(self) -> tuple[Contour, ...]:
        self._check_waiting()
        self._end(closed=False)
        return tuple(self.contours)  # empty when every subpath is degenerate: draws nothing
