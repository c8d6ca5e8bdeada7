"""Accuracy on fonts the tests were not written for, and on adversarial polygons.

Fonts: TrueType fonts matplotlib ships (`matplotlib.get_data_path()/fonts/ttf/`), serif and
sans; DejaVu Sans, the font of the built-in text scene, is the reference row. Each font
draws one line of `TEXT` (black on white) at 9, 12, 16, 24 and 48 px (the scenes and the
adversarial ones below are `edgeaa.render.corpus`'s): the glyph outlines come from the font's
quadratic curves through fontTools' pen, flattened within the scene tolerance (1/16 px), one
polygon per glyph, non-zero, advance widths from hmtx, no kerning, no hinting
(`edgeaa.render.builtin.glyph_polygons`). The pen origin is put off the pixel grid (x 3.3 px,
baseline 1.15 size + 0.37 px).

Every method draws the same quantized polygons of one plan (`plan_scene`, 1/16 px grid):

- ``paper``, ``seg4``: `render_scene` with the model engine;
- ``AGG``, ``Skia``: `edgeaa.analysis.compare.agg_scene`, `skia_scene` (8-bit, their own
  blending);
- ``FreeType``: FreeType's own gray rasterizer (the ``smooth`` module), driven through
  matplotlib's ft2font: the plan's polygons are written as the straight-line contours of the
  glyphs of a TrueType font built on the fly (fontTools; 1 font unit = 1/16 px at the size
  used, so every vertex is exact in FreeType's 26.6 fixed point), each glyph rendered
  unhinted (`FT2Font._render_glyph`, a private matplotlib call) into its 8-bit coverage
  bitmap, and the bitmaps composited here in floating point with the reference's operator,
  rounded half up. TrueType glyphs fill non-zero, so FreeType has no even-odd result;
  neither has AGG (aggdraw fills non-zero only).

The reference is `edgeaa.render.exact.exact_image` on the same plan. Errors are |image -
reference| in intensity LSB (full scale 255): the maximum and the RMS over all pixels and
over the pixels an edge passes through; edgeaa's maximum is split by the number of edges
through the pixel (`edgeaa.render.exact.error_rows`), and so are the peers' (same masks).

Icons: matplotlib's SVG toolbar icons (`edgeaa.render.corpus.ICONS`, real path data with
cubic curves) at 16, 24 and 48 px.

Adversarial scenes: a self-intersecting star (even-odd and non-zero), a contour winding
three times round (both rules), two overlapping squares in one polygon (non-zero; same and
opposite orientation), slivers (triangles 1/16 to 1/4 px wide at their open end, at several
angles), and many vertices in one pixel (a square whose top side zigzags 24 times inside one
pixel, and a 16-pointed star of radius 0.45 px).

    python benchmarks/fonts.py [--fonts DejaVuSerif,STIXGeneral,...] [--sizes 9,12,16,24,48]
                               [--icon-sizes 16,24,48] [--no-adversarial] [--json]
"""

from __future__ import annotations

import argparse
import io
import json
import os
import sys
import time
import warnings

import numpy as np

from edgeaa.analysis.compare import agg_scene, polygon_points, skia_scene
from edgeaa.analysis.report import machine_info, machine_line, table
from edgeaa.model import EdgeConfig
from edgeaa.render import plan_scene, render_scene
from edgeaa.render.corpus import FONT_TEXT as TEXT
from edgeaa.render.corpus import (
    FONTS,
    ICONS,
    adversarial_scenes,
    font_file,
    font_scene,
    icon_scene,
)
from edgeaa.render.exact import crossed_cells, edges_per_pixel, error_rows, exact_image
from edgeaa.render.render import Plan
from edgeaa.render.scene import Scene

SIZES = (9, 12, 16, 24, 48)
METHODS = ("paper", "seg4", "AGG", "Skia", "FreeType")
SPLIT = ("no edge", "one edge", "two edges", "three or more")
FT_UNITS = 16  # font units per pixel in the built font: 1/16 px, the plan's grid
FT_PPEM = 64  # pixels per em; units per em = FT_UNITS * FT_PPEM


# -- FreeType ----------------------------------------------------------------------------------


def _font_units(plan: Plan, index: int) -> list[list[tuple[int, int]]]:
    """The polygon's quantized contours in the built font's units: pixel i covers [i, i + 1)
    in FreeType, so +1/2 px as for the peers; y up."""
    out = []
    for pts in polygon_points(plan, index):
        units = np.rint((pts + 0.5) * FT_UNITS).astype(np.int64)
        if not np.allclose(units, (pts + 0.5) * FT_UNITS):
            raise ValueError("a vertex is off the 1/16 px grid")
        out.append([(int(x), int(-y)) for x, y in units])
    return out


def freetype_font(plan: Plan) -> io.BytesIO:
    """A TrueType font whose glyph i + 1 is polygon i of the plan (straight lines only)."""
    from fontTools.fontBuilder import FontBuilder
    from fontTools.pens.ttGlyphPen import TTGlyphPen

    builder = FontBuilder(FT_UNITS * FT_PPEM, isTTF=True)
    names = [".notdef"] + [f"p{i}" for i in range(len(plan.polygons))]
    builder.setupGlyphOrder(names)
    builder.setupCharacterMap({})
    glyphs, metrics = {".notdef": TTGlyphPen(None).glyph()}, {".notdef": (0, 0)}
    for i in range(len(plan.polygons)):
        pen = TTGlyphPen(None)
        contours = _font_units(plan, i)
        for contour in contours:
            if any(not -32768 <= v <= 32767 for p in contour for v in p):
                raise ValueError("the scene is too large for TrueType coordinates")
            pen.moveTo(contour[0])
            for p in contour[1:]:
                pen.lineTo(p)
            pen.closePath()
        glyphs[f"p{i}"] = pen.glyph()
        # FreeType moves a TrueType outline so that its xMin is the left side bearing.
        lsb = min((p[0] for c in contours for p in c), default=0)
        metrics[f"p{i}"] = (0, lsb)
    builder.setupGlyf(glyphs)
    builder.setupHorizontalMetrics(metrics)
    builder.setupHorizontalHeader(ascent=FT_UNITS * FT_PPEM, descent=0)
    builder.setupNameTable({"familyName": "edgeaa scene", "styleName": "Regular"})
    builder.setupOS2()
    builder.setupPost()
    data = io.BytesIO()
    builder.save(data)
    data.seek(0)
    return data


def freetype_scene(plan: Plan) -> np.ndarray | None:
    """FreeType's coverage of every polygon composited over the background (None if a
    polygon is even-odd: a TrueType glyph fills non-zero)."""
    from matplotlib import ft2font

    if any(p.rule != "nonzero" for p in plan.polygons):
        return None
    scene = plan.scene
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        font = ft2font.FT2Font(freetype_font(plan))
    font.set_size(FT_PPEM, 72)  # FT_PPEM px per em
    image = np.full((scene.height, scene.width), float(scene.background))
    for i, poly in enumerate(plan.polygons):
        if poly.empty:
            continue
        bitmap = font._render_glyph(i + 1, ft2font.LoadFlags.NO_HINTING, ft2font.RenderMode.NORMAL)
        alpha = np.asarray(bitmap.buffer, dtype=np.float64) / 255.0
        x0, y0 = bitmap.left, -bitmap.top  # image pixel of the bitmap's first cell
        h, w = alpha.shape
        ix0, iy0 = max(x0, 0), max(y0, 0)
        ix1, iy1 = min(x0 + w, scene.width), min(y0 + h, scene.height)
        if ix1 <= ix0 or iy1 <= iy0:
            continue
        a = alpha[iy0 - y0 : iy1 - y0, ix0 - x0 : ix1 - x0]
        view = image[iy0:iy1, ix0:ix1]
        view += a * (poly.intensity - view)
    return np.floor(image + 0.5).astype(np.int64)


# -- the comparison ----------------------------------------------------------------------------


def crossers(plan: Plan) -> np.ndarray:
    """How many boundary edges pass through each pixel's interior, every cell of each edge's
    bounding box tested (`edgeaa.render.exact.crossed_cells`, exact in integers). Unlike
    `edges_per_pixel`, which tests only the cells where a sent edge left a nonzero delta,
    this counts horizontal edges (not sent: they add nothing) and does not depend on the
    mode."""
    S = plan.config.subpixel_scale
    ox, oy = plan.offset
    height, width = plan.scene.height, plan.scene.width
    edge, xs, ys = [], [], []
    for e in np.flatnonzero(plan.boundary):
        x0, y0, x1, y1 = (int(v) for v in plan.coords[e])
        gx = np.arange(max(min(x0, x1) // S - 1 - ox, 0), min(-(-max(x0, x1) // S) + 2 - ox, width))
        gy = np.arange(
            max(min(y0, y1) // S - 1 - oy, 0), min(-(-max(y0, y1) // S) + 2 - oy, height)
        )
        if len(gx) and len(gy):
            X, Y = np.meshgrid(gx, gy)
            xs.append(X.ravel())
            ys.append(Y.ravel())
            edge.append(np.full(X.size, e))
    count = np.zeros((height, width), dtype=np.int64)
    if edge:
        edge, xs, ys = np.concatenate(edge), np.concatenate(xs), np.concatenate(ys)
        hit = crossed_cells(plan, edge, xs, ys)
        np.add.at(count, (ys[hit], xs[hit]), 1)
    return count


def evaluate(scene: Scene, config: EdgeConfig) -> dict:
    """Every method against the exact reference on one plan."""
    plan = plan_scene(scene, config)
    exact = exact_image(plan)
    images, renders = {}, {}
    for mode in ("paper", "seg4"):
        mine = plan_scene(scene, config.with_(mode=mode))
        if not np.array_equal(mine.coords, plan.coords):
            raise AssertionError("the plans differ between modes")
        renders[mode] = render_scene(mine)
        images[mode] = renders[mode].image
    images["AGG"] = agg_scene(plan) if all(p.rule == "nonzero" for p in plan.polygons) else None
    images["Skia"] = skia_scene(plan)
    images["FreeType"] = freetype_scene(plan)
    count = crossers(plan)
    masks = {
        "no edge": count == 0,
        "one edge": count == 1,
        "two edges": count == 2,
        "three or more": count >= 3,
    }
    edge_px = count > 0
    row = {
        "scene": scene.name,
        "width": scene.width,
        "height": scene.height,
        "edges": int(plan.edge_count),
        "crossings": int(plan.crossings),
        "pixels": {k: int(m.sum()) for k, m in masks.items()},
        "methods": {},
    }
    for name, image in images.items():
        if image is None:
            row["methods"][name] = None
            continue
        err = np.abs(image.astype(np.float64) - exact)
        row["methods"][name] = {
            "max": float(err.max()),
            "rms": float(np.sqrt(np.mean(err**2))),
            "rms_edge": float(np.sqrt(np.mean(err[edge_px] ** 2))) if edge_px.any() else 0.0,
            "split": {k: float(err[m].max()) if m.any() else 0.0 for k, m in masks.items()},
        }
    for mode in ("paper", "seg4"):  # the project's own split, error_rows
        rows = error_rows(renders[mode], exact)
        theirs = edges_per_pixel(renders[mode])
        row["methods"][mode]["error_rows"] = {r.label: r.max_abs for r in rows}
        row["methods"][mode]["miscounted"] = int(np.count_nonzero(theirs != count))
        row["methods"][mode]["miscounted_error"] = float(
            np.abs(images[mode] - exact)[theirs != count].max(initial=0.0)
        )
    return row


# -- output ------------------------------------------------------------------------------------


def _cell(m: dict | None, key: str) -> str:
    return "n/a" if m is None else f"{m[key]:.2f}"


def error_table(rows: list[dict], first: str = "font, size") -> str:
    headers = [first, "edges"] + [f"{m} max" for m in METHODS] + [f"{m} RMS" for m in METHODS]
    body = []
    for r in rows:
        cells = [r["scene"], str(r["edges"])]
        cells += [_cell(r["methods"][m], "max") for m in METHODS]
        cells += [_cell(r["methods"][m], "rms") for m in METHODS]
        body.append(cells)
    return table(headers, body)


def rms_edge_table(rows: list[dict], first: str) -> str:
    headers = [first] + [f"{m} RMS" for m in METHODS]
    body = [[r["scene"]] + [_cell(r["methods"][m], "rms_edge") for m in METHODS] for r in rows]
    return table(headers, body)


def split_table(rows: list[dict]) -> str:
    """The largest error over all the rows' pixels, by edges through the pixel."""
    headers = ["edges through the pixel", "pixels"] + list(METHODS)
    body = []
    for k in SPLIT:
        cells = [k, f"{sum(r['pixels'][k] for r in rows):,}"]
        for m in METHODS:
            values = [r["methods"][m]["split"][k] for r in rows if r["methods"][m] is not None]
            cells.append(f"{max(values):.2f}" if values else "n/a")
        body.append(cells)
    return table(headers, body)


def split_rows_table(rows: list[dict], first: str) -> str:
    headers = [first] + [f"paper {k}" for k in SPLIT] + [f"seg4 {k}" for k in SPLIT]
    body = []
    for r in rows:
        cells = [r["scene"]]
        for m in ("paper", "seg4"):
            cells += [f"{r['methods'][m]['split'][k]:.2f}" for k in SPLIT]
        body.append(cells)
    return table(headers, body)


def error_rows_note(rows: list[dict]) -> str:
    """How far `error_rows`' split (by `edges_per_pixel`) is from the geometric count."""
    parts = []
    for m in ("paper", "seg4"):
        moved = sum(r["methods"][m]["miscounted"] for r in rows)
        total = sum(r["width"] * r["height"] for r in rows)
        none = max(r["methods"][m]["error_rows"]["no edge"] for r in rows)
        parts.append(
            f"{m}: {moved:,} of {total:,} pixels counted differently, its 'no edge' row "
            f"up to {none:.2f} LSB"
        )
    return (
        "error_rows (edges_per_pixel: sent edges with a nonzero delta in the cell) against "
        "the count above: " + "; ".join(parts) + " (geometric 'no edge' pixels: 0.00)"
    )


def worst(rows: list[dict]) -> dict[str, tuple[float, str]]:
    out = {}
    for m in METHODS:
        found = [(r["methods"][m]["max"], r["scene"]) for r in rows if r["methods"][m]]
        out[m] = max(found) if found else (float("nan"), "")
    return out


FONT_NAMES = ", ".join(name for name, _ in FONTS) + ", ..."


def _sizes(parser: argparse.ArgumentParser, flag: str, text: str) -> list[int]:
    """A comma-separated list of sizes in px, each an integer in [4, 256]."""
    try:
        sizes = [int(s) for s in text.split(",") if s]
    except ValueError:
        sizes = None
    if sizes is None or not all(4 <= s <= 256 for s in sizes):
        parser.error(f"{flag} {text!r}: expected comma-separated px sizes in [4, 256]")
    return sizes


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        epilog="Tables are Markdown; --json prints one JSON object instead.",
    )
    parser.add_argument("--fonts", default=",".join(name for name, _ in FONTS))
    parser.add_argument("--sizes", default=",".join(str(s) for s in SIZES), help="px per em")
    parser.add_argument("--no-adversarial", action="store_true")
    parser.add_argument("--icon-sizes", default="16,24,48", help="px; empty for no icons")
    parser.add_argument("--json", action="store_true", help="print JSON instead of tables")
    args = parser.parse_args()
    config = EdgeConfig()
    kinds = dict(FONTS)
    fonts = [f for f in args.fonts.split(",") if f]
    unknown = [f for f in fonts if not os.path.exists(font_file(f))]
    if unknown:
        parser.error(f"--fonts: no such font {unknown[0]!r}; matplotlib ships {FONT_NAMES}")
    sizes = _sizes(parser, "--sizes", args.sizes)
    icon_sizes = _sizes(parser, "--icon-sizes", args.icon_sizes)
    start = time.perf_counter()
    out = {"machine": machine_info(), "config": str(config), "text": TEXT, "fonts": []}
    for name in fonts:
        for size in sizes:
            print(f"{name} {size} px", file=sys.stderr, flush=True)
            scene, missing = font_scene(name, size, config.full_scale)
            row = evaluate(scene, config)
            row.update(font=name, kind=kinds.get(name, ""), size=size, missing="".join(missing))
            out["fonts"].append(row)
    out["fonts"].sort(key=lambda r: (-r["methods"]["paper"]["max"], r["scene"]))
    out["icons"] = []
    for size in icon_sizes:
        for name in ICONS:
            print(f"icon {name} {size} px", file=sys.stderr, flush=True)
            out["icons"].append(evaluate(icon_scene(name, size, config.full_scale), config))
    out["icons"].sort(key=lambda r: (-r["methods"]["paper"]["max"], r["scene"]))
    out["adversarial"] = []
    if not args.no_adversarial:
        for scene in adversarial_scenes(config.full_scale):
            print(scene.name, file=sys.stderr, flush=True)
            out["adversarial"].append(evaluate(scene, config))
    out["seconds"] = time.perf_counter() - start
    if args.json:
        print(json.dumps(out, indent=1))
        return 0

    rows = out["fonts"]
    print(machine_line())
    print(f"config: {config}; text {TEXT!r}; whole run {out['seconds']:.0f} s")
    print("\nfonts: " + "; ".join(f"{f} ({kinds.get(f, '?')})" for f in fonts))
    missing = {r["font"]: r["missing"] for r in rows if r["missing"]}
    if missing:
        print("characters without a glyph (drawn as .notdef): " + repr(missing))
    if rows:
        print("\n### Fonts: |error| in LSB of 255, worst edgeaa paper first\n")
        print(error_table(rows))
        print("\nRMS over the pixels an edge passes through (the antialiased pixels):\n")
        print(rms_edge_table(rows, "font, size"))
        print("\nLargest |error| over every font and size, by edges through the pixel:\n")
        print(split_table(rows))
        print("\nedgeaa's largest |error| per font and size, by edges through the pixel:\n")
        print(split_rows_table(rows, "font, size"))
        print("\n" + error_rows_note(rows))
        print("\nWorst case of each method over the fonts:\n")
        for m, (value, where) in worst(rows).items():
            print(f"- {m}: {value:.2f} LSB ({where})")
    if out["icons"]:
        print("\n### matplotlib's SVG toolbar icons: |error| in LSB of 255, worst paper first\n")
        print(error_table(out["icons"], "icon"))
        print("\nLargest |error| by edges through the pixel:\n")
        print(split_rows_table(out["icons"], "icon"))
        print("\nWorst case of each method over the icons:\n")
        for m, (value, where) in worst(out["icons"]).items():
            print(f"- {m}: {value:.2f} LSB ({where})")
    adv = out["adversarial"]
    if adv:
        print("\n### Adversarial scenes: |error| in LSB of 255\n")
        print(error_table(adv, "scene"))
        print("\nRMS over the pixels an edge passes through:\n")
        print(rms_edge_table(adv, "scene"))
        print("\nLargest |error| by edges through the pixel:\n")
        print(split_rows_table(adv, "scene"))
        print("\nThe same split, every method, over all the adversarial scenes:\n")
        print(split_table(adv))
        print("\n" + error_rows_note(adv))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
