"""split_crossings (render/geometry.py) against its earlier quadratic form, kept here as the
reference: the same contours, the same inserted points in the same order, on seeded random
polygons (self-intersecting stars, vertex soups, random walks, collinear overlaps, shared
vertices, many vertices in one pixel, repeated vertices, coordinates too large for int64
products). Hypothesis draws the seed and prints it (with the family and size) on failure;
`polygon(seed, family, n, parts)` rebuilds the input.

And the plan's noding (`render.render._node`: one round, or snap rounding): on seeded random
self-intersecting polygons it always returns, leaves no two edges crossing or touching,
and moves the filled region by at most the bound of docs/noding.md."""

from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, given, note, settings
from hypothesis import strategies as st

from edgeaa.render import geometry
from edgeaa.render.geometry import _candidate_pairs, split_crossings

REF_CHUNK = 1 << 22


# --- the reference: split_crossings as it was before the sweep, unchanged -------------------


def _ref_cross(ax: int, ay: int, bx: int, by: int) -> int:
    return ax * by - ay * bx


def _ref_round_div(num: int, den: int) -> int:
    return (2 * num + den) // (2 * den)


def reference_split_crossings(contours: list[np.ndarray]) -> tuple[list[np.ndarray], int]:
    segs = []
    for pts in contours:
        nxt = np.roll(pts, -1, axis=0)
        segs.append(np.concatenate([pts, nxt], axis=1))
    if not segs:
        return contours, 0
    seg = np.concatenate(segs)
    lo_x, hi_x = np.minimum(seg[:, 0], seg[:, 2]), np.maximum(seg[:, 0], seg[:, 2])
    lo_y, hi_y = np.minimum(seg[:, 1], seg[:, 3]), np.maximum(seg[:, 1], seg[:, 3])
    n = len(seg)
    splits: dict[int, list] = {}
    step = max(1, REF_CHUNK // max(1, n))
    rows = seg.tolist()
    for lo in range(0, n, step):
        i = np.arange(lo, min(n, lo + step))[:, None]
        meet = (
            (lo_x[i] <= hi_x[None, :])
            & (lo_x[None, :] <= hi_x[i])
            & (lo_y[i] <= hi_y[None, :])
            & (lo_y[None, :] <= hi_y[i])
            & (np.arange(n)[None, :] > i)
        )
        for a, b in np.argwhere(meet).tolist():
            reference_intersect(a + lo, b, rows, splits)
    if not splits:
        return contours, 0
    out, inserted = [], 0
    base = 0
    for pts in contours:
        points = []
        for k in range(len(pts)):
            points.append(tuple(int(v) for v in pts[k]))
            for _, p in sorted(splits.get(base + k, ())):
                if p != points[-1]:
                    points.append(p)
                    inserted += 1
        base += len(pts)
        kept = [p for i, p in enumerate(points) if p != points[i - 1]]  # cyclic dedup
        out.append(np.array(kept or points[:1], dtype=np.int64))
    return out, inserted


def reference_intersect(i: int, j: int, rows: list, splits: dict) -> None:
    ax, ay, bx, by = rows[i]
    cx, cy, dx, dy = rows[j]
    rx, ry, sx, sy = bx - ax, by - ay, dx - cx, dy - cy
    if (rx, ry) == (0, 0) or (sx, sy) == (0, 0):
        return
    den = _ref_cross(rx, ry, sx, sy)
    if den:
        tn, un = _ref_cross(cx - ax, cy - ay, sx, sy), _ref_cross(cx - ax, cy - ay, rx, ry)
        if den < 0:
            den, tn, un = -den, -tn, -un
        if not (0 <= tn <= den and 0 <= un <= den):
            return
        point = (_ref_round_div(ax * den + tn * rx, den), _ref_round_div(ay * den + tn * ry, den))
        if 0 < tn < den:
            splits.setdefault(i, []).append((Fraction(tn, den), point))
        if 0 < un < den:
            splits.setdefault(j, []).append((Fraction(un, den), point))
        return
    if _ref_cross(cx - ax, cy - ay, rx, ry):
        return
    for (px, py), k, (ox, oy, ux, uy) in (
        ((cx, cy), i, (ax, ay, rx, ry)),
        ((dx, dy), i, (ax, ay, rx, ry)),
        ((ax, ay), j, (cx, cy, sx, sy)),
        ((bx, by), j, (cx, cy, sx, sy)),
    ):
        t = Fraction((px - ox) * ux + (py - oy) * uy, ux * ux + uy * uy)
        if 0 < t < 1:
            splits.setdefault(k, []).append((t, (px, py)))


# --- seeded polygons (also used by benchmarks/noding.py) -------------------------------------


def star(rng: np.random.Generator, n: int) -> np.ndarray:
    """A {n/m} star with jittered radii and angles: self-intersecting for m > 1."""
    m = int(rng.integers(1, max(2, n // 2)))
    k = np.arange(n)
    angle = 2 * np.pi * m * k / n + rng.normal(0, 0.02, n)
    radius = 4096 * (0.6 + 0.4 * rng.random(n))
    return np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1).round() + 8192


def soup(rng: np.random.Generator, n: int) -> np.ndarray:
    """Vertices uniform in a box from 4 sub-pixel units to 2**20 wide (k ~ n**2 crossings)."""
    size = int(rng.choice([4, 16, 256, 4096, 1 << 20]))
    return rng.integers(0, size, (n, 2)) - size // 3


def walk(rng: np.random.Generator, n: int) -> np.ndarray:
    """A closed random walk of short steps: about n log n crossings, most edges short."""
    return np.cumsum(rng.integers(-40, 41, (n, 2)), axis=0) + 5000


def collinear(rng: np.random.Generator, n: int) -> np.ndarray:
    """Vertices on a few lines (some axis-parallel): overlapping collinear edges."""
    lines = [
        (rng.integers(-50, 50, 2), rng.integers(-3, 4, 2)) for _ in range(int(rng.integers(1, 4)))
    ]
    lines = [(p, d if d.any() else np.array([1, 0])) for p, d in lines]
    pick = rng.integers(0, len(lines), n)
    t = rng.integers(-20, 21, n)
    return np.array([lines[c][0] + t[k] * lines[c][1] for k, c in enumerate(pick)])


def shared(rng: np.random.Generator, n: int) -> np.ndarray:
    """Vertices drawn from a small pool: repeated and shared vertices, edges met at ends."""
    pool = rng.integers(0, 64, (max(3, n // 4), 2))
    return pool[rng.integers(0, len(pool), n)]


def pixel(rng: np.random.Generator, n: int) -> np.ndarray:
    """Most vertices inside one 16 x 16 pixel, a few far away."""
    pts = rng.integers(0, 16, (n, 2)) + 320
    far = rng.random(n) < 0.15
    pts[far] = rng.integers(0, 1024, (int(far.sum()), 2))
    return pts


def repeats(rng: np.random.Generator, n: int) -> np.ndarray:
    """Another family's vertices, some repeated in a row: zero-length edges."""
    base = FAMILIES[str(rng.choice(["star", "soup", "walk", "shared"]))](rng, n)
    return np.repeat(base, rng.integers(1, 4, len(base)), axis=0)[: max(n, 1)]


def huge(rng: np.random.Generator, n: int) -> np.ndarray:
    """Coordinates around 2**30 (the int64 filter's limit) or 2**40 (past it)."""
    size = int(rng.choice([1 << 31, 1 << 41]))
    return rng.integers(-size, size, (n, 2)) // int(rng.choice([1, 1 << 20]))


FAMILIES = {f.__name__: f for f in (star, soup, walk, collinear, shared, pixel, repeats, huge)}


def polygon(seed: int, family: str, n: int, parts: int = 1) -> list[np.ndarray]:
    """`parts` contours of about n vertices in all, int64, from one seed."""
    rng = np.random.default_rng(seed)
    sizes = [max(1, n // parts + int(rng.integers(-2, 3))) for _ in range(parts)]
    return [FAMILIES[family](rng, size).astype(np.int64) for size in sizes]


# --- the tests ------------------------------------------------------------------------------


def assert_same(contours: list[np.ndarray]) -> None:
    want, want_inserted = reference_split_crossings(contours)
    got, got_inserted = split_crossings(contours)
    assert got_inserted == want_inserted
    assert (got is contours) == (want is contours)
    assert len(got) == len(want)
    for g, w in zip(got, want, strict=True):
        assert g.dtype == w.dtype and g.shape == w.shape and g.tolist() == w.tolist()


@settings(
    derandomize=True,
    deadline=None,
    max_examples=400,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(
    seed=st.integers(0, 2**32 - 1),
    family=st.sampled_from(sorted(FAMILIES)),
    n=st.integers(1, 60),
    parts=st.integers(1, 3),
)
def test_split_crossings_matches_the_reference(seed, family, n, parts):
    note(f"input: polygon(seed={seed}, family={family!r}, n={n}, parts={parts})")
    assert_same(polygon(seed, family, n, parts))


@pytest.mark.parametrize("family", sorted(FAMILIES))
@pytest.mark.parametrize("seed", range(3))
def test_larger_polygons_match_in_small_chunks(monkeypatch, family, seed):
    """Up to 300 vertices, with the sweep's pairs cut into chunks of 97 (many blocks)."""
    monkeypatch.setattr(geometry, "PAIRS", 97)
    assert_same(polygon(seed, family, 100 + 100 * seed, parts=1 + seed % 2))


def _productive_pairs(seg: np.ndarray) -> set[tuple[int, int]]:
    """Pairs (i < j) for which the reference's exact test inserts something, by brute force."""
    rows, found = seg.tolist(), set()
    for i, j in itertools.combinations(range(len(rows)), 2):
        splits: dict[int, list] = {}
        reference_intersect(i, j, rows, splits)
        if splits:
            found.add((i, j))
    return found


@pytest.mark.parametrize("family", sorted(FAMILIES))
@pytest.mark.parametrize("seed", range(4))
def test_the_sweep_yields_exactly_the_pairs_that_split(family, seed):
    contours = polygon(seed, family, 40, parts=2)
    seg = np.concatenate([np.concatenate([p, np.roll(p, -1, axis=0)], axis=1) for p in contours])
    pairs = list(_candidate_pairs(seg))
    assert len(pairs) == len(set(pairs)) and all(i < j for i, j in pairs)
    productive = _productive_pairs(seg)
    if np.abs(seg).max() < geometry.SAFE:
        assert set(pairs) == productive  # the int64 filter is _intersect's test exactly
    else:
        assert set(pairs) >= productive  # past int64: every box-overlapping pair


def test_empty_and_tiny_inputs():
    for contours in ([], [np.zeros((0, 2), np.int64)], [np.array([[3, 4]], np.int64)]):
        assert_same(contours)
    assert_same([np.array([[0, 0], [8, 8]], np.int64), np.array([[0, 8], [8, 0]], np.int64)])


def test_a_long_outline_and_a_comb_are_not_quadratic():
    """20,000 edges: a fine circle (boxes meet only neighbours) and a comb whose teeth all
    overlap along x (the sweep takes y). Each would be 2 * 10**8 box tests the old way."""
    a = np.linspace(0, 2 * np.pi, 20000, endpoint=False)
    circle = (np.stack([np.cos(a), np.sin(a)], axis=1) * 30000).round().astype(np.int64)
    (out,), inserted = split_crossings([circle])
    assert inserted == 0 and out.tolist() == circle.tolist()
    k = np.arange(5000)
    ys = np.stack([4 * k, 4 * k, 4 * k + 2, 4 * k + 2], axis=1).ravel()
    comb = np.stack([np.tile([0, 30000, 30000, 0], 5000), ys], axis=1)
    comb = np.concatenate([comb, [[-10, ys[-1]], [-10, 0]]]).astype(np.int64)
    (out,), inserted = split_crossings([comb])
    assert inserted == 0


def test_split_points_closer_than_a_float_keep_their_exact_order():
    """Two crossings of one edge whose t differ by about 2**-57 (the same float): the exact t
    orders them, and they round to different points (k + 1/2 - 2**-29 and k + 1/2)."""
    L, k, M = 1 << 28, 1 << 27, 1 << 27
    contours = [
        np.array([[L, 0], [0, 0]], np.int64),  # the split edge runs towards -x
        np.array([[k, -M], [k + 1, M + 1]], np.int64),  # crosses y = 0 just left of k + 1/2
        np.array([[k, -1], [k + 1, 1]], np.int64),  # crosses at k + 1/2, rounded up to k + 1
    ]
    assert (L - k - 0.5) / L == (L - k - 0.5 + 1 / (4 * M + 2)) / L  # a float tie
    assert_same(contours)
    (first, *_), _ = split_crossings(contours)
    assert first.tolist()[:3] == [[L, 0], [k + 1, 0], [k, 0]]


# --- the plan's noding: always a plan, nothing crossing, the area within the bound ----------


def crossings_left(contours: list[np.ndarray]) -> list[tuple]:
    """Pairs of edges of the contours that still cross at a point inside both, or where an end
    of one lies inside the other (exact integers, numpy over all pairs)."""
    seg = np.concatenate([np.concatenate([p, np.roll(p, -1, axis=0)], axis=1) for p in contours])
    seg = seg[np.any(seg[:, 0:2] != seg[:, 2:4], axis=1)].astype(object)
    i, j = np.triu_indices(len(seg), 1)
    a, b, c, d = seg[i, 0:2], seg[i, 2:4], seg[j, 0:2], seg[j, 2:4]

    def orient(p, q, r):
        return (q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0])

    def strictly_inside(p, q, v):  # v on segment p q, not an end
        dot = (v[:, 0] - p[:, 0]) * (q[:, 0] - p[:, 0]) + (v[:, 1] - p[:, 1]) * (q[:, 1] - p[:, 1])
        length = (q[:, 0] - p[:, 0]) ** 2 + (q[:, 1] - p[:, 1]) ** 2
        return (orient(p, q, v) == 0) & (dot > 0) & (dot < length)

    cross = (orient(a, b, c) * orient(a, b, d) < 0) & (orient(c, d, a) * orient(c, d, b) < 0)
    touch = (
        strictly_inside(a, b, c)
        | strictly_inside(a, b, d)
        | strictly_inside(c, d, a)
        | strictly_inside(c, d, b)
    )
    bad = np.flatnonzero(cross | touch)
    return [(seg[i[k]].tolist(), seg[j[k]].tolist()) for k in bad]


def filled_region(edges: np.ndarray, rule: str, scale: int):
    """The region the edges bound under the fill rule (shapely), in pixels."""
    import shapely

    from edgeaa.render.exact import winding_float
    from edgeaa.render.geometry import fills

    coords = edges.astype(np.float64) / scale
    noded = shapely.union_all(shapely.linestrings(coords.reshape(-1, 2, 2)))
    faces = shapely.get_parts(shapely.polygonize(shapely.get_parts(noded)))
    if not len(faces):
        return shapely.Polygon()
    points = shapely.get_coordinates(shapely.point_on_surface(faces))
    keep = fills(winding_float(coords, points[:, 0], points[:, 1]), rule)
    return shapely.union_all(faces[keep])


@settings(derandomize=True, deadline=None, max_examples=300)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(4, 14),
    size=st.sampled_from([4.0, 12.0, 40.0]),
    bits=st.integers(0, 4),
    rule=st.sampled_from(["nonzero", "evenodd"]),
)
def test_the_plan_nodes_every_self_intersecting_polygon(seed, n, size, bits, rule):
    """plan_scene always returns; no edge of the plan crosses or touches another inside it;
    the filled region moves by at most the bound of docs/noding.md: every edge stays within
    half a grid step (1/2S px on each axis) of where it was, so the region changes only
    inside those tubes, of area at most sqrt(2) |e| / S + 1 / S**2 each."""
    from edgeaa.model import EdgeConfig
    from edgeaa.render import Polygon, Scene, plan_scene

    note(f"input: seed={seed}, n={n}, size={size}, bits={bits}, rule={rule!r}")
    rng = np.random.default_rng(seed)
    points = tuple(map(tuple, rng.uniform(0, size, (n, 2)).round(4).tolist()))
    side = int(size) + 2
    config = EdgeConfig(subpixel_bits=bits)
    plan = plan_scene(Scene(side, side, (Polygon((points,), fill_rule=rule),)), config)
    S = config.subpixel_scale
    if not plan.edge_count:
        return  # collapsed on the grid (fewer than 3 distinct vertices): nothing to node
    pieces = [plan.coords[plan.contour == c][:, 0:2] for c in np.unique(plan.contour)]
    assert crossings_left(pieces) == []
    quantized = np.floor(np.array(points) * S + 0.5).astype(np.int64)
    keep = np.any(quantized != np.roll(quantized, 1, axis=0), axis=1)
    quantized = quantized[keep]
    before = np.concatenate([quantized, np.roll(quantized, -1, axis=0)], axis=1)
    after = plan.coords - np.tile(np.array(plan.offset) * S, 2)
    moved = filled_region(before, rule, S).symmetric_difference(filled_region(after, rule, S))
    lengths = np.hypot(before[:, 2] - before[:, 0], before[:, 3] - before[:, 1]) / S
    bound = float(np.sum(np.sqrt(2) * lengths / S + 1 / S**2))
    assert moved.area <= bound + 1e-9


# The first random 12-vertex even-odd polygon that the earlier noding refused ("edges still
# cross after 16 rounds of splitting"): seed 1106 of uniform(0, 64) vertices.
REFUSED = (
    (50.143, 57.85), (11.573, 25.227), (38.471, 61.867), (49.767, 59.852), (60.386, 47.582),
    (54.852, 35.105), (55.592, 22.29), (52.491, 19.952), (16.325, 0.702), (59.72, 47.344),
    (52.149, 4.935), (59.407, 45.735),
)  # fmt: skip


def test_a_polygon_that_splitting_again_never_nodes_is_snap_rounded():
    from edgeaa.model import EdgeConfig
    from edgeaa.render import Polygon, Scene, plan_scene, render_scene

    scene = Scene(64, 64, (Polygon((REFUSED,), fill_rule="evenodd"),))
    plan = plan_scene(scene, EdgeConfig())
    pieces = [plan.coords[plan.contour == c][:, 0:2] for c in np.unique(plan.contour)]
    assert crossings_left(pieces) == []
    assert render_scene(plan).image.any()


# --- the fill-rule sides from the sweep against the banded winding numbers ------------------


def _as_quantized(contours: list[np.ndarray]) -> list[np.ndarray]:
    """The contours as the plan's quantization leaves them: no vertex repeated in a row (no
    zero-length edge, whose midpoint has no sides), at least 3 distinct vertices each."""
    out = []
    for c in contours:
        c = c[np.any(c != np.roll(c, 1, axis=0), axis=1)]
        if len(np.unique(c, axis=0)) >= 3:
            out.append(c)
    return out


def _sides_both_ways(monkeypatch, edges, rules, group=None):
    """side_fills with every polygon swept and with none (the banded winding numbers)."""
    monkeypatch.setattr(geometry, "SWEEP_PAIRS", 0)
    swept = geometry.side_fills(edges, rules, group)
    monkeypatch.setattr(geometry, "SWEEP_PAIRS", 10**18)
    banded = geometry.side_fills(edges, rules, group)
    return swept, banded


@settings(derandomize=True, deadline=None, max_examples=300)
@given(
    seed=st.integers(0, 2**32 - 1),
    family=st.sampled_from(sorted(set(FAMILIES) - {"huge"})),  # past int64: refused by plans
    n=st.integers(1, 80),
    parts=st.integers(1, 4),
    polygons=st.integers(1, 3),
)
def test_the_swept_sides_are_the_banded_ones_on_noded_polygons(seed, family, n, parts, polygons):
    """Noded by the plan's noding (`render._node`): self-intersecting stars, soups, walks,
    collinear overlaps, shared and repeated vertices, many vertices in one pixel; several
    polygons at once (stacked by group) with both fill rules."""
    import pytest as _pytest

    from edgeaa.render.render import _node

    note(f"input: polygon(seed={seed}, family={family!r}, n={n}, parts={parts}) x {polygons}")
    edges, group, rules = [], [], []
    for g in range(polygons):
        noded, _ = _node(_as_quantized(polygon(seed + g, family, n, parts)))
        seg = geometry.contour_segments([c for c in noded if len(c) >= 2])
        edges.append(seg)
        group += [g] * len(seg)
        rules += ["evenodd" if (seed + g) % 2 else "nonzero"] * len(seg)
    edges = np.concatenate(edges)
    mp = _pytest.MonkeyPatch()
    try:
        swept, banded = _sides_both_ways(mp, edges, np.array(rules), np.array(group))
    finally:
        mp.undo()
    for s, b in zip(swept, banded, strict=True):
        assert s.tolist() == b.tolist()


def radial_star(n: int) -> tuple:
    """n vertices alternating 240 px and 20 px from the centre of a 512 px square: every
    edge spans most of the rows (the banded pairs' quadratic case)."""
    a = 2 * np.pi * np.arange(n) / n
    r = np.where(np.arange(n) % 2 == 0, 240.0, 20.0)
    return tuple(zip((256 + r * np.cos(a)).tolist(), (256 + r * np.sin(a)).tolist(), strict=True))


def _plans_both_ways(monkeypatch, scene):
    from edgeaa.model import EdgeConfig
    from edgeaa.render import plan_scene

    monkeypatch.setattr(geometry, "SWEEP_PAIRS", 0)
    swept = plan_scene(scene, EdgeConfig())
    monkeypatch.setattr(geometry, "SWEEP_PAIRS", 10**18)
    banded = plan_scene(scene, EdgeConfig())
    return swept, banded


def _corpus_scenes():
    from edgeaa.model import EdgeConfig
    from edgeaa.render import Polygon, Scene, builtin
    from edgeaa.render.builtin import BUILTINS
    from edgeaa.render.corpus import adversarial_scenes, font_scene

    scenes = [builtin(name, EdgeConfig()) for name in BUILTINS]
    scenes += [font_scene(font, size)[0] for font in ("DejaVuSans", "cmr10") for size in (9, 32)]
    scenes += list(adversarial_scenes())
    sliver = ((1.0, 1.0), (500.0, 1.5), (1.0, 1.25), (500.0, 1.0), (1.0, 2.0))
    stars = [
        Polygon((radial_star(n),), 200, rule) for n, rule in ((600, "nonzero"), (300, "evenodd"))
    ]
    scenes.append(Scene(512, 512, (*stars, Polygon((sliver,), 100, "evenodd")), background=0))
    return scenes


def test_the_plans_are_the_same_swept_or_banded(monkeypatch):
    """The built-ins, fonts, the corpus's adversarial scenes, two radial stars and a
    self-crossing sliver: every edge's inside side (so every image) the same both ways."""
    for scene in _corpus_scenes():
        swept, banded = _plans_both_ways(monkeypatch, scene)
        assert np.array_equal(swept.coords, banded.coords), scene.name
        assert swept.inside.tolist() == banded.inside.tolist(), scene.name
        assert swept.duplicates == banded.duplicates, scene.name


@pytest.mark.parametrize("size", [1, 7])
def test_the_plans_are_the_same_in_passes_of_any_size(monkeypatch, size):
    """The crossing search (`BATCH_EDGES`) and the side test (`SIDE_EDGES`) take the
    polygons in passes to bound their memory: passes of a polygon each (size 1) or of a few
    edges give the one-pass plan on the corpus, edge for edge and side for side."""
    from edgeaa.model import EdgeConfig
    from edgeaa.render import plan_scene
    from edgeaa.render import render as render_module

    for scene in _corpus_scenes():
        monkeypatch.setattr(render_module, "BATCH_EDGES", 1 << 40)
        monkeypatch.setattr(render_module, "SIDE_EDGES", 1 << 40)
        whole = plan_scene(scene, EdgeConfig())
        monkeypatch.setattr(render_module, "BATCH_EDGES", size)
        monkeypatch.setattr(render_module, "SIDE_EDGES", size)
        passes = plan_scene(scene, EdgeConfig())
        assert np.array_equal(whole.coords, passes.coords), scene.name
        assert whole.inside.tolist() == passes.inside.tolist(), scene.name
        assert (whole.duplicates, whole.crossings) == (passes.duplicates, passes.crossings)
        assert np.array_equal(whole.polygon, passes.polygon), scene.name


def test_a_radial_star_is_swept(monkeypatch):
    """3,000 vertices (the radial star of benchmarks/bench_sweep.py): the plan sweeps it and
    gets the banded winding numbers' sides."""
    from edgeaa.render import Polygon, Scene

    scene = Scene(512, 512, (Polygon((radial_star(3000),), 255, "nonzero"),), background=0)
    swept, banded = _plans_both_ways(monkeypatch, scene)
    monkeypatch.undo()
    assert geometry._swept(swept.coords, swept.polygon).all()
    assert swept.inside.tolist() == banded.inside.tolist()
    assert (swept.inside != "").sum() > 2000


# --- the crossing search's neighbour sweep: it finds a split whenever there is one ----------


def _with_defect(contours: list[np.ndarray], rng: np.random.Generator) -> list[np.ndarray]:
    """Noded contours with at most one defect: a vertex moved onto another edge's midpoint
    (a T), onto another vertex (a shared end), or an edge doubled back over half of itself
    (a collinear overlap)."""
    from edgeaa.render.render import _node

    noded = [c.copy() for c in _node(contours)[0] if len(c) >= 2]
    if not noded:
        return noded
    ci, cj = int(rng.integers(len(noded))), int(rng.integers(len(noded)))
    c, other = noded[ci], noded[cj]
    i, j = int(rng.integers(len(c))), int(rng.integers(len(other)))
    a, b = other[j], other[(j + 1) % len(other)]
    kind = int(rng.integers(4))
    if kind == 0 and not ((b - a) % 2).any():
        c[i] = (a + b) // 2  # on the grid
    elif kind == 1:
        c[i] = a
    elif kind == 2 and not ((b - a) % 2).any():  # a b m b: back over the half m b
        noded[cj] = np.insert(other, j + 2, [(a + b) // 2, b], axis=0)
    return noded


@settings(derandomize=True, deadline=None, max_examples=400)
@given(
    seed=st.integers(0, 2**32 - 1),
    family=st.sampled_from(sorted(set(FAMILIES) - {"huge"})),
    n=st.integers(2, 30),
    parts=st.integers(1, 3),
    defect=st.booleans(),
)
def test_the_neighbour_sweep_finds_a_split_whenever_there_is_one(seed, family, n, parts, defect):
    """Whether any pair of the sweep's neighbours splits is whether any pair at all does (by
    brute force): on raw random polygons and on noded ones with one defect (few splits,
    all of them degenerate: T-junctions, shared ends, collinear overlaps, horizontals)."""
    note(f"input: polygon(seed={seed}, family={family!r}, n={n}, parts={parts}), {defect}")
    contours = polygon(seed, family, n, parts)
    if defect:
        contours = _with_defect(contours, np.random.default_rng(seed))
    seg = geometry.contour_segments(contours)
    if not len(seg):
        return
    found = geometry._may_split(seg.T.astype(np.int64), *geometry._sweep_neighbours(seg))
    assert bool(found.any()) == bool(_productive_pairs(seg))


@pytest.mark.parametrize("family", sorted(set(FAMILIES) - {"huge"}))
@pytest.mark.parametrize("seed", range(4))
def test_split_crossings_is_the_reference_with_the_neighbour_sweep_first(monkeypatch, family, seed):
    """Every search checked by the sweep first (SWEEP_BOXES 0): the same pairs, so the same
    splits, as the reference's, raw and noded."""
    monkeypatch.setattr(geometry, "SWEEP_BOXES", 0)
    contours = polygon(seed, family, 60 + 40 * seed, parts=1 + seed % 3)
    assert_same(contours)
    assert_same(_with_defect(contours, np.random.default_rng(seed)))
    seg = geometry.contour_segments(contours)
    assert set(_candidate_pairs(seg)) == _productive_pairs(seg)


NEIGHBOUR_CASES = {
    "an X whose arms meet only after an edge between them ends": [
        [[0, 0], [10, 10]], [[10, 0], [0, 10]], [[5, 0], [5, 2]],
    ],
    "a T: a vertex on a horizontal edge's interior": [[[0, 0], [10, 0]], [[4, 0], [4, 9]]],
    "a horizontal crossing a vertical": [[[0, 5], [10, 5]], [[4, 0], [4, 9]]],
    "collinear overlap from one vertex": [[[0, 0], [8, 8]], [[0, 0], [4, 4], [0, 9]]],
    "shared ends only": [[[0, 0], [8, 8], [8, 0]], [[8, 8], [16, 0], [16, 16]]],
    "coincident copies only": [[[0, 0], [8, 8], [8, 0]], [[8, 8], [0, 0], [0, 8]]],
}  # fmt: skip


@pytest.mark.parametrize("name", sorted(NEIGHBOUR_CASES))
def test_the_neighbour_sweep_on_hand_made_cases(name):
    contours = [np.array(c, dtype=np.int64) for c in NEIGHBOUR_CASES[name]]
    seg = geometry.contour_segments(contours)
    found = geometry._may_split(seg.T.astype(np.int64), *geometry._sweep_neighbours(seg))
    assert bool(found.any()) == bool(_productive_pairs(seg)), name
