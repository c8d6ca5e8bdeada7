"""The configurations and the edge generators the tests share.

Configurations: `GEOMETRY_CONFIGS` (three coordinate, sub-pixel and intensity widths; the model
tests set mode and accumulator per test), `CORE_CONFIGS` (the hardware core's configurations,
modes and accumulators included) and `VECTOR_CONFIG_FIELDS` (the vectorized model's, built with
`vector_config`).

Edge generators (hypothesis strategies, and seeded ones taking a `random.Random`):
`slope_edges` (the major and minor deltas drawn directly, slopes 0 and 1 and the range ends
often), `span_edges` and `random_span_edge` (P1 within a span of P0; axis-aligned and diagonal
often), `random_any_length_edge` (endpoints uniform over the whole range), `edge_commands` and
`random_edge_commands` (good or bad commands for the core, vertices often on pixel centres or
corners, optionally with a clip window `window_near` the edge).

Scenes: `TINY_SCENE` (two polygons, one a path with a curve) and `small_scenes` (hypothesis:
1 to 3 random polygons, both fill rules).
"""

from __future__ import annotations

import random
from dataclasses import replace

import pytest
from hypothesis import strategies as st

from edgeaa.model import Clip, Edge, EdgeConfig
from edgeaa.model.config import ACCUMULATORS, MODES
from edgeaa.render import Polygon, Scene

# -- configurations ----------------------------------------------------------------------------

# The model tests' configurations (bounds, reference, clip): widths only, the tests set the
# mode and the accumulator.
GEOMETRY_CONFIGS = {
    "default": EdgeConfig(),
    "wide": EdgeConfig(coord_bits=15, subpixel_bits=8),
    "tiny": EdgeConfig(coord_bits=5, subpixel_bits=0, intensity_bits=4),
}


# The hardware core's configurations (tests/test_core_*.py).
CORE_CONFIGS = {
    "default": EdgeConfig(),
    "pw": EdgeConfig(mode="pw"),
    "seg2": EdgeConfig(mode="seg2"),
    "seg4": EdgeConfig(mode="seg4"),
    "truncated": EdgeConfig(accumulator="truncated"),
    "small": EdgeConfig(coord_bits=4, subpixel_bits=0, intensity_bits=4),
    "wide": EdgeConfig(coord_bits=15, subpixel_bits=8),
    # The fewest fraction bits allowed: ties of the exact-remainder tests become reachable.
    "lowfrac": EdgeConfig(
        coord_bits=5, subpixel_bits=6, intensity_bits=2, frac_bits=8, mode="seg2"
    ),
}

# The core configurations the default run simulates: the default, seg4 (the mode the README
# recommends), the narrowest and widest words and the fewest fraction bits. pw, seg2 and the
# truncated accumulator differ from these in the model's arithmetic, not the core's
# structure; they run with `-m slow` (the default run's time, README "Tests").
QUICK_CORE_CONFIGS = ("default", "seg4", "small", "wide", "lowfrac")


def core_config_params(*extra: str) -> list:
    """`CORE_CONFIGS`' names (and `extra`) for a parametrize, those not in
    `QUICK_CORE_CONFIGS` marked slow."""
    names = [*CORE_CONFIGS, *extra]
    return [
        pytest.param(name, marks=() if name in QUICK_CORE_CONFIGS + extra else pytest.mark.slow)
        for name in names
    ]


# The vectorized model's configurations (test_vector.py), as EdgeConfig fields by name
# (frac_bits of small_frac is raised to the mode's minimum if needed)
VECTOR_CONFIG_FIELDS = {
    "default": {},
    "wide": dict(coord_bits=15, subpixel_bits=8),
    "tiny": dict(coord_bits=4, subpixel_bits=0, intensity_bits=4),
    "small_frac": dict(frac_bits=9),
    # ifix up to 2**64 - 2**48: beyond int64, exercises the Python-int fallback and object areas
    "bigint": dict(intensity_bits=16, frac_bits=48),
}


def vector_config(name: str, mode: str = "paper", accumulator: str = "exact") -> EdgeConfig:
    """The vector configuration `name` with `mode` and `accumulator`."""
    fields = dict(VECTOR_CONFIG_FIELDS[name], mode=mode, accumulator=accumulator)
    config = EdgeConfig(**{k: v for k, v in fields.items() if k != "frac_bits"})
    if "frac_bits" in fields:
        config = config.with_(frac_bits=max(fields["frac_bits"], config.min_frac_bits))
    return config


# -- edges in all octants ----------------------------------------------------------------------


ANY_SUBPIXEL_BITS, ANY_INTENSITY_BITS = st.integers(0, 8), st.integers(1, 16)


@st.composite
def edge_configs(
    draw, subpixel_bits=ANY_SUBPIXEL_BITS, intensity_bits=ANY_INTENSITY_BITS
) -> EdgeConfig:
    """Any valid `EdgeConfig`: W 2 to 16, every mode and accumulator, the default or any
    allowed fraction bits up to 48 (`subpixel_bits`, `intensity_bits`: their strategies)."""
    config = EdgeConfig(
        coord_bits=draw(st.integers(2, 16)),
        subpixel_bits=draw(subpixel_bits),
        intensity_bits=draw(intensity_bits),
        mode=draw(st.sampled_from(MODES)),
        accumulator=draw(st.sampled_from(ACCUMULATORS)),
    )
    frac_bits = draw(st.none() | st.integers(config.min_frac_bits, 48))
    return config if frac_bits is None else config.with_(frac_bits=frac_bits)


def _anchor(lo: int, hi: int):
    """Integers in [lo, hi], with the ends drawn often."""
    return st.one_of(st.sampled_from((lo, hi)), st.integers(lo, hi))


@st.composite
def slope_edges(draw, config: EdgeConfig, max_pixels: int | None = None) -> Edge:
    """Edges of `config` in all eight octants, both inside sides and any intensities.

    The major delta is at most max_pixels pixels (default: the whole coordinate range); short
    deltas and the special slopes 0 and 1 are drawn often.
    """
    scale = config.subpixel_scale
    hi = config.max_vertex
    limit = hi if max_pixels is None else min(hi, max_pixels * scale)
    major = draw(
        st.one_of(
            st.integers(1, min(limit, 3 * scale)),
            st.integers(1, limit),
            st.just(limit),
        )
    )
    minor = draw(st.one_of(st.sampled_from((0, major)), st.integers(0, major)))
    swap = draw(st.booleans())
    du = draw(st.sampled_from((1, -1))) * major
    dv = draw(st.sampled_from((1, -1))) * minor
    dx, dy = (dv, du) if swap else (du, dv)
    x0 = draw(_anchor(max(0, -dx), min(hi, hi - dx)))
    y0 = draw(_anchor(max(0, -dy), min(hi, hi - dy)))
    inside = draw(st.sampled_from(("left", "right")))
    full = config.full_scale
    i_in = draw(st.one_of(st.none(), st.integers(0, full)))
    i_out = draw(st.integers(0, full).filter(lambda v: v != (full if i_in is None else i_in)))
    return Edge(x0, y0, x0 + dx, y0 + dy, inside=inside, i_in=i_in, i_out=i_out)


# Hypothesis edges stay within this many pixels of P0 so the step model runs fast; the corner
# corpus and the seeded batches cover full-length edges.
SPAN_PX = 96


def _distinct_intensities(config: EdgeConfig, i_in, i_out: int):
    """Make I_in differ from I_out (I_in None means full scale)."""
    resolved = config.full_scale if i_in is None else i_in
    if resolved == i_out:
        i_out = (i_out + 1) % (config.full_scale + 1)
    return i_in, i_out


@st.composite
def span_edges(draw, config: EdgeConfig, span_px: int = SPAN_PX) -> Edge:
    hi, scale = config.max_vertex, config.subpixel_scale
    span = min(hi, draw(st.sampled_from([1, 4, span_px])) * scale + scale - 1)
    x0, y0 = draw(st.integers(0, hi)), draw(st.integers(0, hi))
    shape = draw(st.sampled_from(["any", "any", "horizontal", "vertical", "diagonal"]))
    x1 = draw(st.integers(max(0, x0 - span), min(hi, x0 + span)))
    y1 = draw(st.integers(max(0, y0 - span), min(hi, y0 + span)))
    if shape == "horizontal":
        y1 = y0
    elif shape == "vertical":
        x1 = x0
    elif shape == "diagonal":
        d = min(abs(x1 - x0), y0 if y1 < y0 else hi - y0)
        y1 = y0 + (d if y1 >= y0 else -d)
        x1 = x0 + (d if x1 >= x0 else -d)
    if (x0, y0) == (x1, y1):
        x1 = x0 + 1 if x0 < hi else x0 - 1
    inside = draw(st.sampled_from(["left", "right"]))
    i_in = draw(st.none() | st.integers(0, config.full_scale))
    i_out = draw(st.integers(0, config.full_scale))
    i_in, i_out = _distinct_intensities(config, i_in, i_out)
    return Edge(x0, y0, x1, y1, inside, i_in, i_out)


def random_span_edge(rng: random.Random, config: EdgeConfig, span_px: int | None = None) -> Edge:
    hi = config.max_vertex
    span = hi if span_px is None else min(hi, span_px * config.subpixel_scale)
    while True:
        x0, y0 = rng.randint(0, hi), rng.randint(0, hi)
        x1 = rng.randint(max(0, x0 - span), min(hi, x0 + span))
        y1 = rng.randint(max(0, y0 - span), min(hi, y0 + span))
        if (x0, y0) != (x1, y1):
            break
    fs = config.full_scale
    i_in, i_out = _distinct_intensities(
        config, rng.choice([None, rng.randint(0, fs)]), rng.choice([0, rng.randint(0, fs)])
    )
    return Edge(x0, y0, x1, y1, rng.choice(["left", "right"]), i_in, i_out)


def random_any_length_edge(rng: random.Random, config: EdgeConfig) -> Edge:
    """Any edge of the configuration: endpoints uniform over the whole coordinate range."""
    hi = config.max_vertex
    while True:
        x0, y0, x1, y1 = (rng.randint(0, hi) for _ in range(4))
        if (x0, y0) != (x1, y1):
            break
    full = config.full_scale
    i_in = rng.randint(0, full)
    i_out = (i_in + rng.randint(1, full)) % (full + 1)
    return Edge(x0, y0, x1, y1, inside=rng.choice(("left", "right")), i_in=i_in, i_out=i_out)


# -- edge commands for the core ------------------------------------------------------------------


def snap(config: EdgeConfig, value: int, grid: str) -> int:
    """`value` moved onto a pixel centre or corner (exact geometric coincidences)."""
    S = config.subpixel_scale
    if grid == "centre":
        return value - value % S
    if grid == "corner":
        return min(value - value % S + S // 2, config.max_vertex)
    return value


@st.composite
def edge_commands(draw, config: EdgeConfig, max_pixels: int, clip: bool = False):
    """Edge commands (good or bad) at most `max_pixels` long on each axis, often with their
    vertices on pixel centres or corners; with `clip`, each with a window (`window_near`)."""
    hi, full = config.max_vertex, config.full_scale
    reach = max_pixels * config.subpixel_scale
    x0, y0 = draw(st.integers(0, hi)), draw(st.integers(0, hi))
    x1 = draw(st.integers(max(0, x0 - reach), min(hi, x0 + reach)))
    y1 = draw(st.integers(max(0, y0 - reach), min(hi, y0 + reach)))
    grid = draw(st.sampled_from(("any", "any", "centre", "corner")))
    edge = Edge(
        *(snap(config, value, grid) for value in (x0, y0, x1, y1)),
        inside=draw(st.sampled_from(("left", "right"))),
        i_in=draw(st.integers(0, full)),
        i_out=draw(st.integers(0, full)),
    )
    if clip:
        window = window_near(config, edge, lambda lo, hi: draw(st.integers(lo, hi)))
        edge = replace(edge, clip=window)
    return edge


def window_near(config: EdgeConfig, edge: Edge, pick) -> Clip | None:
    """A clip window for `edge`, drawn with ``pick(lo, hi)`` (an integer in [lo, hi]): none,
    a random one, or bounds within two pixels of the edge's span on both axes, ordered (the
    window cuts the edge's start, its end, both or nothing) or not (often empty)."""
    top, S = 1 << config.coord_bits, config.subpixel_scale
    kind = pick(0, 4)
    if kind == 0:
        return None
    if kind == 1:
        return Clip(*(pick(0, top) for _ in Clip._fields))
    bounds = []
    for a, b in ((edge.x0, edge.x1), (edge.y0, edge.y1)):
        near = (max(0, min(a, b) // S - 2), min(top, -(-max(a, b) // S) + 2))
        low, high = pick(*near), pick(*near)
        bounds.append((min(low, high), max(low, high)) if kind < 4 else (low, high))
    (x_min, x_max), (y_min, y_max) = bounds
    return Clip(x_min, y_min, x_max, y_max)


def random_edge_commands(
    config: EdgeConfig, rng: random.Random, count: int, max_pixels: int, *, clip: bool = False
):
    """Random edge commands (good or bad); with `clip`, each with a window (`window_near`)."""
    hi, full = config.max_vertex, config.full_scale
    reach = max_pixels * config.subpixel_scale
    edges = []
    for _ in range(count):
        x0, y0 = rng.randint(0, hi), rng.randint(0, hi)
        x1 = rng.randint(max(0, x0 - reach), min(hi, x0 + reach))
        y1 = rng.randint(max(0, y0 - reach), min(hi, y0 + reach))
        grid = rng.choice(("any", "any", "centre", "corner"))
        x0, y0, x1, y1 = (snap(config, value, grid) for value in (x0, y0, x1, y1))
        inside = rng.choice(("left", "right"))
        edge = Edge(x0, y0, x1, y1, inside, rng.randint(0, full), rng.randint(0, full))
        if clip:
            edge = replace(edge, clip=window_near(config, edge, rng.randint))
        edges.append(edge)
    return edges


# A scene small enough for Amaranth's simulator: a triangle and an even-odd path with a
# curve, over a grey background (the renderer's, the tile model's and the pipeline's tests).
TINY_SCENE = {
    "width": 20,
    "height": 14,
    "background": 40,
    "polygons": [
        {"points": [[1.5, 1.25], [17.75, 3.5], [8.0625, 12.5]], "intensity": 220},
        {"path": "M 3 11 l 5 -3 q 4 4 -2 5 z", "intensity": 90, "fill_rule": "evenodd"},
    ],
}


def frame_polygon(width: int, height: int, config: EdgeConfig) -> Polygon:
    """A one-pixel frame around a `width` x `height` page (an outer and an inner contour, full
    scale): it reaches every side of the page, so a page's tiles get merged edges."""
    outer = ((0, 0), (width, 0), (width, height), (0, height))
    inner = ((1, 1), (1, height - 1), (width - 1, height - 1), (width - 1, 1))
    return Polygon((outer, inner), config.full_scale, "nonzero", "frame")


@st.composite
def small_scenes(draw, config: EdgeConfig):
    """Scenes of 1 to 3 polygons (1 or 2 contours of 3 to 6 vertices on the 1/16 px grid,
    partly outside the image), either fill rule, random intensities and background."""
    full = config.full_scale
    width, height = draw(st.integers(5, 40)), draw(st.integers(3, 24))
    coord = st.floats(-6, 46, allow_nan=False).map(lambda v: round(v * 16) / 16)
    polygons = []
    for _ in range(draw(st.integers(1, 3))):
        contours = tuple(
            tuple((draw(coord), draw(coord)) for _ in range(draw(st.integers(3, 6))))
            for _ in range(draw(st.integers(1, 2)))
        )
        rule = draw(st.sampled_from(["nonzero", "evenodd"]))
        polygons.append(Polygon(contours, draw(st.integers(0, full)), rule))
    return Scene(width, height, tuple(polygons), background=draw(st.integers(0, full)))
