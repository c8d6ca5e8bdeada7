"""The board's HUD page (`hud_page`): 640 x 480, bright on dark, an attitude display whose
horizon, pitch ladder and ring marks turn with the roll angle, a fixed aircraft mark, a
2 px frame and a line of DejaVu Sans Mono with the roll angle (one line: the ROM holds
every page's commands). `edgeaa board` puts the
pages of a few roll angles in the display-list ROM (`edgeaa.hdl.board`)."""

from __future__ import annotations

import math

from .builtin import glyph_polygons
from .corpus import font_file
from .scene import Polygon, Scene

__all__ = ["ROLLS", "hud_display_list", "hud_page"]

CENTRE = (320.3, 250.2)


def _turned(points, angle: float) -> tuple:
    c, s = math.cos(angle), math.sin(angle)
    cx, cy = CENTRE
    return tuple((cx + x * c - y * s, cy + x * s + y * c) for x, y in points)


def _box(x0: float, y0: float, x1: float, y1: float) -> tuple:
    return ((x0, y0), (x1, y0), (x1, y1), (x0, y1))


def _ring(radius: float, width: float, sides: int) -> tuple:
    def circle(r: float) -> tuple:
        return tuple((r * math.cos(a), r * math.sin(a)) for a in _angles(sides))

    return _turned(circle(radius), 0), _turned(circle(radius - width)[::-1], 0)


def _angles(n: int) -> list[float]:
    return [2 * math.pi * k / n for k in range(n)]


def hud_page(roll_degrees: float, full: int = 255) -> Scene:
    """The page at `roll_degrees` (positive: the horizon and the marks turn clockwise on
    the screen); everything is placed from `CENTRE` by `_turned` (translation included)."""
    dark, bright, mid = round(full * 24 / 255), full, round(full * 150 / 255)
    roll = math.radians(roll_degrees)
    outer = _box(3.5, 3.5, 636.5, 476.5)
    inner = _box(5.5, 5.5, 634.5, 474.5)[::-1]  # reversed: a hole
    polygons = [Polygon((outer, inner), bright, "nonzero", "frame")]
    polygons.append(Polygon(_ring(170, 2.5, 72), mid, "nonzero", "ring"))
    for k in range(12):  # roll marks every 30 degrees on the ring, turning with it
        a = roll + math.pi * k / 6
        mark = _box(-1.2, -185, 1.2, -172 if k % 3 else -195)
        polygons.append(Polygon((_turned(mark, a),), bright, "nonzero", f"mark {k}"))
    horizon = _box(-150, -1.5, 150, 1.5)
    polygons.append(Polygon((_turned(horizon, roll),), bright, "nonzero", "horizon"))
    for k in (-3, -2, -1, 1, 2, 3):
        bar = _box(-50 + 10 * abs(k), 30 * k - 1, 50 - 10 * abs(k), 30 * k + 1)
        polygons.append(Polygon((_turned(bar, roll),), mid, "nonzero", f"ladder {k}"))
    wing = ((-80, 0), (-30, 0), (0, 18), (30, 0), (80, 0), (80, 3), (30, 3), (0, 22), (-30, 3))
    wing += ((-80, 3),)
    polygons.append(Polygon((_turned(wing, 0),), bright, "nonzero", "aircraft"))
    mono = font_file("DejaVuSansMono")
    text = f"EDGEAA HUD  ROLL {roll_degrees:+05.1f}"
    glyphs, _, _ = glyph_polygons(mono, text, 16, 24.3, 452.37, bright)
    polygons.extend(glyphs)
    return Scene(640, 480, tuple(polygons), background=dark, name=f"HUD roll {roll_degrees:g}")


# The pages `edgeaa board` puts in ROM: the roll angles of a swing (the GIF plays them there
# and back).
ROLLS = (-20.0, -10.0, 0.0, 10.0, 20.0)


def hud_display_list(config, tile, rolls=ROLLS):
    """The plans of the pages at `rolls` and their pipeline commands (one list a page), and
    the engine pixel at the image's (0, 0) (every page's: the same frame bounds them)."""
    from .pipeline import scene_commands
    from .render import plan_scene

    plans = [plan_scene(hud_page(roll, config.full_scale), config) for roll in rolls]
    origins = {plan.offset for plan in plans}
    if len(origins) != 1:
        raise ValueError(f"the pages' offsets differ: {sorted(origins)}")
    return plans, [scene_commands(plan, tile) for plan in plans], origins.pop()
