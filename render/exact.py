"""The exact reference: each pixel square intersected with each polygon (shapely), composited.

The polygon's region respects its fill rule: the contours are noded into faces
(`shapely.polygonize` of their union), and a face belongs to the region when the winding
number at a point inside it passes the rule. Each pixel's exact coverage is the area of the
unit square centred on the pixel intersected with the region. The reference image
composites the polygons in order with that coverage, in floating point, with the same
operator as the renderer (I <- I + a (I_p - I)); so the error measures the antialiasing and
its combination at vertices, not the compositing model. The reference uses the quantized
vertices (what the renderer draws): quantization itself moves a vertex by at most 1/32 px
at the default 1/16 px grid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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


def writers_per_pixel(result: Render) -> np.ndarray:
    """How many distinct edges wrote each pixel (all polygons)."""
    scene = result.plan.scene
    w = result.writes
    count = np.zeros((scene.height, scene.width), dtype=np.int64)
    np.add.at(count, (w.y, w.x), 1)  # an edge writes a pixel at most once
    return count


def error_rows(result: Render, exact: np.ndarray) -> list[ErrorRow]:
    """Max and RMS error against the reference: all pixels, then split by writers."""
    full = result.plan.config.full_scale
    err = np.abs(result.image.astype(np.float64) - exact)
    writers = writers_per_pixel(result)
    rows = []
    for label, mask in (
        ("all pixels", np.ones_like(writers, dtype=bool)),
        ("one edge", writers == 1),
        ("several edges", writers >= 2),
        ("fill only", writers == 0),
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
