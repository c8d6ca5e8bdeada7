"""Sample-based coverage baselines: the screen-based antialiasing of the textbook chapter.

Each method places n point samples in a pixel and reports the fraction inside the edge's
half-plane (uniform weights w_i = 1/n, a box filter over the pixel: Real-Time Rendering,
4th ed., section 5.4.2, the chapter in seeds/003):

- ``point``: one sample at the pixel centre: no antialiasing, coverage 0 or 1.
- ``grid2`` .. ``grid16``: ordered n x n grid, samples at the centres of the n x n
  sub-cells (supersampling, SSAA / accumulation buffer).
- ``rgss4``: the 4-sample rotated grid (RGSS), one sample in each row and column of a 4 x 4
  sub-grid. Positions: Direct3D's standard 4x pattern, (-2, -6), (6, -2), (-6, 2), (2, 6)
  in 1/16 px from the centre.
- ``rooks8``: an 8-rooks pattern, one sample in each row and column of an 8 x 8 sub-grid,
  spread so that no diagonal holds them all. Positions: Direct3D's standard 8x pattern,
  (1, -3), (-1, 3), (5, 1), (-3, -5), (-5, 5), (-7, -1), (3, 7), (7, -7) in 1/16 px.

A sample exactly on the edge's line counts as inside when the inside normal points to +x,
or straight down (+y): the half-plane form of the top-left fill rule of GPUs. The tests
are exact (see `geometry`), so ties are really ties.
"""

from __future__ import annotations

import numpy as np

from ..model import Edge, EdgeConfig
from .geometry import edge_arrays


def _grid(n: int) -> np.ndarray:
    centres = (np.arange(n) + 0.5) / n - 0.5
    xs, ys = np.meshgrid(centres, centres, indexing="xy")
    return np.stack([xs.ravel(), ys.ravel()], axis=1)


PATTERNS: dict[str, np.ndarray] = {
    "point": np.zeros((1, 2)),
    "grid2": _grid(2),
    "grid4": _grid(4),
    "grid8": _grid(8),
    "grid16": _grid(16),
    "rgss4": np.array([(-2, -6), (6, -2), (-6, 2), (2, 6)], dtype=np.float64) / 16,
    "rooks8": np.array(
        [(1, -3), (-1, 3), (5, 1), (-3, -5), (-5, 5), (-7, -1), (3, 7), (7, -7)],
        dtype=np.float64,
    )
    / 16,
}

DESCRIPTIONS = {
    "point": "1 sample at the pixel centre (no antialiasing)",
    "grid2": "ordered grid 2x2 (4 samples)",
    "grid4": "ordered grid 4x4 (16 samples)",
    "grid8": "ordered grid 8x8 (64 samples)",
    "grid16": "ordered grid 16x16 (256 samples)",
    "rgss4": "rotated grid, 4 samples (D3D standard 4x)",
    "rooks8": "8-rooks, 8 samples (D3D standard 8x)",
}

CHUNK_ELEMENTS = 1 << 22  # pixel x sample comparisons per numpy pass


def sample_coverage(
    config: EdgeConfig,
    edges: list[Edge],
    edge_index: np.ndarray,
    xs: np.ndarray,
    ys: np.ndarray,
    pattern: str | np.ndarray,
) -> np.ndarray:
    """Fraction of a pattern's samples inside the edge, for pixels (xs[i], ys[i]) of edge
    edge_index[i]. pattern: a name of PATTERNS or an (n, 2) array of offsets in pixels."""
    offsets = PATTERNS[pattern] if isinstance(pattern, str) else np.asarray(pattern, float)
    ea = edge_arrays(config, edges)
    nx, ny = ea.normal
    # Ties (a sample on the line): inside when the inside normal points to +x, or to +y.
    tie_inside = (nx > 0) | ((nx == 0) & (ny > 0))
    xs, ys = np.asarray(xs, dtype=np.float64), np.asarray(ys, dtype=np.float64)
    e = np.asarray(edge_index)
    out = np.empty(len(e), dtype=np.float64)
    step = max(1, CHUNK_ELEMENTS // len(offsets))
    for lo in range(0, len(e), step):
        sl = slice(lo, lo + step)
        ee = e[sl]
        pnx, pny = nx[ee], ny[ee]
        centre = pnx * (xs[sl] - ea.x0[ee]) + pny * (ys[sl] - ea.y0[ee])
        g = centre[:, None] + (
            pnx[:, None] * offsets[None, :, 0] + pny[:, None] * offsets[None, :, 1]
        )
        inside = (g > 0) | ((g == 0) & tie_inside[ee][:, None])
        out[sl] = inside.mean(axis=1)
    return out
