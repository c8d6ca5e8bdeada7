"""The scene renderer: fill polygons, antialias their edges with an engine, combine, composite.

Steps (docs/scenes.md has the reasoning):

1. `plan_scene`: quantize the vertices to the sub-pixel grid (round half up), shift the
   scene by whole pixels so every vertex is in the engine's range, split edges where they
   cross, and classify every edge: its inside side by the fill rule (winding numbers over
   all the polygon's contours, just left and just right of its midpoint); not a boundary
   (filled on both sides or neither); wholly outside the viewport; horizontal or vertical;
   on a pixel boundary. The boundary edges are linked into the outline of the filled region
   and each vertex of it classified for `combine`. Each polygon gets I_out: the background
   when it overlaps no earlier polygon (its edge writes are then final intensities straight
   from the engine), otherwise the intensity farthest from I_in (the finest coverage the
   engine can give, composited in integers).
2. `render_scene`: send the edges that need antialiasing to the engine, each with the image as
   its clip window (the core steps only the columns inside it); compute the writes of
   horizontal and vertical edges on the fill path (`axis_writes`, bit-identical to the
   model); for each polygon in order, fill the pixels whose centre is inside (scanline,
   same fill rule), combine the writes of each pixel into one coverage (`combine`), and
   composite over what is below in integers.

With ``skip=False`` every boundary edge goes to the engine unclipped, nothing is culled, every
write is applied and each polygon is composited over the whole image: the image is the same,
bit for bit (tested); the difference is the work, which `edgeaa render --stats` reports.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..model import Clip, Edge, EdgeConfig, setup
from ..model.column import ArrayArith, IntArith, output_value
from ..model.edge import fold
from .engines import EngineRun, cycles, run_engine
from .geometry import (
    halfplane_coverage,
    halfplane_samples,
    inside_sides,
    sample_mask,
    split_crossings,
)
from .scene import Scene, SceneError

# How two consecutive edges of a chain combine at their shared vertex (see `combine`).
# Convex vertices (the intersection of the insides): min, product, sum - 1; reflex ones (the
# union): max, sum - product, sum. op % 3 is the class: gentle, medium, sharp.
OP_MIN, OP_MUL, OP_AND, OP_MAX, OP_POR, OP_OR = range(6)
NEAR_NUM, NEAR_DEN = 5, 4  # a vertex within this many px of a pixel's centre is near it
WRITE_MARGIN = 2  # px: every write lies within the edge's bounding box grown by this much


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
    next: np.ndarray  # next boundary edge along the outline of the filled region, or -1
    prev: np.ndarray  # previous one, or -1
    inside: np.ndarray  # 'left', 'right' or '' (not a boundary)
    culled: np.ndarray  # wholly outside the viewport: no write can land in the image
    axis: np.ndarray  # horizontal or vertical
    pixel_boundary: np.ndarray  # horizontal or vertical on a pixel boundary
    ops: np.ndarray  # OP_* at the vertex between edge e and next[e]; -1 if not both boundary
    polygons: list[PolygonPlan]
    dropped_contours: int = 0  # contours that collapsed to fewer than 3 vertices
    crossings: int = 0  # vertices inserted where edges cross (split_crossings)
    duplicates: int = 0  # coincident boundary edges left to the first of them

    @property
    def boundary(self) -> np.ndarray:
        return self.inside != ""

    @property
    def edge_count(self) -> int:
        return len(self.coords)

    @property
    def viewport(self) -> Clip:
        """The image in engine pixels as the core's clip window (within its range)."""
        top = 1 << self.config.coord_bits
        ox, oy = self.offset
        x_max, y_max = ox + self.scene.width - 1, oy + self.scene.height - 1
        return Clip(min(ox, top), min(oy, top), min(x_max, top), min(y_max, top))

    def edge(self, e: int, clip: bool = False) -> Edge:
        """Edge e as a command; clip: with the viewport as its clip window."""
        p = self.polygons[self.polygon[e]]
        x0, y0, x1, y1 = (int(v) for v in self.coords[e])
        window = self.viewport if clip else None
        return Edge(x0, y0, x1, y1, str(self.inside[e]), p.intensity, p.i_out, window)


def _alternative_out(intensity: int, background: int, full: int) -> int:
    """I_out farthest from I_in (background on a tie): the finest engine coverage."""
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
    # culled: wholly outside the viewport, no write can land in the image
    culled = (hi_x < 0) | (lo_x >= scene.width) | (hi_y < 0) | (lo_y >= scene.height)
    horizontal = coords[:, 1] == coords[:, 3]
    vertical = coords[:, 0] == coords[:, 2]
    axis = horizontal | vertical
    on_line = (2 * coords - S) % (2 * S) == 0  # a coordinate on a pixel boundary (k + 1/2)
    pixel_boundary = (horizontal & on_line[:, 1]) | (vertical & on_line[:, 0])
    nxt, prv = _outline(coords, inside, polygon)
    ops = _vertex_ops(coords, inside, nxt)
    polys = _polygon_plans(scene, intensities, starts, boxes, config.full_scale)
    return Plan(
        config, scene, offset, coords, polygon, contour, nxt, prv, inside, culled, axis,
        pixel_boundary, ops, polys, dropped, crossings, duplicates,
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
    indices of the kept vertices) and how many contours were dropped."""
    contours, owners, dropped = [], [], 0
    for i, poly in enumerate(scene.polygons):
        for j, contour in enumerate(poly.contours):
            pts = np.floor(np.asarray(contour, dtype=np.float64) * S + 0.5)
            keep = np.any(pts != np.roll(pts, 1, axis=0), axis=1)
            pts = pts[keep] if keep.any() else pts[:1]
            if len({tuple(p) for p in pts.tolist()}) < 3:
                dropped += 1
                continue
            contours.append(pts)
            owners.append((i, j, np.flatnonzero(keep) if keep.any() else np.arange(1)))
    return contours, owners, dropped


def _offset(config: EdgeConfig, scene: Scene, contours, owners) -> tuple[int, int]:
    """Whole pixels to add so that no vertex is negative; checks that the scene then fits."""
    S = config.subpixel_scale
    offset = [0, 0]
    if contours:
        allpts = np.concatenate(contours)
        for axis in (0, 1):
            lo = allpts[:, axis].min()
            offset[axis] = max(0, math.ceil(-lo / S))
        _check_range(config, scene, contours, owners, offset)
    return offset[0], offset[1]


def _split_edges(scene: Scene, contours, owners, offset, S: int):
    """The edges of every polygon in engine coordinates, split where they cross.

    Returns coords (E, 4), the polygon and contour of each edge, the first edge of each
    polygon (and the edge count last) and how many vertices were inserted at crossings.
    """
    shift = np.array(offset, dtype=np.int64) * S
    coords, polygon, contour = [], [], []
    starts = [0] * (len(scene.polygons) + 1)
    count = crossings = 0
    for i in range(len(scene.polygons)):
        mine = [
            pts.astype(np.int64) + shift
            for (k, _, _), pts in zip(owners, contours, strict=True)
            if k == i
        ]
        mine, inserted = split_crossings(mine)
        crossings += inserted
        for q in mine:
            n = len(q)
            if n < 2:
                continue
            coords.append(np.concatenate([q, np.roll(q, -1, axis=0)], axis=1))
            polygon.append(np.full(n, i))
            contour.append(np.full(n, len(contour)))
            count += n
        starts[i + 1] = count
    return _joined(coords, 4), _joined(polygon), _joined(contour), starts, crossings


def _joined(parts: list[np.ndarray], width: int | None = None) -> np.ndarray:
    if parts:
        return np.concatenate(parts).astype(np.int64)
    return np.zeros((0, width) if width else 0, dtype=np.int64)


def _inside_sides(scene: Scene, coords: np.ndarray, starts: list[int]):
    """Each edge's inside side by its polygon's fill rule ('' if not a boundary); returns the
    sides and how many coincident boundary edges were left to the first of them."""
    inside = np.full(len(coords), "", dtype="<U5")
    duplicates = 0
    for i, poly in enumerate(scene.polygons):
        a, b = starts[i], starts[i + 1]
        if b > a:
            inside[a:b] = inside_sides(coords[a:b], poly.fill_rule)
            # Coincident boundary edges (shared by two contours, or overlapping) have the
            # same filled side: the first one draws it.
            seen = set()
            for e in range(a, b):
                x0, y0, x1, y1 = coords[e].tolist()
                key = (min((x0, y0), (x1, y1)), max((x0, y0), (x1, y1)))
                if inside[e] and key in seen:
                    inside[e] = ""
                    duplicates += 1
                elif inside[e]:
                    seen.add(key)
    return inside, duplicates


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
    polys = []
    windows = []
    for i, poly in enumerate(scene.polygons):
        a, b = starts[i], starts[i + 1]
        if b > a:
            window = (
                max(0, int(lo_x[a:b].min())),
                max(0, int(lo_y[a:b].min())),
                min(scene.width, int(hi_x[a:b].max()) + 1),
                min(scene.height, int(hi_y[a:b].max()) + 1),
            )
        else:
            window = (0, 0, 0, 0)
        overlaps = any(_meets(window, w) for w in windows)
        windows.append(window)
        value = intensities[i]
        equal = value == scene.background
        i_out = (
            scene.background
            if not (overlaps or equal)
            else _alternative_out(value, scene.background, full)
        )
        polys.append(PolygonPlan(i, value, i_out, poly.fill_rule, a, b, window, equal, overlaps))
    return polys


def _meets(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3] and a[0] < a[2]


def _check_range(config, scene, contours, owners, offset) -> None:
    S = config.subpixel_scale
    hi = config.max_vertex
    allpts = np.concatenate(contours)
    for axis, name in ((0, "x"), (1, "y")):
        top = allpts[:, axis].max() + offset[axis] * S
        if top <= hi:
            continue
        for (i, j, kept), pts in zip(owners, contours, strict=True):
            bad = np.flatnonzero(pts[:, axis] + offset[axis] * S > hi)
            if len(bad):
                k = int(kept[bad[0]])
                x, y = scene.polygons[i].contours[j][k]
                lo = allpts[:, axis].min() / S
                raise SceneError(
                    f"polygon {i} contour {j} vertex {k} at ({x:g}, {y:g}) px does not fit "
                    f"the configured coordinate range: the scene spans {name} from {lo:g} to "
                    f"{allpts[:, axis].max() / S:g} px, more than the engine's [0, {hi / S}] px "
                    f"(coord_bits = {config.coord_bits}, subpixel_bits = "
                    f"{config.subpixel_bits})"
                )


def oriented(coords: np.ndarray, inside: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end of each edge travelled with its inside on the left."""
    left = (inside != "right")[:, None]
    p0, p1 = coords[:, 0:2], coords[:, 2:4]
    return np.where(left, p0, p1), np.where(left, p1, p0)


def _outline(coords: np.ndarray, inside: np.ndarray, polygon: np.ndarray):
    """Link the boundary edges into the outline of each polygon's filled region.

    Travel every boundary edge with the inside on its left; at its end vertex the outline
    continues with the outgoing boundary edge that turns most to the left: the one bounding
    the same filled wedge (at a crossing of an even-odd star, the four edges pair up into
    two wedges). For a simple polygon this is the contour order. -1: no successor.
    """
    start, end = oriented(coords, inside)
    nxt = np.full(len(coords), -1, dtype=np.int64)
    prv = np.full(len(coords), -1, dtype=np.int64)
    outgoing: dict = {}
    boundary = np.flatnonzero(inside != "")
    for e in boundary.tolist():
        outgoing.setdefault((int(polygon[e]), *start[e].tolist()), []).append(e)
    d = (end - start).astype(np.float64)
    for a in boundary.tolist():
        options = outgoing.get((int(polygon[a]), *end[a].tolist()), [])
        if not options:
            continue
        # the turn from a to b, y up: atan2(cross, dot) with y flipped
        ax, ay = d[a, 0], -d[a, 1]
        best = max(
            options,
            key=lambda b: math.atan2(ax * -d[b, 1] - ay * d[b, 0], ax * d[b, 0] + ay * -d[b, 1]),
        )
        nxt[a], prv[best] = best, a
    return nxt, prv


def _vertex_ops(coords: np.ndarray, inside: np.ndarray, nxt: np.ndarray) -> np.ndarray:
    """The combination at the vertex between edge a and b = next[a] (both boundaries).

    With both travelled inside-left: convex when b heads into a's inside (n_a . d_b >= 0,
    n_a the left normal): the polygon is locally the intersection of the two insides, whose
    area lies between c_a + c_b - 1 and min(c_a, c_b). By the turn angle phi between d_a and
    d_b: min when gentle (phi < 45 degrees: the lines nearly agree), the product c_a c_b
    when medium (exact for a right-angled corner on the pixel grid), c_a + c_b - 1 when
    sharp (phi > 135: a thin wedge). Reflex: the union, by the same angles max,
    c_a + c_b - c_a c_b, c_a + c_b. Decided in exact integers. -1: no successor.
    """
    ops = np.full(len(coords), -1, dtype=np.int8)
    linked = np.flatnonzero(nxt >= 0)
    if not len(linked):
        return ops
    start, end = oriented(coords, inside)
    d = (end - start).astype(object)  # Python ints: the squares may be wide
    da, db = d[linked], d[nxt[linked]]
    turn_in = da[:, 1] * db[:, 0] - da[:, 0] * db[:, 1]  # (dy, -dx) . d_b
    ahead = da[:, 0] * db[:, 0] + da[:, 1] * db[:, 1]
    norms = (da[:, 0] ** 2 + da[:, 1] ** 2) * (db[:, 0] ** 2 + db[:, 1] ** 2)
    steep = 2 * ahead * ahead > norms  # |cos phi| > 1/sqrt(2)
    gentle = np.array([bool(a > 0 and s) for a, s in zip(ahead, steep, strict=True)])
    sharp = np.array([bool(a < 0 and s) for a, s in zip(ahead, steep, strict=True)])
    convex = np.array([t >= 0 for t in turn_in], dtype=bool)
    kind = np.where(gentle, OP_MIN, np.where(sharp, OP_AND, OP_MUL))
    ops[linked] = np.where(convex, kind, kind + 3)  # MAX, POR, OR follow MIN, MUL, AND
    return ops


def _column_ranges(config: EdgeConfig, coords: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per edge: x-major, and its stepped columns' first and last major coordinate (screen):
    the model's fold (`edgeaa.model.edge.fold`) on arrays, its folded columns c0 .. c1
    mirrored back when the major axis steps down."""
    zero = np.zeros(len(coords), dtype=np.int64)
    f = fold(ArrayArith(config, np.int64), config, *coords.T, zero, zero, True)
    lo = np.where(f.major_neg, -f.c1, f.c0)
    hi = np.where(f.major_neg, -f.c0, f.c1)
    return f.x_major, lo, hi


# -- the fill path ------------------------------------------------------------------------------


def axis_writes(config: EdgeConfig, edge: Edge) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The writes of a horizontal or vertical edge, exactly as the model makes them.

    With a zero minor delta the increments K and K/2 are 0, so the accumulator keeps its
    start value J in every column: no row step, no neighbour (exit above needs J > ifix, exit
    below J < 0), one write per column, all with value I_B + sign * round(J / 2**F).
    """
    st = setup(config, edge)
    if st.dv != 0:
        raise ValueError(f"not a horizontal or vertical edge: {edge}")
    value = output_value(IntArith(config), config, st, st.jq)
    i = np.arange(st.columns, dtype=np.int64)
    return st.x + i * st.col_dx, st.y + i * st.col_dy, np.full(st.columns, value, np.int64)


# -- rendering ----------------------------------------------------------------------------------


@dataclass
class Writes:
    """Writes in the image: scene edge, image x, y, engine value."""

    edge: np.ndarray
    x: np.ndarray
    y: np.ndarray
    value: np.ndarray

    def __len__(self) -> int:
        return len(self.edge)


@dataclass
class Render:
    image: np.ndarray  # (height, width) int64 intensities
    plan: Plan
    engine: str
    skip: bool
    sent: np.ndarray  # scene edges sent to the engine, in order
    fill_path: np.ndarray  # scene edges drawn on the fill path
    skipped_equal: np.ndarray  # edges of polygons skipped as I_in == I_out
    culled: np.ndarray  # edges culled: wholly outside the viewport
    writes: Writes  # every write landing in the image (engine and fill path)
    engine_writes: int  # writes the engine produced (also outside the image)
    fill_path_writes: int
    not_applied: int  # writes whose pixel ends with the value the fill gives
    zero_writes: int  # writes of coverage 0
    pixel_stores: int  # image pixels written (fill spans and applied writes)
    pixels_touched: int  # image pixels read or written
    cycles: int  # timing model: first command to last write
    engine_run: EngineRun
    seconds: float = 0.0  # whole render
    multi_pixels: int = 0  # pixels combined from several writes of one polygon
    timings: dict = field(default_factory=dict)


def _rdiv(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """num / den rounded half up, den > 0, in integers."""
    return (2 * num + den) // (2 * den)


def composite(below: np.ndarray, q: np.ndarray, intensity: int, d: int) -> np.ndarray:
    """Coverage q / d of intensity over `below`: below + round(q (I - below) / d)."""
    return below + _rdiv(q * (intensity - below), d)


def render_scene(
    scene: Scene | Plan,
    config: EdgeConfig | None = None,
    *,
    engine: str = "model",
    skip: bool = True,
    progress=None,
) -> Render:
    """Render a scene (or a plan of one) through an engine. progress(done, total, stage)."""
    start = time.perf_counter()
    plan = scene if isinstance(scene, Plan) else plan_scene(scene, config or EdgeConfig())
    config = plan.config
    boundary = plan.boundary
    skipped_poly = np.array([p.equal and not p.overlaps for p in plan.polygons], dtype=bool)
    equal = skipped_poly[plan.polygon] & boundary if skip else np.zeros_like(boundary)
    culled = boundary & ~equal & plan.culled if skip else np.zeros_like(boundary)
    fill_path = boundary & ~equal & ~culled & plan.axis if skip else np.zeros_like(boundary)
    sent = np.flatnonzero(boundary & ~equal & ~culled & ~fill_path)
    timings = {"plan": time.perf_counter() - start}

    def report(stage):
        if progress is None:
            return None
        return lambda done, total: progress(done, total, stage)

    t = time.perf_counter()
    edges = [plan.edge(int(e), clip=skip) for e in sent]  # clipped to the image in setup
    run = run_engine(config, edges, engine, progress=report(engine))
    timings["engine"] = time.perf_counter() - t
    t = time.perf_counter()
    parts = [(sent[run.edge_index], run.x, run.y, run.value)]
    fill_ids = np.flatnonzero(fill_path)
    fill_count = 0
    for e in fill_ids:
        x, y, v = axis_writes(config, plan.edge(int(e)))
        parts.append((np.full(len(x), e, dtype=np.int64), x, y, v))
        fill_count += len(x)
    ids, x, y, value = (np.concatenate([p[i] for p in parts]).astype(np.int64) for i in range(4))
    x, y = x - plan.offset[0], y - plan.offset[1]
    inside = (x >= 0) & (x < plan.scene.width) & (y >= 0) & (y < plan.scene.height)
    writes = Writes(ids[inside], x[inside], y[inside], value[inside])
    timings["writes"] = time.perf_counter() - t

    t = time.perf_counter()
    image = np.full((plan.scene.height, plan.scene.width), plan.scene.background, dtype=np.int64)
    order = np.argsort(plan.polygon[writes.edge], kind="stable")
    by_poly = np.searchsorted(plan.polygon[writes.edge][order], np.arange(len(plan.polygons) + 1))
    stats = {"not_applied": 0, "zero": 0, "stores": 0, "touched": 0, "multi": 0}
    for i, poly in enumerate(plan.polygons):
        if progress is not None:
            progress(i, len(plan.polygons), "composite")
        if skip and skipped_poly[i]:
            continue
        rows = order[by_poly[i] : by_poly[i + 1]]
        sub = Writes(*(getattr(writes, n)[rows] for n in Writes.__dataclass_fields__))
        _draw_polygon(plan, poly, sub, image, skip, stats)
    if progress is not None:
        progress(len(plan.polygons), len(plan.polygons), "composite")
    timings["composite"] = time.perf_counter() - t
    return Render(
        image=image,
        plan=plan,
        engine=engine,
        skip=skip,
        sent=sent,
        fill_path=fill_ids,
        skipped_equal=np.flatnonzero(equal),
        culled=np.flatnonzero(culled),
        writes=writes,
        engine_writes=len(run),
        fill_path_writes=fill_count,
        not_applied=stats["not_applied"],
        zero_writes=stats["zero"],
        pixel_stores=stats["stores"],
        pixels_touched=stats["touched"],
        cycles=cycles(config, edges),
        engine_run=run,
        seconds=time.perf_counter() - start,
        multi_pixels=stats["multi"],
        timings=timings,
    )


def _draw_polygon(plan: Plan, poly: PolygonPlan, w: Writes, image, skip: bool, stats) -> None:
    config, scene = plan.config, plan.scene
    S = config.subpixel_scale
    d = abs(poly.intensity - poly.i_out)
    sigma = 1 if poly.intensity > poly.i_out else -1
    if skip:
        x0, y0, x1, y1 = poly.window
    else:
        x0, y0, x1, y1 = 0, 0, scene.width, scene.height
    if x1 <= x0 or y1 <= y0:
        return
    ox, oy = plan.offset
    edges = plan.coords[poly.start : poly.stop]
    ys = (np.arange(y0, y1, dtype=np.int64) + oy) * S
    f = sample_mask(edges, poly.rule, ys, (x0 + ox) * S, S, x1 - x0)
    cols = x1 - x0
    q = sigma * (w.value - poly.i_out)
    stats["zero"] += int(np.count_nonzero(q == 0))
    key = (w.y - y0) * cols + (w.x - x0)
    if len(key) and (key.min() < 0 or key.max() >= (y1 - y0) * cols):
        raise AssertionError("a write outside its polygon's window")  # WRITE_MARGIN is wrong
    keys, qpix, counts, multi = combine(plan, w, q, d, key, f.ravel())
    stats["multi"] += multi
    py, px = keys // cols + y0, keys % cols + x0
    if skip:
        below = image[py, px]
        window = image[y0:y1, x0:x1]
        window[f] = poly.intensity  # the span fill
        new = composite(below, qpix, poly.intensity, d)
        store = new != image[py, px]
        image[py[store], px[store]] = new[store]
        stats["not_applied"] += int(counts[~store].sum())
        stats["stores"] += int(np.count_nonzero(f)) + int(np.count_nonzero(store))
        stats["touched"] += (y1 - y0) * cols
    else:  # composite the whole image: every pixel read and written
        qfull = np.where(f, d, 0).astype(np.int64)
        qfull[py - y0, px - x0] = qpix
        image[:] = composite(image, qfull, poly.intensity, d)
        stats["stores"] += image.size
        stats["touched"] += image.size


def combine(plan: Plan, w: Writes, q, d: int, key, f):
    """One coverage (numerator over d) per written pixel of one polygon (docs/scenes.md).

    w: the polygon's writes, q their coverage numerators, key their pixel's index in the
    polygon's window, f the window's centre samples (flattened). A vertex is *near* a pixel
    when it lies within NEAR_NUM / NEAR_DEN = 1.25 px of the pixel's centre on both axes:
    there an edge's supporting line, which the engine does not clip at the endpoints, stops
    being the boundary.

    - A pixel written by one edge, with neither of its vertices near: that write's coverage.
    - Otherwise the pixel's edges are completed with their vertex partners: across each near
      vertex, the neighbour on the outline joins (and on through further near vertices). A
      partner that did not write the pixel but steps its column or row does not cross the
      pixel: its coverage is its centre sample (0 or all); in a column it does not step, its
      exact half-plane area (rounded to 1/d). Edges joined by a near vertex form a chain,
      folded along its vertices by the vertex's rule (`_vertex_ops`): min, product, sum - 1,
      max, sum - product, sum (clamped); the centre samples h fold with and (convex), or.
    - One chain: its folded coverage. Several chains (a thin stroke or gap, separate parts of
      the outline): f d + sum over chains of (Q_c - h_c d), clamped to [0, d], with f the
      polygon's centre sample: each chain corrects the centre sample by what it covers.

    Returns the pixel keys, their coverage, the writes per pixel and how many were combined.
    """
    S = plan.config.subpixel_scale
    ox, oy = plan.offset
    reach = NEAR_NUM * S // NEAR_DEN  # a vertex this close (each axis) is near, sub-pixel units
    n = len(key)
    if n == 0:
        z = np.zeros(0, dtype=np.int64)
        return z, z, z, 0
    order = np.lexsort((w.edge, key))
    key, q, edge = key[order], q[order], w.edge[order]
    ex, ey = (w.x[order] + ox) * S, (w.y[order] + oy) * S
    h = halfplane_samples(plan.coords[edge], plan.inside[edge] == "left", ex, ey)
    keys, starts, counts = np.unique(key, return_index=True, return_counts=True)
    out = q[starts].copy()
    c = plan.coords[edge[starts]]
    cx, cy = ex[starts], ey[starts]
    near = np.zeros(len(starts), dtype=bool)
    for vx, vy in ((c[:, 0], c[:, 1]), (c[:, 2], c[:, 3])):
        near |= (np.abs(vx - cx) <= reach) & (np.abs(vy - cy) <= reach)
    hard = np.flatnonzero((counts > 1) | near)
    if len(hard):
        coords = plan.coords.tolist()
        joints = oriented(plan.coords, plan.inside)[1].tolist()  # vertex between e and next[e]
        left = (plan.inside == "left").tolist()
        nxt, prv, ops = plan.next.tolist(), plan.prev.tolist(), plan.ops.tolist()
        x_major, c_lo, c_hi = (a.tolist() for a in _column_ranges(plan.config, plan.coords))
        edge_l, q_l, h_l = edge.tolist(), q.tolist(), h.tolist()
        ex_l, ey_l = ex.tolist(), ey.tolist()
        f_l = f.tolist()
        starts_l, counts_l, keys_l = starts.tolist(), counts.tolist(), keys.tolist()

        def sample(e, px, py):
            ax, ay, bx, by = coords[e]
            dx, dy = bx - ax, by - ay
            g = dy * (px - ax) - dx * (py - ay)
            g = g if g else (dy if dy else -dx)
            return int((g > 0) == left[e])

        for j in hard.tolist():
            s, count = starts_l[j], counts_l[j]
            px, py = ex_l[s], ey_l[s]

            def near_end(e, px=px, py=py):  # the vertex between e and next[e] is near
                if e < 0:
                    return False
                vx, vy = joints[e]
                return abs(vx - px) <= reach and abs(vy - py) <= reach

            cov, samp = {}, {}
            for r in range(s, s + count):
                cov[edge_l[r]], samp[edge_l[r]] = q_l[r], h_l[r]
            for e in list(cov):
                for step, joint in ((prv, prv[e]), (nxt, e)):  # joint: edge ending at the vertex
                    partner = step[e]
                    while near_end(joint) and partner >= 0 and partner not in cov:
                        samp[partner] = hp = sample(partner, px, py)
                        major = (px if x_major[partner] else py) // S
                        if c_lo[partner] <= major <= c_hi[partner]:
                            cov[partner] = hp * d  # stepped here, no write: misses the pixel
                        else:  # a column the engine does not step: the exact area
                            cov[partner] = halfplane_coverage(
                                coords[partner], left[partner], px // S, py // S, S, d
                            )
                        joint = step[joint]
                        partner = step[partner]
            linked = {e for e in cov if ops[e] >= 0 and nxt[e] in cov and near_end(e)}
            out[j] = _fold(cov, samp, nxt, linked, ops, d, f_l[keys_l[j]])
    return keys, out, counts, int(np.count_nonzero(counts > 1))


def _apply(op: int, qa: int, qb: int, d: int) -> int:
    if op == OP_MIN:
        return min(qa, qb)
    if op == OP_MUL:
        return (2 * qa * qb + d) // (2 * d)
    if op == OP_AND:
        return max(qa + qb - d, 0)
    if op == OP_MAX:
        return max(qa, qb)
    if op == OP_POR:
        return qa + qb - (2 * qa * qb + d) // (2 * d)
    return min(qa + qb, d)


def _fold(cov: dict, samp: dict, nxt, linked: set, ops, d: int, f: bool) -> int:
    """Fold each chain of linked edges (e -> nxt[e] for e in linked) along its vertices:
    gentle vertices first (pieces of one smooth curve), then medium, then sharp ones (the
    corners between curves), left to right within a class."""
    members = cov.keys()
    heads = {nxt[e] for e in linked}
    starts = [e for e in members if e not in heads]
    seen = set()
    chains = []
    for e in sorted(starts) + sorted(members):  # then cycles, broken at their lowest edge
        if e in seen:
            continue
        seen.add(e)
        items, joints = [(cov[e], samp[e])], []
        while e in linked and nxt[e] not in seen:
            joints.append(ops[e])
            e = nxt[e]
            seen.add(e)
            items.append((cov[e], samp[e]))
        for level in (0, 1, 2):  # OP_MIN/OP_MAX, OP_MUL/OP_POR, OP_AND/OP_OR
            kept_items, kept_joints = [items[0]], []
            for op, item in zip(joints, items[1:], strict=True):
                if op % 3 == level:
                    qa, ha = kept_items[-1]
                    h = ha & item[1] if op < OP_MAX else ha | item[1]
                    kept_items[-1] = (_apply(op, qa, item[0], d), h)
                else:
                    kept_items.append(item)
                    kept_joints.append(op)
            items, joints = kept_items, kept_joints
        chains.append(items[0])
    if len(chains) == 1:
        return chains[0][0]
    total = d * int(f) + sum(qc - hc * d for qc, hc in chains)
    return min(max(total, 0), d)
