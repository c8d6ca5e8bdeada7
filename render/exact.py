"""The exact reference: each pixel square intersected with each polygon (shapely), composited.

The polygon's region respects its fill rule: the contours are noded into faces
(`shapely.polygonize` of their union), and a face belongs to the region when the winding
number at a point inside it passes the rule. Each pixel's exact coverage is the area of the
unit square centred on the pixel intersected with the region. The reference image
composites the polygons in order with that coverage, in floating point, with the same
operator as the renderer (I <- I + a (I_p - I)); so the error measures the antialiasing and
its accumulation at vertices, not the compositing model. The reference uses the quantized
vertices (what the renderer draws): quantization itself moves a vertex by at most 1/32 px
at the default 1/16 px grid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.accumulate import Window, resolve_rows
from .geometry import fills
from .render import Plan, Render


def winding_float(edges: np.ndarray, px: np.ndarray, py: np.ndarray) -> np.ndarray:
    """Winding numbers of points off the boundary (floats), Sunday's crossing rule."""
    ax, ay, bx, by = (edges[:, i][None, :] for i in range(4))
    px, py = px[:, None], py[:, None]
    is_left = (bx - ax) * (py - ay) - (px - ax) * (by - ay)
    up = (ay <= py) & (by > py) & (is_left > 0)
    down = (ay > py) & (by <= py) & (is_left < 0)
    return up.sum(axis=1) - down.sum(axis=1)


def polygon_region(plan: Plan, index: int):
    """The polygon's filled region (a shapely geometry) in image pixels."""
    import shapely

    poly = plan.polygons[index]
    S = plan.config.subpixel_scale
    coords = plan.coords[poly.start : poly.stop].astype(np.float64) / S
    coords = coords - np.array(plan.offset * 2, dtype=np.float64)
    if not len(coords):
        return shapely.Polygon()
    segments = shapely.linestrings(coords.reshape(-1, 2, 2))
    noded = shapely.union_all(segments)
    faces = shapely.get_parts(shapely.polygonize(shapely.get_parts(noded)))
    if not len(faces):
        return shapely.Polygon()
    points = shapely.get_coordinates(shapely.point_on_surface(faces))
    keep = fills(winding_float(coords, points[:, 0], points[:, 1]), poly.rule)
    return shapely.union_all(faces[keep])


def exact_coverage(plan: Plan, index: int) -> tuple[tuple[int, int, int, int], np.ndarray]:
    """Exact coverage of the polygon's window: (x0, y0, x1, y1) and a (rows, cols) array."""
    import shapely

    window = plan.polygons[index].window
    x0, y0, x1, y1 = window
    if x1 <= x0 or y1 <= y0:
        return window, np.zeros((0, 0))
    region = polygon_region(plan, index)
    ys, xs = np.mgrid[y0:y1, x0:x1]
    xs, ys = xs.ravel().astype(np.float64), ys.ravel().astype(np.float64)
    out = shapely.contains_xy(region, xs, ys).astype(np.float64)
    boxes = shapely.box(xs - 0.5, ys - 0.5, xs + 0.5, ys + 0.5)
    shapely.prepare(region)
    cut = shapely.intersects(region.boundary, boxes)
    out[cut] = shapely.area(shapely.intersection(boxes[cut], region))
    return window, out.reshape(y1 - y0, x1 - x0)


def exact_image(plan: Plan, progress=None) -> np.ndarray:
    """The reference image (float64): the polygons' exact coverages composited in order."""
    scene = plan.scene
    image = np.full((scene.height, scene.width), float(scene.background))
    for i, poly in enumerate(plan.polygons):
        if progress is not None:
            progress(i, len(plan.polygons), "exact")
        (x0, y0, x1, y1), a = exact_coverage(plan, i)
        if a.size:
            view = image[y0:y1, x0:x1]
            view += a * (poly.intensity - view)
    if progress is not None:
        progress(len(plan.polygons), len(plan.polygons), "exact")
    return image


@dataclass(frozen=True)
class ErrorRow:
    label: str
    pixels: int
    max_abs: float  # intensity LSB
    rms: float
    full_scale: int

    @property
    def max_coverage(self) -> float:
        return self.max_abs / self.full_scale

    @property
    def rms_coverage(self) -> float:
        return self.rms / self.full_scale


def crossed_cells(plan: Plan, edge: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Which of the cells (x, y) (image pixels) the scene edge `edge` passes through the
    interior of, decided exactly in doubled sub-pixel integers: the segment's box meets the
    open pixel square and the square's corners lie strictly on both sides of its line."""
    S = plan.config.subpixel_scale
    ox, oy = plan.offset
    ax, ay, bx, by = (2 * plan.coords[edge, i] for i in range(4))
    cx, cy = 2 * (x + ox) * S, 2 * (y + oy) * S  # pixel centre, doubled
    inside_box = (
        (np.minimum(ax, bx) < cx + S)
        & (np.maximum(ax, bx) > cx - S)
        & (np.minimum(ay, by) < cy + S)
        & (np.maximum(ay, by) > cy - S)
    )
    sides = [
        (bx - ax) * (cy + sy - ay) - (by - ay) * (cx + sx - ax) for sx in (-S, S) for sy in (-S, S)
    ]
    low, high = np.minimum.reduce(sides), np.maximum.reduce(sides)
    return inside_box & (low < 0) & (high > 0)


def candidate_cells(plan: Plan, edges: np.ndarray) -> tuple[np.ndarray, ...]:
    """Image pixels along each edge, a superset of those it passes through: per pixel column
    (row, for a y-major edge) the three pixels from the one holding the segment's low end
    in it. Returns (edge, x, y) arrays."""
    S = plan.config.subpixel_scale
    c = plan.coords[edges]
    x_major = np.abs(c[:, 2] - c[:, 0]) >= np.abs(c[:, 3] - c[:, 1])
    # along the major axis (p) and the minor (q), in sub-pixel units
    p0 = np.where(x_major, c[:, 0], c[:, 1])
    q0 = np.where(x_major, c[:, 1], c[:, 0])
    p1 = np.where(x_major, c[:, 2], c[:, 3])
    q1 = np.where(x_major, c[:, 3], c[:, 2])
    lo, hi = np.minimum(p0, p1), np.maximum(p0, p1)
    first = (2 * lo + S) // (2 * S)  # pixel holding lo
    count = (2 * hi + S) // (2 * S) - first + 1
    edge = np.repeat(np.arange(len(edges)), count)
    column = (
        np.repeat(first, count)
        + np.arange(count.sum())
        - np.repeat(np.cumsum(count) - count, count)
    )
    # the segment's lower minor coordinate over the column's span, as a float (candidates only)
    a0, b0, a1, b1 = p0[edge], q0[edge], p1[edge], q1[edge]
    left = np.clip((2 * column - 1) * S / 2, np.minimum(a0, a1), np.maximum(a0, a1))
    right = np.clip((2 * column + 1) * S / 2, np.minimum(a0, a1), np.maximum(a0, a1))
    span = np.where(a1 != a0, a1 - a0, 1)
    qa = b0 + (b1 - b0) * (left - a0) / span
    qb = b0 + (b1 - b0) * (right - a0) / span
    row = np.floor(np.minimum(qa, qb) / S + 0.5).astype(np.int64) - 1
    out_edge = np.repeat(edges[edge], 3)
    major = np.repeat(column, 3)
    minor = np.repeat(row, 3) + np.tile(np.arange(3), len(row))
    xm = np.repeat(x_major[edge], 3)
    ox, oy = plan.offset
    return out_edge, np.where(xm, major, minor) - ox, np.where(xm, minor, major) - oy


def edges_per_pixel(result: Render) -> np.ndarray:
    """How many boundary edges pass through each pixel's interior (all polygons)."""
    plan = result.plan
    scene = plan.scene
    edge, x, y = candidate_cells(plan, np.flatnonzero(plan.boundary))
    onscreen = (x >= 0) & (x < scene.width) & (y >= 0) & (y < scene.height)
    cells = np.unique(np.stack([edge[onscreen], y[onscreen], x[onscreen]]), axis=1)
    edge, y, x = cells
    crossed = crossed_cells(plan, edge, x, y)
    count = np.zeros((scene.height, scene.width), dtype=np.int64)
    np.add.at(count, (y[crossed], x[crossed]), 1)
    return count


def sum_errors(result: Render) -> np.ndarray:
    """|resolved sum - exact coverage| of each pixel, in fixed-point units (``ifix`` a whole
    pixel), for a scene of one polygon rendered with ``skip=False``: the accumulation's own
    error before the fill's clamp is rounded to intensities (docs/algorithm.md 13.6)."""
    plan, deltas = result.plan, result.deltas
    scene, poly = plan.scene, plan.polygons[0]
    assert len(plan.polygons) == 1 and not result.skip, "one polygon, rendered whole"
    ifix = abs(poly.intensity - poly.i_out) << plan.config.F
    sums = np.zeros((scene.height, scene.width))
    window = Window(0, 0, scene.width, scene.height)
    for block in resolve_rows(window, deltas.x, deltas.y, deltas.delta, poly.rule, ifix):
        sums[block.rows] = block.coverage
    (x0, y0, x1, y1), area = exact_coverage(plan, 0)
    exact = np.zeros_like(sums)
    exact[y0:y1, x0:x1] = area * ifix
    return np.abs(sums - exact)


def error_rows(result: Render, exact: np.ndarray) -> list[ErrorRow]:
    """Max and RMS error against the reference: all pixels, then by the number of edges
    passing through the pixel (0: wholly inside or outside every polygon); a colour image
    against its colour reference (`edgeaa.render.paint.exact_colour`) by its worst channel."""
    full = result.plan.config.full_scale
    err = np.abs(result.image.astype(np.float64) - exact)
    if err.ndim == 3:  # a colour image (`paint`): each pixel's worst channel
        err = err.max(axis=2)
    crossers = edges_per_pixel(result)
    rows = []
    for label, mask in (
        ("all pixels", np.ones_like(crossers, dtype=bool)),
        ("no edge", crossers == 0),
        ("one edge", crossers == 1),
        ("two edges", crossers == 2),
        ("three or more", crossers >= 3),
    ):
        e = err[mask]
        rows.append(
            ErrorRow(
                label,
                int(e.size),
                float(e.max()) if e.size else 0.0,
                float(np.sqrt(np.mean(e**2))) if e.size else 0.0,
                full,
            )
        )
    return rows


def error_table(rows: list[ErrorRow]) -> str:
    lines = [
        f"{'pixels':14} {'count':>7} {'max |err| LSB':>14} {'RMS LSB':>8} "
        f"{'max |err| cov':>14} {'RMS cov':>9}"
    ]
    for r in rows:
        lines.append(
            f"{r.label:14} {r.pixels:7d} {r.max_abs:14.3f} {r.rms:8.3f} "
            f"{r.max_coverage:14.5f} {r.rms_coverage:9.5f}"
        )
    return "\n".join(lines)
