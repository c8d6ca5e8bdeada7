"""The scene renderer: every polygon by signed-area accumulation (docs/scenes.md).

1. `plan_scene`: quantize the vertices to the sub-pixel grid (round half up), shift the
   scene by whole pixels so every vertex is in the engine's range, split edges where they
   cross, and classify every edge: its inside side by the fill rule (winding numbers over
   all the polygon's contours, just left and just right of its midpoint), or not a boundary
   (filled on both sides or neither); horizontal (adds nothing); wholly above, below or right
   of the viewport (culled); wholly left of it (projected: only its cover matters there).
   Each polygon gets I_out: the background when it overlaps no earlier polygon, otherwise
   the intensity farthest from I_in (the finest coverage steps), composited in integers.
2. `render_scene`: send the boundary edges to the engine, which steps each edge's columns
   and emits its signed-area deltas (`edgeaa.model.column.column_deltas`); per polygon, add
   them into an accumulation buffer over the polygon's window, prefix-sum the touched rows,
   apply the fill rule and composite the coverage over what is below
   (`edgeaa.model.accumulate`). Many polygons are accumulated together in one buffer
   (`_accumulation_runs`) and composited in waves of windows that share no pixel, each
   polygon after every earlier polygon whose window meets its own: the same image, with
   numpy's per-call cost paid once per run (and once per wave to composite).
   The model's render with skipping does this band of rows by band (`render.bands`): only
   one band's deltas and buffers exist at a time, and the image is the same.

The boundary edges alone bound the filled region, each with its inside on one side, so the
sums are the region's exact area (up to the estimate) even where subpaths overlap or cross.

With ``skip=False`` every boundary edge goes to the engine unclipped and unprojected, and
each polygon's buffer covers the whole image: the image is the same, bit for bit (tested);
the difference is the work, which `edgeaa render --stats` reports.
"""

from __future__ import annotations

import builtins
import itertools
import math
import time
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager, nullcontext
from dataclasses import dataclass, field, replace
from functools import cached_property, partial

import numpy as np

from ..model import Clip, Edge, EdgeConfig
from ..model.accumulate import (
    Window,
    composite,
    evenodd_coverage,
    intensity_offset,
    nonzero_coverage,
    resolve_rows,
)
from ..model.beat import DELTAS
from ..model.column import ArrayArith
from ..model.vector import weighted_runs
from .bands import Band, band_columns, band_rows, split_bands
from .engines import DeltaRun, cycles_of, run_deltas
from .geometry import (
    SAFE,
    NodingLimit,
    contour_segments,
    hot_points,
    inside_sides,
    snap_round,
    split_contours,
    split_crossings,
)
from .scene import (
    MAX_NODED_EDGES,
    MAX_STEPPED_COLUMNS,
    Scene,
    SceneError,
)

WRITE_MARGIN = 2  # px: every delta lies within the edge's bounding box grown by this much


@dataclass(frozen=True)
class PolygonPlan:
    index: int
    intensity: int  # I_in of its edges
    i_out: int  # I_out of its edges
    rule: str
    start: int  # its edges are start .. stop - 1
    stop: int
    window: tuple[int, int, int, int]  # image pixels x0, y0, x1, y1 (exclusive) it can touch
    equal: bool  # intensity == background
    overlaps: bool  # its window meets an earlier polygon's

    @property
    def empty(self) -> bool:
        x0, y0, x1, y1 = self.window
        return x1 <= x0 or y1 <= y0


@dataclass
class Plan:
    """A quantized scene in engine coordinates, every edge classified."""

    config: EdgeConfig
    scene: Scene
    offset: tuple[int, int]  # whole pixels added to scene coordinates
    coords: np.ndarray  # (E, 4) int64 x0 y0 x1 y1 in sub-pixel units, engine coordinates
    polygon: np.ndarray  # polygon of each edge
    contour: np.ndarray  # contour of each edge (a contour's edges are consecutive, in order)
    inside: np.ndarray  # 'left', 'right' or '' (not a boundary)
    culled: np.ndarray  # wholly above, below or right of the viewport: nothing lands there
    left: np.ndarray  # wholly left of the viewport: only its cover reaches the image
    horizontal: np.ndarray  # adds nothing to any cell
    polygons: list[PolygonPlan]
    dropped_contours: int = 0  # contours that collapsed to fewer than 3 vertices
    crossings: int = 0  # vertices inserted where edges cross (split_crossings)
    duplicates: int = 0  # coincident boundary edges left to the first of them

    @property
    def boundary(self) -> np.ndarray:
        return self.inside != ""

    @cached_property
    def intensities(self) -> tuple[np.ndarray, np.ndarray]:
        """Each polygon's I_in and I_out, as arrays."""
        intensity = np.array([p.intensity for p in self.polygons], dtype=np.int64)
        return intensity, np.array([p.i_out for p in self.polygons], dtype=np.int64)

    @property
    def edge_count(self) -> int:
        return len(self.coords)

    @property
    def in_range(self) -> bool:
        """Whether every vertex is in the engine's range (`_offset`: if not, only the edges
        that reach the image are, and only a render that skips the rest can be made)."""
        return not len(self.coords) or (
            self.coords.min() >= 0 and self.coords.max() <= self.config.max_vertex
        )

    @property
    def viewport(self) -> Clip:
        """The image in engine pixels as the core's clip window (within its range)."""
        top = 1 << self.config.coord_bits
        ox, oy = self.offset
        x_max, y_max = ox + self.scene.width - 1, oy + self.scene.height - 1
        return Clip(min(ox, top), min(oy, top), min(x_max, top), min(y_max, top))

    @property
    def accumulation_clip(self) -> Clip:
        """The viewport without its left bound: columns left of the image still carry their
        cover into it, so they are stepped (or the edge projected, `edge`)."""
        return self.viewport._replace(x_min=0)

    def edge(self, e: int, clip: bool = False) -> Edge:
        """Edge e as a command; clip: cut to `accumulation_clip`, and an edge wholly left of
        the image replaced by its projection on the column left of it (same cover per row,
        so the same sums in the image, and one column per row to step)."""
        p = self.polygons[self.polygon[e]]
        x0, y0, x1, y1 = (int(v) for v in self.coords[e])
        if clip and self.left[e]:
            x0 = x1 = (self.offset[0] - 1) * self.config.subpixel_scale
        window = self.accumulation_clip if clip else None
        return Edge(x0, y0, x1, y1, str(self.inside[e]), p.intensity, p.i_out, window)


@dataclass(frozen=True)
class EdgeArrays:
    """Edge commands as arrays (`edgeaa.model.edge.setup_batch`'s arguments), one element per
    edge: what `Plan.edge` gives one at a time, without building the objects."""

    x0: np.ndarray
    y0: np.ndarray
    x1: np.ndarray
    y1: np.ndarray
    inside_left: np.ndarray
    i_in: np.ndarray
    i_out: np.ndarray
    clip: Clip | tuple[np.ndarray, ...] | None  # one window for all, or four arrays

    @classmethod
    def from_edges(cls, config: EdgeConfig, edges: list[Edge]) -> EdgeArrays:
        """Edge objects (each with its own clip window, or none) as arrays."""
        full = Clip.full(config)
        rows = [
            (e.x0, e.y0, e.x1, e.y1, e.inside == "left", *e.intensities(config), *e.window(config))
            for e in edges
        ]
        cols = [np.array(c, dtype=np.int64) for c in zip(*rows, strict=True)] or [
            np.zeros(0, np.int64) for _ in range(7 + len(full))
        ]
        cols[4] = cols[4].astype(bool)
        return cls(*cols[:7], tuple(cols[7:]))

    def __len__(self) -> int:
        return len(self.x0)

    def take(self, index) -> EdgeArrays:
        """The edges `index` (a slice or an array of indices), in that order."""
        clip = self.clip
        if isinstance(clip, tuple) and not isinstance(clip, Clip):  # an array per bound
            clip = tuple(bound[index] for bound in clip)
        return EdgeArrays(*(a[index] for a in self.args()), clip)

    def args(self) -> tuple:
        return (self.x0, self.y0, self.x1, self.y1, self.inside_left, self.i_in, self.i_out)

    def edges(self) -> list[Edge]:
        """The same commands as `Edge` objects (for the simulators' drivers)."""
        rows = zip(*(a.tolist() for a in self.args()), strict=True)
        if self.clip is None or isinstance(self.clip, Clip):
            clips = [self.clip] * len(self)
        else:  # four arrays
            clips = [Clip(*c) for c in zip(*(a.tolist() for a in self.clip), strict=True)]
        return [
            Edge(x0, y0, x1, y1, "left" if left else "right", i_in, i_out, clip)
            for (x0, y0, x1, y1, left, i_in, i_out), clip in zip(rows, clips, strict=True)
        ]


def edge_arrays(plan: Plan, ids: np.ndarray, clip: bool) -> EdgeArrays:
    """Edges `ids` of the plan as arrays, exactly as `Plan.edge(e, clip)` gives each."""
    c = plan.coords[ids]
    x0, x1 = c[:, 0].copy(), c[:, 2].copy()
    if clip:
        left = plan.left[ids]
        x0[left] = x1[left] = (plan.offset[0] - 1) * plan.config.subpixel_scale
    owner = plan.polygon[ids]
    intensity, i_out = plan.intensities
    return EdgeArrays(
        x0, c[:, 1], x1, c[:, 3], plan.inside[ids] == "left",
        intensity[owner] if len(owner) else np.zeros(0, np.int64),
        i_out[owner] if len(owner) else np.zeros(0, np.int64),
        plan.accumulation_clip if clip else None,
    )  # fmt: skip


def _alternative_out(intensity: int, background: int, full: int) -> int:
    """I_out farthest from I_in (background on a tie): the finest coverage steps."""
    far = 0 if intensity > full - intensity else full
    return background if abs(intensity - background) >= abs(intensity - far) else far


def plan_scene(scene: Scene, config: EdgeConfig) -> Plan:
    """Quantize, shift and classify a scene for `config` (raises SceneError if it does not
    fit: image larger than 2**coord_bits, an intensity or a vertex out of range)."""
    S = config.subpixel_scale
    intensities = _check_scene(scene, config)
    contours, owners, dropped = _quantize(scene, S)
    offset = _offset(config, scene, contours, owners)
    coords, polygon, contour, starts, crossings = _split_edges(scene, contours, owners, offset, S)
    inside, duplicates = _inside_sides(scene, coords, starts)
    boxes = _write_boxes(coords, offset, S)
    lo_x, lo_y, hi_x, hi_y = boxes
    culled = (lo_x >= scene.width) | (hi_y < 0) | (lo_y >= scene.height)
    left = ~culled & (hi_x <= 0)  # every delta lands in or left of the image's first column
    horizontal = coords[:, 1] == coords[:, 3]
    polys = _polygon_plans(scene, intensities, starts, boxes, config.full_scale)
    return Plan(
        config, scene, offset, coords, polygon, contour, inside, culled, left, horizontal,
        polys, dropped, crossings, duplicates,
    )  # fmt: skip


def _check_scene(scene: Scene, config: EdgeConfig) -> list[int]:
    """Check the image size and the intensities; return each polygon's I_in."""
    full = config.full_scale
    limit = 1 << config.coord_bits
    for name, value in (("width", scene.width), ("height", scene.height)):
        if value > limit:
            raise SceneError(
                f"scene {name} {value} px is larger than the coordinate range allows "
                f"({limit} px, coord_bits = {config.coord_bits})"
            )
    if not 0 <= scene.background <= full:
        raise SceneError(
            f"background {scene.background} is outside [0, {full}] "
            f"(intensity_bits = {config.intensity_bits})"
        )
    intensities = []
    for i, poly in enumerate(scene.polygons):
        value = full if poly.intensity is None else poly.intensity
        if not 0 <= value <= full:
            raise SceneError(
                f"polygon {i}: intensity {value} is outside [0, {full}] "
                f"(intensity_bits = {config.intensity_bits})"
            )
        intensities.append(value)
    return intensities


def _quantize(scene: Scene, S: int):
    """Round the vertices half up to the 2**-s grid, drop repeated vertices and collapsed
    contours. Returns the contours (sub-pixel units), their owners (polygon, contour, the
    indices of the kept vertices) and how many contours were dropped. Every contour in one
    pass of numpy (per contour, the calls cost more than the work)."""
    labels = [(i, j) for i, poly in enumerate(scene.polygons) for j in range(len(poly.contours))]
    if not labels:
        return [], [], 0
    sizes = np.array([len(c) for poly in scene.polygons for c in poly.contours], dtype=np.int64)
    first = np.cumsum(sizes) - sizes
    chain = itertools.chain.from_iterable  # twice as fast as np.asarray on the tuples
    values = np.fromiter(chain(chain(chain(p.contours) for p in scene.polygons)), np.float64)
    if len(values) != 2 * sizes.sum():  # not all (x, y): np.asarray says what is wrong
        flat = [p for poly in scene.polygons for contour in poly.contours for p in contour]
        values = np.asarray(flat, dtype=np.float64)
    pts = values.reshape(-1, 2)  # rounded in place: the scene's floats are a page's memory
    pts *= S
    pts += 0.5
    np.floor(pts, out=pts)
    prev = np.arange(-1, len(pts) - 1)
    prev[first] = first + sizes - 1  # a contour's first vertex follows its last
    keep = (pts[:, 0] != pts[prev, 0]) | (pts[:, 1] != pts[prev, 1])
    del prev
    none = np.add.reduceat(keep, first) == 0  # one point repeated: keep its first
    keep[first[none]] = True
    owner = np.repeat(np.arange(len(sizes)), sizes)[keep]
    kept = pts[keep]
    order = np.lexsort((kept[:, 1], kept[:, 0], owner))  # distinct points per contour
    by_owner, by_point = owner[order], kept[order]
    same = np.zeros(len(order), dtype=bool)
    same[1:] = (by_owner[1:] == by_owner[:-1]) & np.all(by_point[1:] == by_point[:-1], axis=1)
    distinct = np.bincount(by_owner[~same], minlength=len(sizes))
    del by_owner, by_point, same, order
    counts = np.bincount(owner, minlength=len(sizes))
    ends = np.cumsum(counts).tolist()  # slices, not np.split: its cost is per piece
    kept_local = (np.arange(len(pts)) - np.repeat(first, sizes))[keep]  # index in its contour
    parts = [kept[a:b] for a, b in zip([0, *ends], ends, strict=False)]
    indices = [kept_local[a:b] for a, b in zip([0, *ends], ends, strict=False)]
    contours, owners = [], []
    for (i, j), part, index, n in zip(labels, parts, indices, distinct.tolist(), strict=True):
        if n >= 3:
            contours.append(part)
            owners.append((i, j, index))
    return contours, owners, len(labels) - len(contours)


def _offset(config: EdgeConfig, scene: Scene, contours, owners) -> tuple[int, int]:
    """Whole pixels to add so that no vertex is negative, if the scene then fits the range.
    Otherwise only the vertices of edges that reach the image need it: an edge wholly above,
    below or right of the image is never sent, and one wholly left of it is sent as its
    projection on the column left of the image (its y and that column need the range, not
    its x). `Plan.in_range` is then false, and a render without skipping is refused. Checks
    that the vertices that need it fit."""
    S = config.subpixel_scale
    if not contours:
        return 0, 0
    allpts = np.concatenate(contours)
    offset = [max(0, math.ceil(-allpts[:, axis].min() / S)) for axis in (0, 1)]
    fits = all(allpts[:, axis].max() + offset[axis] * S <= config.max_vertex for axis in (0, 1))
    if fits and (offset[0] - 1) * S <= config.max_vertex:  # and the projections' column
        return offset[0], offset[1]
    need, left = _reaching(scene, contours, S)
    for axis in (0, 1):
        used = [pts[n[axis], axis] for pts, n in zip(contours, need, strict=True)]
        lowest = min((u.min() for u in used if len(u)), default=0)
        offset[axis] = max(0, math.ceil(-lowest / S))
    offset[0] = max(offset[0], int(left))  # the projection column, ox - 1, is in range
    _check_range(config, scene, contours, owners, offset, need)
    return offset[0], offset[1]


def _reaching(scene: Scene, contours, S: int) -> tuple[list[tuple], bool]:
    """Per contour, which vertices need the range in x and in y: those of an edge that is
    not wholly outside the image by `_write_boxes` (the test `plan_scene` applies after
    splitting; a piece lies within its edge's box), in y also those of an edge wholly left of
    it. And whether any edge lies wholly left of the image."""
    need, left = [], False
    for pts in contours:
        edges = np.concatenate([pts, np.roll(pts, -1, axis=0)], axis=1).astype(np.int64)
        lo_x, lo_y, hi_x, hi_y = _write_boxes(edges, (0, 0), S)
        sent = ~((lo_x >= scene.width) | (hi_y < 0) | (lo_y >= scene.height))
        wholly_left = sent & (hi_x <= 0)
        left = left or bool(wholly_left.any())
        reaches = sent & ~wholly_left
        # vertex k starts edge k and ends edge k - 1
        need.append((reaches | np.roll(reaches, 1), sent | np.roll(sent, 1)))
    return need, left


def _split_edges(scene: Scene, contours, owners, offset, S: int):
    """The edges of every polygon in engine coordinates, split where they cross.

    Returns coords (E, 4), the polygon and contour of each edge, the first edge of each
    polygon (and the edge count last) and how many vertices were inserted at crossings.
    """
    shift = np.array(offset, dtype=np.int64) * S
    crossings = 0
    by_polygon: list[list[np.ndarray]] = [[] for _ in scene.polygons]
    for (k, _, _), pts in zip(owners, contours, strict=True):
        by_polygon[k].append(pts.astype(np.int64) + shift)
    crossing, noded = _crossing(by_polygon)
    final, owner = [], []  # the contours after splitting, in order, and their polygons
    for i, mine in enumerate(by_polygon):
        if crossing[i]:  # only these need a look again, polygon by polygon
            mine, inserted = _node_polygon(i, mine)
            crossings += inserted
        elif i in noded:  # noded in its batch
            mine, inserted = noded[i]
            crossings += inserted
        final += [q for q in mine if len(q) >= 2]
        owner += [i] * sum(len(q) >= 2 for q in mine)
    sizes = np.array([len(q) for q in final], dtype=np.int64)
    coords = contour_segments(final)
    polygon = np.repeat(np.array(owner, dtype=np.int64), sizes)
    contour = np.repeat(np.arange(len(final), dtype=np.int64), sizes)
    counts = np.bincount(polygon, minlength=len(scene.polygons))
    starts = [0, *np.cumsum(counts).tolist()]
    return coords, polygon, contour, starts, crossings


BATCH_EDGES = 1 << 13  # edges a search of `_crossing` takes at most (its temporaries, some
# 150 bytes an edge, were 12 MiB of the 4,000-glyph page's peak in one search)


def _crossing(by_polygon: list[list[np.ndarray]]) -> tuple[np.ndarray, dict]:
    """Whether each polygon has edges that cross or touch (`split_crossings` would insert a
    point), for many polygons in one search: each is moved right, past the previous one,
    so that no two polygons' boxes meet, in batches of at most BATCH_EDGES edges (whole
    polygons) whose coordinates stay below geometry.SAFE / 2 (the search's exact integer
    filter). A batch whose points would pass
    the limit is left to the polygons one by one (True).

    A crossing polygon whose batch splitting leaves nothing to split in a second round
    (searched in one batch too) is noded already: `_node`'s result, given back in the dict
    (polygon: contours and points inserted) and not left to `_node_polygon` (False)."""
    out = np.ones(len(by_polygon), dtype=bool)
    noded: dict[int, tuple[list[np.ndarray], int]] = {}
    batch: list[int] = []
    moved: list[np.ndarray] = []
    shifts: list[np.ndarray] = []
    base = edges = 0

    def flush():
        if batch:
            try:
                after, inserted, pairs = split_contours(moved, MAX_NODED_EDGES)
            except NodingLimit:
                return
            sizes = np.array([len(c) for c in after]) != np.array([len(c) for c in moved])
            owner = np.repeat(batch, [len(by_polygon[i]) for i in batch])
            out[batch] = False
            out[owner[sizes]] = True
            _node_batch(by_polygon, owner, after, inserted, pairs, shifts, out, noded)

    boxes = _polygon_boxes(by_polygon)
    for i, mine in enumerate(by_polygon):
        if not mine:
            out[i] = False
            continue
        lo_x, lo_y, hi_x, hi_y = boxes[i]
        size = sum(map(len, mine))
        wide = base + (hi_x - lo_x) + 1 >= SAFE // 2 or hi_y - lo_y >= SAFE // 2
        if wide or edges + size > BATCH_EDGES:
            flush()
            batch, moved, shifts, base, edges = [], [], [], 0, 0
        if hi_x - lo_x >= SAFE // 2 or hi_y - lo_y >= SAFE // 2:
            continue  # too wide for any batch: one by one
        batch.append(i)
        shift = np.array([base - lo_x, -lo_y])
        moved += [c + shift for c in mine]
        shifts += [shift] * len(mine)
        base += hi_x - lo_x + 1
        edges += size
    flush()
    return out, noded


def _polygon_boxes(by_polygon: list[list[np.ndarray]]) -> list[list[int]]:
    """Each polygon's bounding box of its contours' points (x0, y0, x1, y1, inclusive; zeros
    for a polygon without contours), for all polygons in a few numpy calls."""
    contours = [c for mine in by_polygon for c in mine if len(c)]
    if not contours:
        return [[0, 0, 0, 0]] * len(by_polygon)
    points = np.concatenate(contours)
    sizes = np.array([len(c) for c in contours], dtype=np.int64)
    per_polygon = np.array([sum(len(c) > 0 for c in mine) for mine in by_polygon])
    owner = np.repeat(np.arange(len(by_polygon)), per_polygon)
    owner = np.repeat(owner, sizes)  # each point's polygon, ascending
    starts = np.searchsorted(owner, np.arange(len(by_polygon)))
    has = per_polygon > 0
    boxes = np.zeros((len(by_polygon), 4), dtype=np.int64)
    first = starts[has]
    boxes[has, 0:2] = np.minimum.reduceat(points, first, axis=0)
    boxes[has, 2:4] = np.maximum.reduceat(points, first, axis=0)
    return boxes.tolist()


def _node_batch(by_polygon, owner, after, inserted, pairs, shifts, out, noded) -> None:
    """The second round of `_node` for the crossing polygons of a batch (`_crossing`), at
    once: a polygon it splits no more is noded (into `noded`, out False) where `_node` alone
    would have given the same, within its limit, exact filter and size (otherwise it stays
    True, for `_node_polygon`)."""
    crossing = np.flatnonzero(out[owner])  # contours of the batch's crossing polygons
    if not len(crossing):
        return
    try:
        _, more, pairs2 = split_contours([after[c] for c in crossing], MAX_NODED_EDGES)
    except NodingLimit:
        return  # each alone, where its own limit decides
    split_again = set(owner[crossing[np.array(more) > 0]].tolist())
    for i in dict.fromkeys(owner[crossing].tolist()):
        mine = by_polygon[i]
        n = sum(map(len, mine))
        points = np.concatenate(mine)
        exact = points.min() > -SAFE and points.max() < SAFE  # as `_node`'s search is alone
        if i in split_again or not exact or max(pairs, pairs2) >= MAX_NODED_EDGES - n:
            continue
        picks = np.flatnonzero(owner == i)
        contours = [after[c] - shifts[c] for c in picks]
        if sum(map(len, contours)) <= MAX_NODED_EDGES:
            noded[i] = (contours, sum(inserted[c] for c in picks))
            out[i] = False


def _node_polygon(i: int, mine: list[np.ndarray]) -> tuple[list[np.ndarray], int]:
    """`_node` on polygon i's contours, with its limit named in a SceneError."""
    try:
        mine, inserted = _node(mine, MAX_NODED_EDGES - sum(map(len, mine)))
    except NodingLimit:
        raise SceneError(
            f"polygon {i}: its edges cross so often that splitting them at the crossings "
            f"gives more than the limit of {MAX_NODED_EDGES:,} edges per polygon "
            f"({sum(map(len, mine)):,} before splitting); simplify its outline"
        ) from None
    if sum(map(len, mine)) > MAX_NODED_EDGES:
        raise SceneError(
            f"polygon {i}: splitting its edges at the crossings gives "
            f"{sum(map(len, mine)):,} edges, more than the limit of {MAX_NODED_EDGES:,} "
            "per polygon; simplify its outline"
        )
    return mine, inserted


def _node(contours: list[np.ndarray], limit: int | None = None) -> tuple[list[np.ndarray], int]:
    """Split the contours where they cross so that no edge crosses another (docs/noding.md).

    One round of `split_crossings` rounds each crossing to the grid; if nothing crosses or
    touches after it (a second round inserts nothing), that is the noding. Otherwise a
    rounded point moved an edge across or onto another, and the contours are snap-rounded
    instead (`snap_round`, with every vertex and rounded crossing as a hot pixel): no two of
    its edges cross, and a last exact round splits where an edge passes through a vertex or
    overlaps another (points already on the grid, so nothing moves). Should that round ever
    round a crossing (snap rounding's theorem says it cannot), its point becomes hot and the
    snap is redone: the hot points only grow, within the contours' box, so this ends; a
    crossing rounded onto a point already hot would snap the same way again, and is raised
    as a bug. Raises NodingLimit (`geometry`) when more than `limit` points would be inserted.
    """
    once, inserted = split_crossings(contours, limit)
    if not inserted or not split_crossings(once, limit)[1]:
        return once, inserted
    hot = hot_points(contours, limit)
    while True:
        snapped = snap_round(contours, hot, limit)
        noded, _ = split_crossings(snapped, limit)
        points = np.concatenate(noded)
        new = points[~_rows_in(points, np.concatenate(snapped))]  # rounded crossings
        if not len(new):
            added = sum(map(len, noded)) - sum(map(len, contours))
            return noded, max(0, added)
        if _rows_in(new, hot).any():  # snapped again, it would not change: the theorem failed
            raise RuntimeError("snap rounding left two edges crossing (a bug: please report)")
        hot = np.unique(np.concatenate([hot, new]), axis=0)


def _rows_in(rows: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Whether each (x, y) row of `rows` is a row of `table`."""
    known = {tuple(r) for r in table.tolist()}
    return np.array([tuple(r) in known for r in rows.tolist()], dtype=bool)


SIDE_EDGES = 1 << 12  # edges per pass of the side test (whole polygons): its temporaries,
# some 200 bytes an edge, were 30 MiB of the 4,000-glyph page's peak in one pass


def _inside_sides(scene: Scene, coords: np.ndarray, starts: list[int]):
    """Each edge's inside side by its polygon's fill rule ('' if not a boundary), the
    polygons in passes of about SIDE_EDGES edges (a polygon's sides count its own edges
    only, so any cut between polygons gives the same sides); returns the sides and how many
    coincident boundary edges were left to the first of them."""
    inside = np.zeros(len(coords), dtype="<U5")
    starts = np.asarray(starts, dtype=np.int64)
    dropped, a = 0, 0
    while a < len(scene.polygons):
        # the polygons from a whose edges end within SIDE_EDGES of a's first (one at least)
        b = max(a + 1, int(np.searchsorted(starts, starts[a] + SIDE_EDGES, side="right")) - 1)
        lo, hi = starts[a], starts[b]
        group = np.repeat(np.arange(b - a), np.diff(starts[a : b + 1]))
        rules = np.array([p.fill_rule for p in scene.polygons[a:b]])[group]
        part = inside_sides(coords[lo:hi], rules, group).astype("<U5")
        dropped += _drop_coincident(coords[lo:hi], part, group)
        inside[lo:hi] = part
        a = b
    return inside, dropped


def _drop_coincident(coords: np.ndarray, inside: np.ndarray, group: np.ndarray) -> int:
    """Coincident boundary edges of one polygon (`group`: each edge's), shared by two
    contours or overlapping, have the same filled side: the first one draws it, the others
    become interior (their deltas would count the winding twice). Returns how many were
    dropped."""
    edges = np.flatnonzero(inside != "")
    if len(edges) < 2:
        return 0
    p0, p1 = coords[edges, 0:2], coords[edges, 2:4]
    swap = (p0[:, 0] > p1[:, 0]) | ((p0[:, 0] == p1[:, 0]) & (p0[:, 1] > p1[:, 1]))
    keys = np.where(swap[:, None], np.hstack([p1, p0]), np.hstack([p0, p1]))
    keys = np.concatenate([group[edges][:, None], keys], axis=1)
    order = np.lexsort(keys.T[::-1])  # stable: equal keys keep their edge order
    ranked = keys[order]
    repeat = np.all(ranked[1:] == ranked[:-1], axis=1)
    later = order[1:][repeat]
    inside[edges[later]] = ""
    return len(later)


def _write_boxes(coords: np.ndarray, offset, S: int) -> tuple[np.ndarray, ...]:
    """Image pixels lo_x, lo_y, hi_x, hi_y (inclusive) each edge's writes can land on: its
    bounding box grown by WRITE_MARGIN px (docs/model.md s. 5-6)."""
    ox, oy = offset
    lo_x = np.floor_divide(np.minimum(coords[:, 0], coords[:, 2]), S) - WRITE_MARGIN - ox
    hi_x = -np.floor_divide(-np.maximum(coords[:, 0], coords[:, 2]), S) + WRITE_MARGIN - ox
    lo_y = np.floor_divide(np.minimum(coords[:, 1], coords[:, 3]), S) - WRITE_MARGIN - oy
    hi_y = -np.floor_divide(-np.maximum(coords[:, 1], coords[:, 3]), S) + WRITE_MARGIN - oy
    return lo_x, lo_y, hi_x, hi_y


def _polygon_plans(scene: Scene, intensities, starts, boxes, full: int) -> list[PolygonPlan]:
    """Each polygon's window and I_out: the background unless it overlaps an earlier polygon
    or equals the background, then the intensity farthest from I_in."""
    lo_x, lo_y, hi_x, hi_y = boxes
    starts = np.asarray(starts, dtype=np.int64)
    has = starts[1:] > starts[:-1]
    windows = np.zeros((len(scene.polygons), 4), dtype=np.int64)
    if has.any():
        first = starts[:-1][has]
        windows[has] = np.stack(
            [
                np.maximum(0, np.minimum.reduceat(lo_x, first)),
                np.maximum(0, np.minimum.reduceat(lo_y, first)),
                np.minimum(scene.width, np.maximum.reduceat(hi_x, first) + 1),
                np.minimum(scene.height, np.maximum.reduceat(hi_y, first) + 1),
            ],
            axis=1,
        )
    overlaps = _meets_earlier(windows, scene.width, scene.height)
    polys = []
    for i, poly in enumerate(scene.polygons):
        value = intensities[i]
        equal = value == scene.background
        i_out = (
            scene.background
            if not (overlaps[i] or equal)
            else _alternative_out(value, scene.background, full)
        )
        window = tuple(int(v) for v in windows[i])
        a, b = int(starts[i]), int(starts[i + 1])
        polys.append(
            PolygonPlan(i, value, i_out, poly.fill_rule, a, b, window, equal, bool(overlaps[i]))
        )
    return polys


PAIR_ROWS = 128  # rows of `_meets_earlier`'s pair test a pass: six bools a pair per temporary,
# so a block of 8,192 windows is 6 MB a pass (1,024 rows were 15 MB of the map's peak)


STRIP_PIXELS = 1 << 18  # pixels of a strip of `_meets_earlier` (its tables: 9 bytes a pixel)


def _meets_earlier(windows: np.ndarray, width: int, height: int) -> np.ndarray:
    """Whether each window (x0, y0, x1, y1: the pixels [x0, x1) x [y0, y1) of the image)
    shares a pixel with an earlier one, in strips of whole rows of about STRIP_PIXELS
    pixels (the shared pixel lies in some strip, where both windows' parts are): the
    tables of a strip, not of the image (the 5,000-cell map's 1144 x 1144: 12 MB)."""
    out = np.zeros(len(windows), dtype=bool)
    rows = max(1, STRIP_PIXELS // max(width, 1))
    for top in range(0, height, rows):
        bottom = min(top + rows, height)
        k = np.flatnonzero((windows[:, 1] < bottom) & (windows[:, 3] > top))
        part = windows[k].copy()
        part[:, 1::2] = np.clip(part[:, 1::2], top, bottom) - top
        out[k] |= _meets_earlier_in(part, width, bottom - top)
    return out


def _meets_earlier_in(windows: np.ndarray, width: int, height: int) -> np.ndarray:
    """`_meets_earlier` in one image (a strip). In blocks of B windows: against the earlier blocks
    by a summed-area table of the pixels they cover, within the block pair by pair, so
    (P / B) image passes plus P B pairs, with B four times the square root of the image's
    pixels (not P**2 pairs: 66,666 windows would be 2.2e9)."""
    x0, y0, x1, y1 = windows.T
    live = (x0 < x1) & (y0 < y1)
    out = np.zeros(len(windows), dtype=bool)
    cover = np.zeros((height + 1, width + 1), dtype=np.int32)  # 2-D difference array
    # int32 throughout (counts of windows, of pixels: at most MAX_PIXELS), in place: numpy's
    # cumsum of int32 is int64 unless told, twice the image's memory per temporary
    table = np.zeros((height + 1, width + 1), dtype=np.int32)
    block = int(np.clip(4 * math.isqrt(width * height), 64, 8192))  # image passes cost most
    for s in range(0, len(windows), block):
        k = np.arange(s, min(s + block, len(windows)))
        k = k[live[k]]
        if s and len(k):
            np.cumsum(cover, axis=0, dtype=np.int32, out=table)
            np.cumsum(table, axis=1, dtype=np.int32, out=table)
            filled = table[:height, :width] > 0
            np.cumsum(filled, axis=0, dtype=np.int32, out=table[1:, 1:])
            np.cumsum(table[1:, 1:], axis=1, dtype=np.int32, out=table[1:, 1:])
            table[0, :], table[:, 0] = 0, 0
            hits = table[y1[k], x1[k]] - table[y0[k], x1[k]] - table[y1[k], x0[k]]
            out[k] = hits + table[y0[k], x0[k]] > 0
        for r in range(0, len(k), PAIR_ROWS):  # the block's pairs, PAIR_ROWS rows at a time
            a, b = k[r : r + PAIR_ROWS, None], k[None, :]
            pairs = (x0[a] < x1[b]) & (x0[b] < x1[a]) & (y0[a] < y1[b]) & (y0[b] < y1[a])
            out[a[:, 0]] |= np.tril(pairs, r - 1).any(axis=1)
        for ys, xs, sign in ((y0, x0, 1), (y0, x1, -1), (y1, x0, -1), (y1, x1, 1)):
            np.add.at(cover, (ys[k], xs[k]), sign)
    return out


def _check_range(config, scene, contours, owners, offset, need=None) -> None:
    """Refuse, naming the first vertex that does not fit, a scene whose vertices do not fit
    the engine's range after the offset (per contour, `need` marks the vertices that must,
    in x and in y; default all)."""
    S = config.subpixel_scale
    hi = config.max_vertex
    if need is None:
        need = [(np.ones(len(p), dtype=bool),) * 2 for p in contours]
    every = all(n[0].all() and n[1].all() for n in need)
    which = "the scene spans" if every else "the edges that reach the image span"
    for axis, name in ((0, "x"), (1, "y")):
        used = np.concatenate([p[n[axis], axis] for p, n in zip(contours, need, strict=True)])
        if not len(used) or used.max() + offset[axis] * S <= hi:
            continue
        for (i, j, kept), pts, n in zip(owners, contours, need, strict=True):
            bad = np.flatnonzero(n[axis] & (pts[:, axis] + offset[axis] * S > hi))
            if len(bad):
                k = int(kept[bad[0]])
                x, y = scene.polygons[i].contours[j][k]
                raise SceneError(
                    f"polygon {i} contour {j} vertex {k} at ({x:g}, {y:g}) px does not fit "
                    f"the configured coordinate range: {which} {name} from "
                    f"{used.min() / S:g} to {used.max() / S:g} px, more than the engine's "
                    f"[0, {hi / S}] px (coord_bits = {config.coord_bits}, subpixel_bits = "
                    f"{config.subpixel_bits})"
                )


# -- rendering ----------------------------------------------------------------------------------


M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3  # glibc's mallopt parameters (malloc.h)
KEEP_FREED = 64 << 20  # bytes of freed memory malloc keeps at the heap's top for reuse
HEAP_ARRAYS = 32 << 20  # blocks up to this size come from the heap (glibc's largest)


def keep_freed_memory() -> bool:
    """Ask glibc's malloc to keep freed memory for reuse (up to KEEP_FREED at the heap's
    top, blocks up to HEAP_ARRAYS from the heap) rather than hand it back to the kernel after
    each numpy temporary: every fresh page costs a fault, about 2.5 us on the measured
    machine (a VM), more than the arithmetic on it (the 1,250-cell map's render 65 -> 40 ms
    CPU, docs/results.md section 7). Process-wide, so `edgeaa render` calls it, not the
    library. False (and nothing done) without glibc."""
    import ctypes

    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    return bool(mallopt(M_MMAP_THRESHOLD, HEAP_ARRAYS)) & bool(
        mallopt(M_TRIM_THRESHOLD, KEEP_FREED)
    )


@dataclass
class Render:
    image: np.ndarray  # (height, width) intensities, the narrowest unsigned type
    plan: Plan
    engine: str
    skip: bool
    sent: np.ndarray  # scene edges sent to the engine, in order
    skipped_equal: np.ndarray  # edges of polygons skipped as I_in == I_out == background
    culled: np.ndarray  # edges culled: wholly above, below or right of the viewport
    projected: np.ndarray  # edges wholly left, sent as their projection
    horizontal: np.ndarray  # horizontal boundary edges not sent (they add nothing)
    # every nonzero delta the engine produced, in image pixels; None in several bands, whose
    # deltas are dropped once composited (what a band touches is all a render holds)
    deltas: DeltaRun | None
    delta_count: int  # nonzero deltas (in bands: those in the image's rows)
    engine_seconds: float  # the engine's own time (`DeltaRun.seconds`, over the bands)
    rows_scanned: int  # buffer rows prefix-summed
    cells_scanned: int  # buffer cells prefix-summed and resolved
    pixel_stores: int  # image pixels written
    seconds: float = 0.0  # whole render
    timings: dict = field(default_factory=dict)  # wall seconds per stage
    cpu: dict = field(default_factory=dict)  # CPU seconds per stage, every thread's
    bands: int = 1  # bands of rows rendered (`render.bands`)
    workers: int = 1  # threads that rendered them
    # Rendered by the hardware pipeline (`edgeaa.render.pipeline.render_pipeline`): its run
    # (clocks, counters; `edgeaa.sim.simulators.pipeline_harness.PipelineRun`) and the pixels
    # where its image differs from the model's.
    pipeline: object | None = None
    pipeline_tile: object | None = None  # its `edgeaa.model.tile.TileConfig`
    mismatches: int | None = None

    @cached_property
    def cycles(self) -> int:
        """The timing model's clocks from the first command to the last beat, the edges sent
        as one stream to the image (not band by band): computed when asked (--stats)."""
        from ..model.edge import setup_batch

        arrays = edge_arrays(self.plan, self.sent, clip=self.skip)
        setups = setup_batch(self.plan.config, *arrays.args(), arrays.clip)
        return cycles_of(self.plan.config, (setups.columns, setups.clipped_start), DELTAS)


def edges_to_send(plan: Plan, skip: bool) -> dict[str, np.ndarray]:
    """Which boundary edges go to the engine, and which are skipped by which rule."""
    boundary = plan.boundary
    none = np.zeros_like(boundary)
    if not skip and not plan.in_range:
        raise SceneError(
            "without skipping every edge goes to the engine, but the scene's edges wholly "
            f"outside the image do not fit its coordinate range (coord_bits = "
            f"{plan.config.coord_bits}); render with skipping (no --no-skip or --stats)"
        )
    if not skip:
        return dict(sent=np.flatnonzero(boundary), equal=none, culled=none, left=none, flat=none)
    skipped_poly = np.array([p.equal and not p.overlaps for p in plan.polygons], dtype=bool)
    equal = boundary & skipped_poly[plan.polygon] if len(plan.polygons) else none
    live = boundary & ~equal
    culled = live & plan.culled
    flat = live & ~culled & plan.horizontal
    left = live & ~culled & ~flat & plan.left
    sent = np.flatnonzero(live & ~culled & ~flat)
    return dict(sent=sent, equal=equal, culled=culled, left=left, flat=flat)


def render_scene(
    scene: Scene | Plan,
    config: EdgeConfig | None = None,
    *,
    engine: str = "model",
    skip: bool = True,
    progress=None,
    canvas=None,
    rows: int | None = None,
    workers: int = 1,
) -> Render:
    """Render a scene (or a plan of one): the deltas from `engine` (the model, or the
    stepper core alone in a simulator), accumulated and resolved by the model. The whole
    pipeline in hardware is `edgeaa.render.pipeline.render_pipeline`. progress(done, total,
    stage). A `canvas` (`edgeaa.render.paint.Canvas`, for a colour scene planned as its
    coverage) composites instead, and its image is the render's. The model's render with
    skipping goes in bands of `rows` rows (`render.bands`; None: about BAND_COLUMNS columns
    a band), the others in one; the image is the same either way. `workers` threads render
    the bands (numpy releases the GIL in its loops): less wall time, more CPU and memory
    (docs/results.md section 7)."""
    start = time.perf_counter()
    plan = scene if isinstance(scene, Plan) else plan_scene(scene, config or EdgeConfig())
    chosen = edges_to_send(plan, skip)
    sent = chosen["sent"]
    timings = {"plan": time.perf_counter() - start, "engine": 0.0, "accumulate": 0.0}
    cpu = {"engine": 0.0, "accumulate": 0.0}
    # The narrowest unsigned type that holds full scale: a 16384 x 16384 image is 256 MiB.
    dtype = np.min_scalar_type(plan.config.full_scale)
    image = np.full((plan.scene.height, plan.scene.width), plan.scene.background, dtype=dtype)
    image = image if canvas is None else canvas.image
    counts = {"rows": 0, "cells": 0, "stores": 0, "columns": 0}
    bands = _bands(plan, sent, rows if engine == "model" and skip and canvas is None else 0)
    windows = np.array([p.window for p in plan.polygons], dtype=np.int64).reshape(-1, 4)
    work = partial(_render_band, plan, windows, image, engine, skip, canvas, progress, len(bands))
    workers = min(workers, len(bands))
    made = {"deltas": 0, "seconds": 0.0}
    with ThreadPoolExecutor(workers) if workers > 1 else nullcontext() as pool:
        for done, deltas in (pool or builtins).map(work, bands):  # in order, as they finish
            for name in counts:
                counts[name] += done.counts[name]
            for name in cpu:
                timings[name] += done.wall[name]
                cpu[name] += done.cpu[name]
            made["deltas"] += len(deltas)
            made["seconds"] += deltas.seconds
            if counts["columns"] > MAX_STEPPED_COLUMNS:
                _refuse_columns(counts["columns"], len(bands) > 1)
    if canvas is not None:
        canvas.finish()  # the group layers still open
    if progress is not None:
        progress(len(plan.polygons), len(plan.polygons), "accumulate")
    return Render(
        image=image,
        plan=plan,
        engine=engine,
        skip=skip,
        sent=sent,
        skipped_equal=np.flatnonzero(chosen["equal"]),
        culled=np.flatnonzero(chosen["culled"]),
        projected=np.flatnonzero(chosen["left"]),
        horizontal=np.flatnonzero(chosen["flat"]),
        deltas=deltas if len(bands) == 1 else None,
        delta_count=made["deltas"],
        engine_seconds=made["seconds"],
        rows_scanned=counts["rows"],
        cells_scanned=counts["cells"],
        pixel_stores=counts["stores"],
        seconds=time.perf_counter() - start,
        timings=timings,
        cpu=cpu,
        bands=len(bands),
        workers=workers,
    )


@dataclass
class _BandWork:
    """What one band's render did: its counts, and wall and CPU seconds per stage."""

    counts: dict = field(
        default_factory=lambda: dict.fromkeys(("rows", "cells", "stores", "columns"), 0)
    )
    wall: dict = field(default_factory=lambda: {"engine": 0.0, "accumulate": 0.0})
    cpu: dict = field(default_factory=lambda: {"engine": 0.0, "accumulate": 0.0})

    @contextmanager
    def stage(self, name: str):
        """Add the block's wall seconds and this thread's CPU seconds to the stage's."""
        wall, used = time.perf_counter(), time.thread_time()
        yield
        self.wall[name] += time.perf_counter() - wall
        self.cpu[name] += time.thread_time() - used


def _render_band(plan, windows, image, engine, skip, canvas, progress, bands: int, band: Band):
    """One band: its deltas from the engine, accumulated, resolved and composited into its
    rows of `image` (bands share no pixel, so they may run in threads). Returns what it did
    and its deltas."""
    done = _BandWork()
    with done.stage("engine"):
        deltas = _band_deltas(plan, band, engine, skip, progress, done.counts, bands > 1)
    with done.stage("accumulate"):
        cut = _band_windows(windows, band) if skip else None
        _accumulate(plan, deltas, cut, image, skip, done.counts, canvas, progress)
    return done, deltas


def _bands(plan: Plan, sent: np.ndarray, rows: int | None) -> list[Band]:
    """The bands of `rows` rows the image is rendered in (`render.bands`): None chooses by
    the edges' size, 0 is one band (the whole image, every edge sent, the deltas not cut to
    its rows); one band also with the truncated accumulator, whose clipped start may round
    differently (docs/model.md 5.1)."""
    height = plan.scene.height
    if rows == 0 or plan.config.accumulator != "exact":
        return [Band(0, height, sent)]
    S = plan.config.subpixel_scale
    coords = plan.coords[sent]
    if rows is None:  # columns along each edge's major axis, about
        extent = np.maximum(abs(coords[:, 2] - coords[:, 0]), abs(coords[:, 3] - coords[:, 1]))
        rows = band_rows(height, int((extent // S + 1).sum()))
    _, lo_y, _, hi_y = _write_boxes(coords, plan.offset, S)
    return split_bands(height, rows, sent, lo_y, hi_y)


def _band_windows(windows: np.ndarray, band: Band) -> np.ndarray:
    """The polygons' windows cut to the band's rows."""
    cut = windows.copy()
    cut[:, 1] = np.maximum(cut[:, 1], band.y0)
    cut[:, 3] = np.minimum(cut[:, 3], band.y1)
    return cut


RUN_EDGES = 1 << 12  # edges the model sets up at once within a band (some 400 bytes an edge)
RUN_COLUMNS = 1 << 13  # and steps at once: its deltas, zeros and all, are 128 bytes a column
# (and as much again in `in_image`) until the nonzero ones in the band are kept, narrowed


def _band_deltas(plan: Plan, band: Band, engine: str, skip: bool, progress, counts, cut: bool):
    """The nonzero deltas of the band's edges (clipped to the band's rows when `cut`, and
    only those in its rows kept), in image pixels, in the narrowest integer types. The model
    sets up the band's edges RUN_EDGES at a time and steps them about RUN_COLUMNS columns at
    a time, each run cut down as it comes; a simulator takes the band as one stream (its
    clocks count the whole stream)."""
    arrays = edge_arrays(plan, band.edges, clip=skip)
    if cut:
        arrays = replace(arrays, clip=_band_clip(plan, band, arrays))
    rows, bounds = ((band.y0, band.y1) if cut else None), _delta_range(plan.config)
    model = engine == "model"
    step = RUN_EDGES if model else max(len(arrays), 1)
    runs = []
    for start in range(0, max(len(arrays), 1), step):
        ids, edges = band.edges[start : start + step], arrays.take(slice(start, start + step))
        setups = _check_columns(plan.config, edges, counts, cut)
        states = setups.columns.astype(np.int64) + 1  # an edge of no column costs a little
        parts = weighted_runs(states, RUN_COLUMNS) if model else []
        for part in parts or [slice(None)]:
            report = _run_report(progress, engine, start + (part.start or 0), len(arrays))
            run, _ = run_deltas(
                plan.config, edges.take(part), engine, progress=report, setups=setups.take(part)
            )
            runs.append(run.in_image(ids[part], plan.offset, rows, bounds))
    return runs[0] if len(runs) == 1 else DeltaRun.joined(runs)


def _run_report(progress, engine: str, first: int, total: int):
    """The engine's progress(done, total) of a run whose edges start at the band's `first`,
    said as progress(done in the band, the band's `total`, engine); None without progress."""
    if progress is None:
        return None
    return lambda done, _: progress(first + done, total, engine)


def _band_clip(plan: Plan, band: Band, arrays: EdgeArrays) -> tuple[np.ndarray, ...]:
    """Each edge's clip window in the band: the accumulation clip cut to the band's rows and
    to the columns where the edge's line is near them (`bands.band_columns`)."""
    top = 1 << plan.config.coord_bits
    oy = plan.offset[1]
    y_min, y_max = min(oy + band.y0, top), min(oy + band.y1 - 1, top)
    coords = np.stack([arrays.x0, arrays.y0, arrays.x1, arrays.y1], axis=1)
    lo, hi = band_columns(coords, plan.config.subpixel_scale, y_min, y_max)
    whole = plan.accumulation_clip
    x_min, x_max = np.clip(lo, whole.x_min, whole.x_max), np.clip(hi, whole.x_min, whole.x_max)
    return x_min, np.full_like(x_min, y_min), x_max, np.full_like(x_min, y_max)


def _delta_range(config: EdgeConfig) -> tuple[int, ...]:
    """The bounds of a delta's image x and y and its value (`DeltaRun.in_image`)."""
    reach = 4 << config.coord_bits  # image pixels: 2**W and the offset, with margins
    delta = config.register_widths()["delta"]
    return (-reach, reach, delta.min, delta.max)


def _check_columns(config: EdgeConfig, arrays: EdgeArrays, counts, cut: bool):
    """Count the columns the edges step (in bands, each band's: a column near two bands' rows
    is stepped in both); refuse past MAX_STEPPED_COLUMNS (the simulators hold every
    column's four cells: about 300 bytes a column at its peak). Returns their setups (a
    `SetupBatch`, which the engine takes on)."""
    from ..model.edge import setup_batch

    setups = setup_batch(config, *arrays.args(), arrays.clip)
    counts["columns"] += int(setups.columns.sum())
    if counts["columns"] > MAX_STEPPED_COLUMNS:
        _refuse_columns(counts["columns"], cut)
    return setups


def _refuse_columns(columns: int, banded: bool):
    so_far = " in the bands rendered so far" if banded else ""
    raise SceneError(
        f"the scene's edges step {columns:,} columns{so_far} (pixels along each edge's major "
        f"axis, within the image's rows and left of its right side), more than the limit of "
        f"{MAX_STEPPED_COLUMNS:,}; use fewer or shorter edges"
    )


def _accumulate(plan: Plan, deltas: DeltaRun, windows, image, skip: bool, counts, canvas, progress):
    """Accumulate, resolve and composite the deltas polygon by polygon in order, many
    polygons to a buffer (`_accumulation_runs`) without a canvas, over `windows` (each
    polygon's, cut to a band; None: the whole image, without skipping)."""
    polygon_of = plan.polygon[deltas.edge]
    # the engine keeps the edges' order, and a polygon's edges are consecutive: no sort then
    order = None if (np.diff(polygon_of) >= 0).all() else np.argsort(polygon_of, kind="stable")
    by_poly = np.searchsorted(
        polygon_of if order is None else polygon_of[order], np.arange(len(plan.polygons) + 1)
    )
    drawn = np.flatnonzero(by_poly[1:] > by_poly[:-1]).tolist()
    batch = skip and canvas is None and deltas.delta.dtype != object  # a canvas: one by one
    for run in _accumulation_runs(plan, drawn, windows) if batch else [[[i]] for i in drawn]:
        if progress is not None:
            progress(run[0][0], len(plan.polygons), "accumulate")
        polys = np.array([i for wave in run for i in wave])
        lo, size = by_poly[polys], by_poly[polys + 1] - by_poly[polys]
        picks = np.repeat(lo - (np.cumsum(size) - size), size) + np.arange(size.sum())
        picks = picks if order is None else order[picks]  # the polygons' deltas, in order
        if len(polys) == 1:
            poly = plan.polygons[polys[0]]
            window = None if windows is None else windows[polys[0]]
            _draw_polygon(plan, poly, deltas.take(picks), image, window, counts, canvas)
        else:
            _draw_run(plan, run, deltas.take(picks), size, image, counts, windows)


RUN_POLYGONS = 4096  # polygons accumulated in one buffer at most (`_accumulation_runs`)
RUN_CELLS = 1 << 16  # and its cells: some 60 bytes a cell of temporaries (1 << 18 was 4 MB
# more at the maps' peaks)
RUN_PAIRS = 1 << 22  # candidate window pairs past which runs are not looked for


def _accumulation_runs(plan: Plan, drawn: list[int], windows=None) -> list[list[list[int]]]:
    """The polygons `drawn` in runs to accumulate in one buffer each (`_draw_run`), each run
    a list of waves: no two windows of a wave share a pixel, and a polygon's wave comes after
    the wave of every earlier polygon whose window meets its own (one more than theirs), so
    compositing wave by wave keeps the order wherever it matters. A run holds at most
    RUN_POLYGONS polygons and RUN_CELLS cells of buffer (its windows' areas at most); a
    polygon with an empty window draws nothing and is a run of its own. Past RUN_PAIRS
    candidate pairs (windows heaped on each other), every polygon is a run of its own, in
    order. `windows`: every polygon's (default the plan's)."""
    if windows is None:
        windows = np.array([p.window for p in plan.polygons], dtype=np.int64).reshape(-1, 4)
    boxes = windows[np.asarray(drawn, dtype=np.int64)]
    live = (boxes[:, 2] > boxes[:, 0]) & (boxes[:, 3] > boxes[:, 1])
    ids = np.flatnonzero(live)
    pairs = _meeting_windows(boxes[ids])
    if pairs is None:
        return [[[i]] for i in drawn]
    a, b = np.sort(np.stack(pairs), axis=0)  # positions in ids, a before b in drawn order
    by_later = np.lexsort((a, b))
    wave = [0] * len(ids)
    for j, k in zip(a[by_later].tolist(), b[by_later].tolist(), strict=True):
        if wave[j] >= wave[k]:  # every pair ending at j came before: wave[j] is final
            wave[k] = wave[j] + 1
    areas = ((boxes[ids, 2] - boxes[ids, 0]) * (boxes[ids, 3] - boxes[ids, 1])).tolist()
    polys = np.asarray(drawn)[ids].tolist()
    runs = [[[drawn[i]]] for i in np.flatnonzero(~live)]
    run: list[list[int]] = []
    last = size = cells = 0
    for k in np.argsort(wave, kind="stable").tolist():  # by wave, in order within one
        if run and (size >= RUN_POLYGONS or cells + areas[k] > RUN_CELLS):
            runs.append(run)
            run, size, cells = [], 0, 0
        if not run or wave[k] != last:
            run.append([])
        run[-1].append(polys[k])
        last, size, cells = wave[k], size + 1, cells + areas[k]
    return runs + [run] if run else runs


def _meeting_windows(boxes: np.ndarray):
    """The pairs (a, b) of windows (x0, y0, x1, y1, none empty) that share a pixel: a sweep
    along x (sorted by x0, each window's partners are those starting before its x1), then y.
    None past RUN_PAIRS candidates."""
    order = np.argsort(boxes[:, 0], kind="stable")
    start = boxes[order, 0]
    counts = np.searchsorted(start, boxes[order, 2], side="left") - np.arange(1, len(order) + 1)
    counts = np.maximum(counts, 0)
    if counts.sum() > RUN_PAIRS:
        return None
    a = np.repeat(np.arange(len(order)), counts)
    b = a + 1 + np.arange(len(a)) - np.repeat(np.cumsum(counts) - counts, counts)
    a, b = order[a], order[b]
    meet = (boxes[a, 1] < boxes[b, 3]) & (boxes[b, 1] < boxes[a, 3])
    return a[meet], b[meet]


class _InPlace(ArrayArith):
    """`ArrayArith` whose abs and min write into their first operand: the fill rule on a
    buffer of `_draw_run`'s own, without a fresh array (and its pages) per step."""

    @staticmethod
    def abs(a):
        return np.abs(a, out=a)

    @staticmethod
    def min(a, b):
        return np.minimum(a, b, out=a)


def _draw_run(plan: Plan, run: list[list[int]], deltas: DeltaRun, sizes, image, counts, windows):
    """`_draw_polygon` on every polygon of a run (`_accumulation_runs`) at once: each
    polygon's touched rows, each as wide as its window, laid end to end in one flat buffer
    whose first cell of a row takes away the previous row's total, so that one prefix sum
    gives every row's own. The coverage is composited wave by wave (the windows of a wave
    share no pixel). Every pixel gets exactly what `_draw_polygon` gives it, in the same
    order, with the numpy calls paid once per run, and once per wave to composite.
    `windows`: every polygon's."""
    config = plan.config
    ids = [i for wave in run for i in wave]
    polys = [plan.polygons[i] for i in ids]
    x0, y0, x1, y1 = windows[ids].T
    d = np.array([abs(p.intensity - p.i_out) for p in polys], dtype=np.int64)
    value = np.array([p.intensity for p in polys], dtype=np.int64)
    odd = np.array([p.rule == "evenodd" for p in polys], dtype=bool)
    k = np.repeat(np.arange(len(polys)), sizes)  # each delta's polygon (`sizes` deltas each)
    x, y, delta = deltas.x, deltas.y, deltas.delta
    keep = (y >= y0[k]) & (y < y1[k]) & (x < x1[k])
    k, y, delta = k[keep], y[keep], delta[keep]
    x = np.maximum(x[keep], x0[k]) - x0[k]
    # the rows touched, in order of polygon then row, without a sort: each window's rows
    base = np.cumsum(y1 - y0) - (y1 - y0)
    key = base[k] + y - y0[k]
    touched = np.zeros(int((y1 - y0).sum()), dtype=bool)
    touched[key] = True
    rows = np.flatnonzero(touched)
    owner = np.searchsorted(base, rows, side="right") - 1
    image_row = rows - base[owner] + y0[owner]
    row_of = np.cumsum(touched)[key] - 1
    width = (x1 - x0)[owner]
    start = np.cumsum(width) - width
    # |a row's partial sums| <= its sum of |delta|, a cell <= that and the previous row's;
    # int32 when these, 2 ifix (even-odd's period) and ifix + 2**F fit (half the memory)
    shift = d << config.F
    size = np.zeros(len(rows), dtype=np.int64)
    np.add.at(size, row_of, np.abs(delta.astype(np.int64)))  # alike types: add.at's fast loop
    bound = max(int(size.max(initial=0)), int(shift.max(initial=0)) + (1 << config.F))
    dtype = np.int32 if 2 * bound < 1 << 31 else np.int64
    delta = delta.astype(dtype)
    sums = np.zeros(int(width.sum()), dtype=dtype)
    np.add.at(sums, start[row_of] + x, delta)
    totals = np.zeros(len(rows), dtype=dtype)
    np.add.at(totals, row_of, delta)
    sums[start[1:]] -= totals[:-1]
    np.cumsum(sums, out=sums)  # in place: every fresh array costs its pages
    same = len(shift) and (shift == shift[0]).all()
    ifix = int(shift[0]) if same else np.repeat(shift[owner].astype(dtype), width)
    odd_cells = np.repeat(odd[owner], width) if odd.any() else None
    folded = None if odd_cells is None else evenodd_coverage(ArrayArith, sums, ifix)
    coverage = nonzero_coverage(_InPlace, sums, ifix)  # sums becomes the coverage
    if odd_cells is not None:
        np.copyto(coverage, folded, where=odd_cells)
    counts["rows"] += len(rows)
    counts["cells"] += len(sums)
    # intensity_offset(c) > 0 iff c >= half a step: only those cells are rounded
    covered = coverage >= 1 << (config.F - 1)
    cells = np.flatnonzero(covered)  # by row: by polygon, so by wave
    row = np.repeat(np.arange(len(rows)), np.add.reduceat(covered, start, dtype=np.int64))
    mine = owner[row]
    qq = intensity_offset(coverage[cells].astype(np.int64), config.F)
    pixel = image_row[row] * image.shape[1] + (cells - start[row] + x0[mine])
    value, d = value[mine], d[mine]
    waves = np.cumsum([0] + [len(wave) for wave in run])
    flat = image.reshape(-1, copy=False)  # a view (an error rather than a copy)
    for lo, hi in itertools.pairwise(np.searchsorted(mine, waves).tolist()):
        w = slice(lo, hi)
        _composite_into(flat, pixel[w], qq[w], value[w], d[w], counts)


def _composite_into(flat, pixel, q, value, d, counts) -> None:
    """Composite `value` at coverage `q` of `d` over the pixels `pixel` of the flattened
    image (each may be an array, one per pixel), storing only the pixels that change."""
    below = flat[pixel].astype(np.int64)
    full = q == d  # whole pixels take the intensity, no division
    new = np.where(full, value, composite(below, q, value, d))
    changed = new != below
    counts["stores"] += int(np.count_nonzero(changed))
    flat[pixel[changed]] = new[changed]


def _draw_polygon(
    plan: Plan, poly: PolygonPlan, deltas: DeltaRun, image, window, counts, canvas=None
):
    """Accumulate one polygon's deltas over `window` (x0, y0, x1, y1; None: the whole
    image), resolve, composite over the image (or over the canvas's channels)."""

    config, scene = plan.config, plan.scene
    d = abs(poly.intensity - poly.i_out)
    x0, y0, x1, y1 = (0, 0, scene.width, scene.height) if window is None else map(int, window)
    window = Window(x0, y0, x1, y1)
    ifix = d << config.F
    for block in resolve_rows(window, deltas.x, deltas.y, deltas.delta, poly.rule, ifix):
        counts["rows"] += len(block.rows)
        counts["cells"] += block.cells_scanned
        q = intensity_offset(block.coverage, config.F)
        rows, cols = np.nonzero(q)  # only covered pixels change
        rows, cols = block.rows[rows], cols + x0
        qq = q[q != 0].astype(np.int64)
        if canvas is not None:
            canvas.draw(poly.index, rows, cols, qq, d)
            counts["stores"] += len(qq)
            continue
        flat = image.reshape(-1, copy=False)  # a view (an error rather than a copy)
        _composite_into(flat, rows * scene.width + cols, qq, poly.intensity, d, counts)
