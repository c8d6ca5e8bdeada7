"""The seeds' antialiasing methods on the analysis' common pixel set (beside `evaluate`).

Sample patterns (`msaa`) are evaluated on the pixels like `sampling`'s. The image methods
(MLAA, MLAA with slope prediction, FXAA, FXAA with geometry edges, TAA) post-process a
rendered image, so each edge's half-plane is point sampled (at pixel centres, the top-left
tie rule of `sampling`) into an image around its compared pixels, MARGIN pixels wider on
every side so that the staircase continues as far as MLAA searches; the method runs on the
image and its values are read at the compared pixels. The object numbers the geometry
variant of FXAA needs are the inside flags themselves (a half-plane has two objects).
Images of a chunk of edges are stacked and padded to one size and processed together.
"""

from __future__ import annotations

import numpy as np

from ..model import Edge, EdgeConfig
from . import evaluate, fxaa, mlaa, msaa, temporal
from .evaluate import MethodRun, PixelSet, timed
from .geometry import edge_arrays, edge_bounds

SAMPLE_METHODS = tuple(msaa.PATTERNS)
IMAGE_METHODS = ("mlaa", "mlaa-slope", "fxaa", "fxaa-geom", "taa")
METHODS = SAMPLE_METHODS + IMAGE_METHODS
MARGIN = mlaa.MAX_SEARCH + 2
CHUNK_PIXELS = 1 << 21  # image pixels processed at once

DESCRIPTIONS = {
    **{name: p.description for name, p in msaa.PATTERNS.items()},
    "mlaa": "MLAA on the point-sampled image (L/Z/U shapes, area table)",
    "mlaa-slope": "MLAA with the seed's slope-predicted endpoints",
    "fxaa": "FXAA 3.11 style (luma edges), on the point-sampled image",
    "fxaa-geom": "FXAA with edges from geometry (object per pixel)",
    "taa": f"TAA: Halton jitter, alpha {temporal.ALPHA}, clamp, {temporal.STATIC_FRAMES} frames",
}
# Values a pixel holds before the method resolves it (what sizes the frame buffer).
VALUES_PER_PIXEL = {
    **{name: p.stored for name, p in msaa.PATTERNS.items()},
    "mlaa": 1,
    "mlaa-slope": 1,
    "fxaa": 1,
    "fxaa-geom": 1,
    "taa": 2,  # the frame and the history
}


def apply(name: str, sample, ids=None) -> np.ndarray:
    """Run image method `name`; sample(jx, jy) renders the aliased image with the sample moved
    by (jx, jy) px; ids(image) gives the object per pixel (default: the image itself)."""
    if name == "taa":
        return temporal.still(sample)
    image = sample(0.0, 0.0)
    if name == "mlaa":
        return mlaa.mlaa(image)
    if name == "mlaa-slope":
        return mlaa.mlaa(image, predict=mlaa.PREDICT_STEPS)
    if name == "fxaa":
        return fxaa.fxaa(image)
    if name == "fxaa-geom":
        return fxaa.fxaa(image, image if ids is None else ids(image))
    raise ValueError(f"unknown image method {name!r}")


def _boxes(pixels: PixelSet, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per edge: the origin (x, y) and size (w, h) of its image, and whether it has pixels."""
    bounds = edge_bounds(pixels.edge_index, count)
    origin, size = np.zeros((count, 2), np.int64), np.ones((count, 2), np.int64)
    used = bounds[1:] > bounds[:-1]
    for k in np.flatnonzero(used):
        xs, ys = pixels.x[bounds[k] : bounds[k + 1]], pixels.y[bounds[k] : bounds[k + 1]]
        origin[k] = xs.min() - MARGIN, ys.min() - MARGIN
        size[k] = xs.max() - xs.min() + 1 + 2 * MARGIN, ys.max() - ys.min() + 1 + 2 * MARGIN
    return origin, size, used


def _chunks(size: np.ndarray, used: np.ndarray):
    """Groups of edges whose padded images fit CHUNK_PIXELS together."""
    group, w, h = [], 0, 0
    for k in np.flatnonzero(used):
        nw, nh = max(w, size[k, 0]), max(h, size[k, 1])
        if group and nw * nh * (len(group) + 1) > CHUNK_PIXELS:
            yield np.array(group), w, h
            group, nw, nh = [], size[k, 0], size[k, 1]
        group.append(k)
        w, h = nw, nh
    if group:
        yield np.array(group), w, h


def half_plane_sampler(config: EdgeConfig, edges: list[Edge], group, origin, w: int, h: int):
    """sample(jx, jy): the (len(group), h, w) point-sampled images of the edges' half-planes."""
    ea = edge_arrays(config, edges)
    nx, ny = (n[group, None, None] for n in ea.normal)
    tie_inside = (nx > 0) | ((nx == 0) & (ny > 0))
    xs = origin[group, 0, None, None] + np.arange(w)[None, None, :] - ea.x0[group, None, None]
    ys = origin[group, 1, None, None] + np.arange(h)[None, :, None] - ea.y0[group, None, None]

    def sample(jx: float, jy: float) -> np.ndarray:
        g = nx * (xs + jx) + ny * (ys + jy)
        return ((g > 0) | ((g == 0) & tie_inside)).astype(np.float64)

    return sample


def image_coverage(config: EdgeConfig, edges: list[Edge], pixels: PixelSet, name: str):
    """The image method's value at every pixel of the set, and the image pixels processed."""
    origin, size, used = _boxes(pixels, len(edges))
    bounds = edge_bounds(pixels.edge_index, len(edges))
    out = np.empty(len(pixels))
    processed = 0
    for group, w, h in _chunks(size, used):
        images = apply(name, half_plane_sampler(config, edges, group, origin, w, h))
        processed += images.size
        for i, k in enumerate(group):
            lo, hi = bounds[k], bounds[k + 1]
            px, py = pixels.x[lo:hi] - origin[k, 0], pixels.y[lo:hi] - origin[k, 1]
            out[lo:hi] = images[i, py, px]
    return out, processed


def run_method(
    config: EdgeConfig,
    edges: list[Edge],
    pixels: PixelSet,
    name: str,
    *,
    coverage: str = "model",
    jobs=None,
) -> MethodRun:
    """`evaluate.run_method`, extended to the methods of this module."""
    if name in msaa.PATTERNS:
        seconds, cov = timed(
            lambda: msaa.pattern_coverage(
                config, edges, pixels.edge_index, pixels.x, pixels.y, name
            )
        )
        return MethodRun(name, cov, seconds, len(pixels))
    if name in IMAGE_METHODS:
        seconds, (cov, processed) = timed(lambda: image_coverage(config, edges, pixels, name))
        return MethodRun(name, cov, seconds, processed)
    return evaluate.run_method(config, edges, pixels, name, coverage=coverage, jobs=jobs)
