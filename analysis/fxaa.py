"""FXAA in the 3.11 style, and the seed's variant with edges from geometry (seeds/002).

FXAA 3.11 "quality" (Lottes, NVIDIA 2011; described in its white paper and in the textbook
chapter, seeds/003), per pixel M with neighbours N, S, W, E and corners:

1. Local contrast: range = max - min of the luma of M, N, S, W, E; pixels with range below
   max(EDGE_THRESHOLD_MIN, EDGE_THRESHOLD * max) are left alone (the documented defaults
   0.0833 and 0.166).
2. Edge direction: horizontal when the vertical second differences of the three columns,
   weighted 1, 2, 1, outweigh the horizontal ones of the three rows.
3. Side: the neighbour across the edge (N or S for a horizontal edge) with the larger
   gradient; the edge's midline lies half a pixel towards it, where its luma is the mean
   of the two.
4. End search: along the midline both ways, with the steps of quality preset 12 (1, 1.5, 2,
   4, 12 px), until the midline's luma has moved from the mean by a quarter of the gradient.
5. Blend: a pixel closer to an end where the luma turns the right way (its sign test) is
   shifted towards the neighbour by 1/2 - distance / span length; the sub-pixel term
   (a low-pass of the 3 x 3 neighbourhood against the contrast, smoothed and squared,
   times SUBPIX = 0.75) sets a floor on the shift. The result is the bilinear sample at
   that shift: M + shift (neighbour - M).

The geometry variant (seeds/002) decides steps 1 to 4 from geometry instead of luma: a pixel
is processed when a 4-neighbour is owned by another object (the renderer knows which object
owns each pixel), and the direction, side and ends are found on the indicator "owned by the
same object as M" in place of luma. Only the blend uses the colours, so luma structure
inside an object (stripes, a hatch, highlights) is never blurred. The seed's own blend
formulas (its equations 7 to 11, a fixed 1/4 px offset scaled by a contrast term) are not
used: FXAA's end-distance offset is kept, so the two variants differ only in what they
call an edge.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

EDGE_THRESHOLD = 0.166
EDGE_THRESHOLD_MIN = 0.0833
SUBPIX = 0.75
SEARCH_STEPS = (1.0, 1.5, 2.0, 4.0, 12.0)  # quality preset 12

Sampler = Callable[[np.ndarray, np.ndarray], np.ndarray]  # (dy, dx) offsets -> values


def _gather(image: np.ndarray, b, y, x) -> Sampler:
    h, w = image.shape[-2:]

    def at(dy, dx):
        return image[b, np.clip(y + dy, 0, h - 1), np.clip(x + dx, 0, w - 1)]

    return at


def _same_object(ids: np.ndarray, b, y, x) -> Sampler:
    ids_at = _gather(ids, b, y, x)
    own = ids_at(0, 0)
    return lambda dy, dx: (ids_at(dy, dx) == own).astype(np.float64)


def _along(at: Sampler, horizontal, side, pos):
    """The midline's value at distance pos (fractional) along the edge: the mean of the pixel
    row (or column) and the one across the edge, linearly interpolated between pixels."""
    lo = np.floor(pos).astype(np.int64)
    frac = pos - lo
    out = 0.0
    for step, weight in ((lo, 1 - frac), (lo + 1, frac)):
        dy, dx = np.where(horizontal, 0, step), np.where(horizontal, step, 0)
        cy, cx = np.where(horizontal, side, 0), np.where(horizontal, 0, side)
        out = out + weight * (at(dy, dx) + at(dy + cy, dx + cx)) / 2
    return out


def _end_distance(at: Sampler, horizontal, side, mean, scaled, sign):
    """Distance to the end of the edge in direction sign (+1, -1), and the luma there minus
    the midline mean (FXAA's lumaEnd)."""
    dist = np.zeros(len(mean))
    end = np.zeros(len(mean))
    done = np.zeros(len(mean), dtype=bool)
    for step in SEARCH_STEPS:
        dist = np.where(done, dist, dist + step)
        value = _along(at, horizontal, side, sign * dist) - mean
        end = np.where(done, end, value)
        done |= np.abs(value) >= scaled
    return dist, end


def _subpix(at: Sampler, m, contrast):
    cross = at(-1, 0) + at(1, 0) + at(0, -1) + at(0, 1)
    corners = at(-1, -1) + at(-1, 1) + at(1, -1) + at(1, 1)
    low = (2 * cross + corners) / 12
    b = np.clip(np.abs(low - m) / np.maximum(contrast, 1e-12), 0, 1)
    return ((-2 * b + 3) * b * b) ** 2 * SUBPIX


def _direction(at: Sampler):
    """Horizontal-edge flag: FXAA's weighted second differences across rows and columns."""

    def second(d0, d1, e0, e1):
        return np.abs(at(d0, d1) + at(e0, e1) - 2 * at((d0 + e0) // 2, (d1 + e1) // 2))

    horz = second(-1, -1, 1, -1) + 2 * second(-1, 0, 1, 0) + second(-1, 1, 1, 1)
    vert = second(-1, -1, -1, 1) + 2 * second(0, -1, 0, 1) + second(1, -1, 1, 1)
    return horz >= vert


def _shift(at: Sampler, contrast):
    """Per pixel: edge direction, side (-1 towards N or W, +1 towards S or E) and the shift."""
    m = at(0, 0)
    horizontal = _direction(at)
    n = np.where(horizontal, at(-1, 0), at(0, -1))
    s = np.where(horizontal, at(1, 0), at(0, 1))
    grad_n, grad_s = np.abs(n - m), np.abs(s - m)
    pair_n = grad_n >= grad_s
    side = np.where(pair_n, -1, 1)
    mean = (m + np.where(pair_n, n, s)) / 2
    scaled = np.maximum(grad_n, grad_s) / 4
    dist_n, end_n = _end_distance(at, horizontal, side, mean, scaled, -1)
    dist_p, end_p = _end_distance(at, horizontal, side, mean, scaled, 1)
    m_below = (m - mean) < 0
    nearer_n = dist_n < dist_p
    # the end nearer the pixel must turn away from M's side of the mean (FXAA's goodSpan)
    good = np.where(nearer_n, (end_n < 0) != m_below, (end_p < 0) != m_below)
    offset = np.where(good, 0.5 - np.minimum(dist_n, dist_p) / (dist_n + dist_p), 0.0)
    return horizontal, side, np.maximum(offset, _subpix(at, m, contrast))


def _contrast(at: Sampler):
    values = np.stack([at(0, 0), at(-1, 0), at(1, 0), at(0, -1), at(0, 1)])
    return values.max(axis=0), values.max(axis=0) - values.min(axis=0)


def _geometry_edges(ids: np.ndarray) -> np.ndarray:
    padded = np.pad(ids, [(0, 0)] * (ids.ndim - 2) + [(1, 1), (1, 1)], mode="edge")
    centre = padded[..., 1:-1, 1:-1]
    return (
        (padded[..., :-2, 1:-1] != centre)
        | (padded[..., 2:, 1:-1] != centre)
        | (padded[..., 1:-1, :-2] != centre)
        | (padded[..., 1:-1, 2:] != centre)
    )


def fxaa(image: np.ndarray, ids: np.ndarray | None = None) -> np.ndarray:
    """FXAA of an image (..., H, W) of values in [0, 1] (the luma of a grey image). With ids
    (an object number per pixel, same shape): the geometry variant."""
    image = np.asarray(image, dtype=np.float64)
    if image.ndim == 2:
        return fxaa(image[None], None if ids is None else np.asarray(ids)[None])[0]
    if ids is None:
        b, y, x = np.nonzero(np.ones(image.shape, dtype=bool))
        top, contrast = _contrast(_gather(image, b, y, x))
        keep = contrast >= np.maximum(EDGE_THRESHOLD_MIN, top * EDGE_THRESHOLD)
        b, y, x = b[keep], y[keep], x[keep]
        at = _gather(image, b, y, x)
    else:
        b, y, x = np.nonzero(_geometry_edges(np.asarray(ids)))
        at = _same_object(np.asarray(ids), b, y, x)
    horizontal, side, offset = _shift(at, _contrast(at)[1])
    colour = _gather(image, b, y, x)
    m = colour(0, 0)
    other = np.where(horizontal, colour(side, 0), colour(0, side))
    out = image.copy()
    out[b, y, x] = m + offset * (other - m)
    return out
