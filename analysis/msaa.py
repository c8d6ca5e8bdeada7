"""MSAA sample patterns from the textbook chapter (seeds/003, section 5.4.2) beside `sampling`.

`sampling` holds the box-filtered patterns with one sample set per pixel (point, ordered grids,
the Direct3D standard 4x and 8x patterns as ``rgss4`` and ``rooks8``). This module adds the
patterns that need more than that:

- ``msaa2``: Direct3D's standard 2x pattern, (4, 4) and (-4, -4) in 1/16 px from the centre.
- ``quincunx``: five taps, the centre weighted 1/2 and the four pixel corners 1/8 each. A
  corner sample is shared by the four pixels that meet there, so a pixel stores 1 + 4/4 = 2
  samples. The weights approximate a tent filter; where an edge runs along a pixel boundary
  its corner samples lie on the edge and the tie rule gives them to one side, so a
  pixel-aligned square comes out blurred by 1/4 on two sides (the blur the chapter notes).
- ``flipquad``: the four RGSS samples pushed out onto the pixel's four edges, where each is
  shared with one neighbour (2 stored per pixel); every other pixel (x + y odd) uses the
  pattern mirrored in x so that the shared samples coincide. The chapter gives the
  construction, not the numbers: we put the samples at thirds of the edges, (-1/6, -1/2),
  (1/2, -1/6), (1/6, 1/2), (-1/2, 1/6) from the centre, so that the four x and the four y
  positions are equally spaced (-1/2, -1/6, 1/6, 1/2), as RGSS's are on its 4 x 4 grid.

Positions are kept in integer units of 1/48 px (48 = 16 * 3 holds the D3D 1/16 px grid and
the thirds), so the inside tests below are exact on vertices of the 2**-s px grid, like
those of `sampling`, and ties follow the same top-left rule.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import Edge, EdgeConfig
from .geometry import edge_arrays

UNITS = 48  # sample positions in 1/48 px


@dataclass(frozen=True)
class SamplePattern:
    """Sample offsets from the pixel centre in 1/UNITS px, their weights, whether pixels with
    x + y odd use the x-mirrored pattern, and the samples a pixel stores after sharing."""

    units: np.ndarray  # (n, 2) int
    weights: np.ndarray  # (n,) summing to 1
    mirrored: bool
    stored: float
    description: str

    @property
    def offsets(self) -> np.ndarray:
        return self.units / UNITS


def _pattern(units, weights=None, *, mirrored=False, stored=None, description=""):
    units = np.array(units, dtype=np.int64)
    n = len(units)
    weights = np.full(n, 1.0 / n) if weights is None else np.array(weights, dtype=np.float64)
    return SamplePattern(
        units, weights, mirrored, float(n if stored is None else stored), description
    )


CORNERS = [(-24, -24), (24, -24), (-24, 24), (24, 24)]
PATTERNS: dict[str, SamplePattern] = {
    "msaa2": _pattern([(12, 12), (-12, -12)], description="MSAA 2x, D3D standard positions"),
    "quincunx": _pattern(
        [(0, 0), *CORNERS],
        [1 / 2, 1 / 8, 1 / 8, 1 / 8, 1 / 8],
        stored=2,
        description="quincunx: centre 1/2, shared corners 1/8 each",
    ),
    "flipquad": _pattern(
        [(-8, -24), (24, -8), (8, 24), (-24, 8)],
        mirrored=True,
        stored=2,
        description="FLIPQUAD: RGSS on the pixel edges, shared, mirrored every other pixel",
    ),
}


def pixel_units(pattern: SamplePattern, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """(pixels, n, 2) sample offsets in 1/UNITS px for pixels (xs, ys) (mirrored on odd)."""
    units = np.broadcast_to(pattern.units, (len(xs), *pattern.units.shape)).copy()
    if pattern.mirrored:
        odd = ((np.asarray(xs) + np.asarray(ys)) & 1).astype(bool)
        units[odd, :, 0] *= -1
    return units


def pattern_coverage(
    config: EdgeConfig,
    edges: list[Edge],
    edge_index: np.ndarray,
    xs: np.ndarray,
    ys: np.ndarray,
    pattern: str | SamplePattern,
) -> np.ndarray:
    """Weighted fraction of the pattern's samples inside the edge's half-plane, for pixels
    (xs[i], ys[i]) of edge edge_index[i]; the top-left tie rule of `sampling`."""
    pattern = PATTERNS[pattern] if isinstance(pattern, str) else pattern
    ea = edge_arrays(config, edges)
    nx, ny = ea.normal
    tie_inside = (nx > 0) | ((nx == 0) & (ny > 0))
    e = np.asarray(edge_index)
    xs, ys = np.asarray(xs, dtype=np.int64), np.asarray(ys, dtype=np.int64)
    units = pixel_units(pattern, xs, ys).astype(np.float64)
    # Everything times UNITS: integers and dyadic vertices, so the products are exact.
    cx = (xs - ea.x0[e]) * UNITS
    cy = (ys - ea.y0[e]) * UNITS
    g = nx[e, None] * (cx[:, None] + units[:, :, 0]) + ny[e, None] * (cy[:, None] + units[:, :, 1])
    inside = (g > 0) | ((g == 0) & tie_inside[e, None])
    return inside @ pattern.weights
