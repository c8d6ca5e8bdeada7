"""SVG files as scenes: the subset icon sets, glyph exports and HUD artwork use (docs/scenes.md,
"SVG files").

svgelements (PyPI) reads the XML: CSS in `style` elements and attributes, inheritance,
`use`/`defs`, every transform, `viewBox` with `preserveAspectRatio`, lengths and units,
colours (named, hex, rgb(), currentColor), shapes as path segments, and the arc rules of the
SVG implementation notes (out-of-range radii scaled up, flags). This module turns each
painted shape into `Polygon`s, the same representation the JSON format gives: its fill (one
polygon, the shape's fill rule) and its stroke (one non-zero polygon of pieces,
`edgeaa.render.stroke`), in document order.

Curves are flattened in the shape's own coordinates with the scene tolerance divided by the
transform's largest stretch (its largest singular value), so the chords stay within the
tolerance in pixels; the points are then transformed. A stroke is expanded in the shape's
coordinates, where its width is given, and transformed with it (a non-uniform scale gives
the stroke SVG gives). Elements outside the subset (text, images, gradients and patterns,
masks, filters, clip paths, markers) are refused naming the element, or skipped with a
warning when `lenient`.
"""

from __future__ import annotations

import io
import math
from collections import Counter
from collections.abc import Callable
from dataclasses import replace

from .scene import (
    DEFAULT_TOLERANCE,
    MAX_COORD,
    MAX_EDGES,
    MAX_POLYGON_EDGES,
    Polygon,
    Scene,
    SceneError,
    centre_arc,
    check_pixels,
    close_subpath,
    cubic_pieces,
    cubic_tangents,
    flatten_cubic,
    flatten_quadratic,
    quadratic_pieces,
    quadratic_tangents,
    read_text,
)
from .stroke import CAPS, JOINS, StrokeStyle, Subpath, stroke_outline, subpath_of

Point = tuple[float, float]
# Elements whose drawing needs more than filled and stroked outlines in flat colours.
UNSUPPORTED = (
    "text", "tspan", "textPath", "image", "mask", "filter", "clipPath", "pattern", "marker",
    "foreignObject", "linearGradient", "radialGradient", "switch", "video", "audio", "canvas",
)  # fmt: skip
# Attributes that reference one of them from a shape.
UNSUPPORTED_REFERENCES = ("mask", "filter", "clip-path", "marker-start", "marker-mid", "marker-end")


def _refuse(what: str, lenient: bool, warn: Callable[[str], None]) -> None:
    """`what` (the file and element) refused, or with `lenient` skipped with a warning."""
    if not lenient:
        raise SceneError(
            f"{what} is outside the SVG subset (docs/scenes.md); --lenient skips it with a warning"
        )
    warn(f"skipped {what} (outside the SVG subset)")


def load_svg(
    path: str,
    size: tuple[int, int] | None = None,
    scale: float | None = None,
    lenient: bool = False,
    warn: Callable[[str], None] = print,
    tolerance: float = DEFAULT_TOLERANCE,
) -> Scene:
    """Read an SVG file as a scene: the image is the SVG's width x height (px, rounded up),
    times `scale`; or `size` (width, height), the drawing fitted into it by the root's
    preserveAspectRatio (as if the root's width and height were those)."""
    import svgelements as se

    text = read_text(path)
    svg = _parse(se, text, path)
    width, height = float(svg.width), float(svg.height)
    if not (width > 0 and height > 0 and math.isfinite(width * height)):
        raise SceneError(f"{path}: the SVG has no positive width and height (or viewBox)")
    outer = se.Matrix()
    if size is not None:
        outer, pixels = _fitted(se, svg, size, width, height), size
    else:
        factor = 1.0 if scale is None else scale
        outer = se.Matrix.scale(factor)
        pixels = (math.ceil(width * factor - 1e-9), math.ceil(height * factor - 1e-9))
    if pixels[0] * pixels[1] > (1 << 40) or min(pixels) < 1:
        raise SceneError(f"{path}: the image would be {pixels[0]} x {pixels[1]} px")
    check_pixels(path, *pixels)
    # SVG's pixel i covers [i, i + 1]; the model's is centred on i
    outer = outer * se.Matrix.translate(-0.5, -0.5)
    polygons: list[Polygon] = []
    budget = [MAX_EDGES]
    said: set[str] = set()
    warn = _once(warn, said)
    groups = _Groups(se, svg, path)
    for element in svg.elements():
        chain = groups.chain(element)
        if chain is not None:
            found = _element(se, element, outer, tolerance, lenient, warn, path, budget)
            polygons += groups.place(found, chain, element)
    name = path.rsplit("/", 1)[-1].rsplit(".", 1)[0]
    transparent = (0.0, 0.0, 0.0, 0.0)  # SVG's canvas
    polygons, layers = _fold_layers(polygons, groups.opacities)
    return Scene(pixels[0], pixels[1], tuple(polygons), 0, name, tolerance, transparent, layers)


class _Groups:
    """SVG's `opacity` (not inherited: svgelements copies it down to the children, so each
    element's own comes from its attributes) on a container (`g`, `use`, `svg`) or on a shape
    with both a fill and a stroke: the content drawn into a transparent layer, composited with
    the opacity (`edgeaa.render.paint`). `opacities` holds each layer's."""

    def __init__(self, se, svg, source: str):
        self.se, self.source = se, source
        self.parents: dict[int, object] = {}
        todo = [svg]
        while todo:  # every container's children (svgelements: a container is a list)
            node = todo.pop()
            for child in node:
                self.parents[id(child)] = node
                if isinstance(child, list):
                    todo.append(child)
        self.ids: dict[int, int] = {}  # id(container) -> its layer
        self.opacities: list[float] = []

    def own(self, element) -> float:
        attributes = element.values.get("attributes") or {}
        where = f"{self.source}: <{_tag(element)}>"
        return _fraction(attributes.get("opacity"), 1.0, where, "opacity")

    def chain(self, element) -> tuple[int, ...] | None:
        """The layers of the element's containers with opacity below 1, outermost first;
        None when one's opacity is 0 (nothing inside is drawn)."""
        out = []
        node = self.parents.get(id(element))
        while node is not None:
            opacity = self.own(node)
            if opacity == 0:
                return None
            if opacity < 1:
                out.append(self._layer(node, opacity))
            node = self.parents.get(id(node))
        return tuple(out[::-1])

    def _layer(self, key, opacity: float) -> int:
        if id(key) not in self.ids:
            self.ids[id(key)] = len(self.opacities)
            self.opacities.append(opacity)
        return self.ids[id(key)]

    def place(self, polygons: list[Polygon], chain, element) -> list[Polygon]:
        """The element's polygons inside its containers' layers; its own opacity on the
        paints of one, or as a layer of the fill and the stroke together."""
        opacity = self.own(element) if polygons else 1.0
        if opacity == 0:
            return []
        if opacity < 1:
            chain += (self._layer(element, opacity),)
        return [replace(p, layers=chain) for p in polygons]


def _fold_layers(polygons: list[Polygon], opacities: list[float]):
    """A layer holding one polygon is that polygon with its alpha times the opacity (exact:
    source-over of one paint scaled by the opacity); the others renumbered in order."""
    counts = Counter(layer for p in polygons for layer in p.layers)
    keep = sorted(layer for layer, n in counts.items() if n > 1)
    number = {layer: i for i, layer in enumerate(keep)}
    out = []
    for p in polygons:
        alpha = p.paint[3]
        for layer in p.layers:
            if layer not in number:
                alpha *= opacities[layer]
        layers = tuple(number[layer] for layer in p.layers if layer in number)
        out.append(replace(p, paint=(*p.paint[:3], alpha), layers=layers))
    return out, tuple(opacities[layer] for layer in keep)


def _fitted(se, svg, size: tuple[int, int], width: float, height: float):
    """The matrix that redraws the SVG on `size` pixels as if its root's width and height
    were those: its view box mapped there by its preserveAspectRatio instead (svgelements
    has already mapped it onto width x height); without a view box, width x height is
    fitted (xMidYMid meet)."""
    box = svg.viewbox
    if box is None or not (box.width and box.height):
        fit = se.Viewbox.viewbox_transform(0, 0, *size, 0, 0, width, height, "xMidYMid meet")
        return se.Matrix(fit)
    aspect = box.preserve_aspect_ratio or "xMidYMid meet"
    args = (box.x, box.y, box.width, box.height, aspect)
    before = se.Matrix(se.Viewbox.viewbox_transform(0, 0, width, height, *args))
    after = se.Matrix(se.Viewbox.viewbox_transform(0, 0, *size, *args))
    return ~before * after  # svgelements: a * b applies a, then b


def _once(warn: Callable[[str], None], said: set[str]) -> Callable[[str], None]:
    """`warn`, each message once (an element repeated by the hundred gives one line)."""

    def once(message: str) -> None:
        if message not in said:
            said.add(message)
            warn(message)

    return once


def _parse(se, text: str, path: str):
    """svgelements' SVG root, or a one-line SceneError (the library's own failures too)."""
    from xml.etree.ElementTree import ParseError

    try:
        svg = se.SVG.parse(io.StringIO(text), reify=False, ppi=96.0)
    except ParseError as error:
        raise SceneError(f"{path}: not well-formed XML: {error}") from None
    except RecursionError:
        raise SceneError(f"{path}: the SVG is nested too deeply") from None
    except Exception as error:  # the library's own failures on odd input: one line, no trace
        raise SceneError(
            f"{path}: svgelements cannot read it: {type(error).__name__}: {error}"
        ) from None
    if not isinstance(svg, se.SVG):
        raise SceneError(f"{path}: no <svg> root element")
    return svg


def _tag(element) -> str:
    tag = str(getattr(element, "values", {}).get("tag", ""))
    return tag.rsplit("}", 1)[-1]


def _element(se, element, outer, tol, lenient, warn, source, budget) -> list[Polygon]:
    """The polygons of one element (none for containers and metadata)."""
    tag = _tag(element)
    if isinstance(element, se.Text | se.Image) or tag in UNSUPPORTED:
        _refuse(f"{source}: <{tag or type(element).__name__.lower()}>", lenient, warn)
        return []
    if not isinstance(element, se.Shape):
        return []
    where = f"{source}: <{tag}>" + (f" id={element.id!r}" if element.id else "")
    values = element.values
    for attribute in UNSUPPORTED_REFERENCES:
        if values.get(attribute) not in (None, "", "none"):
            _refuse(f"{where} {attribute}={values[attribute]!r}", lenient, warn)
            return []
    if values.get("vector-effect") not in (None, "", "none"):  # strokes in screen space
        _refuse(f"{where} vector-effect={values['vector-effect']!r}", lenient, warn)
        return []
    if values.get("display") == "none" or values.get("visibility") in ("hidden", "collapse"):
        return []
    matrix = element.transform * outer if element.transform is not None else outer
    stretch = _stretch(matrix)
    if stretch == 0:
        return []  # scaled to nothing
    try:
        paths = _subpaths(se, element, tol / stretch, budget[0], where)
    except (ValueError, ArithmeticError) as error:  # the library's on odd numbers
        raise SceneError(f"{where}: {error}") from None
    out = []
    for kind, paint in (("fill", element.fill), ("stroke", element.stroke)):
        raw = str(values.get(kind) or "")
        if raw.strip().startswith("url("):
            _refuse(f"{where} {kind}={raw!r} (a gradient or pattern paint)", lenient, warn)
            continue
        if paint is None or paint.value is None or paint.alpha == 0:
            continue
        rgba = (paint.red / 255, paint.green / 255, paint.blue / 255, paint.alpha / 255)
        if kind == "fill":
            contours = _fill_contours(paths, matrix, where)
            rule = "evenodd" if values.get("fill-rule") == "evenodd" else "nonzero"
        else:
            style = _stroke_style(element, values, where)
            contours = _stroke_contours(paths, style, matrix, tol / stretch, budget[0], where)
            rule = "nonzero"
        if not contours:
            continue
        edges = sum(map(len, contours))
        if edges > MAX_POLYGON_EDGES:
            raise SceneError(
                f"{where}: its {kind} has {edges:,} edges, more than the limit of "
                f"{MAX_POLYGON_EDGES:,} per polygon (curves at tolerance {tol:g} px)"
            )
        budget[0] -= edges
        if budget[0] < 0:
            raise SceneError(f"{source}: more than the limit of {MAX_EDGES:,} edges per scene")
        out.append(Polygon(tuple(contours), None, rule, f"{where} {kind}", rgba))
    return out


def _stretch(matrix) -> float:
    """The largest singular value of the matrix's linear part."""
    a, b, c, d = matrix.a, matrix.b, matrix.c, matrix.d
    s = (a * a + b * b + c * c + d * d) / 2
    det = a * d - b * c
    return math.sqrt(s + math.sqrt(max(0.0, s * s - det * det)))


def _fraction(value, default: float, where: str, name: str) -> float:
    """An opacity: a number or a percentage, clamped to [0, 1] as CSS says."""
    if value in (None, ""):
        return default
    text = str(value).strip()
    try:
        number = float(text[:-1]) / 100 if text.endswith("%") else float(text)
    except ValueError:
        raise SceneError(f"{where}: {name} {text!r} is not a number") from None
    if not math.isfinite(number):
        raise SceneError(f"{where}: {name} {text!r} is not a finite number")
    return min(1.0, max(0.0, number))


def _subpaths(se, element, tol: float, limit: int, where: str) -> list[Subpath]:
    """The shape's path flattened in its own coordinates: every subpath's points, whether it
    was closed (Z), which points are corners between segments, the curves' tangents."""
    out: list[Subpath] = []
    points: list[Point] = []
    corners: list[bool] = []
    tangents: list[list] = []  # per point: [end tangent, start tangent] of the curves there
    closed = False
    count = 0

    def finish():
        if points:
            out.append(subpath_of(points, corners, tangents, closed, _same))

    for segment in se.Path(element).segments(transformed=False):
        if isinstance(segment, se.Move):
            finish()
            points, corners, closed = [_xy(segment.end)], [True], False
            tangents = [[None, None]]
            continue
        if not points:  # a segment after Z without M starts at the subpath's start
            points, corners, closed = [_xy(segment.start)], [True], False
            tangents = [[None, None]]
        new, (start, end) = _flatten(se, segment, tol)
        count += len(new)
        if count > limit:
            raise SceneError(f"{where}: its path needs more than the limit of {limit:,} edges")
        points += new
        corners += [False] * (len(new) - 1) + [True]
        tangents[-1][1] = start or tangents[-1][1]
        tangents += [[None, None] for _ in new]
        tangents[-1][0] = end
        if isinstance(segment, se.Close):
            closed = True
            finish()
            points, corners, tangents = [], [], []
    finish()
    return out


def _xy(point) -> Point:
    return (float(point[0]), float(point[1]))


SAME = 1e-9  # px: points this close are one (far below the 1/256 px finest grid)


def _same(p: Point, q: Point) -> bool:
    """Equal within SAME px, the float noise of svgelements' shapes (a circle's last arc ends
    2e-15 px off its start)."""
    return abs(p[0] - q[0]) <= SAME and abs(p[1] - q[1]) <= SAME


def _flatten(se, segment, tol: float):
    """The segment's points after its start, chords within tol; its tangents at both ends
    (None for a line)."""
    start, end = _xy(segment.start), _xy(segment.end)
    if isinstance(segment, se.CubicBezier):
        c1, c2 = _xy(segment.control1), _xy(segment.control2)
        _check_pieces(cubic_pieces(start, c1, c2, end, tol))
        return flatten_cubic(start, c1, c2, end, tol), cubic_tangents(start, c1, c2, end)
    if isinstance(segment, se.QuadraticBezier):
        c = _xy(segment.control)
        _check_pieces(quadratic_pieces(start, c, end, tol))
        return flatten_quadratic(start, c, end, tol), quadratic_tangents(start, c, end)
    if isinstance(segment, se.Arc):
        return centre_arc(segment, end, tol)
    return [end], (None, None)  # Line, Close


def _check_pieces(n: int) -> None:
    if n > MAX_POLYGON_EDGES:
        raise SceneError(
            f"a curve needs {n:,} pieces, more than the limit of "
            f"{MAX_POLYGON_EDGES:,} edges per polygon"
        )


def _transform(matrix, points, where: str) -> tuple[Point, ...]:
    a, b, c, d, e, f = matrix.a, matrix.b, matrix.c, matrix.d, matrix.e, matrix.f
    out = tuple((a * x + c * y + e, b * x + d * y + f) for x, y in points)
    for x, y in out:
        if not (abs(x) <= MAX_COORD and abs(y) <= MAX_COORD):
            raise SceneError(
                f"{where}: reaches ({x:g}, {y:g}) px, beyond the limit of +-{MAX_COORD:,.0f} px"
            )
    return out


def _fill_contours(paths: list[Subpath], matrix, where: str) -> list[tuple[Point, ...]]:
    """Every subpath closed for filling; those enclosing nothing dropped (SVG draws nothing)."""
    contours: list = []
    for path in paths:
        close_subpath(list(_transform(matrix, path.points, where)), contours)
    return contours


def _stroke_style(element, values, where: str) -> StrokeStyle:
    cap = str(values.get("stroke-linecap") or "butt")
    join = str(values.get("stroke-linejoin") or "miter")
    if cap not in CAPS:
        raise SceneError(f"{where}: stroke-linecap {cap!r} (allowed: {', '.join(CAPS)})")
    join = "miter" if join in ("miter-clip", "arcs") else join  # SVG 2's fall back to miter
    if join not in JOINS:
        raise SceneError(f"{where}: stroke-linejoin {join!r} (allowed: {', '.join(JOINS)})")
    width = float(element.stroke_width)
    limit = float(values.get("stroke-miterlimit") or 4)
    if not (math.isfinite(width) and width >= 0 and math.isfinite(limit) and limit >= 1):
        raise SceneError(f"{where}: stroke-width must be >= 0 and stroke-miterlimit >= 1")
    dashes = _dashes(values.get("stroke-dasharray"), where)
    offset = _length(values.get("stroke-dashoffset") or "0", where, "stroke-dashoffset")
    return StrokeStyle(width, cap, join, limit, dashes, offset)


def _length(text: str, where: str, name: str) -> float:
    try:
        value = float(str(text).strip().removesuffix("px"))
    except ValueError:
        raise SceneError(f"{where}: {name} {text!r} is not a length in user units") from None
    if not math.isfinite(value):
        raise SceneError(f"{where}: {name} {text!r} is not finite")
    return value


def _dashes(text, where: str) -> tuple[float, ...]:
    """stroke-dasharray: none, or lengths (commas or spaces); a negative one is an error, all
    zero is solid (SVG's rules)."""
    if text in (None, "", "none"):
        return ()
    parts = str(text).replace(",", " ").split()
    values = tuple(_length(p, where, "stroke-dasharray") for p in parts)
    if any(v < 0 for v in values):
        raise SceneError(f"{where}: stroke-dasharray {text!r} has a negative length")
    return values if sum(values) > 0 else ()


def _stroke_contours(paths, style, matrix, tol, limit, where) -> list[tuple[Point, ...]]:
    try:
        pieces = stroke_outline(paths, style, tol, limit)
    except ValueError as error:
        raise SceneError(f"{where}: {error}") from None
    return [_transform(matrix, piece, where) for piece in pieces]
