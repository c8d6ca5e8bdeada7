"""Real rasterizers measured on the same edges: Skia, Anti-Grain Geometry, scikit-image.

Per-edge coverage, fairly. For each edge a quadrilateral is built whose one edge is the test
edge P0 -> P1 itself and whose other edges stay out of the compared pixels: from P1 and P0
it extends across the minor axis to the inside, beyond the mask (P0, P1, P1 + R m, P0 + R m,
m the unit step of the minor axis towards the inside: vertical sides for an x-major edge,
horizontal for a y-major one). The sides lie in the endpoints' own columns, which are not
compared, and the far side lies outside the mask. So in every column strictly between the
endpoints the quadrilateral is the half-plane, whose coverage is compared with
`edgeaa.model.exact_coverage_array` (`geometry.inner_columns`). The vertices are exact
(multiples of 2**-s, exact in float32 too). The polygon is rasterized into an 8-bit mask
that covers the edge's writes plus one pixel, so each peer fills only that box.

(An earlier version continued the edge's line beyond P0 and P1 to a far rectangle. Skia
then rasterizes one long nearly horizontal segment instead of the test edge, and on such
segments it can drop the antialiasing of a whole row: a test edge from (474.25, 91.9375)
to (485.5, 92.0625) came out as a hard 0/255 step, error 0.55. The peers must see the edge
as it is.)

Pixel centres. edgeaa's pixel (x, y) is centred on the integers; Skia's and AGG's pixel
(i, j) covers [i, i + 1) x [j, j + 1). A point p of the image is at p - origin + 1/2 in the
mask's coordinates (origin: the mask's top-left edgeaa pixel). `convention_check` checks it
on the half-plane x < 10.25, whose pixel column 10 is 3/4 covered.

- Skia (skia-python): alpha-only raster surface (`ImageInfo.MakeA8`), path fill, winding,
  `Paint(AntiAlias=True)`: Skia's analytic antialiasing for paths.
- AGG (aggdraw 1.4.1): `Draw.polygon` on a PIL 'L' image with a brush; AGG's
  `rasterizer_scanline_aa` accumulates exact cell areas on a 1/256 px grid, linear gamma.
  aggdraw widens a brush-only polygon by 1/4 px (it renders the fill through
  `conv_contour` with width 0.5, "expand polygons by 0.5 pixels by default" in its
  changelog). Passing a pen of width 0 (and opacity 0, so its outline draws nothing) sets
  that width to 0: ``agg`` does this; ``agg-default`` is the plain brush call, for
  reference.
- scikit-image `draw.line_aa` (Zingl's antialiased line, integer endpoints) draws a line,
  not an edge: it is compared on lines (see `line_*`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model import Edge, EdgeConfig
from ..model.vector import WriteBatch
from .geometry import edge_bounds

FILL_PEERS = ("skia", "agg", "agg-default")
LINE_PEERS = ("skimage-line_aa", "skia-stroke", "agg-stroke")

DESCRIPTIONS = {
    "skia": "Skia analytic AA path fill, A8 mask (skia-python)",
    "agg": "AGG exact-area scanline fill, 8-bit (aggdraw, 1/4 px widening off)",
    "agg-default": "AGG via aggdraw's default brush fill (widened by 1/4 px)",
    "skimage-line_aa": "scikit-image draw.line_aa (Zingl AA line, float values)",
    "skia-stroke": "Skia AA stroke, width 1 px, butt caps, A8 mask",
    "agg-stroke": "AGG stroke via aggdraw Pen(width 1), 8-bit",
}


def versions() -> dict[str, str]:
    """Versions of the peer libraries (for the record)."""
    out = {}
    try:
        import skia

        out["skia-python"] = skia.__version__
    except ImportError:  # pragma: no cover - a declared dependency
        out["skia-python"] = "missing"
    try:
        import aggdraw

        out["aggdraw"] = getattr(aggdraw, "VERSION", getattr(aggdraw, "__version__", "?"))
    except ImportError:  # pragma: no cover
        out["aggdraw"] = "missing"
    try:
        import skimage

        out["scikit-image"] = skimage.__version__
    except ImportError:  # pragma: no cover
        out["scikit-image"] = "missing"
    return out


@dataclass(frozen=True)
class MaskJob:
    """One rasterization: a mask of w x h pixels whose pixel (0, 0) is edgeaa pixel origin,
    and the polygon (or line) to draw in the mask's coordinates."""

    origin: tuple[int, int]
    size: tuple[int, int]  # (w, h)
    points: tuple[tuple[float, float], ...]


def mask_box(xs: np.ndarray, ys: np.ndarray, margin: int = 1) -> tuple[tuple, tuple]:
    x_lo, y_lo = int(xs.min()) - margin, int(ys.min()) - margin
    w, h = int(xs.max()) + margin - x_lo + 1, int(ys.max()) + margin - y_lo + 1
    return (x_lo, y_lo), (w, h)


def half_plane_polygon(
    config: EdgeConfig, edge: Edge, origin: tuple[int, int], size: tuple[int, int]
) -> tuple[tuple[float, float], ...]:
    """The trapezoid of the module docstring, in the mask's coordinates (+1/2 shift)."""
    scale = config.subpixel_scale
    x0, y0, x1, y1 = (v / scale for v in (edge.x0, edge.y0, edge.x1, edge.y1))
    dx, dy = x1 - x0, y1 - y0
    side = 1.0 if edge.inside == "left" else -1.0
    nx, ny = side * dy, -side * dx  # the inside normal
    reach = math.ceil(math.hypot(*size)) + 4  # farther than the mask's far side
    if abs(dx) >= abs(dy):  # x-major: the sides are vertical, in the endpoint columns
        ox, oy = 0.0, math.copysign(reach, ny)
    else:  # y-major: horizontal sides
        ox, oy = math.copysign(reach, nx), 0.0
    shift_x, shift_y = 0.5 - origin[0], 0.5 - origin[1]
    points = [(x0, y0), (x1, y1), (x1 + ox, y1 + oy), (x0 + ox, y0 + oy)]
    return tuple((px + shift_x, py + shift_y) for px, py in points)


def fill_jobs(config: EdgeConfig, edges: list[Edge], batch: WriteBatch) -> list[MaskJob]:
    """One mask job per edge: the box of all its writes plus one pixel, its half-plane."""
    bounds = edge_bounds(batch.edge_index, len(edges))
    jobs = []
    for k, edge in enumerate(edges):
        lo, hi = bounds[k], bounds[k + 1]
        origin, size = mask_box(batch.x[lo:hi], batch.y[lo:hi])
        jobs.append(MaskJob(origin, size, half_plane_polygon(config, edge, origin, size)))
    return jobs


# -- renderers: each returns an (h, w) uint8 mask -----------------------------------------------


def _skia_mask(job: MaskJob, draw) -> np.ndarray:
    """`draw(canvas)` on a cleared 8-bit alpha surface of the job's size; its pixels."""
    import skia

    w, h = job.size
    info = skia.ImageInfo.MakeA8(w, h)
    surface = skia.Surface.MakeRaster(info)
    canvas = surface.getCanvas()
    canvas.clear(skia.ColorTRANSPARENT)
    draw(canvas)
    mask = np.empty((h, w), dtype=np.uint8)
    surface.readPixels(info, mask, w)
    return mask


def skia_fill(job: MaskJob) -> np.ndarray:
    import skia

    path = skia.Path.Polygon([skia.Point(x, y) for x, y in job.points], True)
    return _skia_mask(job, lambda canvas: canvas.drawPath(path, skia.Paint(AntiAlias=True)))


def agg_fill(job: MaskJob, *, widen: bool = False) -> np.ndarray:
    import aggdraw
    from PIL import Image

    image = Image.new("L", job.size, 0)
    draw = aggdraw.Draw(image)
    flat = [c for point in job.points for c in point]
    if widen:
        draw.polygon(flat, aggdraw.Brush(255))
    else:
        draw.polygon(flat, aggdraw.Pen(0, 0, 0), aggdraw.Brush(255))
    draw.flush()
    return np.asarray(image)


def skia_stroke(job: MaskJob) -> np.ndarray:
    import skia

    paint = skia.Paint(AntiAlias=True, Style=skia.Paint.kStroke_Style, StrokeWidth=1.0)
    paint.setStrokeCap(skia.Paint.kButt_Cap)
    (x0, y0), (x1, y1) = job.points
    return _skia_mask(job, lambda canvas: canvas.drawLine(x0, y0, x1, y1, paint))


def agg_stroke(job: MaskJob) -> np.ndarray:
    import aggdraw
    from PIL import Image

    image = Image.new("L", job.size, 0)
    draw = aggdraw.Draw(image)
    (x0, y0), (x1, y1) = job.points
    draw.line((x0, y0, x1, y1), aggdraw.Pen(255, 1.0))
    draw.flush()
    return np.asarray(image)


def skimage_line(job: MaskJob) -> np.ndarray:
    """line_aa into a float mask; its endpoints are pixel centres (integers, no shift)."""
    from skimage.draw import line_aa

    w, h = job.size
    (x0, y0), (x1, y1) = ((round(x - 0.5), round(y - 0.5)) for x, y in job.points)
    rr, cc, val = line_aa(y0, x0, y1, x1)
    mask = np.zeros((h, w), dtype=np.float64)
    keep = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
    mask[rr[keep], cc[keep]] = val[keep]
    return mask


RENDERERS = {
    "skia": skia_fill,
    "agg": agg_fill,
    "agg-default": lambda job: agg_fill(job, widen=True),
    "skimage-line_aa": skimage_line,
    "skia-stroke": skia_stroke,
    "agg-stroke": agg_stroke,
}
SCALE = {name: 255.0 for name in RENDERERS}
SCALE["skimage-line_aa"] = 1.0


def render(name: str, jobs: list[MaskJob]) -> list[np.ndarray]:
    renderer = RENDERERS[name]
    return [renderer(job) for job in jobs]


def gather(
    name: str,
    jobs: list[MaskJob],
    masks: list[np.ndarray],
    edge_index: np.ndarray,
    xs: np.ndarray,
    ys: np.ndarray,
) -> np.ndarray:
    """Coverage in [0, 1] of pixels (xs, ys) of edge edge_index (sorted) from its mask."""
    out = np.empty(len(edge_index), dtype=np.float64)
    bounds = edge_bounds(edge_index, len(jobs))
    for k, (job, mask) in enumerate(zip(jobs, masks, strict=True)):
        lo, hi = bounds[k], bounds[k + 1]
        if hi > lo:
            out[lo:hi] = mask[ys[lo:hi] - job.origin[1], xs[lo:hi] - job.origin[0]]
    return out / SCALE[name]


# -- lines --------------------------------------------------------------------------------------


def integer_lines(config: EdgeConfig, edges: list[Edge]) -> list[tuple[int, int, int, int]]:
    """The edges' endpoints rounded to pixel centres (line_aa takes integers); lines of fewer
    than three columns are dropped."""
    scale = config.subpixel_scale
    lines = []
    for edge in edges:
        x0, y0, x1, y1 = (round(v / scale) for v in (edge.x0, edge.y0, edge.x1, edge.y1))
        if max(abs(x1 - x0), abs(y1 - y0)) >= 3:
            lines.append((x0, y0, x1, y1))
    return lines


@dataclass(frozen=True)
class LinePixels:
    """The compared pixels of integer lines: every pixel of the columns strictly between the
    endpoints within 2 rows of the line's crossing of the column centre (a 1 px wide line
    covers at most 1/2 + sqrt(2)/2 rows either side of it)."""

    edge_index: np.ndarray
    x: np.ndarray
    y: np.ndarray
    exact: np.ndarray  # area of the pixel inside the 1 px wide strip around the line


def line_pixels(lines: list[tuple[int, int, int, int]]) -> LinePixels:
    from .geometry import halfplane_area

    es, xs, ys = [], [], []
    for k, (x0, y0, x1, y1) in enumerate(lines):
        dx, dy = x1 - x0, y1 - y0
        x_major = abs(dx) >= abs(dy)
        p0, q0, dp, dq = (x0, y0, dx, dy) if x_major else (y0, x0, dy, dx)
        step = 1 if dp > 0 else -1
        cols = np.arange(p0 + step, p0 + dp, step)
        centre = q0 + dq * (cols - p0) / dp
        rows = np.round(centre)[:, None] + np.arange(-2, 3)[None, :]
        cols = np.repeat(cols, 5)
        rows = rows.ravel().astype(np.int64)
        px, py = (cols, rows) if x_major else (rows, cols)
        es.append(np.full(len(cols), k))
        xs.append(px)
        ys.append(py)
    e, x, y = (np.concatenate(v).astype(np.int64) for v in (es, xs, ys))
    arr = np.array(lines, dtype=np.float64)
    x0, y0, dx, dy = arr[e, 0], arr[e, 1], arr[e, 2] - arr[e, 0], arr[e, 3] - arr[e, 1]
    length = np.hypot(dx, dy)
    a, b = -dy / length, dx / length  # unit normal
    dist = a * (x - x0) + b * (y - y0)  # signed distance of the pixel centre from the line
    exact = halfplane_area(a, b, 0.5 - dist) - halfplane_area(a, b, -0.5 - dist)
    return LinePixels(e, x, y, exact)


def line_jobs(lines: list[tuple[int, int, int, int]], pixels: LinePixels) -> list[MaskJob]:
    bounds = edge_bounds(pixels.edge_index, len(lines))
    jobs = []
    for k, (x0, y0, x1, y1) in enumerate(lines):
        lo, hi = bounds[k], bounds[k + 1]
        px = np.concatenate([pixels.x[lo:hi], [x0, x1]])
        py = np.concatenate([pixels.y[lo:hi], [y0, y1]])
        origin, size = mask_box(px, py)
        shift_x, shift_y = 0.5 - origin[0], 0.5 - origin[1]
        jobs.append(
            MaskJob(origin, size, ((x0 + shift_x, y0 + shift_y), (x1 + shift_x, y1 + shift_y)))
        )
    return jobs


# -- the pixel-centre convention ------------------------------------------------------------


def convention_check(config: EdgeConfig | None = None) -> dict[str, float]:
    """Coverage each fill peer gives pixel (10, 8) for the half-plane x < 10.25 (exact 0.75).

    The half-plane is the edge (10.25, 1) -> (10.25, 15) with inside = right (travelling down,
    the right is -x), drawn through `half_plane_polygon` like every bench edge.
    """
    config = config or EdgeConfig()
    edge = Edge.from_pixels(config, "10.25", 1, "10.25", 15, inside="right")
    origin, size = (0, 0), (16, 16)
    job = MaskJob(origin, size, half_plane_polygon(config, edge, origin, size))
    e, xs, ys = np.zeros(1, np.int64), np.array([10]), np.array([8])
    return {
        name: float(gather(name, [job], render(name, [job]), e, xs, ys)[0]) for name in FILL_PEERS
    }
