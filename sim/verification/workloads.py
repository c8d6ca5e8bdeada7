"""Seeded edge streams for co-simulation and benchmarks, and seeded random scenes for the
pipeline (`random_scene`); each replayable from its seed alone."""

from __future__ import annotations

import math
import random
from collections.abc import Iterator
from dataclasses import replace
from itertools import islice

from ...model import Clip, Edge, EdgeConfig, EdgeError, setup
from ...render.scene import Polygon, Scene

CLIP_KINDS = ("empty", "start", "end", "both", "loose")


def random_sim_edges(
    config: EdgeConfig,
    count: int,
    seed: int,
    *,
    max_pixels: int = 48,
    bad_fraction: float = 0.0,
    clip_fraction: float = 0.0,
) -> list[Edge]:
    """`count` edges in all octants with sub-pixel endpoints, random sides and intensities.

    Major deltas are up to `max_pixels` pixels (the simulators' time goes into columns);
    about `bad_fraction` of the commands are bad (zero length or I_in == I_out), which the core
    must drop and count. About `clip_fraction` of the edges get a random clip window
    (`random_clip`: some hold none of the edge's columns, some cut its start, its end or
    both); the others keep clip None. The windows come from their own generator, so the
    geometry is the same whatever `clip_fraction` is. The first `count` of `iter_sim_edges`.
    """
    draw = iter_sim_edges(
        config,
        seed,
        max_pixels=max_pixels,
        bad_fraction=bad_fraction,
        clip_fraction=clip_fraction,
    )
    return list(islice(draw, count))


def iter_sim_edges(
    config: EdgeConfig,
    seed: int,
    *,
    max_pixels: int = 48,
    bad_fraction: float = 0.0,
    clip_fraction: float = 0.0,
) -> Iterator[Edge]:
    """The edges of `random_sim_edges`, one at a time and without end, so a caller can take
    them in pieces of bounded size. Each edge's geometry comes from one generator and its
    window from another, each used in edge order, so the pieces are the edges of one draw."""
    rng = random.Random(seed)
    clip_rng = random.Random(f"clip/{seed}")
    hi = config.max_vertex
    span = min(hi, max_pixels * config.subpixel_scale)
    full = config.full_scale
    while True:
        x0, y0 = rng.randint(0, hi), rng.randint(0, hi)
        x1 = min(hi, max(0, x0 + rng.randint(-span, span)))
        y1 = min(hi, max(0, y0 + rng.randint(-span, span)))
        i_in, i_out = rng.randint(0, full), rng.randint(0, full)
        if rng.random() < bad_fraction:
            if rng.random() < 0.5:
                x1, y1 = x0, y0
            else:
                i_out = i_in
        elif (x0, y0) == (x1, y1):
            x1 = x0 + 1 if x0 < hi else x0 - 1
        elif i_in == i_out:
            i_out = full - i_in if 2 * i_in != full else 0
        inside = rng.choice(("left", "right"))
        edge = Edge(x0, y0, x1, y1, inside=inside, i_in=i_in, i_out=i_out)
        if clip_fraction and clip_rng.random() < clip_fraction:
            edge = replace(edge, clip=random_clip(config, edge, clip_rng))
        yield edge


def major_columns(config: EdgeConfig, edge: Edge) -> tuple[int, int, int]:
    """(first, last, step): the major-axis pixels of the edge's first and last unclipped
    columns and the direction from first to last (+1 or -1). For a bad command, a guess
    from its endpoints (the core drops it whatever the window)."""
    unclipped = replace(edge, clip=None)
    try:
        st = setup(config, unclipped)
    except EdgeError:
        scale = config.subpixel_scale
        x_major = abs(edge.x1 - edge.x0) >= abs(edge.y1 - edge.y0)
        a, b = (edge.x0, edge.x1) if x_major else (edge.y0, edge.y1)
        first, last = (a + scale // 2) // scale, (b + scale // 2) // scale
        return first, last, 1 if last >= first else -1
    first, step = (st.x, st.col_dx) if st.x_major else (st.y, st.col_dy)
    return first, first + (st.columns - 1) * step, step


def random_clip(config: EdgeConfig, edge: Edge, rng: random.Random) -> Clip:
    """A random window for `edge`, of a kind drawn from `CLIP_KINDS`: ``empty`` holds none of
    its columns (min > max, or all before or after them), ``start``/``end``/``both`` cut at
    least one column at that end when the edge has two or more (so the rest is not empty),
    ``loose`` holds all of them with room to spare. The minor-axis bounds, which the core
    ignores, are random and in either order."""
    top = 1 << config.coord_bits
    first, last, step = major_columns(config, edge)
    lo, hi = min(first, last), max(first, last)
    n = hi - lo + 1
    kind = rng.choice(CLIP_KINDS)
    if kind == "empty":
        choices = ["inverted"] + (["below"] if lo > 0 else []) + (["above"] if hi < top else [])
        where = rng.choice(choices)
        if where == "below":
            a = rng.randint(0, lo - 1)
            a_min, a_max = a, rng.randint(a, lo - 1)
        elif where == "above":
            a = rng.randint(hi + 1, top)
            a_min, a_max = rng.randint(hi + 1, a), a
        else:
            a_max = rng.randint(0, top - 1)
            a_min = rng.randint(a_max + 1, top)
    elif kind == "loose":
        a_min, a_max = rng.randint(0, lo), rng.randint(hi, top)
    else:
        cut_start = kind in ("start", "both") and n > 1
        cut_end = kind in ("end", "both") and n > 1
        # Columns kept: [keep_lo, keep_hi] within [0, n - 1] counted from the lo side.
        keep_lo, keep_hi = 0, n - 1
        start_is_lo = step > 0
        if cut_start and cut_end and n > 2:
            a, b = sorted(rng.sample(range(1, n - 1), 2)) if n > 3 else (1, 1)
            keep_lo, keep_hi = a, b
        elif cut_start or cut_end:
            k = rng.randint(1, n - 1)  # columns cut
            if cut_start == start_is_lo:  # cutting the lo side
                keep_lo = k
            else:
                keep_hi = n - 1 - k
        a_min, a_max = lo + keep_lo, lo + keep_hi
    b_min, b_max = rng.randint(0, top), rng.randint(0, top)
    if abs(edge.x1 - edge.x0) >= abs(edge.y1 - edge.y0):
        return Clip(a_min, b_min, a_max, b_max)
    return Clip(b_min, a_min, b_max, a_max)


# -- random scenes ---------------------------------------------------------------------------

# The largest random scene, in pixels: up to 3 x 3 default tiles (64 x 32), so edges cross tile
# borders both ways, and one scene simulates in well under a second (60 ms on average, 1,000
# scenes on the shared 2-core machine).
SCENE_WIDTH, SCENE_HEIGHT = 160, 80
SCENE_POLYGONS = 4  # the most polygons in a random scene
MARGIN = 8  # pixels a random vertex may lie outside the image (culled and projected edges)


def random_scene(config: EdgeConfig, seed: int) -> Scene:
    """The random scene of `seed`: 1 to `SCENE_POLYGONS` polygons on a background, each of one
    or two contours that are either simple (vertices in angle order round a centre) or
    random vertex soups (self-intersecting, several windings), either fill rule, and an
    intensity from a few levels (0, quarters of full scale) or any; the image is 4 to
    `SCENE_WIDTH` x 2 to `SCENE_HEIGHT` pixels and vertices lie on the sub-pixel grid, some
    outside the image."""
    rng = random.Random(f"edgeaa-scene/{seed}")
    full = config.full_scale
    levels = [0, full // 4, full // 2, 3 * full // 4, full]
    width, height = rng.randint(4, SCENE_WIDTH), rng.randint(2, SCENE_HEIGHT)
    polygons = []
    for index in range(rng.randint(1, SCENE_POLYGONS)):
        contours = tuple(
            _contour(rng, width, height, config.subpixel_scale) for _ in range(rng.randint(1, 2))
        )
        intensity = rng.choice(levels) if rng.random() < 0.7 else rng.randint(0, full)
        rule = rng.choice(("nonzero", "evenodd"))
        polygons.append(Polygon(contours, intensity, rule, f"polygon {index}"))
    background = rng.choice(levels)
    return Scene(width, height, tuple(polygons), background, name=f"random scene {seed}")


def _contour(rng: random.Random, width: int, height: int, scale: int) -> tuple:
    """A simple contour (star-shaped round a random centre) or, half the time, a soup of
    random vertices; 3 to 12 vertices on the 1/`scale` pixel grid."""
    count = rng.randint(3, 12)
    if rng.random() < 0.5:
        points = [
            (rng.uniform(-MARGIN, width + MARGIN), rng.uniform(-MARGIN, height + MARGIN))
            for _ in range(count)
        ]
    else:
        cx, cy = rng.uniform(0, width), rng.uniform(0, height)
        reach = rng.uniform(1, max(width, height) / 2 + MARGIN)
        turns = sorted(rng.uniform(0, 2 * math.pi) for _ in range(count))
        points = []
        for turn in turns:
            r = rng.uniform(0.2, 1) * reach
            points.append((cx + r * math.cos(turn), cy + r * math.sin(turn)))
    return tuple((round(x * scale) / scale, round(y * scale) / scale) for x, y in points)
