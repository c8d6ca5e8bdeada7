"""Shared geometry of the analysis: edges as floats, pixel sets, exact areas, random edges.

Conventions (those of the model, docs/model.md): pixel (x, y) is the unit square centred on
the integers (x, y); x right, y down; an edge's `inside` names the side of its direction of
travel P0 -> P1 as seen on the image. The left of travel (dx, dy) is the side of the normal
(dy, -dx), so the *inside normal* is s (dy, -dx) with s = +1 for inside = left, -1 for right,
and a point p is inside when s (dy (px - x0) - dx (py - y0)) > 0.

All coordinates handled here are dyadic rationals with few bits (vertices on the 2**-s grid,
sample offsets on a 2**-5 grid), so the float64 arithmetic below is exact: sums of products
of such numbers need far fewer than 53 bits.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass

import numpy as np

from ..model import Edge, EdgeConfig, exact_coverage_array
from ..model.vector import WriteBatch


@dataclass(frozen=True)
class EdgeArrays:
    """Per-edge float parameters of a list of edges (pixels), as arrays indexed by edge."""

    x0: np.ndarray
    y0: np.ndarray
    dx: np.ndarray
    dy: np.ndarray
    side: np.ndarray  # +1.0 inside = left, -1.0 inside = right

    @property
    def normal(self) -> tuple[np.ndarray, np.ndarray]:
        """The inside normal s (dy, -dx) (not normalised)."""
        return self.side * self.dy, -self.side * self.dx


def edge_arrays(config: EdgeConfig, edges: list[Edge]) -> EdgeArrays:
    scale = float(config.subpixel_scale)
    raw = np.array([(e.x0, e.y0, e.x1, e.y1) for e in edges], dtype=np.float64).reshape(-1, 4)
    x0, y0, x1, y1 = (raw[:, i] / scale for i in range(4))
    side = np.array([1.0 if e.inside == "left" else -1.0 for e in edges], dtype=np.float64)
    return EdgeArrays(x0, y0, x1 - x0, y1 - y0, side)


def slope_k(config: EdgeConfig, edge: Edge) -> float:
    """The folded slope k = |minor| / |major| in [0, 1]."""
    dx, dy = abs(edge.x1 - edge.x0), abs(edge.y1 - edge.y0)
    return min(dx, dy) / max(dx, dy)


def edge_bounds(edge_index: np.ndarray, count: int) -> np.ndarray:
    """Start offsets of each edge's rows in an array sorted by edge (count + 1 entries)."""
    return np.searchsorted(edge_index, np.arange(count + 1))


def exact_coverage_pixels(
    config: EdgeConfig, edges: list[Edge], edge_index: np.ndarray, xs, ys
) -> np.ndarray:
    """The exact inside area (`exact_coverage_array`) of pixels grouped by edge (sorted)."""
    xs, ys = np.asarray(xs), np.asarray(ys)
    out = np.empty(len(edge_index), dtype=np.float64)
    bounds = edge_bounds(edge_index, len(edges))
    for k, edge in enumerate(edges):
        lo, hi = bounds[k], bounds[k + 1]
        if hi > lo:
            out[lo:hi] = exact_coverage_array(config, edge, xs[lo:hi], ys[lo:hi])
    return out


def column_index(batch: WriteBatch) -> np.ndarray:
    """Each write's column within its edge: 0 for the first stepped column."""
    if len(batch) == 0:
        return np.zeros(0, dtype=np.int64)
    x_major = np.array([st.x_major for st in batch.setups], dtype=bool)[batch.edge_index]
    first = np.array([st.x if st.x_major else st.y for st in batch.setups], dtype=np.int64)[
        batch.edge_index
    ]
    step = np.array([st.col_dx + st.col_dy for st in batch.setups], dtype=np.int64)
    major = np.where(x_major, batch.x, batch.y)
    return (major - first) * step[batch.edge_index]


def inner_columns(batch: WriteBatch) -> np.ndarray:
    """Mask of the writes in columns strictly between the edge's endpoints.

    The first and last stepped columns hold the endpoints; every other column's whole span
    lies strictly between them, so there a polygon whose boundary continues the edge's line
    beyond its endpoints has the half-plane's coverage.
    """
    columns = np.array([st.columns for st in batch.setups], dtype=np.int64)[batch.edge_index]
    col = column_index(batch)
    return (col > 0) & (col < columns - 1)


def pixel_keys(edge_index: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """A unique int64 key per (edge, x, y); x and y lie in [-1, 2**16 + 1]."""
    return (edge_index.astype(np.int64) << 36) | ((xs + 2) << 18) | (ys + 2)


def halfplane_area(a, b, t) -> np.ndarray:
    """Area of {(x, y) in [-1/2, 1/2]^2 : a x + b y < t}, vectorized, (a, b) != (0, 0).

    Folded so that a >= |b| >= 0 (swap and mirror the square); then for each y the inside
    is x < h(y) - 1/2 with h linear, and the area is the mean of clamp(h, 0, 1) over y,
    the closed form of model/reference.py.
    """
    a, b, t = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (a, b, t)))
    swap = np.abs(b) > np.abs(a)
    a, b = np.where(swap, b, a), np.where(swap, a, b)
    a, b = np.abs(a), np.abs(b)  # mirroring x (or y) about 0 keeps the square
    r = b / a
    h_hi = t / a + 0.5 + r / 2  # h at y = -1/2
    h_lo = t / a + 0.5 - r / 2  # h at y = +1/2
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = (_ramp(h_hi) - _ramp(h_lo)) / (h_hi - h_lo)
    return np.where(r == 0, np.clip(h_hi, 0.0, 1.0), mean)


def _ramp(z):
    return np.where(z <= 0, 0.0, np.where(z >= 1, z - 0.5, 0.5 * z * z))


def random_image_edges(
    config: EdgeConfig,
    count: int,
    seed: int,
    *,
    region: int = 512,
    min_length: float = 8.0,
    max_length: float = 200.0,
) -> list[Edge]:
    """Seeded random edges: P0 uniform in the region, direction uniform, length uniform.

    Vertices on the sub-pixel grid inside [1, region - 2] px (so every write and a margin
    around it stays on a region x region image); full-scale inside, background 0; inside
    side random. At least three columns each, so that every edge has an inner column.
    """
    rng = random.Random(seed)
    scale = config.subpixel_scale
    region = min(region, 1 << config.coord_bits)
    lo, hi = 1.0, region - 2.0
    if hi - lo < 2 * min_length:
        raise ValueError(f"region of {region} px is too small for edges of {min_length} px")
    edges: list[Edge] = []
    while len(edges) < count:
        x0, y0 = rng.uniform(lo, hi), rng.uniform(lo, hi)
        angle = rng.uniform(0.0, 2.0 * math.pi)
        length = rng.uniform(min_length, max_length)
        x1, y1 = x0 + length * math.cos(angle), y0 + length * math.sin(angle)
        if not (lo <= x1 <= hi and lo <= y1 <= hi):
            continue
        fixed = [round(v * scale) for v in (x0, y0, x1, y1)]
        if max(abs(fixed[2] - fixed[0]), abs(fixed[3] - fixed[1])) < 3 * scale:
            continue
        edges.append(Edge(*fixed, inside=rng.choice(("left", "right"))))
    return edges
