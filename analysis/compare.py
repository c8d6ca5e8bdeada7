"""Side-by-side renders of one scene and their error against the exact coverage.

Methods, each drawing the whole scene polygon by polygon over the background:

- ``no AA``: one sample at the pixel centre (the renderer's own span fill alone);
- ``edgeaa paper``, ``edgeaa seg4``: `edgeaa.render.render_scene` with the model;
- ``16x16 SSAA``: 256 samples per pixel on an ordered grid (the ``grid16`` pattern of
  `sampling`, here evaluated on whole polygons with the same exact scanline
  test as the span fill, since that module samples single-edge half-planes);
- ``Skia``: skia-python path fill, analytic antialiasing, on an 8-bit surface;
- ``AGG``: aggdraw's path fill (AGG's exact-area scanline rasterizer), with the pen-width-0
  setting of `peers` so that AGG does not widen the polygons by 1/4 px.
  aggdraw fills non-zero only: even-odd polygons are drawn non-zero (noted in the panel).
- the seeds' methods (`aa_scenes`): MSAA 2x, 4x and 8x with the standard
  positions, quincunx and FLIPQUAD resolved per sample; MLAA, MLAA with slope prediction,
  FXAA and FXAA with geometry edges on the point-sampled image; TAA of the still scene.

Skia's and AGG's pixel i covers [i, i + 1); edgeaa's is centred on i: the peers get every
vertex shifted by +1/2 px (the convention of `peers`). The peers composite
with their own 8-bit blending; the others with the renderer's integer arithmetic (no AA,
edgeaa) or in floating point rounded at the end (SSAA).
"""

from __future__ import annotations

from functools import partial

import numpy as np

from ..model import EdgeConfig
from ..progress import ProgressBar
from ..render.exact import exact_image
from ..render.geometry import sample_mask
from ..render.render import Plan, plan_scene, render_scene
from ..render.scene import Scene
from .aa_scenes import method_image

SSAA = 16  # samples per axis


def polygon_points(plan: Plan, index: int) -> list[np.ndarray]:
    """The polygon's contours (quantized) in image pixels."""
    poly = plan.polygons[index]
    S = plan.config.subpixel_scale
    coords = plan.coords[poly.start : poly.stop]
    contours, start = [], 0
    for k in range(len(coords)):
        e = poly.start + k
        if e + 1 == poly.stop or plan.contour[e + 1] != plan.contour[e]:  # it closes here
            pts = coords[start : k + 1, 0:2].astype(np.float64) / S
            contours.append(pts - np.array(plan.offset, dtype=np.float64))
            start = k + 1
    return contours


def trace_polygon(plan: Plan, index: int, move_to, line_to, close) -> None:
    """The polygon's contours through a peer's path calls (`move_to(x, y)`, `line_to(x, y)`,
    `close()`), in the peers' pixel frame (a pixel's centre at half a pixel)."""
    for pts in polygon_points(plan, index):
        move_to(*(pts[0] + 0.5))
        for p in pts[1:]:
            line_to(*(p + 0.5))
        close()


def agg_path(plan: Plan, index: int):
    """The polygon as an AGG (aggdraw) path."""
    import aggdraw

    path = aggdraw.Path()
    trace_polygon(plan, index, path.moveto, path.lineto, path.close)
    return path


def to8(value: int, full: int) -> int:
    """An intensity of the configured scale `full` as an 8-bit one (the peers' scale)."""
    return round(value * 255 / full)


def centre_sampled(plan: Plan) -> np.ndarray:
    """No antialiasing: each polygon covers the pixels whose centre it holds."""
    scene, S = plan.scene, plan.config.subpixel_scale
    image = np.full((scene.height, scene.width), scene.background, dtype=np.int64)
    ox, oy = plan.offset
    for poly in plan.polygons:
        x0, y0, x1, y1 = poly.window
        if poly.empty:
            continue
        edges = plan.coords[poly.start : poly.stop]
        ys = (np.arange(y0, y1) + oy) * S
        f = sample_mask(edges, poly.rule, ys, (x0 + ox) * S, S, x1 - x0)
        image[y0:y1, x0:x1][f] = poly.intensity
    return image


def supersampled(plan: Plan, n: int = SSAA) -> np.ndarray:
    """n x n ordered-grid samples per pixel at offsets (2i + 1 - n) / (2n), composited in
    floating point and rounded (half up) at the end."""
    scene, S = plan.scene, plan.config.subpixel_scale
    image = np.full((scene.height, scene.width), float(scene.background))
    ox, oy = plan.offset
    m = 2 * n  # finer grid: 1 / (2 n S) px, where every sample lies on an integer
    for poly in plan.polygons:
        x0, y0, x1, y1 = poly.window
        if poly.empty:
            continue
        edges = plan.coords[poly.start : poly.stop] * m
        sub = np.arange((y1 - y0) * n)
        ys = (y0 + oy) * S * m + (2 * (sub % n) + 1 - n) * S + (sub // n) * S * m
        xs0 = (x0 + ox) * S * m + (1 - n) * S  # sample j of pixel i: xs0 + (n i + j) 2S
        mask = sample_mask(edges, poly.rule, ys, xs0, 2 * S, (x1 - x0) * n)
        cover = mask.reshape(y1 - y0, n, x1 - x0, n).mean(axis=(1, 3))
        view = image[y0:y1, x0:x1]
        view += cover * (poly.intensity - view)
    return np.floor(image + 0.5).astype(np.int64)


def skia_scene(plan: Plan) -> np.ndarray:
    import skia

    scene = plan.scene
    full = plan.config.full_scale
    surface = skia.Surface(scene.width, scene.height)
    canvas = surface.getCanvas()
    b = to8(scene.background, full)
    canvas.clear(skia.ColorSetRGB(b, b, b))
    for i, poly in enumerate(plan.polygons):
        path = skia.Path()
        trace_polygon(plan, i, path.moveTo, path.lineTo, path.close)
        rule = skia.PathFillType.kEvenOdd if poly.rule == "evenodd" else skia.PathFillType.kWinding
        path.setFillType(rule)
        v = to8(poly.intensity, full)
        canvas.drawPath(path, skia.Paint(AntiAlias=True, Color=skia.ColorSetRGB(v, v, v)))
    pixels = np.asarray(surface.makeImageSnapshot().toarray())[:, :, 0].astype(np.int64)
    return _from8(pixels, full)


def agg_scene(plan: Plan) -> np.ndarray:
    import aggdraw
    from PIL import Image

    scene = plan.scene
    full = plan.config.full_scale
    image = Image.new("L", (scene.width, scene.height), to8(scene.background, full))
    draw = aggdraw.Draw(image)
    for i, poly in enumerate(plan.polygons):
        draw.path(agg_path(plan, i), aggdraw.Pen(0, 0, 0), aggdraw.Brush(to8(poly.intensity, full)))
    draw.flush()
    return _from8(np.asarray(image).astype(np.int64), full)


def _from8(pixels: np.ndarray, full: int) -> np.ndarray:
    """8-bit peer output to the configured intensity scale, rounding half up."""
    return pixels if full == 255 else (2 * pixels * full + 255) // 510


def compare_images(
    scene: Scene, config: EdgeConfig, bar: ProgressBar | None = None
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Every method's image of the scene, and the exact reference (float); `bar` counts one
    step per method and one for the exact reference, each named while it runs."""
    bar = bar or ProgressBar("compare", enabled=False)
    plan = plan_scene(scene, config)
    agg = "AGG" if all(p.fill_rule == "nonzero" for p in scene.polygons) else "AGG (non-zero)"
    methods = [
        ("no AA (centre)", lambda: centre_sampled(plan)),
        *((f"edgeaa {mode}", partial(_render_mode, scene, config, mode)) for mode in MODES),
        (f"{SSAA}x{SSAA} SSAA", lambda: supersampled(plan)),
        ("Skia", lambda: skia_scene(plan)),
        (agg, lambda: agg_scene(plan)),
    ]
    methods += [(title, partial(method_image, plan, name)) for name, title in SEED_METHODS.items()]
    bar(0, len(methods) + 1)
    images = {}
    for title, draw in methods:
        with bar.doing(title):
            images[title] = draw()
    with bar.doing("exact area (shapely)"):
        exact = exact_image(plan)
    return images, exact


MODES = ("paper", "seg4")  # edgeaa's modes in the figure


def _render_mode(scene: Scene, config: EdgeConfig, mode: str) -> np.ndarray:
    return render_scene(plan_scene(scene, config.with_(mode=mode))).image


SEED_METHODS = {
    "msaa2": "MSAA 2x",
    "rgss4": "MSAA 4x",
    "rooks8": "MSAA 8x",
    "quincunx": "quincunx",
    "flipquad": "FLIPQUAD",
    "mlaa": "MLAA",
    "mlaa-slope": "MLAA slope-predicted",
    "fxaa": "FXAA",
    "fxaa-geom": "FXAA geometry edges",
    "taa": "TAA (32 frames)",
}
COLUMNS = 6  # methods per row of the figure when the crop is not wide


def plot_compare(
    scene: Scene,
    config: EdgeConfig,
    path: str,
    crop: tuple[int, int, int, int] | None = None,
    bar: ProgressBar | None = None,
) -> list[tuple[str, float, float]]:
    """Write the figure; returns (method, max |err|, RMS err) in intensity LSB over the crop.
    `bar` shows the methods as they are drawn (`compare_images`), then the figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bar = bar or ProgressBar("compare", enabled=False)
    images, exact = compare_images(scene, config, bar)
    bar(0, 0)  # the figure: no count of its own
    with bar.ticking("figure"):
        return _figure(plt, scene, config, path, crop, images, exact)


def _figure(plt, scene: Scene, config: EdgeConfig, path: str, crop, images, exact):
    """Draw and save the figure of `plot_compare`; return its rows."""
    x0, y0, x1, y1 = crop or (0, 0, scene.width, scene.height)
    exact_crop = exact[y0:y1, x0:x1]
    full = config.full_scale
    n = len(images) + 1
    w, h = x1 - x0, y1 - y0
    vertical = w > 1.5 * h  # wide crops: one row per method, image beside its error
    if vertical:
        fig, grid = plt.subplots(n, 2, figsize=(2 * 4.2, n * (4.2 * h / w + 0.45) + 0.5))
        axes = grid.T
    else:  # rows of COLUMNS methods, each an image row above an error row
        cols, groups = min(n, COLUMNS), -(-n // COLUMNS)
        fig, grid = plt.subplots(
            2 * groups, cols, figsize=(2.2 * cols, groups * (4.4 * h / w + 0.9))
        )
        grid = np.asarray(grid).reshape(2 * groups, cols)
        for ax in grid.ravel()[n:]:
            ax.axis("off")
        cells = [(2 * (k // cols), k % cols) for k in range(groups * cols)]
        axes = np.array([[grid[r, c] for r, c in cells], [grid[r + 1, c] for r, c in cells]])
        for ax in (*axes[0, n:], *axes[1, n:]):
            ax.axis("off")
    errors = [np.abs(img[y0:y1, x0:x1] - exact_crop) for img in images.values()]
    # One colour scale for the antialiased methods; the unantialiased panel saturates.
    top = max(1.0, max(float(e.max()) for e in errors[1:]))
    rows = []
    panels = [*images.items(), ("exact (shapely)", exact)]
    for k, (label, img) in enumerate(panels):
        ax = axes[0, k]
        ax.imshow(img[y0:y1, x0:x1], cmap="gray", vmin=0, vmax=full, interpolation="nearest")
        ax.set_title(label, fontsize=9)
        ax.set_xticks([])
        ax.set_yticks([])
        ax = axes[1, k]
        ax.set_xticks([])
        ax.set_yticks([])
        if k < len(errors):
            err = errors[k]
            shown = ax.imshow(err, cmap="magma", vmin=0, vmax=top, interpolation="nearest")
            rms = float(np.sqrt(np.mean(err**2)))
            clipped = " (clipped)" if err.max() > top else ""
            ax.set_title(f"|error|: max {err.max():.1f}, RMS {rms:.2f}{clipped}", fontsize=8)
            rows.append((label, float(err.max()), rms))
        else:
            ax.axis("off")
            bar = fig.colorbar(shown, ax=ax, fraction=0.5, orientation="horizontal")
            bar.set_label("|error| (intensity LSB)", fontsize=8)
    fig.suptitle(
        f"{scene.name}, pixels {x0}..{x1 - 1} x {y0}..{y1 - 1}: each method and its |image - "
        f"exact area composite|\n(one colour scale, intensity LSB of {full}; vertices on the "
        f"1/{config.subpixel_scale} px grid)",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return rows
