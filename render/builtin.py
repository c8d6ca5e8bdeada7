"""Built-in scenes: a starburst (Siemens star) and a line of text in a framed text field.

- ``starburst``: 32 black wedges from the image centre on white (a Siemens star): spokes at
  64 angles 5.625 degrees apart (every octant; horizontal, vertical and diagonal ones), the
  classic antialiasing test pattern. The wedges reach past the image on every side.
- ``text``: a line of DejaVu Sans (the font matplotlib ships) in a grey-framed white text
  field wider than the image, as in a text box scrolled to its start: the glyph outlines come
  from the font's quadratic curves through fontTools' pen, flattened within the tolerance.

- ``hatch``: three shapes with slanted edges (a tilted square, a triangle, a disc), each filled
  with a pixel-aligned pattern drawn as polygons inside it (1 px stripes across, 1 px stripes
  down, a 2 px checker): luma structure that point sampling already renders exactly, the
  test of FXAA with geometry edges (docs/aa_methods.md). A pattern's polygons are named
  "shape K/...": they belong to the shape's object, not to the geometry.

The first two include what a real scene has and the renderer can skip: polygons equal to the
background, edges off the image, horizontal and vertical edges, edges on pixel boundaries.
"""

from __future__ import annotations

import math
from functools import lru_cache

from ..model import EdgeConfig
from .scene import DEFAULT_TOLERANCE, Contour, Polygon, Scene, flatten_quadratic

BUILTINS = ("starburst", "text", "hatch")
TEXT = "edgeaa renders polygons and text"


def font_path() -> str:
    import matplotlib

    return matplotlib.get_data_path() + "/fonts/ttf/DejaVuSans.ttf"


def builtin(name: str, config: EdgeConfig | None = None) -> Scene:
    config = config or EdgeConfig()
    if name == "starburst":
        return starburst(config.full_scale)
    if name == "text":
        return text_scene(config.full_scale)
    if name == "hatch":
        return hatch_scene(config.full_scale)
    from .scene import SceneError

    raise SceneError(f"unknown built-in scene {name!r} (built-ins: {', '.join(BUILTINS)})")


def starburst(full: int = 255, size: int = 256, wedges: int = 32, radius: float = 200.0) -> Scene:
    """`wedges` black triangles from the centre on full scale (a Siemens star: each wedge
    and each gap spans 180 / wedges degrees)."""
    cx = cy = (size - 1) / 2
    polygons = []
    for i in range(wedges):
        a0, a1 = math.pi * 2 * i / wedges, math.pi * (2 * i + 1) / wedges
        p0 = (cx + radius * math.cos(a0), cy + radius * math.sin(a0))
        p1 = (cx + radius * math.cos(a1), cy + radius * math.sin(a1))
        points = ((cx, cy), _snap(p0), _snap(p1))
        polygons.append(Polygon((points,), 0, "nonzero", f"wedge {i}"))
    return Scene(size, size, tuple(polygons), background=full, name="starburst")


def _snap(p: tuple[float, float]) -> tuple[float, float]:
    """Remove float noise (cos(pi/2) = 6e-17) so axis-aligned spokes are exactly so."""
    return tuple(round(v * 2**20) / 2**20 for v in p)


class _FlattenPen:
    """A fontTools pen that maps font units to pixels (y down) and flattens quadratics."""

    def __init__(self, glyph_set, scale: float, x: float, baseline: float, tolerance: float):
        from fontTools.pens.basePen import BasePen

        outer = self

        class Pen(BasePen):
            def _moveTo(self, pt):
                outer._start(pt)

            def _lineTo(self, pt):
                outer._line(pt)

            def _qCurveToOne(self, pt1, pt2):
                outer._quad(pt1, pt2)

            def _curveToOne(self, pt1, pt2, pt3):
                outer._cubic(pt1, pt2, pt3)

            def _closePath(self):
                outer._close()

            def _endPath(self):
                outer._close()

        self.pen = Pen(glyph_set)
        self.scale, self.x, self.baseline, self.tolerance = scale, x, baseline, tolerance
        self.contours: list[Contour] = []
        self.points: list[tuple[float, float]] = []

    def _map(self, pt):
        return (self.x + pt[0] * self.scale, self.baseline - pt[1] * self.scale)

    def _start(self, pt):
        self._close()
        self.points = [self._map(pt)]

    def _line(self, pt):
        self.points.append(self._map(pt))

    def _quad(self, pt1, pt2):
        self.points.extend(
            flatten_quadratic(self.points[-1], self._map(pt1), self._map(pt2), self.tolerance)
        )

    def _cubic(self, pt1, pt2, pt3):
        from .scene import flatten_cubic

        self.points.extend(
            flatten_cubic(
                self.points[-1], self._map(pt1), self._map(pt2), self._map(pt3), self.tolerance
            )
        )

    def _close(self):
        pts = self.points
        while len(pts) > 1 and pts[-1] == pts[0]:
            pts.pop()
        if len(set(pts)) >= 3:
            self.contours.append(tuple(pts))
        self.points = []


@lru_cache(maxsize=8)
def text_polygons(
    text: str, size: float, x: float, baseline: float, intensity: int, tolerance: float
) -> tuple[tuple[Polygon, ...], float]:
    """`glyph_polygons` in DejaVu Sans (the built-in text's font)."""
    polygons, end, _ = glyph_polygons(font_path(), text, size, x, baseline, intensity, tolerance)
    return polygons, end


def glyph_polygons(
    path: str,
    text: str,
    size: float,
    x: float,
    baseline: float,
    intensity: int,
    tolerance: float = DEFAULT_TOLERANCE,
) -> tuple[tuple[Polygon, ...], float, list[str]]:
    """One polygon per visible glyph of a TrueType/OpenType font file (non-zero rule, as
    TrueType); returns them, the pen position after the last glyph and the characters the
    font has no glyph for (drawn as .notdef). Advance widths from hmtx, no kerning."""
    from fontTools.ttLib import TTFont

    font = TTFont(path)
    glyph_set = font.getGlyphSet()
    cmap = font.getBestCmap()
    scale = size / font["head"].unitsPerEm
    polygons, missing = [], []
    for ch in text:
        if ord(ch) not in cmap:
            missing.append(ch)
        name = cmap.get(ord(ch), ".notdef")
        pen = _FlattenPen(glyph_set, scale, x, baseline, tolerance)
        glyph_set[name].draw(pen.pen)
        pen._close()
        if pen.contours:
            polygons.append(Polygon(tuple(pen.contours), intensity, "nonzero", f"glyph {ch!r}"))
        x += font["hmtx"][name][0] * scale
    return tuple(polygons), x, missing


def text_scene(
    full: int = 255,
    text: str = TEXT,
    size: float = 28.0,
    width: int = 512,
    height: int = 64,
    tolerance: float = DEFAULT_TOLERANCE,
) -> Scene:
    """A white text field framed in grey (2 px, on pixel boundaries) holding a line of black
    text, all inside the image (512 px holds the default text: it ends near 496 px)."""
    grey = round(full * 96 / 255)
    glyphs, end = text_polygons(text, size, 14.0, 42.0, 0, tolerance)
    right = math.ceil(end) + 10.5
    outer = ((5.5, 5.5), (right + 2, 5.5), (right + 2, 58.5), (5.5, 58.5))
    inner = ((7.5, 7.5), (7.5, 56.5), (right, 56.5), (right, 7.5))  # reversed: a hole
    field = Polygon((inner[::-1],), full, "nonzero", "text field")
    frame = Polygon((outer, inner), grey, "nonzero", "frame")
    return Scene(
        width, height, (field, frame, *glyphs), background=full, name="text", tolerance=tolerance
    )


def _regular(cx: float, cy: float, r: float, n: int, turn: float) -> list[tuple[float, float]]:
    return [
        (
            cx + r * math.cos(turn + 2 * math.pi * i / n),
            cy + r * math.sin(turn + 2 * math.pi * i / n),
        )
        for i in range(n)
    ]


def _pattern_cells(kind: str, x0: int, y0: int, x1: int, y1: int):
    """Pixel-aligned rectangles of a pattern over pixels x0..x1, y0..y1 (pixel centres on
    integers, so a 1 px stripe over row r spans r - 1/2 .. r + 1/2)."""
    if kind == "rows":
        return [(x0 - 0.5, r - 0.5, x1 + 0.5, r + 0.5) for r in range(y0, y1 + 1, 2)]
    if kind == "columns":
        return [(c - 0.5, y0 - 0.5, c + 0.5, y1 + 0.5) for c in range(x0, x1 + 1, 2)]
    return [
        (c - 0.5, r - 0.5, c + 1.5, r + 1.5)
        for r in range(y0, y1 + 1, 2)
        for c in range(x0, x1 + 1, 2)
        if ((r - y0) // 2 + (c - x0) // 2) % 2 == 0
    ]


def hatch_scene(full: int = 255, width: int = 256, height: int = 128) -> Scene:
    """Three shapes with slanted edges, each with a pixel-aligned pattern inside it."""
    import shapely

    shapes = (
        (_regular(48, 64, 52, 4, 0.2), "rows", round(full * 0.35), round(full * 0.75)),
        ([(104.3, 112.6), (152.8, 14.2), (170.1, 108.4)], "columns", round(full * 0.2), full),
        (_regular(212, 62, 38, 48, 0.1), "checker", round(full * 0.5), round(full * 0.1)),
    )
    polygons = []
    for k, (points, kind, base, ink) in enumerate(shapes, start=1):
        outline = shapely.Polygon(points)
        polygons.append(Polygon((tuple(map(_snap, points)),), base, "nonzero", f"shape {k}"))
        x0, y0, x1, y1 = (math.floor(v) for v in outline.bounds)
        for j, cell in enumerate(_pattern_cells(kind, x0, y0, x1 + 1, y1 + 1)):
            piece = outline.intersection(shapely.box(*cell))
            if piece.area > 1e-3 and piece.geom_type == "Polygon":
                ring = tuple(_snap(p) for p in piece.exterior.coords[:-1])
                polygons.append(Polygon((ring,), ink, "nonzero", f"shape {k}/{kind} {j}"))
    return Scene(width, height, tuple(polygons), background=full, name="hatch")
