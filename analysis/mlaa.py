"""Morphological antialiasing (MLAA), plain and with the seed's slope-predicted endpoints.

MLAA (Reshetov 2009, as summarised in seeds/000 section 1 and the textbook chapter,
seeds/003) post-processes an aliased image in three steps: (1) find edges between pixels
whose values differ by more than a threshold; (2) for each horizontal run of edge, search
left and right (up to MAX_SEARCH pixels) for its ends and look at the crossing edges there,
which classify the run as an L, Z or U shape, reconstruct the edge as a line and take, per
pixel, the area between that line and the pixel boundary as the blend weight; (3) blend each
pixel with its neighbour across the edge by that weight. Vertical runs are the same on the
transposed image.

Heights are measured up from the run's pixel boundary, in pixels. A crossing edge in the row
above the run at an end puts the line at +1/2 there (the midpoint of the step), one in the
row below at -1/2, none (or both) at 0. The line over a run of length T (ends at t = 0 and
t = T): Z (opposite signs) and L (one end 0) are straight from end to end; U (same sign) is
two straight pieces meeting at height 0 in the middle. Over the pixel column [d, d + 1] the
positive part of the height is the fraction of the pixel above the boundary that lies on the
lower side of the line (it takes the lower pixel's value), the negative part the same for
the pixel below. `area_table` precomputes these two areas for every (left height, right
height, distance to the left end, distance to the right end): the area table of
docs/aa_methods.md.

A pixel can lie beside a horizontal and a vertical run; as seeds/000 section 2.2 does, the
longer run decides which direction the pixel is blended in (both when equal), so the short
one-pixel steps of a shallow staircase do not blend its corner pixels twice.

Slope prediction (seeds/000, section 2.2, "algorithm implementation"): the widths of the
steps of one digital straight line take at most two values, L and L + 1 (its theorem 1).
For a Z run of width L the search looks for the next step end at distance L, then L - 1,
then L + 1 beyond the run's end, one row further in the crossing's direction, with the same
pattern there (the run ends and the crossing is on the same side); once a width L' != L has
been seen only L and L' are tried. Up to PREDICT_STEPS steps each way. The run's line then
joins the midpoints of the outermost steps found, so it follows the long line instead of
the local step (the seed's B -> B').
"""

from __future__ import annotations

import numpy as np

MAX_SEARCH = 16  # pixels searched each way along a run
THRESHOLD = 0.1  # an edge where neighbouring values differ by more than this (full scale 1)
PREDICT_STEPS = 4  # the seed's loop bound N

H_VALUES = np.array([-0.5, 0.0, 0.5])  # crossing codes 0, 1, 2


def positive_area(h0, h1, width=1.0):
    """Integral of max(h, 0) over an interval of `width` where h is linear from h0 to h1."""
    h0, h1 = np.asarray(h0, dtype=np.float64), np.asarray(h1, dtype=np.float64)
    crossing = h0 * h1 < 0
    with np.errstate(divide="ignore", invalid="ignore"):
        tri = np.maximum(h0, h1) ** 2 / (2 * np.abs(h0 - h1))
    return width * np.where(crossing, tri, (np.maximum(h0, 0) + np.maximum(h1, 0)) / 2)


def _line_height(hl, hr, t, total):
    """Height of the reconstructed line at t in [0, total] (L, Z straight; U with a kink)."""
    u_shape = (hl * hr) > 0
    straight = hl + (hr - hl) * t / total
    return np.where(u_shape, hl * np.abs(1 - 2 * t / total), straight)


def pixel_areas(hl, hr, dl, dr):
    """(above, below): areas of the pixel column at distance dl from the left end of a run
    of length dl + dr + 1 taken from the other side, for end heights hl, hr."""
    total = dl + dr + 1.0
    a, b = dl.astype(np.float64), dl + 1.0
    mid = np.clip(total / 2, a, b)
    h_a, h_m, h_b = (_line_height(hl, hr, t, total) for t in (a, mid, b))
    above = positive_area(h_a, h_m, mid - a) + positive_area(h_m, h_b, b - mid)
    below = positive_area(-h_a, -h_m, mid - a) + positive_area(-h_m, -h_b, b - mid)
    return above, below


def area_table(max_search: int = MAX_SEARCH) -> np.ndarray:
    """AREA[code_left, code_right, dl, dr, side]: side 0 the pixel above the run, 1 below."""
    cl, cr, dl, dr = np.meshgrid(
        np.arange(3),
        np.arange(3),
        np.arange(max_search + 1),
        np.arange(max_search + 1),
        indexing="ij",
    )
    above, below = pixel_areas(H_VALUES[cl], H_VALUES[cr], dl, dr)
    return np.stack([above, below], axis=-1)


AREA = area_table()


# -- step 1: edges and runs ---------------------------------------------------------------------


def edges_below(image: np.ndarray, threshold: float) -> np.ndarray:
    """E[..., j, x]: an edge between rows j and j + 1 in column x, shape (..., H - 1, W)."""
    return np.abs(np.diff(image, axis=-2)) > threshold


def edges_left(image: np.ndarray, threshold: float) -> np.ndarray:
    """V[..., r, c]: an edge between columns c - 1 and c of row r, shape (..., H, W + 1); the
    image's outer sides have none (the image is clamped at its border)."""
    inner = np.abs(np.diff(image, axis=-1)) > threshold
    pad = np.zeros((*image.shape[:-1], 1), dtype=bool)
    return np.concatenate([pad, inner, pad], axis=-1)


def run_distances(e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each cell, the number of consecutive set cells to its left and to its right."""
    n = e.shape[-1]
    idx = np.arange(n)
    last_gap = np.maximum.accumulate(np.where(e, -1, idx), axis=-1)
    next_gap = np.flip(np.minimum.accumulate(np.flip(np.where(e, n, idx), -1), axis=-1), -1)
    return idx - last_gap - 1, next_gap - idx - 1


def _take(a: np.ndarray, cols: np.ndarray) -> np.ndarray:
    return np.take_along_axis(a, cols, axis=-1)


def end_heights(e, v, max_search):
    """Per edge cell: distances to the run's ends (capped) and the line's height at each end
    (+1/2 crossing above, -1/2 below, 0 none, both, or end beyond the search)."""
    dl, dr = run_distances(e)
    x = np.arange(e.shape[-1])
    found_l, found_r = dl <= max_search, dr <= max_search
    dl, dr = np.minimum(dl, max_search), np.minimum(dr, max_search)
    xl = np.clip(x - dl, 0, e.shape[-1] - 1)
    xr1 = np.clip(x + dr + 1, 0, e.shape[-1])
    upper, lower = v[..., :-1, :], v[..., 1:, :]  # rows j and j + 1 of boundary j
    hl = 0.5 * (_take(upper, xl).astype(int) - _take(lower, xl)) * found_l
    hr = 0.5 * (_take(upper, xr1).astype(int) - _take(lower, xr1)) * found_r
    return dl, dr, hl, hr


# -- slope prediction (seeds/000) ----------------------------------------------------------------


def _step_end(e, v, b, j, c, up):
    """Whether boundary j ends a run at column c with its crossing on the `up` side only."""
    n_rows, n_cols = e.shape[-2], e.shape[-1]
    ok = (j >= 0) & (j < n_rows) & (c >= 0) & (c < n_cols)
    jj, cc = np.clip(j, 0, n_rows - 1), np.clip(c, 0, n_cols - 1)
    nxt = np.clip(cc + 1, 0, n_cols - 1)
    ends = e[b, jj, cc] & ((cc + 1 >= n_cols) | ~e[b, jj, nxt])
    above, below = v[b, jj, cc + 1], v[b, jj + 1, cc + 1]
    side = np.where(up, above & ~below, below & ~above)
    return ok & ends & side


def extend_right(e, v, b, j, xr, width, up, steps=PREDICT_STEPS):
    """The seed's search: (steps found, pixels added) beyond a Z run's right end. e, v are
    (B, H - 1, W) and (B, H, W + 1); b, j, xr, width, up are per-run arrays."""
    d = np.where(up, -1, 1)
    pos, row = xr.copy(), j.copy()
    count, other = np.zeros_like(xr), np.zeros_like(xr)  # other: the second width, 0 unknown
    active = np.ones(len(xr), dtype=bool)
    for _ in range(steps):
        tries = [width, np.where(other > 0, other, width - 1), np.where(other > 0, 0, width + 1)]
        hit = np.zeros(len(xr), dtype=np.int64)
        for w in tries:
            found = active & (hit == 0) & (w > 0) & _step_end(e, v, b, row + d, pos + w, up)
            hit = np.where(found, w, hit)
        active &= hit > 0
        other = np.where(active & (other == 0) & (hit != width), hit, other)
        pos, row = pos + hit, row + np.where(active, d, 0)
        count += active
    return count, pos - xr


def predicted_areas(e, v, dl, dr, hl, hr, steps=PREDICT_STEPS):
    """(above, below) areas for every edge cell, Z runs' lines extended by slope prediction."""
    above, below = AREA[_code(hl), _code(hr), dl, dr].transpose(-1, *range(e.ndim))
    # Z runs of width 2 or more: a width-1 run lies along the minor axis of a line at 45
    # degrees or steeper, whose steps there are not one row each (the seed's theorem is about
    # the runs along the major axis)
    z = e & (hl * hr < 0) & (dl + dr >= 1)
    b, j, x = np.nonzero(z)
    if len(b) == 0:
        return above, below
    width = dl[z] + dr[z] + 1
    up_r, up_l = hr[z] > 0, hl[z] > 0
    n_r, ext_r = extend_right(e, v, b, j, x + dr[z], width, up_r, steps)
    n_cols = e.shape[-1]
    flip_e, flip_v = np.flip(e, -1), np.flip(v, -1)
    n_l, ext_l = extend_right(flip_e, flip_v, b, j, n_cols - 1 - (x - dl[z]), width, up_l, steps)
    # the line from the outermost step midpoints; the pixel spans [dl, dl + 1] of the run
    t0, t1 = -ext_l.astype(float), width + ext_r.astype(float)
    h0, h1 = hl[z] * (1 + 2 * n_l), hr[z] * (1 + 2 * n_r)
    slope = (h1 - h0) / (t1 - t0)
    ha, hb = h0 + slope * (dl[z] - t0), h0 + slope * (dl[z] + 1 - t0)
    above[z], below[z] = positive_area(ha, hb), positive_area(-ha, -hb)
    return above, below


def _code(h: np.ndarray) -> np.ndarray:
    return (np.sign(h) + 1).astype(np.int64)


# -- steps 2 and 3: weights and blend ------------------------------------------------------------


def horizontal_weights(image, threshold, max_search, predict):
    """Per pixel: weight taken from the pixel below, from the pixel above, and the longest run
    among the horizontal edges beside it (0: none)."""
    e, v = edges_below(image, threshold), edges_left(image, threshold)
    dl, dr, hl, hr = end_heights(e, v, max_search)
    if predict:
        above, below = predicted_areas(e, v, dl, dr, hl, hr, predict)
    else:
        above, below = AREA[_code(hl), _code(hr), dl, dr].transpose(-1, *range(e.ndim))
    above, below = np.where(e, above, 0.0), np.where(e, below, 0.0)
    length = np.where(e, dl + dr + 1, 0)
    pad = np.zeros((*image.shape[:-2], 1, image.shape[-1]))
    from_below = np.concatenate([above, pad], axis=-2)  # row j takes from row j + 1
    from_above = np.concatenate([pad, below], axis=-2)
    run = np.maximum(np.concatenate([length, pad], -2), np.concatenate([pad, length], -2))
    return from_below, from_above, run


def mlaa(
    image: np.ndarray,
    *,
    threshold: float = THRESHOLD,
    max_search: int = MAX_SEARCH,
    predict: int = 0,
) -> np.ndarray:
    """MLAA of an image (..., H, W) of values in [0, 1]; predict > 0: slope prediction with
    that many steps each way."""
    image = np.asarray(image, dtype=np.float64)
    if image.ndim == 2:  # the per-run search indexes (batch, row, column)
        return mlaa(image[None], threshold=threshold, max_search=max_search, predict=predict)[0]
    below, above, run_h = horizontal_weights(image, threshold, max_search, predict)
    t = np.swapaxes(image, -1, -2)
    right, left, run_v = (
        np.swapaxes(a, -1, -2) for a in horizontal_weights(t, threshold, max_search, predict)
    )
    use_h, use_v = run_h >= run_v, run_v >= run_h
    padded = np.pad(image, [(0, 0)] * (image.ndim - 2) + [(1, 1), (1, 1)], mode="edge")
    n_above, n_below = padded[..., :-2, 1:-1], padded[..., 2:, 1:-1]
    n_left, n_right = padded[..., 1:-1, :-2], padded[..., 1:-1, 2:]
    delta = use_h * (below * (n_below - image) + above * (n_above - image))
    delta += use_v * (right * (n_right - image) + left * (n_left - image))
    return image + delta
