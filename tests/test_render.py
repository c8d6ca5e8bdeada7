"""Scenes: parsing, fill rules, the renderer's image against shapely's exact areas, the three
engines bit for bit, and the skipping rules (savings, and the same image)."""

import json
import math
import random
from fractions import Fraction

import numpy as np
import pytest

from edgeaa.cli import main
from edgeaa.model import Edge, EdgeConfig, exact_coverage, run_edge
from edgeaa.model.vector import run_edges
from edgeaa.render import Polygon, Scene, SceneError, builtin, parse_path, parse_scene, render_scene
from edgeaa.render import plan_scene as plan
from edgeaa.render.engines import beat_clocks
from edgeaa.render.exact import error_rows, exact_image, writers_per_pixel
from edgeaa.render.geometry import halfplane_coverage, split_crossings
from edgeaa.render.render import axis_writes
from edgeaa.render.scene import flatten_cubic, flatten_quadratic
from edgeaa.render.stats import rule_savings, stats_report

DEFAULT = EdgeConfig()
BUILTINS = ("starburst", "text")


@pytest.fixture(scope="module")
def plans():
    return {name: plan(builtin(name, DEFAULT), DEFAULT) for name in BUILTINS}


@pytest.fixture(scope="module")
def model_renders(plans):
    return {name: render_scene(p, engine="model") for name, p in plans.items()}


def star(rule: str, intensity: int = 255) -> Scene:
    """A pentagram: its five edges cross; the inner pentagon has winding number 2."""
    r, cx, cy = 20, 24.3, 23.7
    points = tuple(
        (cx + r * math.sin(4 * math.pi * k / 5), cy - r * math.cos(4 * math.pi * k / 5))
        for k in range(5)
    )
    return Scene(48, 48, (Polygon((points,), intensity, rule),), background=0, name="star")


# -- the scene format ---------------------------------------------------------------------------


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
        {"width": 5, "height": 5, "polygons": [{"path": "M 0 0 A 1 1 0 0 1 2 2 Z"}]},
        "arc commands (A/a) are not supported",
    ),
    ({"width": 5, "height": 5, "polygons": [{"path": "M 0 0 L 1 # Z"}]}, "unexpected '#'"),
    ({"width": 5, "height": 5, "polygons": [{"path": "L 1 1 2 2"}]}, "must start with M"),
    ({"width": 5, "height": 5, "polygons": [{"path": "M 0 0 C 1 1 2"}]}, "needs 6 numbers"),
    ({"width": 5, "height": 5, "polygons": [{"path": "M 0 0 L 3 3 Z"}]}, "encloses nothing"),
]


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
        assert rows["one edge"].max_abs <= 5, rule  # k/64 of 255 plus rounding
        assert rows["several edges"].max_abs <= 32, rule  # vertices and crossings
        assert rows["fill only"].max_abs == 0, rule


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


def test_single_edge_pixels_are_within_the_estimate_bound():
    """Away from vertices a pixel written by one edge has the model's error: k/64 of the
    intensity step (paper) plus output rounding; vertex pixels are reported."""
    quad = ((4.3125, 3.75), (57.5, 9.125), (50.0625, 44.6875), (9.25, 37.5))
    scene = Scene(64, 48, (Polygon((quad,), 230),), background=20, name="quad")
    result = render_scene(scene, DEFAULT)
    exact = exact_image(result.plan)
    err = np.abs(result.image - exact)
    writers = writers_per_pixel(result)
    w, coords = result.writes, result.plan.coords / 16
    checked = 0
    for e in np.unique(w.edge):
        x0, y0, x1, y1 = coords[e]
        k = min(abs(x1 - x0), abs(y1 - y0)) / max(abs(x1 - x0), abs(y1 - y0))
        bound = k / 64 * 210 + 0.5 + 0.01
        for x, y in zip(w.x[w.edge == e], w.y[w.edge == e], strict=True):
            far = min(max(abs(x - vx), abs(y - vy)) for vx, vy in quad) > 2
            if writers[y, x] == 1 and far:
                assert err[y, x] <= bound, (e, x, y, err[y, x], bound)
                checked += 1
    assert checked > 100
    rows = {r.label: r for r in error_rows(result, exact)}
    assert rows["several edges"].pixels > 0 and rows["several edges"].max_abs < 40
    assert rows["fill only"].max_abs == 0


def test_error_on_the_builtins_is_small(plans, model_renders):
    for name in BUILTINS:
        rows = {r.label: r for r in error_rows(model_renders[name], exact_image(plans[name]))}
        assert rows["one edge"].max_abs <= 8, name
        assert rows["all pixels"].rms <= 1.5, name
        assert rows["several edges"].max_abs <= 32, name


def test_a_whole_pixel_shift_of_the_scene_shifts_the_image():
    tri = ((3.0625, 2.5), (40.75, 9.3125), (12.5, 30.875))
    image = render_scene(Scene(48, 40, (Polygon((tri,), 200),), background=30), DEFAULT).image
    moved = tuple((x - 5, y - 3) for x, y in tri)  # negative: shifted into range by the plan
    scene = Scene(48, 40, (Polygon((moved,), 200),), background=30)
    result = render_scene(scene, DEFAULT)
    assert result.plan.offset == (2, 1)  # whole pixels: -1.9375 -> 0.0625, -0.5 -> 0.5
    assert np.array_equal(result.image[:37, :43], image[3:, 5:])


# -- engines ------------------------------------------------------------------------------------


def test_model_and_verilator_give_the_same_image_on_the_builtins(plans, model_renders):
    for name in BUILTINS:
        fast = render_scene(plans[name], engine="verilator")
        model = model_renders[name]
        assert np.array_equal(fast.image, model.image), name
        for field in ("edge", "x", "y", "value"):
            assert np.array_equal(getattr(fast.writes, field), getattr(model.writes, field))
        edges = [plans[name].edge(int(e), clip=True) for e in fast.sent]
        # cycles: the measured beats leave in the clocks the timing model predicts
        assert np.array_equal(fast.engine_run.beat_clocks, beat_clocks(DEFAULT, edges)), name
        assert fast.cycles == model.cycles == int(fast.engine_run.beat_clocks[-1]) + 1


def test_amaranth_gives_the_model_image_on_a_tiny_scene():
    scene = parse_scene(
        {
            "width": 20,
            "height": 14,
            "background": 40,
            "polygons": [
                {"points": [[1.5, 1.25], [17.75, 3.5], [8.0625, 12.5]], "intensity": 220},
                {"path": "M 3 11 l 5 -3 q 4 4 -2 5 z", "intensity": 90, "fill_rule": "evenodd"},
            ],
        }
    )
    slow = render_scene(scene, DEFAULT, engine="amaranth")
    model = render_scene(scene, DEFAULT, engine="model")
    assert np.array_equal(slow.image, model.image)
    edges = [slow.plan.edge(int(e), clip=True) for e in slow.sent]
    assert np.array_equal(slow.engine_run.beat_clocks, beat_clocks(DEFAULT, edges))


# -- skipping -----------------------------------------------------------------------------------


def test_every_skipping_rule_saves_work_and_leaves_the_image_unchanged(plans, model_renders):
    totals = {}
    for name in BUILTINS:
        skipping, full = model_renders[name], render_scene(plans[name], skip=False)
        assert np.array_equal(skipping.image, full.image), name
        assert skipping.cycles < full.cycles and len(skipping.sent) < len(full.sent), name
        assert skipping.pixels_touched < full.pixels_touched, name
        for saving in rule_savings(full, skipping):
            got = totals.setdefault(saving.rule, [0, 0, 0])
            got[0] += saving.edges
            got[1] += saving.cycles
            got[2] += saving.engine_writes
        assert skipping.not_applied > 0, name
        report = stats_report(full, skipping)
        assert "images identical: yes" in report and "partly outside" in report
    for rule, (edges, cycles, writes) in totals.items():
        assert edges > 0 and cycles > 0 and writes > 0, rule
    # each rule on its own leaves the image unchanged: turn them off one at a time
    for name, attr in (("starburst", "culled"), ("text", "axis"), ("starburst", "axis")):
        plan = plans[name]
        saved = getattr(plan, attr).copy()
        assert saved.any(), (name, attr)
        try:
            getattr(plan, attr)[:] = False
            alone = render_scene(plan)
        finally:
            getattr(plan, attr)[:] = saved
        assert np.array_equal(alone.image, model_renders[name].image), (name, attr)


def test_the_fill_path_writes_what_the_model_writes(plans):
    configs = [DEFAULT, EdgeConfig(mode="seg4"), EdgeConfig(mode="pw", accumulator="truncated")]
    configs.append(EdgeConfig(coord_bits=9, subpixel_bits=2, intensity_bits=5))
    rng = random.Random(3)
    for config in configs:
        edges = []
        for name in BUILTINS:
            p = plans[name]
            edges += [p.edge(int(e)) for e in np.flatnonzero(p.axis & p.boundary)]
        for _ in range(60):
            a, b = rng.randint(0, config.max_vertex), rng.randint(0, config.max_vertex)
            c = rng.randint(0, config.max_vertex)
            if a == b:
                continue
            i_in, i_out = rng.sample(range(config.full_scale + 1), 2)
            side = rng.choice(["left", "right"])
            edges.append(Edge(a, c, b, c, side, i_in, i_out))
            edges.append(Edge(c, a, c, b, side, i_in, i_out))
        if config is not DEFAULT:
            edges = [_fit(edge, config) for edge in edges]
        batch = run_edges(config, edges)
        for k, edge in enumerate(edges):
            x, y, v = axis_writes(config, edge)
            rows = batch.edge_slice(k)
            for got, want in zip((x, y, v), (batch.x, batch.y, batch.value), strict=True):
                assert np.array_equal(got, want[rows]), edge
        for edge in edges[:: max(1, len(edges) // 20)]:  # and the step model itself
            x, y, v = axis_writes(config, edge)
            want = run_edge(config, edge).writes
            assert [(w.x, w.y, w.value) for w in want] == list(zip(x, y, v, strict=True)), edge


def _fit(edge: Edge, config: EdgeConfig) -> Edge:
    hi = config.max_vertex
    i_in = None if edge.i_in is None else min(edge.i_in, config.full_scale)
    i_out = min(edge.i_out, config.full_scale)
    value_in = config.full_scale if i_in is None else i_in
    if i_out == value_in:
        i_out = 0 if value_in else config.full_scale
    x0, y0, x1, y1 = (min(v, hi) for v in (edge.x0, edge.y0, edge.x1, edge.y1))
    if (x0, y0) == (x1, y1):
        x1 = x0 - 1 if x0 else x0 + 1
    return Edge(x0, y0, x1, y1, edge.inside, i_in, i_out)


def test_culled_edges_write_nothing_inside_the_image(plans):
    p = plans["starburst"]  # the text is wholly inside its image
    culled = np.flatnonzero(p.culled & p.boundary)
    assert len(culled) > 0
    batch = run_edges(DEFAULT, [p.edge(int(e)) for e in culled])
    x, y = batch.x - p.offset[0], batch.y - p.offset[1]
    inside = (x >= 0) & (x < p.scene.width) & (y >= 0) & (y < p.scene.height)
    assert not inside.any()


def test_clipping_to_the_viewport_keeps_every_write_inside_the_image(plans):
    """The viewport clip drops only writes off the image, and it does drop some."""
    p = plans["starburst"]
    sent = np.flatnonzero(p.boundary & ~p.culled & ~p.axis)
    whole = run_edges(DEFAULT, [p.edge(int(e)) for e in sent])
    cut = run_edges(DEFAULT, [p.edge(int(e), clip=True) for e in sent])

    def in_image(batch):
        x, y = batch.x - p.offset[0], batch.y - p.offset[1]
        keep = (x >= 0) & (x < p.scene.width) & (y >= 0) & (y < p.scene.height)
        return sorted(zip(batch.edge_index[keep], x[keep], y[keep], batch.value[keep], strict=True))

    assert in_image(cut) == in_image(whole)
    assert len(cut) < len(whole)


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
    assert "images identical: yes" in text and "several edges" in text and "16-bit" in text
    with Image.open(out) as image:
        assert image.mode.startswith("I;16")
        assert np.asarray(image).max() == round(1000 * 65535 / 1023)


def test_progress_goes_to_stderr(tmp_path, capsys, monkeypatch):
    from edgeaa import command

    monkeypatch.setattr(command, "DELAY", 0.0)
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
    assert rows["one edge"].max_abs <= 8 and rows["fill only"].max_abs == 0


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
        ({"path": "M 0 0 C 1e6 1e6 -1e6 -1e6 9 9 S 1e6 1e6 0 0"}, "limit of 10,000 edges"),
        ({"path": "M 0 0 " + "l 1 0 " * 10001 + "z"}, "more than the limit of 10,000 edges"),
        ({"points": [[i % 7, i // 7] for i in range(10001)]}, "limit of 10,000 edges"),
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
    with pytest.raises(SceneError, match="more than the limit of 200,000 edges per scene"):
        parse_scene({"width": 8, "height": 8, "polygons": polygons})


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
