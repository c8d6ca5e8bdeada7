"""Accuracy on SVG files: matplotlib's SVG icons and the project's stroke cases, against the
exact area of the same outlines, beside resvg (the Rust SVG renderer, PyPI `resvg-py`), AGG
and Skia (docs/results.md, "SVG files").

Each file is read by `edgeaa.render.svg.load_svg` at the size given (its fills and its
strokes expanded into outlines, `edgeaa.render.stroke`) and planned as its outlines'
coverage (`edgeaa.render.paint.coverage_scene`: every polygon full scale over 0, non-zero
or even-odd as written), so every method draws the same quantized polygons of one plan:

- ``paper``, ``seg4``: `render_scene` with the model;
- ``Skia``, ``AGG``: `edgeaa.analysis.compare.skia_scene`, `agg_scene`;
- ``resvg``: the plan's polygons written as an SVG of white paths on black (each vertex
  +1/2 px: resvg's pixel i covers [i, i + 1]) and rendered by resvg, 8-bit.

The reference is `edgeaa.render.exact.exact_image` of the plan. Errors are |image -
reference| in LSB of 255, over every pixel of every file: max and RMS over the pixels an edge
passes through (the others are 0 or full for every method).

`resvg file` is resvg's own render of the file (its parser, its stroker, its flattening)
against edgeaa seg4's colour render of it (premultiplied RGBA, each pixel's worst channel):
how far the two readings of the SVG are apart, not an accuracy figure.

    python benchmarks/svg_accuracy.py [--size 48]
"""

from __future__ import annotations

import argparse
import io
import os
import sys
import time

import numpy as np

from edgeaa.analysis.compare import agg_scene, skia_scene
from edgeaa.model import EdgeConfig
from edgeaa.render import plan_scene, render_scene
from edgeaa.render.exact import edges_per_pixel, exact_image
from edgeaa.render.paint import Canvas, coverage_scene
from edgeaa.render.svg import load_svg

HERE = os.path.dirname(os.path.abspath(__file__))
ICONS = ("home", "back", "forward", "move", "zoom_to_rect", "subplots", "filesave", "help")


def files(size: int) -> list[tuple[str, str, tuple[int, int] | None]]:
    import matplotlib

    images = os.path.join(matplotlib.get_data_path(), "images")
    out = [(f"{name}.svg", os.path.join(images, f"{name}.svg"), (size, size)) for name in ICONS]
    out.append(("strokes.svg", os.path.join(HERE, "svg", "strokes.svg"), None))
    return out


def outline_svg(plan) -> str:
    """The plan's quantized polygons as an SVG for resvg, white on black."""
    from edgeaa.analysis.compare import polygon_points

    scene = plan.scene
    parts = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{scene.width}" '
        f'height="{scene.height}"><rect width="100%" height="100%" fill="black"/>'
    ]
    for i, poly in enumerate(plan.polygons):
        d = " ".join(
            "M " + " L ".join(f"{x + 0.5:.6f} {y + 0.5:.6f}" for x, y in contour) + " Z"
            for contour in polygon_points(plan, i)
        )
        rule = "evenodd" if poly.rule == "evenodd" else "nonzero"
        if d:
            parts.append(f'<path d="{d}" fill="white" fill-rule="{rule}"/>')
    return "".join(parts) + "</svg>"


def resvg_image(svg: str | None = None, path: str | None = None, size=None) -> np.ndarray:
    import resvg_py
    from PIL import Image

    kwargs = {"svg_string": svg} if svg is not None else {"svg_path": path}
    kwargs["dpi"] = 96.0  # the binding's default 0 makes every pt length 0
    if size is not None:
        kwargs.update(width=size[0])  # resvg keeps the aspect (square icons here)
    data = bytes(resvg_py.svg_to_bytes(**kwargs))
    return np.asarray(Image.open(io.BytesIO(data)).convert("RGBA")).astype(np.int64)


def outline_images(scene, config: EdgeConfig):
    """The scene's outlines' coverage (`coverage_scene`: one plan for every method): the plan,
    the exact image, the pixels an edge passes through (seg4's), and each method's image."""
    plan = plan_scene(coverage_scene(scene), config)
    seg4 = render_scene(plan_scene(plan.scene, config.with_(mode="seg4")))
    images = {
        "paper": render_scene(plan_scene(plan.scene, config.with_(mode="paper"))).image,
        "seg4": seg4.image,
        "Skia": skia_scene(plan),
        "AGG": agg_scene(plan),
        "resvg": resvg_image(outline_svg(plan))[..., 0],
    }
    return plan, exact_image(plan), edges_per_pixel(seg4) > 0, images


def outline_errors(scene, config: EdgeConfig) -> dict[str, np.ndarray]:
    """Each method's |image - exact| (LSB) over the pixels an edge passes through."""
    _, exact, edged, images = outline_images(scene, config)
    return {m: np.abs(image.astype(np.float64) - exact)[edged] for m, image in images.items()}


def file_apart(scene, path: str, size, config: EdgeConfig) -> np.ndarray:
    """Per pixel, the worst channel of |resvg's own render of the file - edgeaa seg4's colour
    render| (premultiplied RGBA, LSB)."""
    canvas = Canvas(scene, config.full_scale)
    plan = plan_scene(coverage_scene(scene), config.with_(mode="seg4"))
    render_scene(plan, canvas=canvas)
    theirs = resvg_image(path=path, size=size)
    alpha = theirs[..., 3:4]
    premultiplied = np.concatenate([(theirs[..., :3] * alpha + 127) // 255, alpha], axis=2)
    return np.abs(premultiplied - canvas.image).max(axis=2)


def measure(name: str, path: str, size, config: EdgeConfig, totals: dict) -> list[str]:
    scene = load_svg(path, size=size, lenient=True, warn=lambda message: None)
    errors = outline_errors(scene, config)
    edged = len(next(iter(errors.values())))
    row = [f"{name:24} {scene.width:>4}x{scene.height:<4} {edged:>6}"]
    for method, err in errors.items():
        totals.setdefault(method, []).append(err)
        row.append(f"{err.max():7.2f} {np.sqrt(np.mean(err**2)):5.2f}")
    apart = file_apart(scene, path, size, config)
    row.append(f"{apart.max():6d} {np.sqrt(np.mean(apart**2)):5.2f}")
    return [" ".join(row)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=48, help="the icons' size in px")
    args = parser.parse_args(argv)
    config = EdgeConfig()
    start = time.perf_counter()
    methods = ("paper", "seg4", "Skia", "AGG", "resvg")
    print(f"{'file':24} {'size':>9} {'edged':>6} " + " ".join(f"{m:>13}" for m in methods)
          + f" {'resvg file':>12}")  # fmt: skip
    print(f"{'':41} " + " ".join(f"{'max':>7} {'RMS':>5}" for _ in methods) + "    max   RMS")
    totals: dict[str, list] = {}
    for name, path, size in files(args.size):
        print("\n".join(measure(name, path, size, config, totals)), flush=True)
    cells = [np.concatenate(totals[m]) for m in methods]
    print(f"{'all':24} {'':9} {len(cells[0]):>6} " + " ".join(
        f"{c.max():7.2f} {np.sqrt(np.mean(c**2)):5.2f}" for c in cells))  # fmt: skip
    print(f"({time.perf_counter() - start:.1f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
