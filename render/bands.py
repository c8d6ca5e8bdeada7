"""Bands of image rows: the model render's unit of work and memory (issue 28).

A render with skipping cuts the image into bands of whole rows. Each band's edges (those
whose write box, `render._write_boxes`, meets its rows) go to the engine clipped to the band's
rows, and their deltas are accumulated over the polygons' windows cut to the band and
composited into the band's pixels. So only one band's deltas and buffers exist at a time, and
bands share no pixel: they can be rendered in any order, or at once.

The image is the whole-image render's, bit for bit: the clip window cuts only the major axis
(docs/model.md 5.1), so a y-major edge steps exactly its rows in the band, each with the same
deltas as unclipped (the exact accumulator starts a clipped edge in the state the stepped one
reaches), and an x-major edge steps all its columns in every band it meets; the deltas outside
the band's rows are dropped, as the whole render drops those outside the image. Per pixel the
polygons are composited in the same order. The truncated accumulator's clipped start may
differ by its rounding (docs/model.md 5.1): there the image is one band.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

# Columns (states of the engine's loop) a band should step, about: a band's deltas and its
# accumulation's temporaries grow with its columns (the engine's own arrays do not: it takes a
# band in runs, `render.RUN_EDGES` and `RUN_COLUMNS`). 1 << 16 (before) held 2 to 5 MB more at
# the maps' peaks; 1 << 14 took 8 to 20 % more render time on the maps and pages (each band
# composites its polygons' waves again). A band is at least MIN_BAND_ROWS high (an x-major
# edge is stepped whole in every band it meets).
BAND_COLUMNS = 1 << 15
MIN_BAND_ROWS = 32


# Pixels around a band in which an edge's columns are still stepped: a column writes within
# two rows of its line (docs/model.md section 6), and a pixel more for the rounding.
CLIP_MARGIN = 4


@dataclass(frozen=True)
class Band:
    """Image rows y0 .. y1 - 1 and the scene edges (sent ones, in order) that can write there."""

    y0: int
    y1: int
    edges: np.ndarray


def band_rows(height: int, columns: int) -> int:
    """Rows per band for an image `height` rows high whose edges step about `columns`
    columns: about BAND_COLUMNS columns a band, at least MIN_BAND_ROWS rows."""
    count = max(1, math.ceil(columns / BAND_COLUMNS))
    return min(height, max(MIN_BAND_ROWS, math.ceil(height / count)))


def split_bands(height: int, rows: int, edges: np.ndarray, lo_y, hi_y) -> list[Band]:
    """The bands of `rows` rows (the last one shorter) of an image `height` rows high, each
    with the `edges` whose rows lo_y .. hi_y (image rows, inclusive, clamped to the image)
    meet it; an edge in every band it meets, in the order given."""
    if rows < 1:
        raise ValueError(f"a band has at least one row, not {rows}")
    first = np.clip(lo_y, 0, height - 1) // rows
    last = np.clip(hi_y, 0, height - 1) // rows
    spans = np.maximum(last - first + 1, 0)
    step = np.arange(spans.sum()) - np.repeat(np.cumsum(spans) - spans, spans)
    which = np.repeat(first, spans) + step
    order = np.argsort(which, kind="stable")  # by band, in the given order within one
    ids = np.repeat(np.asarray(edges), spans)[order]
    count = math.ceil(height / rows)
    bounds = np.searchsorted(which[order], np.arange(count + 1)).tolist()
    return [
        Band(k * rows, min((k + 1) * rows, height), ids[a:b])
        for k, (a, b) in enumerate(itertools.pairwise(bounds))
    ]


def band_columns(coords: np.ndarray, S: int, y_min: int, y_max: int):
    """Per edge (x0, y0, x1, y1 in sub-pixel units), the pixel columns lo .. hi (inclusive)
    where its line lies within rows y_min .. y_max (engine pixels) grown by CLIP_MARGIN, grown
    by CLIP_MARGIN too: an x-major edge clipped to them writes every delta it writes in those
    rows, so it is not stepped whole in every band it crosses. (The clip window cuts only
    the major axis: a y-major edge ignores these and is cut to the band's rows.)"""
    ax, ay, bx, by = (coords[:, k] for k in range(4))
    lo_y, hi_y = (y_min - CLIP_MARGIN) * S, (y_max + 1 + CLIP_MARGIN) * S
    dy = by - ay
    flat = dy == 0
    safe = np.where(flat, 1, dy)
    # x where the line meets y = lo_y and y = hi_y, floored (exact integers: no rounding)
    at = [ax + np.floor_divide((y - ay) * (bx - ax), safe) for y in (lo_y, hi_y)]
    left, right = np.minimum(ax, bx), np.maximum(ax, bx)
    lo = np.where(flat, left, np.clip(np.minimum(*at), left, right))
    hi = np.where(flat, right, np.clip(np.maximum(*at) + 1, left, right))
    return lo // S - CLIP_MARGIN, -(-hi // S) + CLIP_MARGIN


def narrow(values: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """`values`, all in [lo, hi], as int32 when that holds -max(|lo|, |hi|) - 1 .. max(|lo|,
    |hi|) (so abs and negation cannot wrap), else as they are (int64, or object arrays of
    wider values). Not narrower: the renderer computes pixel indices (y * width + x) and
    sums in the arrays' own type."""
    reach = max(-lo, hi, 0)
    if values.dtype == object or reach >= 1 << 31:
        return values
    return values.astype(np.int32, copy=False)
