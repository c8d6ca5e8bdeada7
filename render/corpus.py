"""Content the project did not write, for tests and benchmarks: text in the TrueType fonts
matplotlib ships, matplotlib's toolbar icons (real SVG path data), and adversarial polygons
(self-intersections, several windings, slivers, many vertices in one pixel).

    font_scene("DejaVuSerif", 9)       one line of `FONT_TEXT`, black on white
    icon_scene("home", 24)             one icon drawn 24 px wide
    adversarial_scenes()               eight 48 x 48 scenes
    page_scene()                       a 1000 x 800 page of 9-12 px text (the edge limit's case)
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ElementTree

from .builtin import glyph_polygons
from .scene import DEFAULT_TOLERANCE, Polygon, Scene, parse_path

__all__ = [
    "FONTS",
    "FONT_TEXT",
    "ICONS",
    "adversarial_scenes",
    "font_file",
    "font_scene",
    "icon_scene",
    "page_scene",
]

FONT_TEXT = "Hamburgefonstiv AVWxyz 0123 &@Qg"
FONTS = (
    ("DejaVuSans", "sans (the built-in text's font)"),
    ("DejaVuSansMono", "sans mono"),
    ("cmss10", "sans (Computer Modern)"),
    ("DejaVuSerif", "serif"),
    ("STIXGeneral", "serif (Times-like)"),
    ("cmr10", "serif (Computer Modern)"),
    ("STIXGeneralItalic", "serif italic"),
)
# matplotlib's toolbar icons whose shapes are plain filled paths (no transform, one colour).
ICONS = ("home", "back", "forward", "move", "zoom_to_rect", "subplots", "filesave", "help")


def _data_path() -> str:
    import matplotlib

    return matplotlib.get_data_path()


def font_file(name: str) -> str:
    return f"{_data_path()}/fonts/ttf/{name}.ttf"


def font_scene(name: str, size: int, full: int = 255) -> tuple[Scene, list[str]]:
    """`FONT_TEXT` in the font `name` at `size` px, black on white, one non-zero polygon per
    glyph; the pen starts off the pixel grid (x 3.3 px, baseline 1.15 size + 0.37 px).
    Returns the scene and the characters the font has no glyph for."""
    baseline = round(1.15 * size) + 0.37
    glyphs, end, missing = glyph_polygons(font_file(name), FONT_TEXT, size, 3.3, baseline, 0)
    width = math.ceil(end) + 4
    height = math.ceil(baseline + 0.45 * size) + 2
    return Scene(width, height, glyphs, background=full, name=f"{name} {size}px"), missing


def icon_scene(name: str, size: int, full: int = 255) -> Scene:
    """matplotlib's toolbar icon `name` (an SVG of a 72 x 72 view box) drawn `size` px wide,
    black on white, off the pixel grid by (0.3, 0.2) px: one non-zero polygon per filled path,
    curves flattened within the scene tolerance in pixels."""
    if name not in ICONS:
        raise ValueError(f"icon must be one of {', '.join(ICONS)}, not {name!r}")
    root = ElementTree.parse(f"{_data_path()}/images/{name}.svg").getroot()
    box = [float(v) for v in root.get("viewBox").split()]
    scale = size / box[2]
    polygons = []
    for element in root.iter("{http://www.w3.org/2000/svg}path"):
        style = element.get("style", "")
        if re.search(r"fill:\s*none", style):
            continue  # the icons' invisible frame
        contours = parse_path(element.get("d"), DEFAULT_TOLERANCE / scale, f"{name}.svg")
        moved = tuple(
            tuple(((x - box[0]) * scale + 0.3, (y - box[1]) * scale + 0.2) for x, y in contour)
            for contour in contours
        )
        polygons.append(Polygon(moved, 0, "nonzero", f"{name} path {len(polygons)}"))
    side = math.ceil(size * box[3] / box[2]) + 1
    return Scene(size + 1, side, tuple(polygons), background=full, name=f"icon {name} {size}px")


PAGE_TEXT = (
    "The quick brown fox jumps over the lazy dog; pack my box with five dozen liquor jugs. "
    "Sphinx of black quartz, judge my vow: 0123456789 (x + y) * z = 42 & @ # % ? "
)


def page_scene(width: int = 1000, height: int = 800, full: int = 255) -> Scene:
    """A page of DejaVu Serif text, black on white: lines at 9, 10, 11 and 12 px in turn, each
    1.15 of its size below the last, `PAGE_TEXT` repeated from a margin of 4 px, the glyphs
    that fit before the right edge. About 310,000 edges at
    1000 x 800: the size of page the scene limits must let through (docs/scenes.md)."""
    polygons, baseline, line = [], 4.0, 0
    while True:
        size = 9 + line % 4
        baseline += 1.15 * size
        if baseline + 0.3 * size > height:
            break
        text = PAGE_TEXT[(7 * line) % len(PAGE_TEXT) :] + PAGE_TEXT * (2 * width // len(PAGE_TEXT))
        count = int(width / (0.5 * size))  # DejaVu Serif averages about 0.6 em a character
        glyphs, _, _ = glyph_polygons(
            font_file("DejaVuSerif"), text[:count], size, 4.3, baseline, 0
        )
        polygons.extend(g for g in glyphs if max(x for c in g.contours for x, _ in c) < width - 1)
        line += 1
    return Scene(width, height, tuple(polygons), background=full, name=f"page {width}x{height}")


# -- adversarial scenes ------------------------------------------------------------------------


def _star(cx, cy, r_out, r_in, points, turn=0.0):
    pts = []
    for k in range(2 * points):
        r = r_out if k % 2 == 0 else r_in
        a = turn + math.pi * k / points
        pts.append((cx + r * math.cos(a), cy + r * math.sin(a)))
    return tuple(pts)


def _pentagram(cx, cy, r):
    """The five-pointed star drawn in one stroke: its centre has winding 2."""
    return tuple(
        (
            cx + r * math.cos(-math.pi / 2 + 4 * math.pi * k / 5),
            cy + r * math.sin(-math.pi / 2 + 4 * math.pi * k / 5),
        )
        for k in range(5)
    )


def _triple_loop(cx, cy):
    """One contour going three times round (radii 18, 14, 10 px): winding 1, 2, 3 rings."""
    pts = []
    for k in range(3 * 40):
        a = 2 * math.pi * k / 40 + 0.1
        r = 18 - 4 * (k / 40)
        pts.append((cx + r * math.cos(a), cy + r * math.sin(a)))
    return tuple(pts)


SLIVERS = ((0.0, 1 / 16), (3.0, 1 / 8), (27.0, 1 / 16), (45.0, 1 / 4), (63.0, 1 / 16))
SLIVERS += ((88.0, 1 / 8), (90.0, 1 / 16), (135.0, 1 / 8))  # (angle in degrees, open width)


def _slivers() -> tuple[Polygon, ...]:
    """Triangles 40 px long and 1/16 to 1/4 px wide at their open end, at several angles."""
    slivers = []
    for k, (angle, width) in enumerate(SLIVERS):
        t = math.radians(angle)
        ox, oy = 4.2 + 5.1 * k + (25 if angle > 90 else 0), 3.7 + 2.3 * k
        ex, ey = ox + 40.0 * math.cos(t), oy + 40.0 * math.sin(t)
        nx, ny = -math.sin(t) * width, math.cos(t) * width
        tri = ((ox, oy), (ex, ey), (ex + nx, ey + ny))
        slivers.append(Polygon((tri,), 0, "nonzero", f"sliver {k}"))
    return tuple(slivers)


def adversarial_scenes(full: int = 255) -> list[Scene]:
    """Eight 48 x 48 scenes: a self-intersecting pentagram and a contour winding three times
    round (both fill rules), two overlapping squares in one polygon (same and opposite
    orientation), slivers, and many vertices in one pixel (a side zigzagging 24 times inside
    one pixel, a 16-pointed star of radius 0.45 px)."""

    def one(name, contours, rule, size=48):
        return Scene(size, size, (Polygon(contours, 0, rule, name),), background=full, name=name)

    star = _pentagram(24.3, 25.1, 21.0)
    loop = _triple_loop(24.2, 23.9)
    a = ((5.3, 5.3), (30.1, 5.3), (30.1, 30.1), (5.3, 30.1))
    b = ((18.6, 12.2), (42.4, 12.2), (42.4, 40.9), (18.6, 40.9))
    zig = [(5.2, 5.2)]
    zig += [(21.55 + k * 0.8 / 24, 4.75 if k % 2 == 0 else 5.3) for k in range(24)]
    zig += [(40.8, 5.2), (40.8, 40.8), (5.2, 40.8)]
    tiny = _star(10.2, 30.7, 0.45, 0.2, 16, 0.13)
    crowded = (
        Polygon((tuple(zig),), 0, "nonzero", "zigzag"),
        Polygon((tiny,), 0, "nonzero", "tiny star"),
    )
    return [
        one("pentagram even-odd", (star,), "evenodd"),
        one("pentagram non-zero", (star,), "nonzero"),
        one("triple loop even-odd", (loop,), "evenodd"),
        one("triple loop non-zero", (loop,), "nonzero"),
        one("overlapping squares, same direction", (a, b), "nonzero"),
        one("overlapping squares, opposite", (a, b[::-1]), "nonzero"),
        Scene(48, 48, _slivers(), background=full, name="slivers"),
        Scene(48, 48, crowded, background=full, name="many vertices in one pixel"),
    ]
