"""Scenes: parsing, fill rules, the renderer's image against shapely's exact areas, the
skipping rules (savings, and the same image), the engines and the command line.

The renderer accumulates signed-area deltas (docs/algorithm.md section 13); the deltas
themselves, pixel-by-pixel bounds on random shapes and the fill rules are tested in
tests/test_accumulation.py."""

import json
import math
import random
import subprocess
import sys
from dataclasses import replace
from fractions import Fraction

import numpy as np
import pytest
from fixtures import TINY_SCENE, frame_polygon
from hypothesis import given, settings
from hypothesis import strategies as st

from edgeaa.analysis.compare import agg_scene
from edgeaa.cli import main
from edgeaa.model import Edge, EdgeConfig, exact_coverage, setup
from edgeaa.model.beat import DELTAS, WRITES
from edgeaa.model.reference import error_bound
from edgeaa.model.vector import run_edges_deltas
from edgeaa.render import Polygon, Scene, SceneError, builtin, parse_path, parse_scene, render_scene
from edgeaa.render import plan_scene as plan
from edgeaa.render.engines import beat_clocks
from edgeaa.render.exact import crossed_cells, edges_per_pixel, error_rows, exact_image
from edgeaa.render.geometry import halfplane_coverage, split_crossings
from edgeaa.render.scene import flatten_cubic, flatten_quadratic
from edgeaa.render.stats import rule_savings, stats_report

DEFAULT = EdgeConfig()
SEG4 = EdgeConfig(mode="seg4")
BUILTINS = ("starburst", "text")


@pytest.fixture(scope="module")
def plans():
    return {name: plan(builtin(name, DEFAULT), DEFAULT) for name in BUILTINS}


@pytest.fixture(scope="module")
def model_renders(plans):
    return {name: render_scene(p, engine="model") for name, p in plans.items()}


@pytest.fixture(scope="module")
def exact_images(plans):
    """Each built-in's exact reference (the same for every mode: one sub-pixel grid)."""
    return {name: exact_image(p) for name, p in plans.items()}


def star(rule: str, intensity: int = 255) -> Scene:
    """A pentagram: its five edges cross; the inner pentagon has winding number 2."""
    r, cx, cy = 20, 24.3, 23.7
    points = tuple(
        (cx + r * math.sin(4 * math.pi * k / 5), cy - r * math.cos(4 * math.pi * k / 5))
        for k in range(5)
    )
    return Scene(48, 48, (Polygon((points,), intensity, rule),), background=0, name="star")


# -- the scene format ---------------------------------------------------------------------------


def test_a_scene_from_json_text_pauses_the_garbage_collector_and_restores_it(monkeypatch):
    """The parse runs with Python's cyclic collector off (it made the parse superlinear) and
    leaves it as it found it, an error included."""
    import gc

    from edgeaa.render import scene as scene_module
    from edgeaa.render.scene import scene_from_json

    seen, real = [], scene_module.parse_scene

    def parse(*args, **kwargs):
        seen.append(gc.isenabled())
        return real(*args, **kwargs)

    monkeypatch.setattr(scene_module, "parse_scene", parse)
    text = json.dumps({"width": 4, "height": 4, "polygons": [{"points": [[0, 0], [4, 0], [0, 4]]}]})
    assert gc.isenabled() and len(scene_from_json(text).polygons) == 1 and gc.isenabled()
    with pytest.raises(SceneError):
        scene_from_json('{"width": 4}')
    assert gc.isenabled() and seen == [False, False]
    gc.disable()
    try:
        scene_from_json(text)
        assert not gc.isenabled()  # a caller's choice kept
    finally:
        gc.enable()


def test_a_json_scene_with_points_contours_and_path_parses():
    data = {
        "width": 40,
        "height": 30,
        "background": 10,
        "polygons": [
            {"points": [[1, 1], [20, 2.5], [10, 20]], "intensity": 200},
            {
                "contours": [[[2, 2], [30, 2], [30, 25], [2, 25]], [[5, 5], [5, 9], [9, 9]]],
                "fill_rule": "even-odd",
                "name": "box with a hole",
            },
            {"path": "M 1 1 H 9 V 9 Z m 10 0 h 8 v 8 z", "intensity": 0},
        ],
    }
    scene = parse_scene(data)
    assert (scene.width, scene.height, scene.background) == (40, 30, 10)
    first, second, third = scene.polygons
    assert first.contours == (((1, 1), (20, 2.5), (10, 20)),) and first.intensity == 200
    assert second.fill_rule == "evenodd" and len(second.contours) == 2
    assert second.intensity is None  # full scale
    assert third.contours == (
        ((1, 1), (9, 1), (9, 9)),
        ((11, 1), (19, 1), (19, 9)),
    ), "Z closes; m after Z is relative to the subpath's start; the repeated start is dropped"


@pytest.mark.parametrize("digits", ["\u0661\u0662", "\uff11\uff12"])  # Arabic-Indic, full-width
def test_path_numbers_are_ascii_digits_only(digits):
    with pytest.raises(SceneError, match="unexpected"):
        parse_path(f"M 0 0 L {digits} 0 L 0 5 Z")


def test_relative_path_commands_equal_absolute_ones():
    absolute = "M 10 10 L 30 12 H 40 V 30 C 35 40 20 40 15 30 S 5 20 10 15 Q 12 12 14 11 T 10 10 Z"
    relative = (
        "m 10 10 l 20 2 h 10 v 18 c -5 10 -20 10 -25 0 s -10 -10 -5 -15 q 2 -3 4 -4 t -4 -1 z"
    )
    a, r = parse_path(absolute), parse_path(relative)
    assert len(a) == len(r) == 1 and len(a[0]) == len(r[0])
    assert np.allclose(np.array(a[0]), np.array(r[0]), atol=1e-9)
    # implicit repeats: pairs after M are lines, after m relative lines
    assert parse_path("M 0 0 10 0 10 10") == parse_path("M0,0L10,0L10,10")
    assert parse_path("m 0 0 10 0 0 10") == parse_path("M 0 0 L 10 0 L 10 10")
    # S reflects the previous cubic control point; T the previous quadratic one
    s = parse_path("M 0 0 C 10 20 20 20 30 0 S 50 -20 60 0 Z")
    c = parse_path("M 0 0 C 10 20 20 20 30 0 C 40 -20 50 -20 60 0 Z")
    t = parse_path("M 0 0 Q 10 20 20 0 T 40 0 Z")
    q = parse_path("M 0 0 Q 10 20 20 0 Q 30 -20 40 0 Z")
    assert s == c and t == q


def _distance_to_polyline(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    a, b = line[:-1][None], line[1:][None]
    p = points[:, None]
    ab = b - a
    t = np.clip(((p - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-300), 0, 1)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1).min(axis=1)


@pytest.mark.parametrize("tolerance", [1 / 16, 1 / 4, 1.0])
def test_curves_are_flattened_within_the_tolerance(tolerance):
    rng = random.Random(5)
    t = np.linspace(0, 1, 2001)[:, None]
    for _ in range(40):
        p = [np.array([rng.uniform(-50, 50), rng.uniform(-50, 50)]) for _ in range(4)]
        quad = flatten_quadratic(tuple(p[0]), tuple(p[1]), tuple(p[2]), tolerance)
        curve = (1 - t) ** 2 * p[0] + 2 * t * (1 - t) * p[1] + t**2 * p[2]
        line = np.array([p[0], *quad])
        assert _distance_to_polyline(curve, line).max() <= tolerance * (1 + 1e-9)
        cubic = flatten_cubic(*(tuple(v) for v in p), tolerance)
        curve = (
            (1 - t) ** 3 * p[0]
            + 3 * t * (1 - t) ** 2 * p[1]
            + 3 * t**2 * (1 - t) * p[2]
            + t**3 * p[3]
        )
        line = np.array([p[0], *cubic])
        assert _distance_to_polyline(curve, line).max() <= tolerance * (1 + 1e-9)
    # and not wastefully: a gentle curve needs few chords
    assert len(flatten_quadratic((0, 0), (8, 1), (16, 0), 1 / 16)) <= 3


BAD_SCENES = [
    ({"height": 5, "polygons": []}, "missing field 'width'"),
    ({"width": 5, "height": 5}, "missing field 'polygons'"),
    ({"width": 0, "height": 5, "polygons": []}, "width must be at least 1"),
    ({"width": 5, "height": 5, "polygons": [], "colour": 3}, "unknown field 'colour'"),
    (
        {"width": 5, "height": 5, "polygons": [{"points": [[0, 0], [1, 1]]}]},
        "polygon 0 has 2 distinct vertices; a contour needs at least 3",
    ),
    (
        {"width": 5, "height": 5, "polygons": [{"points": [[0, 0], [1, 1], [0, 0]]}]},
        "polygon 0 has 2 distinct vertices",
    ),
    (
        {"width": 5, "height": 5, "polygons": [{"points": [[0, 0], [1, "a"], [2, 0]]}]},
        "polygon 0 vertex 1 y must be a number",
    ),
    (
        {
            "width": 5,
            "height": 5,
            "polygons": [{"points": [[0, 0], [1, 1], [2, 0]], "fill_rule": "winding"}],
        },
        "unknown fill_rule 'winding' (allowed: nonzero, evenodd",
    ),
    ({"width": 5, "height": 5, "polygons": [{"intensity": 3}]}, "needs exactly one of"),
    (
        {"width": 5, "height": 5, "polygons": [{"path": "M 0 0 A 1 1 0 2 1 2 2 Z"}]},
        "arc flag 2 at command 'A' (position 6) must be 0 or 1",
    ),
    (
        {"width": 5, "height": 5, "polygons": [{"path": "M 0 0 h 3 v 3", "color": "red"}]},
        "color must be",
    ),
    (
        {"width": 5, "height": 5, "polygons": [{"path": "M0 0h3v3", "transform": [1, 0, 0]}]},
        "transform must be [a, b, c, d, e, f]",
    ),
    (
        {
            "width": 5,
            "height": 5,
            "polygons": [{"path": "M0 0h3", "stroke": {"width": 1, "cap": "hat"}}],
        },
        "stroke cap 'hat' (allowed: butt, round, square)",
    ),
    (
        {
            "width": 5,
            "height": 5,
            "polygons": [{"path": "M0 0h3", "stroke": {"width": 1}, "fill_rule": "evenodd"}],
        },
        "fill_rule does not apply to a stroke",
    ),
    (
        {
            "width": 5,
            "height": 5,
            "polygons": [{"path": "M0 0h3v3", "intensity": 3, "color": "#fff"}],
        },
        "give intensity or color, not both",
    ),
    ({"width": 5, "height": 5, "polygons": [{"circle": [1, 1]}]}, "circle must be a list of 3"),
    ({"width": 5, "height": 5, "polygons": [{"rect": [0, 0, 3, -3]}]}, "must not be negative"),
    (
        {"width": 5, "height": 5, "polygons": [{"rect": [0, 0, 3, 3], "path": "M0 0h1v1"}]},
        "not path and rect",
    ),
    ({"width": 5, "height": 5, "polygons": [{"path": "M 0 0 L 1 # Z"}]}, "unexpected '#'"),
    ({"width": 5, "height": 5, "polygons": [{"path": "L 1 1 2 2"}]}, "must start with M"),
    ({"width": 5, "height": 5, "polygons": [{"path": "M 0 0 C 1 1 2"}]}, "needs 6 numbers"),
]


def test_degenerate_subpaths_draw_nothing():
    """SVG draws nothing for a subpath without area (`M12 5v1`): it is dropped, the rest of
    the path drawn; a path of nothing else is an empty polygon, not an error."""
    data = {"width": 16, "height": 16, "polygons": [
        {"path": "M 12 5 v 1 M 1 1 L 9 1 L 9 9 Z"}, {"path": "M 0 0 L 3 3 Z"}, {"path": "M2 2"},
    ]}  # fmt: skip
    scene = parse_scene(data)
    assert [len(p.contours) for p in scene.polygons] == [1, 0, 0]
    image = render_scene(scene, DEFAULT).image
    alone = render_scene(parse_scene({**data, "polygons": data["polygons"][:1]}), DEFAULT).image
    assert image[3, 5] == 255 and np.array_equal(image, alone)  # the triangle alone


@pytest.mark.parametrize(("data", "message"), BAD_SCENES, ids=[m for _, m in BAD_SCENES])
def test_bad_scenes_are_rejected_with_a_message_naming_the_problem(data, message):
    with pytest.raises(SceneError) as caught:
        parse_scene(data, source="s.json")
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_scenes_that_do_not_fit_the_configuration_are_rejected():
    small = EdgeConfig(coord_bits=6)  # vertices in [0, 63.9375] px
    tri = ((0, 0), (10, 0), (5, 5))
    wide = Scene(32, 32, (Polygon((tri,)), Polygon((((0, 0), (70.5, 3), (0, 6)),))))
    with pytest.raises(SceneError, match=r"polygon 1 contour 0 vertex 1 at \(70\.5, 3\) px does"):
        plan(wide, small)
    with pytest.raises(SceneError, match="width 65 px is larger than the coordinate range"):
        plan(Scene(65, 8, (Polygon((tri,)),)), small)
    with pytest.raises(SceneError, match=r"polygon 0: intensity 300 is outside \[0, 255\]"):
        plan(Scene(8, 8, (Polygon((tri,), 300),)), DEFAULT)
    # negative coordinates are fine: the scene is shifted by whole pixels into range
    moved = Polygon((((-3.5, -2), (5, 1), (1, 6)),))
    shifted = plan(Scene(8, 8, (moved,)), DEFAULT)
    assert shifted.offset == (4, 2)


# -- geometry: fill rules and sides -------------------------------------------------------------


def test_the_fill_rule_decides_a_self_overlapping_star():
    centre = (24, 24)  # inside the inner pentagon: winding number 2
    tip = (24, 8)  # inside a point of the star: winding number 1
    for rule, centre_filled in (("nonzero", True), ("evenodd", False)):
        result = render_scene(star(rule), DEFAULT)
        assert result.image[centre[1], centre[0]] == (255 if centre_filled else 0), rule
        assert result.image[tip[1], tip[0]] == 255, rule
        rows = {r.label: r for r in error_rows(result, exact_image(result.plan))}
        # k/64 of 255 per edge through the pixel, plus rounding
        assert rows["one edge"].pixels > 100 and rows["one edge"].max_abs <= 255 / 64 + 0.5, rule
        assert rows["two edges"].max_abs <= 2 * 255 / 64 + 0.5, rule
        assert rows["three or more"].max_abs <= 5 * 255 / 64 + 0.5, rule
        assert rows["no edge"].pixels > 2000 and rows["no edge"].max_abs < 1e-9, rule


def test_inside_sides_follow_the_fill_rule():
    square = ((2, 2), (12, 2), (12, 12), (2, 12))  # clockwise on the image (y down)
    hole = ((5, 5), (5, 9), (9, 9), (9, 5))  # the other way round
    # travelling right along the top (2, 2) -> (12, 2), the square lies below: the right side
    one = plan(Scene(16, 16, (Polygon((square,)),)), DEFAULT)
    assert one.inside.tolist() == ["right"] * 4
    reverse = plan(Scene(16, 16, (Polygon((square[::-1],)),)), DEFAULT)
    assert reverse.inside.tolist() == ["left"] * 4
    # a reversed inner contour is a hole under non-zero: its inside faces away from it
    holed = plan(Scene(16, 16, (Polygon((square, hole)),)), DEFAULT)
    assert holed.inside.tolist() == ["right"] * 8
    # the same orientation is not a hole under non-zero (winding 2), is one under even-odd
    same = hole[::-1]
    nonzero = plan(Scene(16, 16, (Polygon((square, same)),)), DEFAULT)
    assert nonzero.inside.tolist()[4:] == [""] * 4, "interior edges are not boundaries"
    evenodd = plan(Scene(16, 16, (Polygon((square, same), None, "evenodd"),)), DEFAULT)
    assert evenodd.inside.tolist()[4:] == ["left"] * 4
    # two squares sharing a side: the shared side is interior; a doubled contour is drawn once
    left = ((2, 2), (7, 2), (7, 12), (2, 12))
    right = ((7, 2), (12, 2), (12, 12), (7, 12))
    pair = plan(Scene(16, 16, (Polygon((left, right)),)), DEFAULT)
    assert pair.inside.tolist().count("") == 2
    double = plan(Scene(16, 16, (Polygon((square, square)),)), DEFAULT)
    assert double.duplicates == 4 and (double.inside != "").sum() == 4
    # the doubled square renders like the single one
    assert np.array_equal(render_scene(double).image, render_scene(one).image)


def test_crossing_edges_are_split_on_the_grid():
    bowtie = [np.array([(0, 0), (32, 32), (32, 0), (0, 32)], dtype=np.int64)]
    (out,), inserted = split_crossings(bowtie)
    assert inserted == 2 and out.tolist() == [
        [0, 0],
        [16, 16],
        [32, 32],
        [32, 0],
        [16, 16],
        [0, 32],
    ]
    (out,), _ = split_crossings([np.array([(0, 0), (3, 1), (3, 0), (0, 1)], dtype=np.int64)])
    assert out.tolist()[1] == [2, 1], "the crossing (1.5, 0.5) is rounded half up"


def _unnoded(contours: list[np.ndarray]) -> list[tuple]:
    """Where the contours' edges are not noded (exact integers): two edges crossing at a
    point inside both ("X"), or a vertex inside another edge ("T", collinear or not)."""
    edges = [
        (tuple(p), tuple(q))
        for contour in contours
        for p, q in zip(contour.tolist(), np.roll(contour, -1, axis=0).tolist(), strict=True)
    ]

    def orient(a, b, c):
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])

    def inside(a, b, v):
        return (
            v not in (a, b)
            and orient(a, b, v) == 0
            and min(a[0], b[0]) <= v[0] <= max(a[0], b[0])
            and min(a[1], b[1]) <= v[1] <= max(a[1], b[1])
        )

    found = []
    for i, (a, b) in enumerate(edges):
        for j, (c, d) in enumerate(edges):
            crossing = orient(a, b, c) * orient(a, b, d) < 0
            if i < j and crossing and orient(c, d, a) * orient(c, d, b) < 0:
                found.append(("X", (a, b), (c, d)))
            found += [("T", (a, b), v) for v in (c, d) if i != j and inside(a, b, v)]
    return found


# Self-intersecting contours (sub-pixel units) that split_crossings leaves unnoded: a pentagon
# on the default 1/16 px grid (two split edges cross again; rendered, 64 LSB off the exact
# area) and a {9/2} star on the 1/4 px grid (a vertex inside an edge; even-odd, 64 LSB off).
# tests/test_accumulation.py renders both.
UNNODED = {
    "pentagon s=4": [(117, 46), (170, 66), (124, 179), (120, 136), (125, 200)],
    "star s=2": [
        (28, 15),
        (5, 19),
        (25, 7),
        (10, 25),
        (18, 3),
        (18, 26),
        (10, 4),
        (25, 22),
        (5, 10),
    ],
}


@pytest.mark.parametrize("contour", list(UNNODED.values()), ids=list(UNNODED))
def test_the_plan_nodes_until_no_edge_crosses(contour):
    """One round of split_crossings can leave edges crossing: a crossing rounded to the grid
    moves an edge across or onto another. The plan then snap-rounds the polygon, and
    nothing crosses (docs/noding.md)."""
    from edgeaa.render.render import _node

    contour = np.array(contour, dtype=np.int64)
    assert _unnoded([contour]), "the contour crosses itself"
    (once,), _ = split_crossings([contour])
    assert _unnoded([once]), "one round leaves a crossing (what the plan must fix)"
    (out,), inserted = _node([contour])
    assert inserted > 0
    assert _unnoded([out]) == []


def test_exact_integer_halfplane_coverage_matches_the_rational_reference():
    rng = random.Random(7)
    for bits in (0, 2, 4):
        config = EdgeConfig(coord_bits=6, subpixel_bits=bits)
        for _ in range(400):
            x0, y0, x1, y1 = (rng.randint(0, config.max_vertex) for _ in range(4))
            if (x0, y0) == (x1, y1):
                continue
            inside = rng.choice(["left", "right"])
            x, y, d = rng.randint(0, 63), rng.randint(0, 63), rng.randint(1, 300)
            area = exact_coverage(config, Edge(x0, y0, x1, y1, inside), x, y)
            want = math.floor(d * area + Fraction(1, 2))
            got = halfplane_coverage((x0, y0, x1, y1), inside == "left", x, y, 2**bits, d)
            assert got == want, (bits, x0, y0, x1, y1, inside, x, y, d)


# -- the image against the exact area -----------------------------------------------------------


def test_every_pixel_is_within_the_bounds_of_the_edges_through_it():
    """A pixel's error is at most k/64 of the intensity step (paper) for each edge passing
    through it, plus output rounding: at the vertices too, where the edges' pieces meet."""
    quad = ((4.3125, 3.75), (57.5, 9.125), (50.0625, 44.6875), (9.25, 37.5))
    scene = Scene(64, 48, (Polygon((quad,), 230),), background=20, name="quad")
    result = render_scene(scene, DEFAULT)
    p = result.plan
    err = np.abs(result.image - exact_image(p))
    ys, xs = (v.ravel() for v in np.mgrid[0:48, 0:64])
    bound = np.full(err.shape, 0.5 + 1e-6)
    units = 8 / (1 << DEFAULT.F)  # the fixed-point floors: a few units of 2**-F LSB
    for e in np.flatnonzero(p.boundary):
        x0, y0, x1, y1 = (int(v) for v in p.coords[e])
        k = min(abs(x1 - x0), abs(y1 - y0)) / max(abs(x1 - x0), abs(y1 - y0))
        hit = crossed_cells(p, np.full(len(xs), e), xs, ys)
        bound[ys[hit], xs[hit]] += error_bound("paper", k) * 210 + units
    worst = np.unravel_index(np.argmax(err - bound), err.shape)
    assert (err <= bound).all(), (worst, err[worst], bound[worst])
    rows = {r.label: r for r in error_rows(result, exact_image(p))}
    assert rows["one edge"].pixels > 100 and rows["two edges"].pixels > 0
    assert rows["no edge"].max_abs < 1e-9  # a pixel no edge passes through is exact


def test_error_on_the_builtins_is_small(plans, model_renders, exact_images, capsys):
    """seg4: at most 1 LSB on pixels one or two edges pass through, 3 LSB anywhere but the
    starburst's centre (32 wedges meet there; reported), and a lower RMS than AGG's exact-
    area scanline fill; paper: at most 5 LSB on pixels one edge passes through."""
    for name in BUILTINS:
        exact = exact_images[name]
        paper = {r.label: r for r in error_rows(model_renders[name], exact)}
        assert paper["one edge"].max_abs <= 5, (name, paper["one edge"])
        assert paper["no edge"].max_abs < 1e-9, (name, paper["no edge"])  # exact

        seg4_plan = plan(builtin(name, SEG4), SEG4)
        assert np.array_equal(seg4_plan.coords, plans[name].coords)  # the same reference
        seg4 = render_scene(seg4_plan)
        rows = {r.label: r for r in error_rows(seg4, exact)}
        assert rows["one edge"].max_abs <= 1, (name, rows["one edge"])
        assert rows["two edges"].max_abs <= 1, (name, rows["two edges"])
        assert rows["no edge"].max_abs < 1e-9, (name, rows["no edge"])
        err = np.abs(seg4.image - exact)
        centre = np.zeros(err.shape, dtype=bool)
        if name == "starburst":
            centre[125:131, 125:131] = True  # the centre (127.5, 127.5) and 2 px around it
            count = edges_per_pixel(seg4)[centre]
            with capsys.disabled():
                print(
                    f"\nstarburst centre (seg4): max |error| {err[centre].max():.3f} LSB, "
                    f"RMS {np.sqrt(np.mean(err[centre] ** 2)):.3f}, up to {count.max()} edges "
                    "through a pixel"
                )
            assert err[centre].max() <= count.max() * 255 / 1024 + 0.5 + 1e-6
        assert err[~centre].max() <= 3, (name, np.unravel_index(np.argmax(err), err.shape))

        agg = agg_scene(seg4_plan)
        agg_rms = float(np.sqrt(np.mean((agg - exact) ** 2)))
        assert rows["all pixels"].rms < agg_rms, (name, rows["all pixels"].rms, agg_rms)


def test_pixels_crossed_only_by_a_horizontal_edge_are_not_filed_under_no_edge():
    """edges_per_pixel counts every boundary edge through a pixel, geometrically: a
    horizontal one (never sent) too, and one whose delta there rounds to 0."""
    # the top edge y = 2.25 crosses row 2 (1.5 .. 2.5, a quarter covered); the other edges
    # lie on pixel borders
    rect = ((2.5, 2.25), (10.5, 2.25), (10.5, 8.5), (2.5, 8.5))
    result = render_scene(Scene(14, 12, (Polygon((rect,), 255),), 0, "rect"), DEFAULT)
    exact = exact_image(result.plan)
    assert exact[2, 3] == pytest.approx(255 / 4) and result.image[2, 3] == 64
    assert edges_per_pixel(result)[2, 3:11].tolist() == [1] * 8
    rows = {r.label: r for r in error_rows(result, exact)}
    assert rows["no edge"].max_abs < 1e-9 and rows["one edge"].pixels == 8


def test_a_whole_pixel_shift_of_the_scene_shifts_the_image():
    tri = ((3.0625, 2.5), (40.75, 9.3125), (12.5, 30.875))
    image = render_scene(Scene(48, 40, (Polygon((tri,), 200),), background=30), DEFAULT).image
    moved = tuple((x - 5, y - 3) for x, y in tri)  # negative: shifted into range by the plan
    scene = Scene(48, 40, (Polygon((moved,), 200),), background=30)
    result = render_scene(scene, DEFAULT)
    assert result.plan.offset == (2, 1)  # whole pixels: -1.9375 -> 0.0625, -0.5 -> 0.5
    assert np.array_equal(result.image[:37, :43], image[3:, 5:])


# -- engines ------------------------------------------------------------------------------------


@pytest.mark.parametrize("engine", ["verilator", "amaranth"])
def test_the_simulated_cores_give_the_models_deltas_and_image(engine, plans, model_renders):
    """The polygon core (`PolygonCore`): the model's nonzero deltas in order, the same
    image, and its beats in the clocks the timing model predicts (Amaranth: a tiny scene)."""
    tiny = plan(parse_scene(TINY_SCENE), DEFAULT)
    cases = [(tiny, render_scene(tiny))]
    if engine == "verilator":
        cases += [(plans[name], model_renders[name]) for name in BUILTINS]
    for p, model in cases:
        fast = render_scene(p, engine=engine)
        name = p.scene.name
        assert fast.engine == engine and np.array_equal(fast.image, model.image), name
        for field in ("edge", "x", "y", "delta"):
            assert np.array_equal(getattr(fast.deltas, field), getattr(model.deltas, field))
        edges = [p.edge(int(e), clip=True) for e in fast.sent]
        clocks = fast.deltas.beat_clocks
        assert np.array_equal(clocks, beat_clocks(DEFAULT, edges, DELTAS)), name
        assert fast.cycles == model.cycles == int(clocks[-1]) + 1, name
        assert fast.deltas.clocks >= fast.cycles, name  # the drain after the last beat


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.tuples(st.integers(0, 80), st.booleans(), st.integers(0, 9)), max_size=40),
    st.sampled_from([DEFAULT, SEG4, EdgeConfig(coord_bits=4, subpixel_bits=0, intensity_bits=4)]),
    st.sampled_from([WRITES, DELTAS]),
)
def test_the_vectorized_cycles_are_the_timing_models(commands, config, fmt):
    """`load_clocks` and `stream_cycles` (numpy, the renderer's cycles) against the scalar
    `schedule`, with bad commands (one in ten) and edges with no visible column among them."""
    from edgeaa.model.timing import load_clocks, schedule, stream_cycles

    columns = np.array([c for c, _, _ in commands], dtype=np.int64)
    clipped = np.array([k for _, k, _ in commands], dtype=bool)
    bad = np.array([b == 0 for _, _, b in commands], dtype=bool)
    shapes = [(int(c), bool(k)) for c, k in zip(columns, clipped, strict=True)]
    shapes = [None if b else shape for shape, b in zip(shapes, bad, strict=True)]
    timings = schedule(config, shapes, fmt=fmt)
    loads = [t.load for t in timings if not t.dropped]
    last = max((t.beats[-1] for t in timings if t.beats), default=-1)
    assert load_clocks(config, columns, clipped, bad, fmt).tolist() == loads
    assert stream_cycles(config, columns, clipped, bad, fmt) == last + 1


def test_a_model_render_imports_no_hardware(tmp_path):
    """`edgeaa render` with the model (and --stats) loads nothing of the hardware, its
    simulators or Amaranth: they cost half a second before any work."""
    probe = (
        "import sys\n"
        "from edgeaa.cli import main\n"
        "status = main(sys.argv[1:])\n"
        "names = [m for m in sys.modules if m.split('.')[0] == 'amaranth' or "
        "m.startswith(('edgeaa.hdl', 'edgeaa.sim'))]\n"
        "print('loaded:', sorted(names))\n"
        "sys.exit(status)\n"
    )
    for extra in ([], ["--stats"]):
        argv = ["render", "--builtin", "text", "-o", str(tmp_path / "t.png"), *extra]
        proc = subprocess.run(
            [sys.executable, "-c", probe, *argv], capture_output=True, text=True, check=False
        )
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.splitlines()[-1] == "loaded: []", (extra, proc.stdout)


# -- skipping -----------------------------------------------------------------------------------


def test_every_skipping_rule_saves_work_and_leaves_the_image_unchanged(plans, model_renders):
    """Each rule saves cycles or deltas on the built-ins, but the projection: it saves stepped
    columns (the starburst's), and there the setup of the next edges hides them (it holds an
    edge until the stepper loads it, `edgeaa.model.timing`)."""
    totals, projected_columns = {}, 0
    for name in BUILTINS:
        skipping, full = model_renders[name], render_scene(plans[name], skip=False)
        for e in (int(e) for e in skipping.projected):
            whole, moved = plans[name].edge(e), plans[name].edge(e, clip=True)
            projected_columns += setup(DEFAULT, whole).columns - setup(DEFAULT, moved).columns
        assert np.array_equal(skipping.image, full.image), name
        assert skipping.cycles < full.cycles and len(skipping.sent) < len(full.sent), name
        assert skipping.cells_scanned < full.cells_scanned, name
        assert skipping.delta_count <= full.delta_count, name
        for saving in rule_savings(full, skipping):
            got = totals.setdefault(saving.rule, [0, 0, 0])
            got[0] += saving.edges
            got[1] += saving.cycles
            got[2] += saving.deltas
        report = stats_report(full, skipping)
        assert "images identical: yes" in report and "partly outside" in report, report
        assert "projected" in report and "culled" in report and "horizontal" in report
    assert len(totals) == 5, totals
    projection = totals.pop("edges left of the viewport (projected to its edge)")
    assert projection[0] > 0 and projection[1] >= 0 and projected_columns > 0, projection
    for rule, (edges, cycles, deltas) in totals.items():
        assert edges > 0 and cycles > 0, (rule, edges, cycles, deltas)


@pytest.mark.parametrize(
    ("name", "rule"),
    [
        ("starburst", "culled"),
        ("starburst", "left"),
        ("starburst", "horizontal"),
        ("text", "horizontal"),
        ("text", "equal"),
    ],
)
def test_turning_one_skipping_rule_off_leaves_the_image_unchanged(plans, model_renders, name, rule):
    """Each rule on its own: culled (above, below, right), left (projected), horizontal
    edges, and a polygon equal to the background overlapping nothing."""
    p = plans[name]
    kept = model_renders[name]
    if rule == "equal":
        saved = list(p.polygons)
        assert any(poly.equal and not poly.overlaps for poly in saved)
        p.polygons[:] = [replace(poly, equal=False) for poly in saved]
        try:
            alone = render_scene(p)
        finally:
            p.polygons[:] = saved
        assert len(alone.skipped_equal) == 0 and len(alone.sent) > len(kept.sent)
    else:
        saved = getattr(p, rule).copy()
        assert (saved & p.boundary).any(), (name, rule)
        try:
            getattr(p, rule)[:] = False
            alone = render_scene(p)
        finally:
            getattr(p, rule)[:] = saved
        field = {"culled": "culled", "left": "projected", "horizontal": "horizontal"}[rule]
        assert len(getattr(alone, field)) == 0 and len(getattr(kept, field)) > 0
    assert np.array_equal(alone.image, kept.image), (name, rule)


def test_culled_edges_put_no_delta_where_it_reaches_the_image(plans):
    """An edge above, below or right of the image: none of its deltas lies in an image row
    at or left of the image's last column (where a prefix sum would carry it)."""
    p = plans["starburst"]  # the text is wholly inside its image
    culled = np.flatnonzero(p.culled & p.boundary)
    assert len(culled) > 0
    batch = run_edges_deltas(DEFAULT, [p.edge(int(e)) for e in culled])
    x, y = batch.x - p.offset[0], batch.y - p.offset[1]
    reaches = (y >= 0) & (y < p.scene.height) & (x < p.scene.width) & (batch.delta != 0)
    assert not reaches.any()


def _prefix_sums(p, batch, edges: int) -> np.ndarray:
    """Each edge's deltas summed along +x over the image (a delta left of it carried into
    its first column, one right of it, above or below dropped): (edges, height, width)."""
    height, width = p.scene.height, p.scene.width
    x, y = batch.x - p.offset[0], batch.y - p.offset[1]
    keep = (y >= 0) & (y < height) & (x < width)
    buffer = np.zeros((edges, height, width), dtype=np.int64)
    np.add.at(buffer, (batch.edge_index[keep], y[keep], np.maximum(x[keep], 0)), batch.delta[keep])
    return np.cumsum(buffer, axis=2)


def test_clipping_to_the_viewport_changes_no_sum_inside_the_image(plans):
    """The clip (the viewport without its left bound) drops only columns whose deltas cannot
    reach the image, and it does drop some; an edge wholly left, projected, too."""
    p = plans["starburst"]
    sent = np.flatnonzero(p.boundary & ~p.culled & ~p.horizontal)
    whole = run_edges_deltas(DEFAULT, [p.edge(int(e)) for e in sent])
    cut = run_edges_deltas(DEFAULT, [p.edge(int(e), clip=True) for e in sent])
    assert np.array_equal(_prefix_sums(p, cut, len(sent)), _prefix_sums(p, whole, len(sent)))
    assert len(cut) < len(whole) and p.left[sent].any()


# -- command line -------------------------------------------------------------------------------


def test_render_builtin_text_writes_the_png(tmp_path, capsys, model_renders):
    from PIL import Image

    out = tmp_path / "text.png"
    assert main(["render", "--builtin", "text", "-o", str(out), "--quiet"]) == 0
    with Image.open(out) as image:
        assert image.mode == "L" and image.size == (512, 64)
        assert np.array_equal(np.asarray(image), model_renders["text"].image)
    assert f"wrote {out}" in capsys.readouterr().out


def test_render_stats_and_error_and_16_bit_output(tmp_path, capsys):
    from PIL import Image

    scene = tmp_path / "scene.json"
    scene.write_text(
        json.dumps(
            {
                "width": 32,
                "height": 24,
                "background": 1000,
                "polygons": [{"path": "M 2 2 h 26 l -6 18 z", "intensity": 3}],
            }
        )
    )
    out = tmp_path / "out.png"
    args = ["render", str(scene), "-o", str(out), "--stats", "--error", "--intensity-bits", "10"]
    assert main([*args, "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "images identical: yes" in text and "one edge" in text and "16-bit" in text
    with Image.open(out) as image:
        assert image.mode.startswith("I;16")
        assert np.asarray(image).max() == round(1000 * 65535 / 1023)


def _json_run(capsys, *argv) -> dict:
    assert main(["render", *argv, "--json", "--quiet"]) == 0
    out = capsys.readouterr().out
    return json.loads(out)  # the whole of stdout is one JSON object


def test_render_json_figures_with_error_and_stats(tmp_path, capsys):
    plain = _json_run(capsys, "--builtin", "starburst")
    for key in ("edges", "columns", "cycles", "writes", "deltas", "cells_scanned"):
        assert isinstance(plain[key], int) and plain[key] > 0, key
    assert plain["writes"] == plain["deltas"] and plain["scene"] == "starburst"
    assert "max_abs_lsb" not in plain and "savings" not in plain

    error = _json_run(capsys, "--builtin", "starburst", "--error", "--mode", "seg4")
    assert error["pixels"] == 256 * 256
    assert 0 < error["rms_lsb"] < error["max_abs_lsb"] <= 3
    labels = [row["pixels"] for row in error["by_edges_per_pixel"]]
    assert labels == ["all pixels", "no edge", "one edge", "two edges", "three or more"]
    assert sum(row["count"] for row in error["by_edges_per_pixel"][1:]) == error["pixels"]

    out = tmp_path / "s.png"
    stats = _json_run(capsys, "--builtin", "starburst", "--stats", "-o", str(out))
    assert out.exists()
    without = stats["without_skipping"]
    for key in ("edges", "columns", "cycles"):
        assert stats[key] < without[key], key
    assert stats["writes"] <= without["deltas"]
    rules = {saving["rule"]: saving for saving in stats["savings"]}
    assert len(rules) == 5 and all(
        set(r) == {"rule", "edges", "cycles", "deltas"} for r in rules.values()
    )
    assert sum(r["cycles"] for r in rules.values()) > 0


@pytest.mark.parametrize("engine", ["verilator", "amaranth"])
def test_render_through_a_simulated_core_writes_the_models_png(engine, tmp_path, capsys):
    from PIL import Image

    scene = tmp_path / "tiny.json"
    scene.write_text(json.dumps(TINY_SCENE))
    out = tmp_path / f"{engine}.png"
    assert main(["render", str(scene), "--engine", engine, "-o", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert f"engine {engine}" in text and "clocks simulated" in text, text
    with Image.open(out) as image:
        assert np.array_equal(np.asarray(image), render_scene(parse_scene(TINY_SCENE)).image)


def test_progress_goes_to_stderr(tmp_path, capsys, monkeypatch):
    from edgeaa import progress

    monkeypatch.setattr(progress, "DELAY", 0.0)
    assert main(["render", "--builtin", "starburst", "-o", str(tmp_path / "s.png")]) == 0
    captured = capsys.readouterr()
    assert "render:" in captured.err and "100.0%" in captured.err
    assert "%" not in captured.out and "[#" not in captured.out


BAD_COMMANDS = [
    ([], "give a scene file or --builtin NAME"),
    (["x.json", "--builtin", "text"], "give a scene file or --builtin NAME"),
    (["--builtin", "circle"], "invalid choice: 'circle'"),
    (["--builtin", "text", "-o", "out.jpg"], "unsupported format (allowed: .png)"),
    (["--builtin", "text", "--compare"], "--compare needs -o FIGURE.png"),
    (["--builtin", "text", "--engine", "spice"], "invalid choice: 'spice'"),
    (["/nonexistent/scene.json"], "cannot read scene /nonexistent/scene.json"),
    (["--builtin", "text", "--coord-bits", "8"], "larger than the coordinate range allows"),
]


@pytest.mark.parametrize(("argv", "message"), BAD_COMMANDS, ids=[m for _, m in BAD_COMMANDS])
def test_bad_render_commands_are_one_line_errors_with_status_2(argv, message, capsys):
    assert main(["render", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and err.startswith("edgeaa")


def test_a_scene_file_with_bad_json_is_a_one_line_error(tmp_path, capsys):
    bad = tmp_path / "bad.json"
    bad.write_text('{"width": 3,')
    assert main(["render", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "not valid JSON" in err and err.count("\n") == 1


def test_compare_figure(tmp_path, capsys):
    out = tmp_path / "compare.png"
    assert main(["render", "--builtin", "starburst", "--compare", "--crop", "96,96,160,160",
                 "-o", str(out)]) == 0  # fmt: skip
    assert out.exists() and "Skia" in capsys.readouterr().out


def test_the_example_in_the_docs_renders(tmp_path):
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "scenes.md").read_text()
    example = text.split("```json\n", 1)[1].split("```", 1)[0]
    scene = parse_scene(json.loads(example))
    result = render_scene(scene, DEFAULT)
    assert result.image.shape == (40, 64) and len(result.sent) > 0
    rows = {r.label: r for r in error_rows(result, exact_image(result.plan))}
    assert rows["one edge"].max_abs <= 255 / 64 + 0.5 and rows["no edge"].max_abs < 1e-9


# -- errors and limits (docs/scenes.md) ------------------------------------------------------


def _render_file(tmp_path, capsys, content: bytes, *options):
    scene = tmp_path / "scene.json"
    scene.write_bytes(content)
    status = main(["render", str(scene), "--quiet", *options])
    return status, capsys.readouterr().err


SQUARE = {"points": [[1, 1], [9, 1], [9, 9], [1, 9]]}


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (b"\xff\xfe{}", "not UTF-8 text (byte 0xff at offset 0)"),
        (b"[" * 100000 + b"]" * 100000, "JSON nested too deeply"),
        (b'{"width": 8, "width": 9, "height": 8, "polygons": []}', "key 'width' appears twice"),
        (b'{"width": NaN, "height": 8, "polygons": []}', "NaN is not allowed"),
        (b'{"width": 1e400, "height": 8, "polygons": []}', "'1e400' is beyond the range"),
        (b'{"width": ' + b"1" * 5000 + b', "height": 8, "polygons": []}', "more than 30 digits"),
        (b'{"width": 65536, "height": 65536, "polygons": []}', "more than the limit of 16,777,216"),
        (b'{"width": 8, "height": 8, "tolerance": 1e-9, "polygons": []}', "below the limit"),
    ],
)
def test_bad_scene_files_are_one_line_errors(tmp_path, capsys, content, message):
    status, err = _render_file(tmp_path, capsys, content)
    assert status == 2 and message in err and err.count("\n") == 1, err


@pytest.mark.parametrize(
    ("polygon", "message"),
    [
        ({"points": [[0, 0], [1, [1]], [2, 0]]}, "vertex 1 y must be a number, not [1]"),
        ({"points": [[0, 0], [1e300, 0], [2, 2]]}, "beyond the limit of +-1,048,576 px"),
        ({**SQUARE, "fill_rule": ["evenodd"]}, "unknown fill_rule ['evenodd']"),
        ({"path": "M 0 0 L 8 0 L 8 8 L"}, "command 'L' at position 18 needs 2 numbers"),
        ({"path": "M 0 0 L 8 0 L M 8 8 Z"}, "command 'L' at position 12 needs 2 numbers"),
        ({"path": "M 0 0 C 1e300 0 0 1e300 9 9 Z"}, "'1e300' at position 8 is beyond the limit"),
        (
            {"path": "M 0 0" + " C 1e6 1e6 -1e6 -1e6 9 9 C 1e6 1e6 -1e6 -1e6 0 0" * 2},
            "limit of 20,000 edges",
        ),
        ({"path": "M 0 0 " + "l 1 0 " * 20001 + "z"}, "more than the limit of 20,000 edges"),
        ({"points": [[i % 7, i // 7] for i in range(20001)]}, "limit of 20,000 edges"),
    ],
)
def test_bad_polygons_are_refused_with_the_limit(polygon, message):
    with pytest.raises(SceneError) as error:
        parse_scene({"width": 8, "height": 8, "polygons": [polygon]})
    assert message in str(error.value) and "\n" not in str(error.value)


def test_a_scene_past_the_edge_limit_is_refused_before_it_is_flattened():
    from edgeaa.render.scene import MAX_EDGES, MAX_POLYGON_EDGES

    ring = [[i % 2, i // 2] for i in range(MAX_POLYGON_EDGES)]
    polygons = [{"points": ring}] * (MAX_EDGES // MAX_POLYGON_EDGES + 1)
    with pytest.raises(SceneError, match=f"more than the limit of {MAX_EDGES:,} edges per scene"):
        parse_scene({"width": 8, "height": 8, "polygons": polygons})


def _ink(image: np.ndarray, full: int = 255) -> float:
    """Black ink on white in pixels: the covered area the image shows."""
    return float((full - image.astype(np.int64)).sum()) / full


def test_a_12000_vertex_outline_renders_with_its_area():
    # A coast-like outline (the 10,000-edge polygon limit refused it): the ink is its area.
    t = np.arange(12_000) * 2 * math.pi / 12_000
    r = 380 + 12 * np.sin(37 * t) + 6 * np.sin(211 * t) + 3 * np.sin(1777 * t)
    points = np.stack([500 + r * np.cos(t), 400 + r * np.sin(t)], 1).round(3)
    scene = parse_scene(
        {
            "width": 1000,
            "height": 800,
            "background": 255,
            "polygons": [{"points": points.tolist(), "intensity": 0}],
        }
    )
    x, y = points.T
    area = abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))) / 2
    assert abs(_ink(render_scene(scene, DEFAULT).image) - area) < 1e-4 * area


@pytest.mark.slow
def test_a_page_of_small_text_renders_with_its_area():
    # 1000 x 800 px of 9-12 px serif text, about 300,000 edges (the 200,000-edge scene limit
    # refused it): parsed through the JSON reader (its limits), the ink is the glyphs' area.
    from edgeaa.render.corpus import page_scene

    page = page_scene()
    polygons = [
        {"contours": [list(map(list, c)) for c in p.contours], "intensity": 0}
        for p in page.polygons
    ]
    scene = parse_scene({"width": 1000, "height": 800, "background": 255, "polygons": polygons})
    edges = sum(len(c) for p in scene.polygons for c in p.contours)
    assert edges > 290_000
    area = 0.0  # TrueType contours: holes wound against their outline, so signed areas add
    for p in scene.polygons:
        for c in p.contours:
            x, y = np.array(c).T
            area += float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) / 2
    assert abs(_ink(render_scene(scene, DEFAULT).image) - abs(area)) < 2e-3 * abs(area)


def test_svg_whitespace_includes_form_feed():
    expected = parse_path("M 0 0 L 8 0 L 8 8 Z")
    assert parse_path("M\f0\t0\nL\r8,0\f\fL 8 8Z") == expected


def test_a_zero_length_segment_splits_nothing():
    # It used to divide by zero (Fraction(0, 0)) on the collinear branch of _intersect.
    square = np.array([[0, 0], [0, 0], [4, 0], [4, 4], [0, 4]], dtype=np.int64)
    contours, inserted = split_crossings([square])
    assert inserted == 0 and contours[0].tolist() == square.tolist()


def test_a_huge_image_at_coord_bits_16_is_refused_before_allocating(tmp_path, capsys):
    scene = {"width": 65536, "height": 65536, "polygons": [SQUARE]}
    status, err = _render_file(tmp_path, capsys, json.dumps(scene).encode(), "--coord-bits", "16")
    assert status == 2 and "4,294,967,296 pixels, more than the limit of 16,777,216" in err


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--crop", "0,0,4,4"], "--crop selects the pixels of the --compare figure"),
        (["--compare", "--error", "-o", "f.png"], "--compare and --error cannot be combined"),
        (["--stats", "--no-skip"], "--stats and --no-skip cannot be combined"),
        (["--compare", "--engine", "verilator", "-o", "f.png"], "--engine does not apply"),
        (["--mode", "seg4", "--mode", "paper"], "argument --mode: given twice"),
        (["-o", "."], "is a directory"),
        (["-o", "missing/out.png"], "directory 'missing' does not exist"),
    ],
)
def test_conflicting_render_options_are_refused(tmp_path, capsys, monkeypatch, options, message):
    monkeypatch.chdir(tmp_path)
    scene = json.dumps({"width": 16, "height": 16, "polygons": [SQUARE]}).encode()
    status, err = _render_file(tmp_path, capsys, scene, *options)
    assert status == 2 and message in err and err.count("\n") == 1, err


def test_the_output_may_not_be_the_input(tmp_path, capsys):
    scene = tmp_path / "scene.png"  # a scene file with an image's name
    scene.write_text(json.dumps({"width": 16, "height": 16, "polygons": [SQUARE]}))
    before = scene.read_bytes()
    assert main(["render", str(scene), "-o", str(tmp_path / "." / "scene.png")]) == 2
    assert "is the input file" in capsys.readouterr().err and scene.read_bytes() == before


def test_compare_refuses_a_scene_too_large_for_its_reference(tmp_path, capsys):
    scene = json.dumps({"width": 512, "height": 512, "polygons": [SQUARE]}).encode()
    status, err = _render_file(tmp_path, capsys, scene, "--compare", "-o", str(tmp_path / "f.png"))
    assert status == 2 and "--compare: the image is 512 x 512" in err and "65,536" in err


def test_a_png_that_fails_to_save_leaves_nothing(tmp_path, capsys, monkeypatch):
    from edgeaa.render import cli as render_cli

    def save_half(image, full_scale, intensity_bits, path):
        with open(path, "wb") as file:
            file.write(b"\x89PNG\r\n\x1a\n")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(render_cli, "write_png", save_half)
    out = tmp_path / "out.png"
    assert main(["render", "--builtin", "starburst", "--quiet", "-o", str(out)]) == 2
    assert "cannot write" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_a_failed_build_is_one_line_with_its_cause():
    from edgeaa.render.cli import _cause

    log = "Verilator build failed:\nmake -C obj\n%Error: core.v:12:5: Signal too wide\nmake: *** 1"
    assert (
        _cause(RuntimeError(log)) == "Verilator build failed: %Error: core.v:12:5: Signal too wide"
    )
    assert _cause(RuntimeError("harness failed (139): \nSegmentation fault")) == (
        "harness failed (139): Segmentation fault"
    )


# --- bounded planning: far-off polygons, the overlap test, the winding numbers, the limits ---


def test_a_polygon_far_left_of_the_image_is_drawn_and_carries_no_cover(tmp_path, capsys):
    """Its span fits the range, the image's does too, but not both with every vertex made
    non-negative: only its projection's column and its y need the range."""
    near = Polygon((((4, 4), (40, 8), (20, 28)),), 100)
    far = Polygon((((-3000, 2), (-2990, 2), (-2995, 30)),), 0)
    alone = render_scene(Scene(64, 32, (near,), 255), DEFAULT).image
    both = render_scene(Scene(64, 32, (far, near), 255), DEFAULT)
    assert both.plan.offset[0] < 2048 and not both.plan.in_range
    assert len(both.projected)
    assert np.array_equal(both.image, alone)
    path = tmp_path / "far.json"
    scene = {"width": 64, "height": 32, "polygons": [{"points": far.contours[0]}]}
    path.write_text(json.dumps(scene))
    assert main(["render", str(path), "-o", str(tmp_path / "far.png"), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["render", str(path), "--stats", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("edgeaa render: error: without skipping") and err.count("\n") == 1


def _meets_earlier_reference(windows) -> list[bool]:
    def meets(a, b):
        return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3] and a[0] < a[2]

    return [any(meets(w, v) for v in windows[:i]) for i, w in enumerate(windows)]


@pytest.mark.parametrize("seed", range(6))
def test_the_overlap_of_windows_matches_the_pairwise_test(seed, monkeypatch):
    from edgeaa.render.render import _meets_earlier

    rng = np.random.default_rng(seed)
    width, height = int(rng.integers(1, 40)), int(rng.integers(1, 40))
    n = int(rng.integers(1, 300))
    lo = rng.integers(-5, 45, (n, 2))
    hi = lo + rng.integers(0, 20, (n, 2))  # a box's pixels, clamped as `_polygon_plans` does
    windows = np.concatenate([np.maximum(lo, 0), np.minimum(hi + 1, [width, height])], axis=1)
    want = _meets_earlier_reference(windows.tolist())
    note = f"seed {seed}"
    assert _meets_earlier(windows, width, height).tolist() == want, note
    monkeypatch.setattr(math, "isqrt", lambda _: 8)  # blocks of 64: across blocks too
    assert _meets_earlier(windows, width, height).tolist() == want, note
    monkeypatch.setattr(math, "isqrt", lambda _: 512)  # one block of 2048: rows in parts
    many = np.concatenate([windows] * 8)[:2048]
    want = _meets_earlier_reference(many.tolist())
    assert _meets_earlier(many, width, height).tolist() == want, note
    for rows in (1, 3):  # strips of a row, of three: a window in several, met in one
        monkeypatch.setattr("edgeaa.render.render.STRIP_PIXELS", rows * width)
        assert _meets_earlier(many, width, height).tolist() == want, f"{note}, strips {rows}"


def _winding_reference(edges, points, first, second):
    """winding_numbers as it was: every point against every edge."""
    from edgeaa.render.geometry import _lex_sign

    ax, ay, bx, by = (edges[:, i][None, :] for i in range(4))
    ex, ey = bx - ax, by - ay
    px, py = points[:, 0][:, None], points[:, 1][:, None]
    v1x, v1y = first[:, 0][:, None], first[:, 1][:, None]
    v2x, v2y = second[:, 0][:, None], second[:, 1][:, None]
    sy = _lex_sign(v1y, v2y)
    a_le = (ay < py) | ((ay == py) & (sy > 0))
    b_gt = (by > py) | ((by == py) & (sy < 0))
    left = _lex_sign(ex * (py - ay) - (px - ax) * ey, ex * v1y - v1x * ey, ex * v2y - v2x * ey)
    return (a_le & b_gt & (left > 0)).sum(axis=1) - (~a_le & ~b_gt & (left < 0)).sum(axis=1)


@pytest.mark.parametrize("seed", range(8))
def test_winding_numbers_match_every_point_against_every_edge(seed, monkeypatch):
    from edgeaa.render import geometry

    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 200))
    pts = rng.integers(0, 12, (n, 2))  # small: many ties on the edges' ends and rows
    edges = np.concatenate([pts, np.roll(pts, -1, axis=0)], axis=1)
    points = rng.integers(-1, 13, (500, 2))
    first = rng.choice([-1, 1], (500, 2))
    second = np.stack([first[:, 1], -first[:, 0]], axis=1)
    want = _winding_reference(edges, points, first, second)
    assert np.array_equal(geometry.winding_numbers(edges, points, first, second), want), seed
    monkeypatch.setattr(geometry, "CHUNK", 7)  # many passes, bands cut anywhere
    assert np.array_equal(geometry.winding_numbers(edges, points, first, second), want), seed


def _quantize_reference(scene, S):
    """The planner's quantization as it was: contour by contour."""
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


def _split_edges_reference(scene, contours, owners, offset, S):
    """The planner's edges as they were built: polygon by polygon, contour by contour."""
    from edgeaa.render.render import _crossing, _node_polygon

    shift = np.array(offset, dtype=np.int64) * S
    coords, polygon, contour, starts, count, crossings = [], [], [], [0], 0, 0
    by_polygon = [[] for _ in scene.polygons]
    for (k, _, _), pts in zip(owners, contours, strict=True):
        by_polygon[k].append(pts.astype(np.int64) + shift)
    crossing, noded = _crossing(by_polygon)
    for i, mine in enumerate(by_polygon):
        if crossing[i] or i in noded:  # each crossing polygon noded alone
            mine, inserted = _node_polygon(i, mine)
            crossings += inserted
        for q in mine:
            if len(q) >= 2:
                coords.append(np.concatenate([q, np.roll(q, -1, axis=0)], axis=1))
                polygon.append(np.full(len(q), i))
                contour.append(np.full(len(q), len(contour)))
                count += len(q)
        starts.append(count)
    joined = [np.concatenate(x).astype(np.int64) if x else None for x in (coords, polygon, contour)]
    return (*joined, starts, crossings)


def _check_plan_against_reference(scene):
    from edgeaa.render.render import _offset, _quantize, _split_edges

    S = DEFAULT.subpixel_scale
    got, want = _quantize(scene, S), _quantize_reference(scene, S)
    assert got[2] == want[2] and len(got[0]) == len(want[0]), scene.name
    for a, b, (i, j, k), (i2, j2, k2) in zip(got[0], want[0], got[1], want[1], strict=True):
        assert np.array_equal(a, b) and (i, j) == (i2, j2) and np.array_equal(k, k2), scene.name
    if not want[0]:
        return
    offset = _offset(DEFAULT, scene, *want[:2])
    edges = _split_edges(scene, got[0], got[1], offset, S)
    reference = _split_edges_reference(scene, want[0], want[1], offset, S)
    for a, b in zip(edges, reference, strict=True):
        assert np.array_equal(a, b), scene.name


def test_the_plan_is_the_reference_plan_on_the_corpus():
    """The planner's quantization and edges in numpy over whole arrays (issue 28) against the
    contour-by-contour reference: the built-ins, the fonts and icons matplotlib ships, the
    adversarial polygons."""
    from edgeaa.render.corpus import ICONS, adversarial_scenes, font_scene, icon_scene

    scenes = [builtin(name, DEFAULT) for name in ("starburst", "text", "hatch")]
    scenes += [font_scene(font, 9)[0] for font in ("DejaVuSans", "STIXGeneral", "cmr10")]
    scenes += [icon_scene(name, 24) for name in ICONS] + adversarial_scenes()
    for scene in scenes:
        _check_plan_against_reference(scene)


_vertex = st.tuples(st.integers(-8, 40), st.integers(-8, 40)).map(lambda p: (p[0] / 3, p[1] / 3))


@settings(max_examples=150, deadline=None)
@given(st.lists(st.lists(st.lists(_vertex, min_size=1, max_size=9), min_size=1, max_size=3),
                min_size=1, max_size=6))  # fmt: skip
def test_the_plan_is_the_reference_plan_on_random_scenes(polygons):
    """Repeated vertices, contours that collapse to a point or a segment, crossing contours:
    the same quantized contours, owners, drops and edges as the reference."""
    scene = Scene(16, 16, tuple(Polygon(tuple(map(tuple, c)), 128, "nonzero") for c in polygons), 0)
    _check_plan_against_reference(scene)


def _many_polygons(seed: int) -> Scene:
    """Small triangles and quads strewn over 96 x 64 px (some overlapping, some apart, a few
    past the image's sides), both fill rules, several intensities."""
    rng = np.random.default_rng(seed)
    polygons = []
    for _ in range(int(rng.integers(2, 120))):
        cx, cy = rng.uniform(-6, 100), rng.uniform(-6, 70)
        pts = [
            (cx + rng.uniform(-9, 9), cy + rng.uniform(-9, 9)) for _ in range(rng.integers(3, 5))
        ]
        rule = "evenodd" if rng.random() < 0.3 else "nonzero"
        polygons.append(Polygon((tuple(pts),), int(rng.integers(0, 256)), rule))
    return Scene(96, 64, tuple(polygons), int(rng.integers(0, 256)), name=f"many {seed}")


@pytest.mark.parametrize("seed", range(12))
def test_polygons_accumulated_in_runs_give_the_polygon_by_polygon_image(seed, monkeypatch):
    """Polygons are accumulated in one buffer and composited in waves of windows that share
    no pixel (`_accumulation_runs`, `_draw_run`): the same image and the same counts as one
    polygon at a time, in order."""
    from edgeaa.render import render as renderer

    scene = _many_polygons(seed)
    runs = renderer._accumulation_runs(plan(scene, DEFAULT), list(range(len(scene.polygons))))
    assert len(runs) < len(scene.polygons) or len(scene.polygons) < 5, seed  # runs of several
    waves = [wave for run in runs for wave in run]
    assert max(map(len, runs)) > 1 or len(waves) == len(runs), seed  # runs of several waves
    scenes = [scene]
    if seed == 0:
        scenes += [builtin(name, DEFAULT) for name in ("starburst", "text", "hatch")]
    for scene in scenes:
        p = plan(scene, DEFAULT)
        together = render_scene(p)
        with monkeypatch.context() as m:
            m.setattr(
                renderer, "_accumulation_runs", lambda plan, drawn, *_: [[[i]] for i in drawn]
            )
            alone = render_scene(p)
        note = f"{scene.name}, seed {seed}"
        assert np.array_equal(together.image, alone.image), note
        for name in ("rows_scanned", "cells_scanned", "pixel_stores"):
            assert getattr(together, name) == getattr(alone, name), (note, name)


def test_a_polygon_whose_splitting_passes_the_limit_is_refused_before_the_work():
    from edgeaa.render.scene import MAX_NODED_EDGES

    rng = np.random.default_rng(0)
    soup = tuple(map(tuple, rng.uniform(0, 256, (2000, 2)).round(3).tolist()))
    with pytest.raises(SceneError, match=f"limit of {MAX_NODED_EDGES:,} edges per polygon"):
        plan(Scene(257, 257, (Polygon((soup,)),)), DEFAULT)


@pytest.mark.parametrize("engine", ["verilator", "amaranth"])
def test_a_scene_past_an_engines_clock_limit_is_refused_before_it_runs(
    engine, tmp_path, capsys, monkeypatch
):
    from edgeaa.model.tile import TileConfig
    from edgeaa.render import pipeline

    tiny = plan(parse_scene(TINY_SCENE), DEFAULT)
    tile = TileConfig(DEFAULT)
    needs, _ = pipeline.clock_estimate(tiny, tile)
    monkeypatch.setitem(pipeline.MAX_PIPELINE_CLOCKS, engine, needs - 1)
    monkeypatch.setattr(pipeline, "render_scene", None)  # nothing may run
    with pytest.raises(SceneError, match=f"engine's limit of {needs - 1:,}"):
        pipeline.render_pipeline(tiny, engine, tile)
    scene = tmp_path / "tiny.json"
    scene.write_text(json.dumps(TINY_SCENE))
    out = tmp_path / "out.png"
    assert main(["render", str(scene), "--engine", engine, "-o", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("edgeaa render: error: the scene needs about") and err.count("\n") == 1
    assert not out.exists()


@pytest.mark.parametrize("name", ["starburst", "text", "hatch"])
@pytest.mark.parametrize("units", [1, 4])
def test_the_clock_estimate_is_above_the_simulated_clocks_and_within_about_twice(name, units):
    """The estimate that the engines' limits apply to is an upper one on the built-ins, as
    the pipeline's cycle model (checked against the simulated clocks in test_pipeline.py)
    counts them, compact and fast, and a fair one: at most 2.5 times (2.01 to 2.39 measured;
    the estimate that charged every edge in every tile right of it was 3.2 to 9.5 times; 2.3
    before it counted what it had missed: docs/hardware.md, "The clock estimate, an upper
    bound")."""
    from edgeaa.model.pipeline import PipelineConfig
    from edgeaa.model.pipeline_timing import pipeline_cycles
    from edgeaa.model.tile import TileConfig
    from edgeaa.render import pipeline

    p = plan(builtin(name), DEFAULT)
    tile = PipelineConfig(TileConfig(DEFAULT), units)  # one scan lane
    commands = pipeline.scene_commands(p, tile.tile)
    exact = pipeline_cycles(tile, commands).clocks
    estimate, count = pipeline.clock_estimate(p, tile)
    assert exact <= estimate <= 2.5 * exact, (exact, estimate)
    assert len(commands) <= count <= 1.1 * len(commands)


@pytest.mark.parametrize(("pipeline", "scan_lanes"), [("compact", 1), ("fast", 2), ("fast", 4)])
@pytest.mark.parametrize(("width", "height"), [(8, 4), (16, 8)])
def test_the_clock_estimate_is_above_the_clocks_of_random_pages(
    pipeline, scan_lanes, width, height
):
    """Seeded random scenes cut to a small page, half of them inside a frame polygon, so that
    polygons reach past every side of the image (merged edges in every tile, edges culled
    right of it): the estimate is never below the cycle model's clocks. It was, down to 0.62
    of them in 8 x 4 tiles, before it counted the beats' clocks in the accumulator, an
    x-major edge's columns outside the band's rows, edges far left of the image and culled
    right of it, the last flush and the resolve's latency before a flush."""
    from edgeaa.model.pipeline import PipelineConfig
    from edgeaa.model.pipeline_timing import pipeline_cycles
    from edgeaa.model.tile import TileConfig
    from edgeaa.render import pipeline as tiler
    from edgeaa.sim.verification.workloads import random_scene

    page_w, page_h = 5 * width, 6 * height
    frame = frame_polygon(page_w, page_h, DEFAULT)
    config = PipelineConfig.named(pipeline, TileConfig(DEFAULT, width, height))
    config = replace(config, scan_lanes=scan_lanes)  # fast's, or four (counted as two)
    for seed in range(12):
        scene = random_scene(DEFAULT, seed)
        polygons = (frame, *scene.polygons) if seed % 2 else scene.polygons
        scene = replace(scene, width=page_w, height=page_h, polygons=polygons)
        p = plan(scene, DEFAULT)
        exact = pipeline_cycles(config, tiler.scene_commands(p, config.tile)).clocks
        estimate, _ = tiler.clock_estimate(p, config)
        assert exact <= estimate, f"seed {seed}: {estimate:,} estimated, {exact:,} clocks"


@pytest.mark.parametrize("name", ["starburst", "text", "hatch"])
def test_the_clock_estimate_of_the_fast_pipeline_counts_the_flushs_beats(name):
    """Four pixel lanes and two scan lanes (the fast pipeline): the estimate stays above the
    cycle model's clocks, with the flush at four pixels a clock and the scan two cells a
    clock (the accumulator takes a beat's cells two a clock too), and within 3 times (1.93
    to 2.88 measured: its scans, over each polygon's rows in the band and on to the tile's
    last column when the polygon has an edge right of it, count the most; 2.7 before it
    counted what it had missed)."""
    from edgeaa.model.pipeline import PipelineConfig
    from edgeaa.model.pipeline_timing import pipeline_cycles
    from edgeaa.model.tile import TileConfig
    from edgeaa.render import pipeline

    p = plan(builtin(name, DEFAULT), DEFAULT)
    fast = PipelineConfig.named("fast", TileConfig(DEFAULT))
    assert (fast.pixel_lanes, fast.scan_lanes) == (4, 2)
    exact = pipeline_cycles(fast, pipeline.scene_commands(p, fast.tile)).clocks
    estimate, _ = pipeline.clock_estimate(p, fast)
    assert exact <= estimate <= 3.0 * exact, (exact, estimate)


def test_a_comb_is_swept_and_the_engine_refuses_work_past_its_limit(monkeypatch):
    """A comb of tall teeth: every midpoint is level with every edge, so its inside sides
    come from the sweep (no limit on those pairs any more), and every edge steps the
    image's height (the engine's columns, still limited)."""
    from edgeaa.render import geometry
    from edgeaa.render import render as planner

    teeth = [p for k in range(40) for p in ((2 + k, 1.0), (2.5 + k, 60.0))]
    comb = Scene(64, 64, (Polygon((tuple(teeth),)),))
    whole = plan(comb, DEFAULT)
    assert geometry.level_pairs(whole.coords, whole.polygon) > 80 * 80
    assert geometry._swept(whole.coords, whole.polygon).all()
    monkeypatch.setattr(geometry, "SWEEP_PAIRS", 1 << 62)
    assert plan(comb, DEFAULT).inside.tolist() == whole.inside.tolist()
    monkeypatch.setattr(planner, "MAX_STEPPED_COLUMNS", 80 * 59 - 1)
    with pytest.raises(SceneError, match="columns"):
        render_scene(comb, DEFAULT)


def test_stats_with_a_horizontal_edge_left_of_the_image(tmp_path, capsys):
    """A horizontal edge wholly left of the image is dropped, not projected: --stats measured
    it as clipped (a zero-length projection) and failed after the PNG was written."""
    scene = tmp_path / "left.json"
    polygon = {"contours": [[[-5, 2], [-2, 2], [10, 10]]], "intensity": 200}
    scene.write_text(json.dumps({"width": 16, "height": 16, "polygons": [polygon]}))
    out = tmp_path / "left.png"
    assert main(["render", str(scene), "--stats", "--quiet", "-o", str(out)]) == 0
    assert out.exists() and "edges partly outside" in capsys.readouterr().out


def test_the_render_command_keeps_freed_memory_on_glibc():
    """`keep_freed_memory` sets glibc's malloc thresholds (True there), and says False where
    there is no mallopt."""
    import platform

    from edgeaa.render.render import keep_freed_memory

    assert keep_freed_memory() is (platform.libc_ver()[0] == "glibc")


@pytest.mark.parametrize("seed", range(6))
def test_polygons_noded_in_their_batch_plan_as_when_noded_alone(seed, monkeypatch):
    """`_crossing` nodes the polygons whose crossings one round settles in its batches
    (`_node_batch`); the plan is the one `_node_polygon` gives each polygon alone: the same
    edges, sides, windows and crossings count, and the same image."""
    from edgeaa.render import render as renderer

    rng = np.random.default_rng(seed)
    print(f"seed {seed}")
    polygons = []
    for k in range(int(rng.integers(3, 25))):
        cx, cy = rng.uniform(4, 92), rng.uniform(4, 60)
        pts = tuple((cx + rng.uniform(-9, 9), cy + rng.uniform(-9, 9)) for _ in range(6))
        polygons.append(Polygon((pts,), int(rng.integers(0, 256)), "nonzero", f"p{k}"))
    polygons += [Polygon((UNNODED["pentagon s=4"],), 30, "evenodd", "snapped")]  # 2nd round
    scene = Scene(96, 64, tuple(polygons), 255, name=f"crossing {seed}")
    together = plan(scene, DEFAULT)
    _, noded = renderer._crossing([[np.array(c, np.int64) for c in p.contours] for p in polygons])
    assert noded, seed  # some polygons were noded in their batch
    with monkeypatch.context() as m:
        m.setattr(renderer, "_crossing", lambda by: (np.ones(len(by), dtype=bool), {}))
        alone = plan(scene, DEFAULT)
    assert together.crossings == alone.crossings > 0, seed
    for name in ("coords", "polygon", "contour", "inside"):
        assert np.array_equal(getattr(together, name), getattr(alone, name)), (seed, name)
    assert together.polygons == alone.polygons, seed
    assert np.array_equal(render_scene(together).image, render_scene(alone).image), seed
