"""Exact integer geometry of the renderer: winding numbers, fill-rule sides, sample masks.

Every coordinate here is an integer (sub-pixel units, or a finer integer grid), so each test
is exact. Points that may lie exactly on an edge are moved by a symbolic perturbation
(simulation of simplicity): a point P + e1 v1 + e2 v2 with 0 < e2 << e1 << 1, whose tests are
decided lexicographically. No tie is ever left undecided, and the same point gets the same
answer from every test that uses the same perturbation.

- Sample points (pixel centres, supersampling points) use P + (e1, e2): nudged right, then
  down. The scanline fill's half-open rule (an edge counts on the rows y with
  min(y0, y1) <= y < max(y0, y1); a sample counts a crossing at x_c when x >= x_c) is this
  perturbation, and `halfplane_samples` uses it too, so an edge's centre sample and the
  polygon's centre sample agree.
- The side of an edge is judged at its midpoint M moved by e1 (+-n) + e2 d, n = (dy, -dx)
  the left normal on the image (y down), d = (dx, dy) the direction.
"""

from __future__ import annotations

from itertools import groupby
from operator import itemgetter

import numpy as np

CHUNK = 1 << 15  # point x edge pairs per numpy pass (about 3 MB of temporaries: 1 << 18 was
# 25 MB, in one polygon of many pairs too; 1 << 20 was no faster on the 4,000-glyph page)


def fills(winding: np.ndarray, rule: str) -> np.ndarray:
    """Whether a winding number is inside by the fill rule."""
    if rule == "evenodd":
        return (winding & 1) == 1
    return winding != 0


def _lex_sign(*terms: np.ndarray) -> np.ndarray:
    """Sign of t0 + e1 t1 + e2 t2 + ...: the sign of the first nonzero term."""
    out = np.sign(terms[0])
    for term in terms[1:]:
        out = np.where(out == 0, np.sign(term), out)
    return out


def winding_numbers(
    edges: np.ndarray, points: np.ndarray, first: np.ndarray, second: np.ndarray
) -> np.ndarray:
    """Winding number of each perturbed point P + e1 first + e2 second about closed contours.

    edges: (E, 4) int64 rows x0 y0 x1 y1; points, first, second: (P, 2) int64. The crossing
    rule is Sunday's (a ray to +x; an upward crossing with P left of the edge counts +1, a
    downward one with P right of it -1), decided exactly with the perturbation. first and
    second must not both be parallel to any edge and (first_y, second_y) != (0, 0).

    Only an edge whose closed y range holds P's y can count, so only those pairs are tested
    (`_stabbing_pairs`): the work is the sum over the points of the edges met by a short
    horizontal band around each, not P x E.
    """
    return _windings(edges, points, [(first, second)])[0]


def _windings(edges: np.ndarray, points: np.ndarray, perturbations) -> list[np.ndarray]:
    """`winding_numbers` of the same points under several perturbations (first, second),
    from one search for the pairs. Only a pair where P is on the edge's line or on the row
    of one of its ends (a tie) depends on the perturbation: the others are decided once,
    and the perturbed test runs on each chunk's ties as they come (kept to the end, the
    ties of a page of text were 10 MiB of temporaries at the plan's peak)."""
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 4)
    points = np.asarray(points, dtype=np.int64).reshape(-1, 2)
    ax, ay, bx, by = (edges[:, i].copy() for i in range(4))
    ex, ey = bx - ax, by - ay
    px, py = points[:, 0].copy(), points[:, 1].copy()
    n = len(points)
    steps = [
        tuple(np.broadcast_to(np.asarray(v, dtype=np.int64), points.shape) for v in pair)
        for pair in perturbations
    ]
    ups, downs = [[] for _ in steps], [[] for _ in steps]  # the points of crossing pairs
    for q, e in _stabbing_pairs(np.minimum(ay, by), np.maximum(ay, by), py):
        y = py[q]
        above_a, above_b = ay[e] - y, by[e] - y  # > 0: the end is below P on the image
        t0 = ex[e] * (y - ay[e]) - (px[q] - ax[e]) * ey[e]
        tie = (above_a == 0) | (above_b == 0) | (t0 == 0)
        up = (above_a < 0) & (above_b > 0) & (t0 > 0)  # never a tie: every term nonzero
        down = (above_a > 0) & (above_b < 0) & (t0 < 0)
        common = q[up], q[down]
        q, e, t0 = q[tie], e[tie], t0[tie]
        for k, (first, second) in enumerate(steps):
            v1x, v1y, v2x, v2y = first[q, 0], first[q, 1], second[q, 0], second[q, 1]
            sy = _lex_sign(v1y, v2y)  # the point's y moves up (-) or down (+) from py
            y, ex_, ey_ = py[q], ex[e], ey[e]
            a_le = (ay[e] < y) | ((ay[e] == y) & (sy > 0))  # a.y <= P.y
            b_gt = (by[e] > y) | ((by[e] == y) & (sy < 0))  # b.y > P.y
            left = _lex_sign(t0, ex_ * v1y - v1x * ey_, ex_ * v2y - v2x * ey_)
            ups[k] += [common[0], q[a_le & b_gt & (left > 0)]]
            downs[k] += [common[1], q[~a_le & ~b_gt & (left < 0)]]
    empty = np.zeros(0, dtype=np.int64)
    return [
        np.bincount(np.concatenate([empty, *up]), minlength=n)
        - np.bincount(np.concatenate([empty, *down]), minlength=n)
        for up, down in zip(ups, downs, strict=True)
    ]


BAND = 32  # points per horizontal band of `_stabbing_pairs`


def _stabbing_pairs(lo: np.ndarray, hi: np.ndarray, ys: np.ndarray):
    """Yield (point, interval) index arrays, about CHUNK pairs at a time, for every point y
    and interval [lo, hi] with lo <= y <= hi (and some pairs that fail it, filtered out).

    The points sorted by y are cut into bands of BAND points; an interval goes to every band
    its y range meets, and is paired with that band's points. Each point is in one band, so
    no pair comes twice. The pairs are the intervals meeting each band times its points:
    O(P log P + sum of the bands each interval spans + the pairs kept)."""
    if not len(ys) or not len(lo):
        return
    order = np.argsort(ys, kind="stable")
    sorted_y = ys[order]
    starts = np.arange(0, len(ys), BAND)
    bottom = sorted_y[starts]  # each band's lowest y
    size = np.diff(np.append(starts, len(ys)))
    # from the last band starting below lo (its top may reach lo; equal ys span bands)
    first = np.maximum(np.searchsorted(bottom, lo, side="left") - 1, 0)
    last = np.searchsorted(bottom, hi, side="right") - 1
    keep = last >= first
    spans = np.where(keep, last - first + 1, 0)
    edge = np.repeat(np.arange(len(lo)), spans)
    band = (
        np.repeat(first, spans) + np.arange(len(edge)) - np.repeat(np.cumsum(spans) - spans, spans)
    )
    by_band = np.argsort(band, kind="stable")
    edge, band = edge[by_band], band[by_band]
    count = size[band]
    cum = np.cumsum(count)
    i0 = 0
    while i0 < len(edge):
        i1 = max(i0 + 1, int(np.searchsorted(cum, cum[i0] - count[i0] + CHUNK, side="right")))
        c = count[i0:i1]
        e = np.repeat(edge[i0:i1], c)
        k = np.repeat(starts[band[i0:i1]], c) + np.arange(len(e)) - np.repeat(np.cumsum(c) - c, c)
        y = sorted_y[k]
        hit = (lo[e] <= y) & (y <= hi[e])
        yield order[k[hit]], e[hit]
        i0 = i1


def side_fills(
    edges: np.ndarray, rule: str | np.ndarray, group: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Whether the fill covers the side just left and just right of each edge's midpoint.

    Left is the left of travel on the image (y down): the side of the normal (dy, -dx). The
    winding numbers count every contour of the polygon, so holes, overlapping contours and
    self-intersections are judged by the fill rule.

    Several polygons at once: `group` numbers each edge's polygon (0, 1, ...) and `rule` is
    then one per edge (an array of 'nonzero' and 'evenodd'). Polygon g is moved down by g
    times the edges' height plus one, so the polygons' y ranges are disjoint and the winding
    numbers (only ever differences of coordinates within a polygon) count its own edges.
    """
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 4)
    if group is not None and len(edges):
        edges = edges.copy()
        edges[:, 1::2] += _group_shift(edges[:, 1::2], group)
    doubled = 2 * edges
    mid = edges[:, 0:2] + edges[:, 2:4]  # the midpoint, doubled
    d = edges[:, 2:4] - edges[:, 0:2]
    normal = np.stack([d[:, 1], -d[:, 0]], axis=1)
    left = np.zeros(len(edges), dtype=np.int64)
    right = np.zeros(len(edges), dtype=np.int64)
    swept = _swept(edges, group)  # polygons whose banded pairs would be too many
    band = ~swept  # the polygons' y ranges are disjoint: each part counts its own edges
    band = slice(None) if band.all() else band  # all of them: views, not five copies
    left[band], right[band] = _windings(
        doubled[band], mid[band], [(normal[band], d[band]), (-normal[band], d[band])]
    )
    if swept.any():
        k = len(np.flatnonzero(swept))
        points = np.concatenate([mid[swept]] * 2)
        first = np.concatenate([normal[swept], -normal[swept]])
        second = np.concatenate([d[swept]] * 2)
        w = _sweep_sides(doubled[swept], points, first, second)
        left[swept], right[swept] = w[:k], w[k:]
    if isinstance(rule, str):
        return fills(left, rule), fills(right, rule)
    odd = np.asarray(rule) == "evenodd"
    return tuple(np.where(odd, fills(w, "evenodd"), fills(w, "nonzero")) for w in (left, right))


def _sweep_sides(edges: np.ndarray, points, first, second) -> np.ndarray:
    """`winding_numbers` of the perturbed points for noded edges (none crosses or touches
    another's interior), from the sweep's first edge east of each point (`_first_east`):
    the point's face is the face just west of that edge, whose winding number is the face's
    just east of it plus the edge's and its coincident copies' crossings (+1 down, -1 up);
    and the face just east of an edge is the face of its own east midpoint query when that
    is among the points. So each point's winding number is a sum along a chain of points,
    taken by pointer doubling: O(P log P) in numpy after the sweep's O((E + P) log E).

    The points must be the edges' midpoints perturbed to both sides, as `side_fills` makes
    them: first the east or west of edge k for k < E, then the other side (E + k)."""
    n = len(edges)
    east_of = _first_east(edges.tolist(), points.tolist(), first.tolist(), second.tolist())
    h = np.array(east_of, dtype=np.int64)
    swap = (edges[:, 0] > edges[:, 2]) | (
        (edges[:, 0] == edges[:, 2]) & (edges[:, 1] > edges[:, 3])
    )
    canon = np.where(swap[:, None], edges[:, [2, 3, 0, 1]], edges)
    _, cls = np.unique(canon, axis=0, return_inverse=True)
    cls = cls.reshape(-1)
    step = np.bincount(cls, weights=np.sign(edges[:, 3] - edges[:, 1])).astype(np.int64)
    # the query on the east of edge k: the first (M + e1 n, n = (dy, -dx)) when dy > 0
    east = np.where(first[:n, 0] > 0, np.arange(n), n + np.arange(n))
    found = h >= 0
    nxt = np.where(found, east[np.maximum(h, 0)], -1)
    w = np.where(found, step[cls[np.maximum(h, 0)]], 0)
    for _ in range(64):
        more = nxt >= 0
        if not more.any():
            return w
        w = w + np.where(more, w[np.maximum(nxt, 0)], 0)
        nxt = np.where(more, nxt[np.maximum(nxt, 0)], -1)
    raise RuntimeError("the sweep's chain of faces did not end (a bug: please report)")


SWEEP_PAIRS = 64  # level pairs per edge past which a polygon's sides come from the sweep


def _sign(v: int) -> int:
    return (v > 0) - (v < 0)


def _low_ends(edges: list) -> list[tuple[int, int, int, int]]:
    """Each edge as its low end (x, y) and its direction (dx, dy) from there, dy >= 0."""
    return [
        (ax, ay, bx - ax, by - ay) if ay < by else (bx, by, ax - bx, ay - by)
        for ax, ay, bx, by in edges
    ]


def _place(active: list, low: list, x: int, y: int, dx: int, dy: int, s: int) -> int:
    """Where the line through (x, y) of direction (dx, dy > 0) goes in `active` (edges in x
    order at row y + s e, e > 0 infinitesimal): before the first edge it is not east of."""
    a, b = 0, len(active)
    while a < b:
        m = (a + b) >> 1
        fx, fy, fdx, fdy = low[active[m]]
        c = (x - fx) * fdy - (y - fy) * fdx  # its x at row y against f's, times fdy > 0
        if c < 0 or (c == 0 and s * (dx * fdy - fdx * dy) <= 0):  # then by slope
            b = m
        else:
            a = m + 1
    return a


def _remove(active: list, low: list, k: int, y: int) -> int:
    """Take edge k out of `active` at its high end's row y (the order at row y - e); its
    index. Among the edges equal to it there, found by identity."""
    x, _, dx, dy = low[k]
    i = _place(active, low, x + dx, y, dx, dy, -1)
    while i < len(active) and active[i] != k:
        i += 1
    if i == len(active):  # only if the order was broken by edges that cross
        i = active.index(k)
    del active[i]
    return i


def _first_east(edges: list, points: list, first: list, second: list) -> list[int]:
    """Per perturbed point, the first edge its ray to +x crosses (-1 if none), by a sweep
    down the rows: the edges that cross a row, kept in x order in a list, each point located
    among them by binary search with the exact test of `winding_numbers`. The order of two
    edges never changes along the rows only while no edge crosses or touches another's
    interior (noded edges, as the plan's are). O((E + P) log E) comparisons."""
    events: dict[int, list] = {}  # y: points above it, edges ending, starting, points below
    for k, (_, ay, _, by) in enumerate(edges):
        if ay != by:
            events.setdefault(max(ay, by), [[], [], [], []])[1].append(k)
            events.setdefault(min(ay, by), [[], [], [], []])[2].append(k)
    for q, (p, v1, v2) in enumerate(zip(points, first, second, strict=True)):
        below = (v1[1] or v2[1]) > 0  # the point moves down (+y) from its row
        events.setdefault(p[1], [[], [], [], []])[3 if below else 0].append(q)
    low = _low_ends(edges)
    active: list[int] = []
    out = [-1] * len(points)

    def locate(q: int) -> None:
        (px, py), (v1x, v1y), (v2x, v2y) = points[q], first[q], second[q]
        a, b = 0, len(active)
        while a < b:
            m = (a + b) >> 1
            ax, ay, bx, by = edges[active[m]]
            ex, ey = bx - ax, by - ay
            t = ex * (py - ay) - (px - ax) * ey or ex * v1y - v1x * ey or ex * v2y - v2x * ey
            if _sign(t) * _sign(ey) > 0:  # the point is west of this edge
                b = m
            else:
                a = m + 1
        if a < len(active):
            out[q] = active[a]

    for y in sorted(events):
        above, ending, starting, below = events[y]
        for q in above:
            locate(q)
        for k in ending:
            _remove(active, low, k, y)
        for k in starting:
            x, _, dx, dy = low[k]
            active.insert(_place(active, low, x, y, dx, dy, 1), k)
        for q in below:
            locate(q)
    return out


def _sweep_neighbours(seg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every pair of edges that are ever neighbours in a sweep's x order (Shamos and Hoey):
    if any two edges cross, touch one's interior or overlap, some such pair is among them.

    The plane is sheared first, y' = M y + x with M past the x range: an affine map (it
    keeps every crossing, touch and overlap) under which no edge is horizontal and no two
    distinct points share a row, so the sweep meets one vertex at a time. Up to the first
    such point, the edges' order along a row is the same at every row, and the edges
    through it are neighbours just before it or just after its vertex's insertions; every
    neighbour pair is recorded when it forms. Zero-length edges are left out (they split
    nothing). O(n log n) comparisons in Python."""
    rows = seg.tolist()
    if not rows:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    m = 2 * (int(seg[:, 0::2].max()) - int(seg[:, 0::2].min())) + 1
    sheared = [(ax, m * ay + ax, bx, m * by + bx) for ax, ay, bx, by in rows]
    events: dict[int, list] = {}  # row: edges ending, edges starting
    for k, (_, ay, _, by) in enumerate(sheared):
        if ay != by:
            events.setdefault(max(ay, by), [[], []])[0].append(k)
            events.setdefault(min(ay, by), [[], []])[1].append(k)
    low = _low_ends(sheared)
    active: list[int] = []
    left, right = [], []
    for y in sorted(events):
        ending, starting = events[y]
        for k in ending:
            i = _remove(active, low, k, y)
            if 0 < i < len(active):
                left.append(active[i - 1])
                right.append(active[i])
        for k in starting:
            x, _, dx, dy = low[k]
            i = _place(active, low, x, y, dx, dy, 1)
            if i > 0:
                left.append(active[i - 1])
                right.append(k)
            if i < len(active):
                left.append(k)
                right.append(active[i])
            active.insert(i, k)
    return np.array(left, dtype=np.int64), np.array(right, dtype=np.int64)


def _swept(edges: np.ndarray, group) -> np.ndarray:
    """Per edge, whether its polygon's sides come from the sweep (`_sweep_sides`): its
    midpoint-edge pairs at the same rows (`level_pairs`) pass SWEEP_PAIRS per edge, where
    the banded pairs of `winding_numbers` would be quadratic (a star, a comb). The edges'
    polygons already stacked by `side_fills`."""
    if not len(edges):
        return np.zeros(0, dtype=bool)
    group = np.zeros(len(edges), dtype=np.int64) if group is None else np.asarray(group)
    pairs = np.bincount(group, weights=_level_counts(edges[:, 1::2]))
    return (pairs > SWEEP_PAIRS * np.bincount(group))[group]


def _level_counts(ys: np.ndarray) -> np.ndarray:
    """Per edge (its two y), how many edges' closed y ranges hold its midpoint."""
    lo, hi = np.sort(2 * ys.min(axis=1)), np.sort(2 * ys.max(axis=1))
    mid = ys.sum(axis=1)  # doubled, as side_fills tests them
    return np.searchsorted(lo, mid, side="right") - np.searchsorted(hi, mid, side="left")


def _group_shift(ys: np.ndarray, group) -> np.ndarray:
    """Per edge, the y offset that stacks polygon g below the others (g times the edges'
    height plus one), as a column to add to `ys` (an edge's two y)."""
    return (np.asarray(group, dtype=np.int64) * int(ys.max() - ys.min() + 1))[:, None]


def level_pairs(edges: np.ndarray, group: np.ndarray | None = None) -> int:
    """How many (midpoint, edge) pairs the banded `winding_numbers` would test for
    `side_fills`, twice: per edge midpoint, the edges of its polygon whose closed y range
    holds it (O(E log E), nothing tested; polygons past SWEEP_PAIRS per edge are swept)."""
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 4)
    if not len(edges):
        return 0
    ys = edges[:, 1::2]
    if group is not None:
        ys = ys + _group_shift(ys, group)
    return 2 * int(_level_counts(ys).sum())


def inside_sides(
    edges: np.ndarray, rule: str | np.ndarray, group: np.ndarray | None = None
) -> np.ndarray:
    """'left', 'right', or '' (not a boundary: filled on both sides or neither) per edge
    (several polygons at once as `side_fills` takes them)."""
    left, right = side_fills(edges, rule, group)
    return np.where(left & ~right, "left", np.where(right & ~left, "right", ""))


def sample_mask(
    edges: np.ndarray,
    rule: str,
    ys: np.ndarray,
    x0: int,
    dx: int,
    columns: int,
) -> np.ndarray:
    """Fill-rule membership of the samples (x0 + j dx, ys[r]), j < columns: (R, columns) bool.

    Scanline form of the perturbed point test: every non-horizontal edge adds its direction
    (+1 down, -1 up) from its crossing of each row onward, and the cumulative sum along the
    row is the winding number. Only the R x columns window is touched. ys must be increasing;
    dx > 0; all values in the edges' integer units.
    """
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 4)
    ys = np.asarray(ys, dtype=np.int64)
    acc = np.zeros((len(ys), columns + 1), dtype=np.int32)
    edges = edges[edges[:, 1] != edges[:, 3]]
    if len(edges) and len(ys):
        ax, ay, bx, by = (edges[:, i] for i in range(4))
        direction = np.where(by > ay, 1, -1)
        lo = np.searchsorted(ys, np.minimum(ay, by), side="left")
        hi = np.searchsorted(ys, np.maximum(ay, by), side="left")  # rows with y < max
        counts = hi - lo
        keep = counts > 0
        if keep.any():
            e = np.repeat(np.flatnonzero(keep), counts[keep])
            starts = np.repeat(lo[keep], counts[keep])
            offsets = np.arange(len(e)) - np.repeat(
                np.cumsum(counts[keep]) - counts[keep], counts[keep]
            )
            rows = starts + offsets
            y = ys[rows]
            ey = by[e] - ay[e]
            num = (ax[e] - x0) * ey + (y - ay[e]) * (bx[e] - ax[e])
            den = dx * ey
            num, den = np.where(den < 0, -num, num), np.abs(den)
            first = -((-num) // den)  # ceil: the first sample column at or right of x_c
            np.add.at(acc, (rows, np.clip(first, 0, columns)), direction[e])
    winding = np.cumsum(acc, axis=1)[:, :columns]
    return fills(winding, rule)


def halfplane_samples(
    edges: np.ndarray, inside_left: np.ndarray, px: np.ndarray, py: np.ndarray
) -> np.ndarray:
    """Whether sample points (px, py), perturbed by (e1, e2), lie on the inside of the edge
    (edges row k for sample k; inside_left: the inside is the left of travel)."""
    ax, ay, bx, by = (edges[:, i] for i in range(4))
    dx, dy = bx - ax, by - ay
    left = _lex_sign(dy * (px - ax) - dx * (py - ay), dy, -dx) > 0
    return left == inside_left


def _ramp(z: int, m: int) -> int:
    """2 m**2 G(z / m), G the antiderivative of clamp(z, 0, 1) with G(0) = 0."""
    if z <= 0:
        return 0
    if z >= m:
        return 2 * z * m - m * m
    return z * z


def halfplane_coverage(
    edge: tuple[int, int, int, int], inside_left: bool, x: int, y: int, s: int, d: int
) -> int:
    """round(d * area of pixel (x, y) on the inside of the edge's supporting line), exact.

    edge in sub-pixel units (s per pixel), pixel (x, y) in pixels. The closed form of
    `edgeaa.model.reference` in integers: in the frame where u is the major axis, the area on
    the side of smaller minor coordinate is the mean of clamp(a + k t, 0, 1) over t in
    [0, 1], (G(a + k) - G(a)) / k, with a and k scaled by m = 2 s du to integers. Rounded half
    up.
    """
    ax, ay, bx, by = edge
    dx, dy = bx - ax, by - ay
    side = 1 if inside_left else -1
    if abs(dx) >= abs(dy):
        p0, q0, dp, dq, p, q = ax, ay, dx, dy, x, y
        inside_low = side * dx > 0  # the inside normal s (dy, -dx) points to smaller y
    else:
        p0, q0, dp, dq, p, q = ay, ax, dy, dx, y, x
        inside_low = side * dy < 0  # ... to smaller x
    if dp < 0:
        dp, dq = -dp, -dq
    m = 2 * s * dp
    # a m: the line's height above the pixel's low minor boundary at the span's start
    a = 2 * q0 * dp + dq * (2 * p * s - s - 2 * p0) - (2 * q * s - s) * dp
    if dq == 0:
        num, den = min(max(a, 0), m), m
    else:
        k = 2 * s * dq
        num, den = _ramp(a + k, m) - _ramp(a, m), 2 * m * k
        if den < 0:
            num, den = -num, -den
    if not inside_low:
        num = den - num
    return (2 * d * num + den) // (2 * den)


def _cross(ax: int, ay: int, bx: int, by: int) -> int:
    return ax * by - ay * bx


def _round_div(num: int, den: int) -> int:
    """num / den rounded half up (den > 0)."""
    return (2 * num + den) // (2 * den)


SAFE = 1 << 30  # |coordinate| below this keeps _may_split's products inside int64
PAIRS = 1 << 16  # edge pairs per numpy pass of _candidate_pairs (fits in the caches)
SWEEP_BOXES = 64  # overlapping boxes per edge past which a sweep looks for any split first


class NodingLimit(ValueError):
    """Splitting would insert more than the limit of points (`split_crossings`' limit)."""


def _count_pairs(pairs, limit: int | None):
    """The pairs, raising NodingLimit past `limit` of them (each inserts at least a point)."""
    for n, pair in enumerate(pairs):
        if limit is not None and n >= limit:
            raise NodingLimit(f"more than {limit:,} points")
        yield pair


def contour_segments(contours: list[np.ndarray]) -> np.ndarray:
    """Every edge of closed contours ((n, 2) arrays) as rows x0 y0 x1 y1 (E, 4), in order:
    each vertex to the next, the last to the first. One pass over all of them."""
    if not contours:
        return np.zeros((0, 4), dtype=np.int64)
    sizes = np.array([len(c) for c in contours], dtype=np.int64)
    points = np.concatenate(contours)
    nxt = np.arange(1, len(points) + 1)
    ends = (np.cumsum(sizes) - 1)[sizes > 0]  # an empty contour has no edge
    nxt[ends] = ends - sizes[sizes > 0] + 1  # the last vertex closes to the first
    return np.concatenate([points, points[nxt]], axis=1)


def split_crossings(
    contours: list[np.ndarray], limit: int | None = None
) -> tuple[list[np.ndarray], int]:
    """Insert a vertex wherever an edge of these contours crosses or touches another edge's
    interior (and at the ends of collinear overlaps), so that every edge lies on one side of
    the rest: then the fill rule gives each edge one inside side along its whole length.

    Contours are (n, 2) int64 arrays of closed polygons. A crossing point is rounded half up
    to the integer grid, the same for both edges. Returns the new contours and the number of
    vertices inserted. More than `limit` pairs of edges that split raise NodingLimit before
    any point is computed past them.

    The pairs to test come from a sweep (`_candidate_pairs`): O(n log n + B) numpy work for
    n edges and B pairs whose bounding boxes overlap, and Python work only for the pairs that
    do split (k). Quadratic only when B is, as for random vertex soups, where k is too.
    """
    out, inserted, _ = split_contours(contours, limit)
    return out, int(sum(inserted))


def split_contours(
    contours: list[np.ndarray], limit: int | None = None
) -> tuple[list[np.ndarray], list[int], int]:
    """`split_crossings` with the points inserted into each contour, and the number of edge
    pairs that split (the count its `limit` is held against)."""
    if not contours:
        return contours, [], 0
    seg = contour_segments(contours)
    found = list(_count_pairs(_candidate_pairs(seg), limit))
    edges = sorted({k for pair in found for k in pair})
    rows = dict(zip(edges, seg[edges].tolist(), strict=True))  # only the edges that split
    splits: dict[int, list] = {}
    for i, j in found:
        _intersect(i, j, rows, splits)
    pairs = len(found)
    if not splits:
        return contours, [0] * len(contours), pairs
    out, inserted = _insert_splits(contours, splits, seg)
    return out, inserted, pairs


def _insert_splits(
    contours: list[np.ndarray], splits: dict, seg: np.ndarray
) -> tuple[list[np.ndarray], list[int]]:
    """The contours (their edges `seg`) with each edge's split points inserted in order
    along it, and how many points each got. A contour none of whose edges splits is only
    cleared of repeated vertices (there are none in a plan's)."""
    repeats = np.flatnonzero(np.all(seg[:, 0:2] == seg[:, 2:4], axis=1))  # zero length
    sizes = np.array([len(c) for c in contours], dtype=np.int64)
    owner = np.repeat(np.arange(len(contours)), sizes)
    touched = set(owner[list(splits)].tolist()) | set(owner[repeats].tolist())
    out, inserted, base = [], [], 0
    for c, pts in enumerate(contours):
        if c not in touched:  # as the loop below would give it
            base += len(pts)
            out.append(np.asarray(pts, dtype=np.int64))
            inserted.append(0)
            continue
        points, added = [], 0
        for k, row in enumerate(pts.tolist()):
            points.append(tuple(map(int, row)))
            for p in _along(splits.get(base + k, ())):
                if p != points[-1]:
                    points.append(p)
                    added += 1
        base += len(pts)
        kept = [p for i, p in enumerate(points) if p != points[i - 1]]  # cyclic dedup
        out.append(np.array(kept or points[:1], dtype=np.int64))
        inserted.append(added)
    return out, inserted


def _along(entries) -> list[tuple[int, int]]:
    """The points of (float t, numerator, denominator, point) entries by exact t, then point.
    Sorted by the float first (rounding is monotone, so it never reverses two t); a run of
    equal floats is sorted again exactly."""
    from fractions import Fraction

    points = []
    for _, run in groupby(sorted(entries, key=itemgetter(0)), key=itemgetter(0)):
        run = list(run)
        if len(run) > 1:
            run.sort(key=lambda e: (Fraction(e[1], e[2]), e[3]))
        points.extend(e[3] for e in run)
    return points


def _candidate_pairs(seg: np.ndarray):
    """Yield (i, j), i < j, for every edge pair that may split (a superset of those that do).

    A sweep along the axis whose intervals overlap least: with the edges sorted by their low
    end, edge p's partners are the edges after it whose low end is at most p's high end, one
    searchsorted. The other axis and the exact test (`_may_split`) filter them in numpy, in
    chunks of about PAIRS pairs. When that axis gives more than SWEEP_BOXES pairs per edge
    (a star, a spiral: boxes that all overlap), a sweep's neighbour pairs
    (`_sweep_neighbours`, O(n log n)) first tell whether any pair splits: if none, there is
    nothing to yield. (Where some pair does, the pairs are still all tested: quadratic when
    the boxes overlap so and something crosses.)
    """
    n = len(seg)
    lo = np.minimum(seg[:, 0:2], seg[:, 2:4]).T.copy()  # rows: x, y
    hi = np.maximum(seg[:, 0:2], seg[:, 2:4]).T.copy()
    best = None
    for axis in (0, 1):
        order = np.argsort(lo[axis], kind="stable")
        ends = np.searchsorted(lo[axis][order], hi[axis][order], side="right")
        counts = ends - np.arange(1, n + 1)
        if best is None or counts.sum() < best[0]:
            best = (counts.sum(), axis, order, counts)
    _, axis, order, counts = best
    lo_o, hi_o = lo[1 - axis], hi[1 - axis]
    exact = seg.dtype.kind in "iu" and n and seg.min() > -SAFE and seg.max() < SAFE
    cols = seg.T.astype(np.int64) if exact else None  # rows: x0, y0, x1, y1
    if exact and best[0] > SWEEP_BOXES * n and not _may_split(cols, *_sweep_neighbours(seg)).any():
        return  # no two edges split each other: nothing to yield, without the B pairs
    cum = np.cumsum(counts)
    p0 = 0
    while p0 < n:
        p1 = max(p0 + 1, int(np.searchsorted(cum, cum[p0] - counts[p0] + PAIRS, side="right")))
        c = counts[p0:p1]
        a = np.repeat(np.arange(p0, p1), c)
        b = a + 1 + np.arange(len(a)) - np.repeat(np.cumsum(c) - c, c)
        i, j = order[a], order[b]
        keep = (lo_o[i] <= hi_o[j]) & (lo_o[j] <= hi_o[i])
        i, j = i[keep], j[keep]
        if exact:
            keep = _may_split(cols, i, j)
            i, j = i[keep], j[keep]
        yield from zip(np.minimum(i, j).tolist(), np.maximum(i, j).tolist(), strict=True)
        p0 = p1


def _may_split(cols: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Whether `_intersect` adds a split point for edges i[m] and j[m]: its tests in int64
    numpy, exact while every |coordinate| < SAFE. cols: (4, n) x0, y0, x1, y1."""
    ax, ay, bx, by = (c[i] for c in cols)
    cx, cy, dx, dy = (c[j] for c in cols)
    rx, ry, sx, sy, wx, wy = bx - ax, by - ay, dx - cx, dy - cy, cx - ax, cy - ay
    den = rx * sy - ry * sx
    tn = wx * sy - wy * sx
    un = wx * ry - wy * rx
    flip = den < 0
    den, tn, un = np.abs(den), np.where(flip, -tn, tn), np.where(flip, -un, un)
    inner = ((tn > 0) & (tn < den)) | ((un > 0) & (un < den))
    keep = (den != 0) & (tn >= 0) & (tn <= den) & (un >= 0) & (un <= den) & inner
    k = np.flatnonzero((den == 0) & (un == 0) & ((rx != 0) | (ry != 0)) & ((sx != 0) | (sy != 0)))
    if len(k):  # collinear: an end of one edge strictly inside the other
        rr, ss = rx[k] ** 2 + ry[k] ** 2, sx[k] ** 2 + sy[k] ** 2
        ends = (
            (wx[k] * rx[k] + wy[k] * ry[k], rr),
            ((dx - ax)[k] * rx[k] + (dy - ay)[k] * ry[k], rr),
            (-(wx[k] * sx[k] + wy[k] * sy[k]), ss),
            ((bx - cx)[k] * sx[k] + (by - cy)[k] * sy[k], ss),
        )
        keep[k] = np.any([(t > 0) & (t < length) for t, length in ends], axis=0)
    return keep


def _add_split(splits: dict, k: int, num: int, den: int, point: tuple[int, int]) -> None:
    """Record a split of edge k at t = num / den (sorted by `_along`)."""
    splits.setdefault(k, []).append((num / den, num, den, point))


def _intersect(i: int, j: int, rows: list, splits: dict) -> None:
    ax, ay, bx, by = rows[i]
    cx, cy, dx, dy = rows[j]
    rx, ry, sx, sy = bx - ax, by - ay, dx - cx, dy - cy
    if (rx, ry) == (0, 0) or (sx, sy) == (0, 0):
        return  # a repeated vertex: a zero-length segment splits nothing and is not split
    den = _cross(rx, ry, sx, sy)
    if den:
        tn, un = _cross(cx - ax, cy - ay, sx, sy), _cross(cx - ax, cy - ay, rx, ry)
        if den < 0:
            den, tn, un = -den, -tn, -un
        if not (0 <= tn <= den and 0 <= un <= den):
            return
        point = (_round_div(ax * den + tn * rx, den), _round_div(ay * den + tn * ry, den))
        if 0 < tn < den:
            _add_split(splits, i, tn, den, point)
        if 0 < un < den:
            _add_split(splits, j, un, den, point)
        return
    if _cross(cx - ax, cy - ay, rx, ry):
        return  # parallel, not collinear
    for (px, py), k, (ox, oy, ux, uy) in (
        ((cx, cy), i, (ax, ay, rx, ry)),
        ((dx, dy), i, (ax, ay, rx, ry)),
        ((ax, ay), j, (cx, cy, sx, sy)),
        ((bx, by), j, (cx, cy, sx, sy)),
    ):
        num, length = (px - ox) * ux + (py - oy) * uy, ux * ux + uy * uy
        if 0 < num < length:
            _add_split(splits, k, num, length, (px, py))


def hot_points(contours: list[np.ndarray], limit: int | None = None) -> np.ndarray:
    """The centres of the hot pixels of snap rounding: every vertex and every crossing point
    of the contours' edges rounded half up to the grid (`split_crossings`' rounding), (H, 2)
    int64, unique. NodingLimit past `limit` pairs of edges that meet."""
    seg = contour_segments(contours)
    rows = seg.tolist()
    splits: dict[int, list] = {}
    for i, j in _count_pairs(_candidate_pairs(seg), limit):
        _intersect(i, j, rows, splits)
    found = [entry[3] for entries in splits.values() for entry in entries]
    points = np.concatenate([seg[:, 0:2], np.array(found, dtype=np.int64).reshape(-1, 2)])
    return np.unique(points, axis=0)


def snap_round(
    contours: list[np.ndarray], hot: np.ndarray, limit: int | None = None
) -> list[np.ndarray]:
    """Snap rounding (Hobby; Guibas and Marimont): each edge becomes the chain through the
    centres of the hot pixels it meets, in the order it meets them. A pixel is the half-open
    square [c - 1/2, c + 1/2) x [c' - 1/2, c' + 1/2) around its centre (c, c'), the cell that
    rounding half up sends to it; `hot` holds the centres (every vertex among them).
    NodingLimit if the chains would have more than `limit` vertices."""
    seg = contour_segments(contours)
    chains: dict[int, list] = {}
    met = 0
    for e, h in _meeting_pairs(seg, hot):
        met += len(e)
        if limit is not None and met - len(seg) > limit:
            raise NodingLimit(f"more than {limit:,} points")
        for i, k in zip(e.tolist(), h.tolist(), strict=True):
            chains.setdefault(i, []).append(k)
    hot_rows = hot.tolist()
    out, base = [], 0
    for pts in contours:
        points = []
        for i in range(base, base + len(pts)):
            met = sorted(chains[i], key=lambda k, i=i: _entry(seg[i].tolist(), hot_rows[k]))
            points.extend(tuple(hot_rows[k]) for k in met[:-1])  # the end starts the next
        base += len(pts)
        kept = [p for i, p in enumerate(points) if p != points[i - 1]]  # cyclic dedup
        out.append(np.array(kept or points[:1], dtype=np.int64))
    return out


def _entry(edge: list, centre: list):
    """Where the edge meets the centre's pixel: (first t, last t) as fractions; distinct
    pixels met by one edge are met at disjoint sets of t, so this orders them."""
    from fractions import Fraction

    (ax, ay, bx, by), lows, highs = edge, [Fraction(0)], [Fraction(1)]
    for a, b, c in ((ax, bx, centre[0]), (ay, by, centre[1])):
        if a != b:
            t0, t1 = Fraction(2 * (c - a) - 1, 2 * (b - a)), Fraction(2 * (c - a) + 1, 2 * (b - a))
            lows.append(min(t0, t1))
            highs.append(max(t0, t1))
    return max(lows), min(highs)


def _meeting_pairs(seg: np.ndarray, hot: np.ndarray):
    """Yield (edge, hot point) index arrays of the edges and hot pixels that meet, exactly.

    A pixel with an integer centre c meets the edge's integer box [lo, hi] iff lo <= c <= hi
    on both axes, so the candidates are the centres in the box (a sweep along x over the
    centres sorted by x, like `_candidate_pairs`); then the edge's parameter intervals in x
    and y, [(2u - 1) / 2d, (2u + 1) / 2d) with u = c - a, must meet each other and [0, 1]."""
    order = np.argsort(hot[:, 0], kind="stable")
    hx, hy = hot[order, 0], hot[order, 1]
    lo = np.minimum(seg[:, 0:2], seg[:, 2:4])
    hi = np.maximum(seg[:, 0:2], seg[:, 2:4])
    begin = np.searchsorted(hx, lo[:, 0], side="left")
    counts = np.searchsorted(hx, hi[:, 0], side="right") - begin
    exact = len(seg) and np.abs(seg).max() < SAFE and np.abs(hot).max() < SAFE
    cum = np.cumsum(counts)
    p0 = 0
    while p0 < len(seg):
        p1 = max(p0 + 1, int(np.searchsorted(cum, cum[p0] - counts[p0] + CHUNK, side="right")))
        c = counts[p0:p1]
        e = np.repeat(np.arange(p0, p1), c)
        k = np.repeat(begin[p0:p1], c) + np.arange(len(e)) - np.repeat(np.cumsum(c) - c, c)
        keep = (lo[e, 1] <= hy[k]) & (hy[k] <= hi[e, 1])
        e, k = e[keep], order[k[keep]]
        cols = seg[e].astype(np.int64 if exact else object).T
        keep = _meets_pixel(*cols, hot[k, 0].astype(cols.dtype), hot[k, 1].astype(cols.dtype))
        yield e[keep], k[keep]
        p0 = p1


def _meets_pixel(ax, ay, bx, by, cx, cy) -> np.ndarray:
    """Whether edge a b meets the half-open pixel of centre c (arrays; int64 exact while
    every |coordinate| < SAFE, else object arrays of Python ints).

    Along the edge, t in [0, 1] closed, and per axis with d = b - a != 0 and u = c - a the
    pixel's interval (2u - 1) / 2d <= t < (2u + 1) / 2d for d > 0, closed at the other end
    for d < 0 (d = 0: every t if u = 0, none otherwise). Intervals on a line meet iff every
    lower bound is below every upper bound (or equal, both closed). The ends of the edge are
    on the grid, never on a pixel's side, so [0, 1] may be taken closed."""
    bounds = []  # (numerator, denominator > 0, closed) of the lower and upper bounds
    ok = np.ones(len(ax), dtype=bool)
    for a, b, c in ((ax, bx, cx), (ay, by, cy)):
        d, u = b - a, c - a
        pos = d > 0
        den = np.where(d == 0, 1, 2 * abs(d))
        low = np.where(pos, 2 * u - 1, -2 * u - 1)
        high = np.where(pos, 2 * u + 1, -2 * u + 1)
        flat = d == 0
        ok &= ~flat | (u == 0)
        # a flat axis with u = 0 constrains nothing: [0, 1] closed
        low, high = np.where(flat, 0, low), np.where(flat, den, high)
        bounds.append(((low, den, pos | flat), (high, den, ~pos | flat)))
    one = np.ones(len(ax), dtype=ax.dtype)
    closed = np.ones(len(ax), dtype=bool)
    lows = [(0 * one, one, closed)] + [b[0] for b in bounds]
    highs = [(one, one, closed)] + [b[1] for b in bounds]
    for ln, ld, lc in lows:
        for hn, hd, hc in highs:
            left, right = ln * hd, hn * ld
            ok &= (left < right) | ((left == right) & lc & hc)
    return ok
