"""The seeds' antialiasing methods: MSAA patterns, MLAA (and slope prediction), FXAA (and
geometry edges), TAA. Known answers on a horizontal edge, a 45 degree edge and pixel-aligned
edges, and properties: constant images stay constant, pixels far from edges are untouched.
"""

from __future__ import annotations

import numpy as np
import pytest

from edgeaa.analysis import aa_methods, evaluate, fxaa, geometry, mlaa, msaa, temporal
from edgeaa.model import Edge, EdgeConfig

SEED = 20261124
CONFIG = EdgeConfig()


def coverage(name: str, edge: Edge, xs, ys) -> np.ndarray:
    e = np.zeros(len(xs), dtype=np.int64)
    return msaa.pattern_coverage(CONFIG, [edge], e, np.array(xs), np.array(ys), name)


def half_plane_image(f, h=48, w=96, n=16):
    """Point-sampled image of {f(x, y) > 0} and its exact coverage (n x n midpoint rule, exact
    to 1/(2n) at worst, far better on a straight line away from corners)."""
    ys, xs = np.mgrid[0:h, 0:w].astype(float)
    offsets = (np.arange(n) + 0.5) / n - 0.5
    exact = sum((f(xs + a, ys + b) > 0).astype(float) for a in offsets for b in offsets)
    return (f(xs, ys) > 0).astype(float), exact / n**2


# -- sample patterns ------------------------------------------------------------------------------


def test_patterns_structure_weights_and_sharing():
    for name, p in msaa.PATTERNS.items():
        assert abs(p.weights.sum() - 1) < 1e-12, name
        assert np.all(np.abs(p.units) <= msaa.UNITS // 2), name  # inside the closed pixel
    assert np.array_equal(msaa.PATTERNS["msaa2"].units * 16 // msaa.UNITS, [(4, 4), (-4, -4)])
    # FLIPQUAD: one sample on each pixel edge, equally spaced x and y, and the neighbour's
    # mirrored pattern shares the samples on the common edges
    fq = msaa.PATTERNS["flipquad"]
    assert sorted(fq.units[:, 0]) == sorted(fq.units[:, 1]) == [-24, -8, 8, 24]
    even = msaa.pixel_units(fq, np.array([0]), np.array([0]))[0]
    right = msaa.pixel_units(fq, np.array([1]), np.array([0]))[0] + (msaa.UNITS, 0)
    below = msaa.pixel_units(fq, np.array([0]), np.array([1]))[0] + (0, msaa.UNITS)
    assert {tuple(u) for u in even} & {tuple(u) for u in right} == {(24, -8)}
    assert {tuple(u) for u in even} & {tuple(u) for u in below} == {(8, 24)}
    assert msaa.PATTERNS["quincunx"].stored == fq.stored == 2


def test_horizontal_edge_known_answers():
    edge = Edge.from_pixels(CONFIG, 1, "8.25", 15, "8.25", inside="left")  # inside: y < 8.25
    # pixel 8 is 3/4 inside; msaa2's sample at y = 8.25 lies on the edge (top-left: outside)
    assert coverage("msaa2", edge, [5], [8])[0] == 0.5
    assert coverage("quincunx", edge, [5], [8])[0] == 0.75  # 1/2 + two corners at 7.5
    assert coverage("flipquad", edge, [5, 6], [8, 8]).tolist() == [0.75, 0.75]


def test_45_degree_edge_through_the_centre():
    edge = Edge.from_pixels(CONFIG, 2, 2, 14, 14, inside="left")
    xs = ys = [8, 9]
    # msaa2's samples lie on the diagonal: it cannot see a 45 degree edge (0 or 1, exact 1/2)
    assert set(coverage("msaa2", edge, xs, ys)) <= {0.0, 1.0}
    assert np.allclose(coverage("flipquad", edge, xs, ys), 0.5)  # two samples either side
    assert set(coverage("quincunx", edge, xs, ys)) <= {1 / 8, 7 / 8}


def test_pixel_aligned_edges_blurred_by_shared_samples():
    """The samples on pixel boundaries go to one side by the tie rule: a pixel-aligned square
    moves by 1/4 on two of its sides (quincunx, FLIPQUAD); msaa2 is exact on it."""
    right = Edge.from_pixels(CONFIG, "10.5", 15, "10.5", 1, inside="left")  # inside: x < 10.5
    left = Edge.from_pixels(CONFIG, "4.5", 1, "4.5", 15, inside="left")  # inside: x > 4.5
    for name in ("quincunx", "flipquad"):
        assert coverage(name, right, [10, 11], [8, 8]).tolist() == [0.75, 0.0], name
        assert coverage(name, left, [4, 5], [8, 8]).tolist() == [0.25, 1.0], name
    assert coverage("msaa2", right, [10, 11], [8, 8]).tolist() == [1.0, 0.0]


def test_patterns_on_random_edges_stay_within_their_quantisation():
    edges = geometry.random_image_edges(CONFIG, 40, SEED, region=128, max_length=60)
    pixels, _ = evaluate.pixel_set(CONFIG, edges)
    for name, p in msaa.PATTERNS.items():
        run = aa_methods.run_method(CONFIG, edges, pixels, name)
        err = np.abs(run.coverage - pixels.exact)
        assert err.max() <= 1 - p.weights.min() + 1e-12, name
        eighths = np.round(run.coverage * 8, 9)
        assert np.all(np.isin(eighths, np.arange(9))), name  # multiples of 1/8
        assert err.mean() < 0.2, name


# -- MLAA -----------------------------------------------------------------------------------------


def test_area_table_known_entries():
    a = mlaa.AREA  # [left code, right code, dl, dr, (above, below)]; codes -1/2, 0, +1/2
    assert np.all(a[1, 1] == 0)  # no crossing at either end: no blend
    # Z of width 1 (a 45 degree staircase): the line crosses the pixel, 1/8 on each side
    assert np.allclose(a[0, 2, 0, 0], [1 / 8, 1 / 8])
    # Z of width 4, first pixel: the line from -1/2 to -1/4 lies below the boundary
    assert np.allclose(a[0, 2, 0, 3], [0, 0.375])
    # U of width 2: each pixel holds a triangle from height 1/2 at the end to 0 in the middle
    assert np.allclose(a[2, 2, 0, 1], [0.25, 0]) and np.allclose(a[2, 2, 1, 0], [0.25, 0])
    # symmetries: mirrored in x the same areas, mirrored in y (heights negated) swapped
    assert np.allclose(a[0, 2, 2, 5], a[2, 0, 5, 2])
    assert np.allclose(a[0, 2, 2, 5], a[2, 0, 2, 5][::-1])


def test_mlaa_is_exact_on_a_staircase_through_its_step_midpoints():
    """Slope 1/4 through (0.5, 20): the steps' midpoints lie on the line, so the reconstructed
    line is the line and MLAA gives the exact areas; slope prediction changes nothing."""
    image, exact = half_plane_image(lambda x, y: y - (20.125 - x / 4), h=40, w=120)
    inner = np.zeros_like(image, dtype=bool)
    inner[4:36, 20:100] = True
    for predict in (0, mlaa.PREDICT_STEPS):
        out = mlaa.mlaa(image, predict=predict)
        assert np.abs(out - exact)[inner].max() < 1e-9, predict
    assert np.abs(image - exact)[inner].max() > 0.3  # the aliased input is far from it


def test_mlaa_leaves_a_horizontal_edge_and_flat_regions_alone():
    image = np.zeros((20, 60))
    image[10:] = 1  # a straight horizontal edge: no steps, nothing to reconstruct
    assert np.array_equal(mlaa.mlaa(image), image)
    for value in (0.0, 0.3, 1.0):
        flat = np.full((16, 16), value)
        assert np.array_equal(mlaa.mlaa(flat), flat)
        assert np.array_equal(fxaa.fxaa(flat), flat)
        assert np.array_equal(fxaa.fxaa(flat, np.zeros((16, 16), int)), flat)


def test_slope_prediction_helps_on_long_shallow_edges():
    for run in (3.4, 5.3, 7.7):
        image, exact = half_plane_image(lambda x, y, r=run: y - (40 - x / r), h=64, w=300)
        inner = np.zeros_like(image, dtype=bool)
        inner[4:60, 30:270] = True
        plain = np.abs(mlaa.mlaa(image) - exact)[inner]
        slope = np.abs(mlaa.mlaa(image, predict=mlaa.PREDICT_STEPS) - exact)[inner]
        assert np.sqrt(np.mean(slope**2)) < 0.9 * np.sqrt(np.mean(plain**2)), run
        assert slope.max() < plain.max(), run


# -- FXAA -----------------------------------------------------------------------------------------


def test_fxaa_subpixel_term_on_a_pixel_aligned_edge():
    """A long horizontal edge has no end in reach, so only the sub-pixel term moves the pixels
    beside it: low-pass 1/3 against contrast 1, smoothed and squared, times 3/4."""
    image = np.zeros((20, 80))
    image[10:] = 1
    out = fxaa.fxaa(image)
    b = 1 / 3
    expected = ((-2 * b + 3) * b * b) ** 2 * fxaa.SUBPIX
    assert np.allclose(out[9, 20:60], expected) and np.allclose(out[10, 20:60], 1 - expected)
    assert np.array_equal(out[:8], image[:8]) and np.array_equal(out[12:], image[12:])


def test_image_methods_leave_pixels_far_from_edges_untouched():
    rng = np.random.default_rng(SEED)
    ids = np.zeros((64, 64), dtype=int)
    for k in range(1, 6):  # random rectangles and discs of random grey
        cy, cx, r = rng.integers(8, 56, 2).tolist() + [int(rng.integers(4, 12))]
        ys, xs = np.mgrid[0:64, 0:64]
        ids[(ys - cy) ** 2 + (xs - cx) ** 2 < r * r] = k
    greys = rng.uniform(0, 1, 6)
    image = greys[ids]
    near = np.zeros_like(ids, dtype=bool)
    for axis in (0, 1):
        step = np.diff(ids, axis=axis) != 0
        pad = [(0, 0), (0, 0)]
        pad[axis] = (1, 0)
        near |= np.pad(step, pad)
        pad[axis] = (0, 1)
        near |= np.pad(step, pad)
    far = ~near
    for out in (mlaa.mlaa(image), fxaa.fxaa(image), fxaa.fxaa(image, ids)):
        assert np.array_equal(out[far], image[far])
        assert not np.array_equal(out, image)


def test_fxaa_geometry_edges_keep_a_hatch_inside_an_object():
    image = np.zeros((32, 32))
    image[8:24, 8:24] = 0.6
    image[8:24:2, 8:24] = 0.9  # stripes drawn inside the square: luma edges, not geometry
    ids = np.zeros((32, 32), dtype=int)
    ids[8:24, 8:24] = 1
    inside = np.zeros_like(ids, dtype=bool)
    inside[10:22, 10:22] = True
    assert np.array_equal(fxaa.fxaa(image, ids)[inside], image[inside])
    assert np.abs(fxaa.fxaa(image) - image)[inside].max() > 0.05  # luma FXAA blurs them


# -- TAA ------------------------------------------------------------------------------------------


def test_halton_jitter_and_taa_known_answers():
    assert temporal.radical_inverse(1, 2) == 0.5 and temporal.radical_inverse(3, 2) == 0.75
    assert abs(temporal.radical_inverse(2, 3) - 2 / 3) < 1e-15
    jit = np.array([temporal.jitter(f) for f in range(temporal.JITTER_CYCLE)])
    assert np.all(jit > -0.5) and np.all(jit < 0.5)  # never on a pixel boundary

    def sample_edge(level):
        return lambda jx, jy: half_plane_image(lambda x, y: level - (y + jy), h=8, w=8, n=1)[0]

    # a pixel-aligned edge is exact (no sample leaves its pixel); a constant image stays
    assert np.array_equal(temporal.still(sample_edge(3.5)), sample_edge(3.5)(0, 0))
    assert np.array_equal(temporal.still(lambda jx, jy: np.full((4, 4), 0.3)), np.full((4, 4), 0.3))
    # a horizontal edge at y = 3.25 (inside above): pixel 3 tends to the fraction of jittered
    # samples above it, 3/4 up to the exponential window's sampling of the 16 jitters
    value = temporal.still(sample_edge(3.25), frames=64)[3, 4]
    assert abs(value - 0.75) < 0.1, value


# -- the common pixel set -------------------------------------------------------------------------


@pytest.mark.parametrize("name", aa_methods.IMAGE_METHODS)
def test_image_methods_on_edges_beat_point_sampling(name):
    edges = geometry.random_image_edges(CONFIG, 12, SEED, region=96, max_length=40)
    pixels, _ = evaluate.pixel_set(CONFIG, edges)
    run = aa_methods.run_method(CONFIG, edges, pixels, name)
    point = aa_methods.run_method(CONFIG, edges, pixels, "point")
    rms = np.sqrt(np.mean((run.coverage - pixels.exact) ** 2))
    rms_point = np.sqrt(np.mean((point.coverage - pixels.exact) ** 2))
    assert rms < 0.6 * rms_point, (name, rms, rms_point)
    assert run.outputs > len(pixels)  # whole images were processed


# -- scenes ---------------------------------------------------------------------------------------


def test_hatch_scene_luma_fxaa_blurs_the_pattern_and_geometry_fxaa_does_not():
    from edgeaa.analysis import aa_scenes
    from edgeaa.render.builtin import builtin
    from edgeaa.render.exact import exact_image
    from edgeaa.render.render import plan_scene

    plan = plan_scene(builtin("hatch", CONFIG), CONFIG)
    ids = aa_scenes.object_ids(plan)
    assert set(np.unique(ids)) == {0, 1, 2, 3}  # background and three shapes, stripes included
    exact = exact_image(plan)

    def rms(name):
        return float(np.sqrt(np.mean((aa_scenes.method_image(plan, name) - exact) ** 2)))

    point, luma, geom = rms("point"), rms("fxaa"), rms("fxaa-geom")
    assert luma > 2 * point  # luma FXAA blurs the pixel-aligned pattern point sampling has right
    assert geom < point and geom < 0.3 * luma
    # MSAA resolved per sample: the 4x pattern is exact on the pattern, better on the edges
    assert rms("rgss4") < point


def test_reproject_reads_the_history_where_each_pixel_was():
    history = np.arange(30.0).reshape(5, 6)
    ys, xs = np.indices(history.shape, dtype=float)
    assert np.array_equal(temporal.reproject(history, ys, xs), history)
    moved = temporal.reproject(history, ys, xs - 1)  # everything moved one pixel right
    assert np.array_equal(moved[:, 1:], history[:, :-1])
    half = temporal.reproject(history, ys + 0.5, xs)
    assert np.allclose(half[:-1], (history[:-1] + history[1:]) / 2)


def test_plot_taa_command_prints_error_and_flicker(tmp_path, capsys):
    from edgeaa.cli import main

    out = tmp_path / "taa.png"
    assert main(["plot", "taa", "--frames", "4", "--quiet", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert out.stat().st_size > 10_000
    rows = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 5 and cells[0] and cells[1][:1].isdigit():
            rows[cells[0]] = [float(c) for c in cells[1:]]
    point, reprojected = rows["point"], rows["TAA, reprojected"]
    in_place = rows["TAA, no reprojection"]
    assert rows["edgeaa-paper"][2] < 1 < reprojected[2]  # mean RMS error, LSB
    assert reprojected[1] < point[1] and reprojected[1] < in_place[1]  # by the last frame
    assert reprojected[3] < point[3]  # flicker
