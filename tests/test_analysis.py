"""The analysis: sample-based baselines, peer conventions, the error sweep, bench and stress.

Fast (seconds each). Every random input is seeded and the seed is in the failure message.
"""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

from edgeaa.analysis import bench, evaluate, geometry, peers, sampling, slope, stress
from edgeaa.analysis.hardware import hardware_figures
from edgeaa.cli import main as edgeaa_main
from edgeaa.model import Edge, EdgeConfig, exact_coverage_array
from edgeaa.model.vector import run_edges
from edgeaa.sim.verification import workloads

SEED = 20240611


def run_cli(capsys, *argv):
    status = edgeaa_main(list(argv))
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def random_half_planes(config: EdgeConfig, count: int, seed: int):
    edges = geometry.random_image_edges(config, count, seed, region=128, max_length=60)
    pixels, _ = evaluate.pixel_set(config, edges)
    return edges, pixels


# -- sample-based baselines --------------------------------------------------------------------


def test_patterns_have_the_textbook_structure():
    for n in (2, 4, 8, 16):
        grid = sampling.PATTERNS[f"grid{n}"]
        assert len(grid) == n * n
        assert np.allclose(np.unique(grid[:, 0]), (np.arange(n) + 0.5) / n - 0.5)
    # N-rooks: one sample per row and per column of the n x n sub-grid
    for name, n in (("rgss4", 4), ("rooks8", 8)):
        offsets = sampling.PATTERNS[name]
        assert len(offsets) == n
        cells = np.floor((offsets + 0.5) * n).astype(int)
        assert sorted(cells[:, 0]) == list(range(n)) and sorted(cells[:, 1]) == list(range(n))
    # rooks8 is not all on one diagonal (the textbook's bad N-rooks pattern)
    cells = np.floor((sampling.PATTERNS["rooks8"] + 0.5) * 8).astype(int)
    assert len(set(cells[:, 0] - cells[:, 1])) > 1 and len(set(cells[:, 0] + cells[:, 1])) > 1


def test_point_sampling_is_zero_or_one_and_right_at_the_centre():
    config = EdgeConfig()
    edges, pixels = random_half_planes(config, 40, SEED)
    cov = sampling.sample_coverage(config, edges, pixels.edge_index, pixels.x, pixels.y, "point")
    assert set(np.unique(cov)) <= {0.0, 1.0}, f"seed {SEED}"
    # the centre is inside exactly when the pixel's exact coverage of a thin slab is > 1/2
    # would be circular; instead check the sign of the line function at the centre directly
    ea = geometry.edge_arrays(config, edges)
    nx, ny = ea.normal
    e = pixels.edge_index
    g = nx[e] * (pixels.x - ea.x0[e]) + ny[e] * (pixels.y - ea.y0[e])
    assert np.array_equal(cov[g != 0] == 1.0, g[g != 0] > 0), f"seed {SEED}"
    # its error is large: somewhere at least 0.4 (a pixel almost half covered)
    assert np.abs(cov - pixels.exact).max() > 0.4, f"seed {SEED}"


@pytest.mark.parametrize("n", [2, 4, 8, 16])
def test_ordered_grid_error_bound_on_half_planes(n):
    config = EdgeConfig()
    edges, pixels = random_half_planes(config, 60, SEED + n)
    cov = sampling.sample_coverage(config, edges, pixels.edge_index, pixels.x, pixels.y, f"grid{n}")
    err = np.abs(cov - pixels.exact)
    # n sub-rows, each a midpoint rule quantised to 1/n: at most 1/(2n), plus a little
    # where the line leaves the pixel sideways inside a sub-row
    assert err.max() <= 1 / (2 * n) + 1 / (8 * n), f"seed {SEED + n}: {err.max()}"
    assert err.max() >= 1 / (4 * n), f"seed {SEED + n}: the bound should be approached"
    assert np.all((cov * n * n) == np.round(cov * n * n))  # multiples of 1/n^2


def test_grid16_axis_aligned_edges_within_one_32nd_and_exact_on_its_grid():
    config = EdgeConfig()
    for j in range(16):
        x = 10 + j / 16
        edge = Edge.from_pixels(config, x, 1, x, 15, inside="right")  # inside: x < 10 + j/16
        xs, ys = np.array([9, 10, 11]), np.array([8, 8, 8])
        e = np.zeros(3, dtype=np.int64)
        cov = sampling.sample_coverage(config, [edge], e, xs, ys, "grid16")
        exact = exact_coverage_array(config, edge, xs, ys)
        assert np.abs(cov - exact).max() <= 1 / 32, (j, cov, exact)
    edge = Edge.from_pixels(config, "10.25", 1, "10.25", 15, inside="right")
    e, xs, ys = np.zeros(1, np.int64), np.array([10]), np.array([8])
    for n in (4, 8, 16):
        assert sampling.sample_coverage(config, [edge], e, xs, ys, f"grid{n}")[0] == 0.75


def test_samples_on_the_line_follow_the_top_left_rule():
    config = EdgeConfig()
    e, xs, ys = np.zeros(1, np.int64), np.array([5]), np.array([10])
    # y = 10.25 passes through grid2's lower sample row (offset +1/4)
    up = Edge.from_pixels(config, 0, "10.25", 20, "10.25", inside="left")  # inside y < 10.25
    down = Edge.from_pixels(config, 0, "10.25", 20, "10.25", inside="right")  # y > 10.25
    # inside normal up (-y): ties are outside; down (+y): ties are inside
    assert sampling.sample_coverage(config, [up], e, xs, ys, "grid2")[0] == 0.5
    assert sampling.sample_coverage(config, [down], e, xs, ys, "grid2")[0] == 0.5
    assert exact_coverage_array(config, up, xs, ys)[0] == 0.75


# -- geometry and peers ---------------------------------------------------------------------------


def test_halfplane_area_matches_the_model_reference():
    config = EdgeConfig()
    rng = random.Random(SEED)
    for _ in range(30):
        edge = Edge(*(rng.randint(0, 400) for _ in range(4)), inside=rng.choice(["left", "right"]))
        if (edge.x0, edge.y0) == (edge.x1, edge.y1):
            continue
        xs = np.arange(-1, 27)
        ys = np.array([rng.randint(-1, 26) for _ in xs])
        s = config.subpixel_scale
        x0, y0 = edge.x0 / s, edge.y0 / s
        dx, dy = (edge.x1 - edge.x0) / s, (edge.y1 - edge.y0) / s
        side = 1 if edge.inside == "left" else -1
        a, b = -side * dy, side * dx  # inside: a x + b y < t
        t = a * x0 + b * y0 - (a * xs + b * ys)
        area = geometry.halfplane_area(a, b, t)
        assert np.allclose(area, exact_coverage_array(config, edge, xs, ys), atol=1e-12), (
            f"seed {SEED}: {edge}"
        )


def test_peer_pixel_centre_convention():
    """Half-plane x < 10.25: pixel column 10 is 3/4 covered; each 8-bit peer within 2/255."""
    values = peers.convention_check()
    for name in ("skia", "agg"):
        assert abs(values[name] - 0.75) <= 2 / 255, (name, values[name])
    # aggdraw's plain brush fill widens the polygon by 1/4 px: column 10 becomes full
    assert values["agg-default"] == 1.0


def test_peers_on_random_edges_measure_the_half_plane():
    """Skia and AGG on the compared pixels of random edges: AGG (exact area) is within a few
    8-bit steps; both are far better than point sampling (so the polygon and the shift are
    right). Skia snaps vertex y to 1/4 px: with vertices on that grid it is close too."""
    for subpixel_bits, skia_rms in ((4, 0.08), (2, 0.02)):
        config = EdgeConfig(subpixel_bits=subpixel_bits)
        edges, pixels = random_half_planes(config, 40, SEED)
        _, batch = evaluate.pixel_set(config, edges)
        jobs = peers.fill_jobs(config, edges, batch)
        for name, max_err, rms in (("agg", 0.02, 0.008), ("skia", 0.5, skia_rms)):
            masks = peers.render(name, jobs)
            cov = peers.gather(name, jobs, masks, pixels.edge_index, pixels.x, pixels.y)
            err = np.abs(cov - pixels.exact)
            assert err.max() <= max_err, (name, subpixel_bits, SEED, err.max())
            assert math.sqrt(np.mean(err**2)) <= rms, (name, subpixel_bits, SEED)


def test_line_reference_and_line_aa():
    lines = [(2, 3, 40, 17), (5, 5, 5 + 20, 5 + 20), (30, 2, 24, 40)]
    pixels = peers.line_pixels(lines)
    # the strip's area per column is its width / cos: 1 / cos(angle) summed over rows
    for k, (x0, y0, x1, y1) in enumerate(lines):
        sel = pixels.edge_index == k
        columns = max(abs(x1 - x0), abs(y1 - y0)) - 1
        per_column = math.hypot(x1 - x0, y1 - y0) / max(abs(x1 - x0), abs(y1 - y0))
        assert pixels.exact[sel].sum() == pytest.approx(columns * per_column, rel=1e-9)
    jobs = peers.line_jobs(lines, pixels)
    masks = peers.render("skimage-line_aa", jobs)
    cov = peers.gather("skimage-line_aa", jobs, masks, pixels.edge_index, pixels.x, pixels.y)
    err = np.abs(cov - pixels.exact)
    assert 0.01 < err.max() < 0.15  # Zingl's 1 - distance is not the strip's area


# -- error against slope ---------------------------------------------------------------------------


def test_error_vs_slope_reproduces_the_bound_ratios():
    # F = 21: a unit negligible next to c_N k at every slope of the sweep, so the worst error
    # over k is the estimate's own (at the derived F the units add up to 0.1 % at small k)
    config = EdgeConfig(frac_bits=21)
    sweep = slope.error_vs_slope(
        config,
        step=5,
        length=24,
        offsets=16,
        methods=evaluate.EDGEAA_METHODS + ("grid4",),
        progress=False,
    )
    for name, per_k in evaluate.BOUND_PER_K.items():
        ratio = sweep.worst_over_k[f"edgeaa-{name}"] / per_k
        assert 0.95 <= ratio <= 1.0 + 1e-3, (name, ratio)
    assert sweep.max_err["edgeaa-paper"][0] < 1e-6  # horizontal edges are exact
    assert np.all(sweep.max_err["edgeaa-seg4"] <= sweep.max_err["edgeaa-paper"] + 1e-12)
    assert sweep.worst["grid4"] > sweep.worst["edgeaa-paper"]


def test_plot_error_vs_slope_command(capsys, tmp_path):
    out = tmp_path / "slope.png"
    argv = ["plot", "error-vs-slope", "--step", "15", "--length", "12", "--offsets", "4"]
    status, stdout, _ = run_cli(capsys, *argv, "--no-peers", "--quiet", "-o", str(out))
    assert status == 0 and out.stat().st_size > 10_000
    assert "edgeaa-paper" in stdout and "grid16" in stdout


def test_bad_input_is_one_line_with_status_2(capsys):
    for argv in (
        ["plot", "error-vs-slope", "-o", "figure.txt"],
        ["plot", "error-vs-slope", "--step", "0"],
        ["bench", "--edges", "0"],
        ["stress", "--widths", "3,x"],
        ["stress", "--widths", "30"],
    ):
        status, out, err = run_cli(capsys, *argv)
        assert status == 2, argv
        assert err.count("\n") == 1 and err.startswith("edgeaa "), (argv, err)


# -- bench -----------------------------------------------------------------------------------------


def test_bench_quick_has_a_row_per_method_with_finite_numbers(capsys, tmp_path):
    out = tmp_path / "pareto.png"
    status, stdout, _ = run_cli(capsys, "bench", "--quick", "--quiet", "-o", str(out))
    assert status == 0 and out.stat().st_size > 10_000
    rows = {}
    for line in stdout.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) >= 6 and cells[0] in bench.FILL_METHODS + peers.LINE_PEERS:
            rows[cells[0]] = cells
    assert set(rows) == set(bench.FILL_METHODS + peers.LINE_PEERS)
    for name in bench.FILL_METHODS:
        max_err, rms, ms, ratio = (float(rows[name][i]) for i in (2, 3, 4, 6))
        assert all(math.isfinite(v) for v in (max_err, rms, ms, ratio)), name
        assert 0 <= rms <= max_err <= 1 and ms > 0 and ratio > 0, name
    for name in peers.LINE_PEERS:
        max_err, rms, ms, ratio = (float(rows[name][i]) for i in (2, 3, 4, 5))
        assert all(math.isfinite(v) for v in (max_err, rms, ms, ratio)), name
    assert float(rows["edgeaa-paper"][6]) == 1.0  # the time baseline
    assert float(rows["edgeaa-seg4"][2]) < 1 / 1024 + 1 / 255  # bound + half an LSB... 8-bit
    assert float(rows["agg"][2]) < float(rows["grid8"][2])


def test_bench_result_is_seeded():
    config = EdgeConfig()
    kwargs = dict(count=8, seed=5, repeats=1, lines=False, progress=False, hardware=False)
    first = bench.run_bench(config, **kwargs)
    again = bench.run_bench(config, **kwargs)
    assert [(r.name, r.max_err, r.rms_err) for r in first.rows] == [
        (r.name, r.max_err, r.rms_err) for r in again.rows
    ]


def test_pareto_front():
    points = [(1.0, 0.5), (2.0, 0.1), (3.0, 0.2), (0.5, 0.9), (2.5, 0.05)]
    assert bench.pareto_front(points) == [3, 0, 1, 4]


def test_hardware_cycles_per_column_are_the_timing_model_s():
    from edgeaa.model.timing import write_cycles

    config = EdgeConfig()
    edges = workloads.random_sim_edges(config, 40, seed=21)
    figures = hardware_figures(config, "edgeaa-paper", edges, synthesis=False)
    beats = [clock for timing in write_cycles(config, edges) for clock in timing.beats]
    assert figures.cycles_per_column == pytest.approx((beats[-1] + 1) / len(beats))
    assert 1 <= figures.cycles_per_column < 2
    assert hardware_figures(config, "skia", edges) is None


# -- stress ----------------------------------------------------------------------------------------


def test_stress_edges_stay_within_the_bound():
    config = EdgeConfig(coord_bits=4, subpixel_bits=2, intensity_bits=4)
    edges = stress.stress_edges(config)
    starts = {(e.x0 % 4) for e in edges} | {(e.y0 % 4) for e in edges}
    assert starts == set(range(4))  # every sub-pixel phase
    for accumulator in ("exact", "truncated"):
        for mode in evaluate.BOUND_PER_K:
            check = stress.check_writes(config.with_(mode=mode, accumulator=accumulator), edges)
            assert check.width_errors == 0 and check.writes > 0
            assert check.violations == 0 and check.ratio <= 1 + 1e-9, (mode, accumulator)


def test_truncated_drift_grows_with_length_and_exact_does_not():
    """On the worst-case edge the truncated accumulator's error beyond the estimate grows
    about one unit per column; the exact accumulator's stays under u_N at any length."""
    for coord_bits in (6, 9):
        base = EdgeConfig(
            coord_bits=coord_bits, subpixel_bits=4, intensity_bits=4, accumulator="truncated"
        )
        f = base.F - 3  # three bits below the truncated accumulator's budget
        m = base.max_vertex
        edge = Edge(0, 0, m, stress.worst_drift_dv(m, f), i_in=1, i_out=0)
        excess = {}
        for accumulator in ("exact", "truncated"):
            config = base.with_(frac_bits=f, accumulator=accumulator)
            batch = run_edges(config, [edge])
            exact = geometry.exact_coverage_pixels(
                config, [edge], batch.edge_index, batch.x, batch.y
            )
            units = (np.abs(batch.coverage() - exact) - edge.y1 / edge.x1 / 64) * 2.0**f
            n = geometry.column_index(batch)
            quarter = n.max() // 4
            excess[accumulator] = (units[n < quarter].max(), units[n >= 3 * quarter].max())
        first, last = excess["truncated"]
        assert last > first + 0.5 * (2 * quarter), (coord_bits, excess)  # ~1 unit per column
        assert max(excess["exact"]) < stress.UNITS["paper"], (coord_bits, excess)


def test_measured_safe_frac_bits_beside_the_derived():
    """The drift on the worst-case edges reaches the budget one bit below the derived F and
    twice it two bits below: the derived F = W + I + 2 keeps one bit of margin."""
    rows = stress.safe_frac_bits((4, 6), (4,), 2, progress=False)
    for row in rows:
        assert row.measured_drift == row.derived - 1, row
        assert row.measured_error is not None and row.measured_error <= row.derived, row
        assert 0.4 <= row.drift[row.derived] <= 0.5 + 1e-9, row
        assert row.drift[row.derived - 2] > 1.5, row
    table = stress.safe_table(rows)
    assert "derived F" in table and "measured F (drift)" in table


def test_stress_command_quick(capsys, tmp_path):
    out = tmp_path / "drift.svg"
    argv = ["stress", "--widths", "2,4", "--intensities", "4", "--plot-coord-bits", "5"]
    argv += ["--plot-intensity-bits", "4", "--quiet", "-o", str(out)]
    status, stdout, _ = run_cli(capsys, *argv)
    assert status == 0 and out.stat().st_size > 10_000
    assert "smallest safe fraction bits" in stdout and "width errors" in stdout
