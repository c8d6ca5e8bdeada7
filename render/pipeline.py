"""A scene through the tile pipeline: per tile, the ops of `edgeaa.model.tile` (tile start,
each polygon's delta beats and end, flush), and the image from the tiles' frames; and a
scene rendered by the simulated hardware pipeline (`render_pipeline`): the commands of
`scene_commands` into `edgeaa.hdl.pipeline.EdgePipeline` in Verilator or Amaranth's
simulator, the image from the pixels it sends.

The image is cut into tiles of `TileConfig` size, row by row. For each tile the polygons
with an edge in its rows are sent in order, each edge with the tile as its clip window
(without its left bound: columns left of the tile carry their cover into it). An edge that
can write in the tile's columns is sent as it is; the edges wholly left of the tile are sent
as their cover per row, merged per polygon into a few vertical edges on the column left of
the tile (a glyph wholly left of it gives none), so no edge is set up and stepped again in
every tile to its right. Edges wholly above, below or right of the tile, and the edges
`edges_to_send` skips, are not sent. With the model's tile stages (`TileModel`) the image is
the renderer's, bit for bit (tested).

A colour scene (planned as its coverage, `edgeaa.render.paint`) goes through a pipeline of
3 channels (`TileConfig.channels`; 4, alpha too, for a translucent background): each
polygon's begin carries its paint and alpha, each tile its background, from the `Canvas`
(`tile_paints`). Its image is the canvas's, bit for bit.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, replace

import numpy as np

from ..model import Clip, Edge
from ..model.pipeline import Command, PipelineConfig, pipeline_config
from ..model.tile import (
    EMPTY_END,
    SCAN_START,
    Beats,
    Flush,
    PolygonEnd,
    TileConfig,
    TileModel,
    TileStart,
    pack_paint,
    resolve_latency,
)
from ..model.timing import EMPTY_EDGE_CYCLES, setup_latency, start_clip_cycles, unit_cycles
from .engines import EngineUnavailable, run_deltas
from .render import (
    EdgeArrays,
    Plan,
    Render,
    _write_boxes,
    edges_to_send,
    render_scene,
)
from .scene import SceneError

PIPELINE_ENGINES = ("verilator", "amaranth")  # simulators of the whole pipeline
# The most clocks (`clock_estimate`, an upper estimate: 1.2 to 2.1 times the cycle model's
# clocks on the built-ins, the HUD, serif text and the 1080p scene; up to 2.6 times with two
# scan lanes) a scene may need in each
# simulator: 60 s of Verilator at its measured 1 to 1.5 million clocks per second; for
# Amaranth's simulator (about 500 clocks per second) the built-ins' 1.3 million
# (docs/scenes.md, "Errors and limits").
MAX_PIPELINE_CLOCKS = {"verilator": 60_000_000, "amaranth": 1_500_000}


@dataclass(frozen=True)
class TileJob:
    """One tile's work: its image pixels (x, y), its edges (each a command with its clip
    window), the polygon of each edge, the polygons sent, in order, and how many scene edges
    wholly left of the tile its merged vertical edges (`projected`) stand for."""

    x: int
    y: int
    edges: list
    polygon_of_edge: np.ndarray
    polygons: list[int]
    left: int = 0
    projected: int = 0


def tile_jobs(plan: Plan, tile: TileConfig) -> Iterator[TileJob]:
    """The tiles of the image, row by row, with what each needs. An edge that crosses the
    tile's rows is sent if it can write in the tile's columns; the edges wholly left of them
    (every write in a column left of the tile, which the accumulator adds into the row's
    first column) are sent as their cover per row, merged per polygon into vertical edges on
    the column left of the tile (`_merged_projection`)."""
    sent = edges_to_send(plan, skip=True)["sent"]
    lo_x, lo_y, hi_x, hi_y = (
        box[sent] for box in _write_boxes(plan.coords, plan.offset, S_of(plan))
    )
    width, height = plan.scene.width, plan.scene.height
    for ty in range(0, height, tile.height):
        band = (hi_y >= ty) & (lo_y < ty + tile.height)
        for tx in range(0, width, tile.width):
            clip = _tile_clip(plan, tile, tx, ty)
            crossing = sent[band & (lo_x < tx + tile.width) & (hi_x >= tx)]
            left = sent[band & (hi_x < tx)]
            edges = [_clipped(plan.edge(int(e), clip=True), clip) for e in crossing]
            column = plan.offset[0] + tx - 1  # engine pixels: the column left of the tile
            merged, merged_owners = _merged_projection(plan, left, clip, column)
            owners = np.concatenate([plan.polygon[crossing], merged_owners]).astype(np.int64)
            polygons = sorted(set(owners.tolist()))  # the scene's order: they composite
            yield TileJob(tx, ty, edges + merged, owners, polygons, len(left), len(merged))


def _merged_projection(
    plan: Plan, left: np.ndarray, clip: Clip, column: int
) -> tuple[list, np.ndarray]:
    """Vertical edges on `column` (the centre of the one left of the tile) with the same
    cover per tile row as the edges `left`, per polygon. Every write of `left` lands left of
    the tile, where only each row's sum reaches its pixels (the accumulator adds it into the
    row's first column), and an edge's sum over a row is its signed height in the row; so
    the frames are the same. Each edge adds its winding sign over its rows (cut to the
    tile's); the sum w(y) is drawn by `_winding_edges` with as few edges as it has rises of
    |w| (at most one per edge of `left`; a closed contour wholly left of the tile gives
    none)."""
    S = S_of(plan)
    top, bottom = clip.y_min * S - S // 2, clip.y_max * S + S // 2  # the tile's rows
    window = _both(plan.accumulation_clip, clip)
    edges, owners = [], []
    coords, polygon = plan.coords[left], plan.polygon[left]
    inside_left = plan.inside[left] == "left"
    for i in dict.fromkeys(polygon.tolist()):
        mine = polygon == i
        y0, y1 = coords[mine, 1], coords[mine, 3]
        # going down with the inside on the left adds +1 to the winding right of the edge
        sign = np.where((y1 > y0) == inside_left[mine], 1, -1)
        lo, hi = np.maximum(np.minimum(y0, y1), top), np.minimum(np.maximum(y0, y1), bottom)
        keep = lo < hi
        steps: dict[int, int] = {}
        for a, b, s in zip(lo[keep].tolist(), hi[keep].tolist(), sign[keep].tolist(), strict=True):
            steps[a] = steps.get(a, 0) + s
            steps[b] = steps.get(b, 0) - s
        poly = plan.polygons[i]
        for a, b, side in _winding_edges(steps):
            edges.append(
                Edge(column * S, a, column * S, b, side, poly.intensity, poly.i_out, window)
            )
            owners.append(i)
    return edges, np.array(owners, dtype=np.int64)


def _winding_edges(steps: dict[int, int]) -> list[tuple[int, int, str]]:
    """Downward vertical edges (y0, y1, inside) whose winding signs add up to the step
    function with `steps` (y: change of w there): an edge opens where |w| rises and the
    latest open one closes where it falls (all close where w changes sign)."""
    out: list[tuple[int, int, str]] = []
    opened: list[int] = []
    w = 0
    for y in sorted(steps):
        new = w + steps[y]
        if new * w <= 0:  # through zero, or to or from it: close every open edge
            while opened:
                out.append((opened.pop(), y, "left" if w > 0 else "right"))
        while len(opened) > abs(new):
            out.append((opened.pop(), y, "left" if w > 0 else "right"))
        opened += [y] * (abs(new) - len(opened))
        w = new
    return out


def S_of(plan: Plan) -> int:
    return plan.config.subpixel_scale


def _tile_clip(plan: Plan, tile: TileConfig, tx: int, ty: int) -> Clip:
    top = 1 << plan.config.coord_bits
    ox, oy = plan.offset
    return Clip(
        0,
        min(oy + ty, top),
        min(ox + tx + tile.width - 1, top),
        min(oy + ty + tile.height - 1, top),
    )


def _both(a: Clip, b: Clip) -> Clip:
    return Clip(
        max(a.x_min, b.x_min), max(a.y_min, b.y_min), min(a.x_max, b.x_max), min(a.y_max, b.y_max)
    )


def _clipped(edge, clip: Clip):
    return replace(edge, clip=_both(edge.clip, clip))


@dataclass(frozen=True)
class TilePaints:
    """What the tiles composite: the background and each plan polygon's paint, a value per
    channel (None for both: grey, the scene's background and the polygons' intensities)."""

    background: tuple | None
    polygons: tuple


def tile_paints(plan: Plan, tile: TileConfig, canvas=None) -> TilePaints:
    """The paints of `plan` from `canvas` (`edgeaa.render.paint.Canvas`, a colour scene's,
    for a tile of 3 channels, or 4 with alpha: a translucent background), or grey (no canvas,
    1 channel): each polygon's red, green, blue and alpha (`PAINT`), the background's
    channels. A translucent background in 3 channels is refused (SceneError, one line), and so
    is a scene with group opacity (layers) or linear-light blending."""
    if (canvas is not None) != (tile.channels > 1):
        raise ValueError(
            f"a {'colour' if canvas else 'grey'} scene in a {tile.channels}-channel tile"
        )
    if canvas is None:
        return TilePaints(None, (None,) * len(plan.polygons))
    if canvas.layered or canvas.linear:
        what = "group opacity (polygons composited as a layer)" if canvas.layered else (
            "linear-light blending")  # fmt: skip
        raise SceneError(
            f"the scene has {what}: the hardware pipeline composites sRGB values without "
            "layers; use --engine model"
        )
    full, channels, alpha = canvas.full, tile.channels, int(canvas.background[3])
    if channels == 3 and alpha != full:
        raise SceneError(
            f"the background has alpha {alpha} of {full}: a 3-channel pipeline's pixels are "
            "opaque; use 4 channels"
        )
    paints = tuple(tuple(int(v) for v in canvas.paints[p.index]) for p in plan.polygons)
    return TilePaints(tuple(int(v) for v in canvas.background[:channels]), paints)


def tile_ops(
    plan: Plan,
    tile: TileConfig,
    job: TileJob,
    engine: str = "model",
    paints: TilePaints | None = None,
) -> list:
    """The ops of one tile: start, each polygon's beats and end, flush."""
    ox, oy = plan.offset
    paints = paints or tile_paints(plan, tile)
    background = plan.scene.background if paints.background is None else paints.background
    ops: list = [TileStart(ox + job.x, oy + job.y, background)]
    run, _ = run_deltas(plan.config, EdgeArrays.from_edges(plan.config, job.edges), engine)
    cells = np.stack([run.x, run.y, run.delta], axis=1).reshape(-1, 4, 3)
    beat_edge = run.edge[::4]
    beat_polygon = job.polygon_of_edge[beat_edge] if len(beat_edge) else beat_edge
    for i in job.polygons:
        poly = plan.polygons[i]
        ops.append(Beats(cells[beat_polygon == i]))
        ops.append(PolygonEnd(poly.intensity, poly.i_out, poly.rule, paints.polygons[i]))
    ops.append(Flush())
    return ops


def render_tiles(plan: Plan, tile: TileConfig, engine: str = "model", canvas=None) -> np.ndarray:
    """The image, tile by tile, through the tile model (deltas from `engine`); a colour
    scene's (`canvas`, 3 or 4 channels) as (height, width, channels)."""
    model, paints = TileModel(tile), tile_paints(plan, tile, canvas)
    frames = [
        model.run(tile_ops(plan, tile, job, engine, paints))[0] for job in tile_jobs(plan, tile)
    ]
    return image_from_frames(plan, tile, frames)


def scene_commands(plan: Plan, tile: TileConfig, canvas=None) -> list[Command]:
    """The scene as pipeline commands (format `COMMAND_VERSION`): per tile, its start, each
    polygon meeting it (begin, edges, end) and a flush. The top clips each edge to the tile
    (`tile_clip`); an edge wholly left of the image is sent as its projection. A colour
    scene (`canvas`, 3 or 4 channels): each begin with its paint and alpha, each tile
    with its background."""
    ox, oy = plan.offset
    paints, bits = tile_paints(plan, tile, canvas), plan.config.intensity_bits
    background = pack_paint(paints.background or (), bits)
    commands = []
    for job in tile_jobs(plan, tile):
        commands.append(Command.tile(ox + job.x, oy + job.y, plan.scene.background, background))
        mine: dict[int, list] = {}
        for edge, owner in zip(job.edges, job.polygon_of_edge.tolist(), strict=True):
            mine.setdefault(owner, []).append(edge)
        for i in job.polygons:
            poly = plan.polygons[i]
            paint = pack_paint(paints.polygons[i] or (), bits)
            commands.append(Command.begin(poly.intensity, poly.i_out, poly.rule, paint))
            for edge in mine[i]:
                commands.append(Command.edge(edge.x0, edge.y0, edge.x1, edge.y1, edge.inside))
            commands.append(Command.end())
        commands.append(Command.flush())
    return commands


def image_from_frames(plan: Plan, tile: TileConfig, frames) -> np.ndarray:
    """The image from the frames of the tiles of `tile_jobs`, in order ((height, width, 3)
    for a colour tile; every pixel is some tile's)."""
    channels = (tile.channels,) if tile.channels > 1 else ()
    image = np.zeros((plan.scene.height, plan.scene.width, *channels), np.int64)
    for job, frame in zip(tile_jobs(plan, tile), frames, strict=True):
        h = min(tile.height, plan.scene.height - job.y)
        w = min(tile.width, plan.scene.width - job.x)
        image[job.y : job.y + h, job.x : job.x + w] = np.asarray(frame)[:h, :w]
    return image


def render_pipeline(
    plan: Plan,
    engine: str = "verilator",
    pipeline: PipelineConfig | TileConfig | None = None,
    *,
    seed: int | None = None,
    idle: float = 0.0,
    stall: float = 0.0,
    progress=None,
    canvas=None,
) -> Render:
    """Render `plan` through the hardware pipeline in a simulator: the image is the pixels
    the hardware sent. The model's render is made beside it (its figures are the model's
    stepper and accumulation counts) and `Render.mismatches` counts the pixels where the
    two differ (0, or it is a bug). `pipeline`: a `PipelineConfig`, or a `TileConfig` (the
    compact pipeline; None: its default tile). `seed`: random idle clocks and back-pressure.
    A colour scene's `canvas` (a fresh `Canvas`; 3 or 4 channels): the image is the
    canvas's."""
    if engine not in PIPELINE_ENGINES:
        raise EngineUnavailable(f"the pipeline runs in {' or '.join(PIPELINE_ENGINES)}")
    pipeline = pipeline_config(pipeline or TileConfig(plan.config))
    tile = pipeline.tile
    if tile.config != plan.config:
        raise ValueError("the tile's stepper configuration is not the plan's")
    check_clocks(plan, pipeline, engine)
    commands = scene_commands(plan, tile, canvas)
    model = render_scene(plan, skip=True, canvas=canvas)
    report = None if progress is None else (lambda done, total: progress(done, total, engine))
    if engine == "verilator":
        from ..sim.simulators import pipeline_harness

        if report is not None:
            report(0, len(commands))
        run = pipeline_harness.run(pipeline, commands, seed=seed or 0, idle=idle, stall=stall)
        if report is not None:
            report(len(commands), len(commands))
    else:
        from ..sim.simulators.amaranth_sim import run_pipeline

        run = run_pipeline(pipeline, commands, seed=seed, idle=idle, stall=stall, progress=report)
    if run.errors or run.edge_errors:
        raise RuntimeError(
            f"the pipeline dropped {run.errors} commands and {run.edge_errors} edges as bad"
        )
    image = image_from_frames(plan, tile, run.frames(tile))
    if canvas is not None and tile.channels == 3:  # an opaque background: alpha is full
        image = np.concatenate([image, np.full_like(image[..., :1], canvas.full)], axis=-1)
    image = image.astype(model.image.dtype)
    differ = (image != model.image).reshape(*image.shape[:2], -1)
    mismatches = int(np.count_nonzero(differ.any(axis=-1)))
    return replace(
        model, image=image, engine=engine, pipeline=run, pipeline_tile=tile, mismatches=mismatches
    )


def clock_estimate(plan: Plan, pipeline: PipelineConfig | TileConfig) -> tuple[int, int]:
    """An upper estimate of the pipeline's clocks on `scene_commands(plan, tile)`, and of the
    number of those commands, from the plan without making them (numpy, per row of tiles;
    no cycle model), counting what `tile_jobs` sends each tile: the edges crossing it, and
    for each polygon with edges wholly left of it at most as many merged vertical edges as
    it has edges on either side, those culled right of the image included
    (`_merged_projection`: one per rise of the winding of the left edges, which is minus the
    rest's; none for a polygon wholly left of the tile). Each sent edge costs its beats'
    clocks in the accumulator (`_edge_clocks`: an x-major edge steps every column from its
    start to the tile's right side, a y-major one its rows in the tile) and a clock, or its
    unit's `unit_cycles` with them over the setup units if more (`start_clip_cycles` more
    for a start-clipped one); each polygon a setup latency and a scan of its rows in the
    band, from its least cell to its greatest (to the tile's last column if it has an edge
    right of the tile); each tile with a polygon the last scan's way through the resolve,
    and its work or the flush before, whichever is more (a flush runs beside the next tile's
    work); then the last flush, and the clear pass after reset. docs/hardware.md, "The
    clock estimate, an upper bound": on the scenes of `benchmarks/bench_pipeline.py` but the
    1080p one, 1.52 to 2.24 times the cycle model's clocks for compact and 1.89 to 3.10 for
    fast; on 200 random pages in each of 8 x 4, 16 x 8, 32 x 16 and 64 x 32 tiles, compact
    and fast, at least 1.12.
    `edgeaa.model.pipeline_timing.pipeline_cycles` is exact, but takes about 20 us a clock
    and needs the commands."""
    pipeline = pipeline_config(pipeline)
    tile, config = pipeline.tile, plan.config
    sent = edges_to_send(plan, skip=True)["sent"]
    boxes = _write_boxes(plan.coords, plan.offset, S_of(plan))
    lo_x, lo_y, hi_x, hi_y = (box[sent] for box in boxes)
    # edges culled right of the image: not sent, but they take part in the winding that
    # the merged edges carry into a tile (a polygon wider than the image)
    beyond = np.flatnonzero(plan.boundary & plan.culled & (boxes[0] >= plan.scene.width))
    beyond_lo_y, beyond_hi_y, beyond_owner = (
        boxes[1][beyond],
        boxes[3][beyond],
        plan.polygon[beyond],
    )
    c = plan.coords[sent]
    dx, dy = abs(c[:, 2] - c[:, 0]), abs(c[:, 3] - c[:, 1])
    x_major = dx >= dy
    slope = np.minimum(dx, dy) / np.maximum(np.maximum(dx, dy), 1)  # minor over major
    units = pipeline.setup_units
    unit = unit_cycles(config, units, pipeline.deltas)  # a unit's clocks per edge, but its columns

    # four scan lanes are counted as two: never more clocks a beat (`beat_clocks`) nor a
    # row's scan (its span widened to beats of four is at most two more cells than to pairs)
    lanes = min(pipeline.scan_lanes, 2)
    per_cell = 2 // lanes  # accumulator clocks per minor line a beat touches
    setup = unit / units
    clipped = start_clip_cycles(config, pipeline.deltas) / pipeline.setup_units
    # a polygon's first edge, over its setup
    latency = setup_latency(config, pipeline.deltas) - setup
    owner = plan.polygon[sent]
    width, height = plan.scene.width, plan.scene.height
    tiles_x = np.arange(0, width, tile.width)
    clocks, commands = float(tile.pixels), 0  # the clear pass after a reset: a cell a clock
    flush = tile.pixels // pipeline.pixel_lanes + 8  # a flush's beats and its latency
    for ty in range(0, height, tile.height):
        band = np.flatnonzero((hi_y >= ty) & (lo_y < ty + tile.height))
        b_lo_x, b_hi_x, b_major, b_slope = lo_x[band], hi_x[band], x_major[band], slope[band]
        rows = np.minimum(hi_y[band], ty + tile.height - 1) - np.maximum(lo_y[band], ty) + 1
        starts_above = ~b_major & (lo_y[band] < ty)  # y-major, its start cut by the tile
        ahead = beyond_owner[(beyond_hi_y >= ty) & (beyond_lo_y < ty + tile.height)]
        mine, wider, merged, extent = _band_polygons(
            owner[band], b_hi_x, lo_y[band], hi_y[band], tile, ty, len(tiles_x), ahead
        )
        for t, tx in enumerate(tiles_x):
            right = tx + tile.width - 1
            crossing = (b_lo_x <= right) & (b_hi_x >= tx)
            span = np.minimum(b_hi_x, right) - b_lo_x + 1
            # an x-major edge steps every column from its start (or the image's left) to
            # the tile's right, those outside the band's rows too (their cells dropped, a
            # clock each); a y-major edge its rows in the band (the window cuts both ends)
            columns = np.where(b_major, span, rows)
            n_merged = merged[:, t]
            sent_edges = int(crossing.sum() + n_merged.sum())
            # a polygon with an edge right of the tile's left side in the band's rows
            on_right = wider.copy()
            on_right[mine[b_hi_x > right]] = True
            present, scanned = _tile_scans(
                mine[crossing],
                b_lo_x[crossing],
                b_hi_x[crossing],
                n_merged > 0,
                on_right,
                extent,
                tx,
                right,
            )
            costs = per_cell, unit, units
            work = _edge_clocks(columns[crossing], b_slope[crossing], *costs).sum()
            work += (_edge_clocks(extent, 0, *costs) * n_merged).sum()  # vertical: no minor step
            work += clipped * (crossing & starts_above).sum()
            work += (latency + 8) * present + scanned / lanes
            if present:  # the last scan's cells through the resolve before the flush reads
                work += SCAN_START + resolve_latency(tile, pipeline.product_stages)
            # the flush (its beats) runs beside the next tile's work
            clocks += max(work, flush)
            commands += sent_edges + 2 * int(present) + 2
    return int(clocks + flush), commands  # and the last tile's flush, after all the work


def _edge_clocks(columns, slope, per_cell: int, unit: float, units: int):
    """An edge's clocks in a stream (`clock_estimate`): its beats' clocks in the accumulator
    and a clock (the stepper waits for each), or its unit's clocks (`unit`) and those over
    the `units` (a unit holds the edge while it is stepped). A beat (a column of the major
    axis) has nonzero cells in one line of the minor axis, two a line (`per_cell`: one
    accumulator clock each, or a pair a clock with two or four scan lanes), and in two lines where
    the edge steps along the minor axis, at most ``ceil(columns * slope)`` times:
    docs/hardware.md, "The clock estimate, an upper bound". For the fast core, which copies
    the bank, both terms count ``C`` or a clock too many: an over-estimate, as the engines'
    clock limits want."""
    holds = per_cell * (columns + np.ceil(columns * slope))
    return np.maximum(holds + 1, (unit + holds) / units)


def _tile_scans(k, lo_x, hi_x, projected, on_right, extent, tx: int, right: int):
    """The polygons a tile scans and the cells they scan, at most: the band's polygons with
    an edge crossing the tile (`k`, their indices, and the edges' write boxes `lo_x`,
    `hi_x`) or a merged edge in it (`projected`), each over its rows in the band (`extent`),
    from its least cell to its greatest, on to the tile's last column if its interior may go
    on there (`on_right`: it has an edge right of the tile's right side in the band's rows;
    without one the winding there is zero), from the tile's first column if merged edges
    carry its winding in from the left."""
    n = len(extent)
    present = projected.copy()
    present[k] = True
    first = np.full(n, right + 1, dtype=np.int64)
    np.minimum.at(first, k, np.maximum(lo_x + 1, tx))
    last = np.full(n, tx - 1, dtype=np.int64)
    np.maximum.at(last, k, np.minimum(hi_x - 1, right))
    last[on_right] = right
    first[projected] = tx
    rows = np.where(present, extent, 0)
    return int((rows > 0).sum()), int((rows * np.maximum(last + 1 - first, 0)).sum())


def _band_polygons(owner, hi_x, lo_y, hi_y, tile: TileConfig, ty: int, tiles: int, ahead):
    """Per edge of a band of tiles its polygon's index among the band's (`mine`), and per
    polygon: whether it has edges culled right of the image in the band (`wider`), for each
    tile at most how many merged edges it gets there (`merged`, polygons x tiles) and its
    rows in the band (`extent`). Merged
    edges carry the winding of the edges wholly left of a tile, one at most for each of
    them and for each of the others (those culled right of the image included: their
    polygons `ahead`)."""
    polygons, mine = np.unique(owner, return_inverse=True)
    ahead = np.asarray(ahead, dtype=np.int64)
    ahead = ahead[np.isin(ahead, polygons)]
    beyond = np.bincount(np.searchsorted(polygons, ahead), minlength=len(polygons))
    # the first tile it is wholly left of (0 for an edge left of the image)
    left_of = np.clip(hi_x // tile.width + 1, 0, tiles)
    left = np.zeros((len(polygons), tiles + 1), dtype=np.int64)
    np.add.at(left, (mine, left_of), 1)
    left = np.cumsum(left, axis=1)[:, :tiles]
    total = np.bincount(mine, minlength=len(polygons))
    merged = np.minimum(left, (total + beyond)[:, None] - left)
    top = np.full(len(polygons), ty + tile.height, dtype=np.int64)
    np.minimum.at(top, mine, np.maximum(lo_y, ty))
    bottom = np.full(len(polygons), ty - 1, dtype=np.int64)
    np.maximum.at(bottom, mine, np.minimum(hi_y, ty + tile.height - 1))
    return mine, beyond > 0, merged, bottom - top + 1


def check_clocks(plan: Plan, tile: PipelineConfig | TileConfig, engine: str) -> None:
    """Refuse (SceneError, one line) a scene whose `clock_estimate` passes the engine's
    limit, before any command is made or the simulator built: it would run for minutes or
    hours."""
    (clocks, commands), limit = clock_estimate(plan, tile), MAX_PIPELINE_CLOCKS[engine]
    tile = pipeline_config(tile).tile
    if clocks > limit:
        raise SceneError(
            f"the scene needs about {clocks:,} pipeline clocks ({commands:,} commands in "
            f"{tile.width} x {tile.height} tiles), more than the {engine} engine's limit of "
            f"{limit:,}; use --engine model, or fewer or smaller polygons"
        )


@dataclass(frozen=True)
class PipelineSaving:
    """What one of the pipeline's skipping rules saves on a scene: how many things it skips
    and the clocks of the stage that would otherwise spend them (`edgeaa.model.timing`,
    `edgeaa.model.tile`'s cycle model); each rule alone, so they do not add up exactly."""

    rule: str
    skipped: int
    clocks: int


def pipeline_savings(plan: Plan, tile: TileConfig) -> list[PipelineSaving]:
    """The savings of `scene_commands` and the tile stages on `plan`."""
    sent = edges_to_send(plan, skip=True)["sent"]
    model = TileModel(tile)
    edges_not_sent = polygons_not_sent = ends = rows = cells = left = merged = 0
    for job in tile_jobs(plan, tile):
        edges_not_sent += len(sent) - (len(job.edges) - job.projected) - job.left
        left, merged = left + job.left, merged + job.projected
        polygons_not_sent += len(plan.polygons) - len(job.polygons)
        for op in tile_ops(plan, tile, job):
            result = model.feed(op)
            if isinstance(op, PolygonEnd):
                ends, rows, cells = ends + 1, rows + result.rows, cells + result.cells
    unscanned = ends * tile.height - rows
    return [
        PipelineSaving(
            "edges not meeting a tile (not sent to it; each would take the setup)",
            edges_not_sent,
            edges_not_sent * EMPTY_EDGE_CYCLES,
        ),
        PipelineSaving(
            "edges wholly left of a tile (merged into vertical edges; a setup each)",
            left - merged,
            (left - merged) * EMPTY_EDGE_CYCLES,
        ),
        PipelineSaving(
            "polygons not meeting a tile (no begin, no end)",
            polygons_not_sent,
            polygons_not_sent * EMPTY_END,
        ),
        PipelineSaving(
            "tile rows with no delta (not scanned at an end)", unscanned, unscanned * tile.width
        ),
        PipelineSaving(
            "columns of a touched row outside the scan span (not scanned at an end)",
            rows * tile.width - cells,
            rows * tile.width - cells,
        ),
        PipelineSaving("clear as each cell is read (no clear pass)", cells, cells),
    ]


def savings_table(savings: list[PipelineSaving]) -> str:
    lines = [f"{'pipeline: saving of each rule alone':70} {'skipped':>8} {'clocks':>10}"]
    lines += [f"{s.rule:70} {s.skipped:8,d} {s.clocks:10,d}" for s in savings]
    return "\n".join(lines)
