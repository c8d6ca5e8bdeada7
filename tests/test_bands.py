"""The model render in bands of rows (`render/bands.py`): the same image as one whole-image
buffer, bit for bit, and memory bounded by what a band touches."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from unittest.mock import patch

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import edgeaa
from edgeaa.cli import main
from edgeaa.model import EdgeConfig
from edgeaa.render import plan_scene, render_scene
from edgeaa.render.bands import band_rows, split_bands
from edgeaa.render.scene import Polygon, Scene

CONFIGS = (EdgeConfig(), EdgeConfig(subpixel_bits=2, intensity_bits=4))


@st.composite
def scenes(draw):
    """A few polygons of 3 to 7 vertices, some reaching past every side of the image, some
    long and thin (edges across many bands), random intensities and fill rules."""
    width, height = draw(st.integers(4, 90)), draw(st.integers(4, 90))
    coord = st.floats(-15, 105, allow_nan=False).map(lambda v: round(v, 2))
    polygons = []
    for _ in range(draw(st.integers(1, 7))):
        points = draw(st.lists(st.tuples(coord, coord), min_size=3, max_size=7))
        rule = draw(st.sampled_from(["nonzero", "evenodd"]))
        polygons.append(Polygon((tuple(points),), draw(st.integers(0, 15)), rule))
    return Scene(width, height, tuple(polygons), background=draw(st.integers(0, 15)))


@settings(max_examples=150, deadline=None)
@given(scenes(), st.integers(1, 90), st.sampled_from(CONFIGS), st.integers(1, 4))
def test_a_banded_render_is_the_whole_buffer_render(scene, rows, config, run_edges):
    """Bands, threads, and the model's runs within a band: of edges set up (`RUN_EDGES`, here
    from one edge a run), of columns stepped (`RUN_COLUMNS`, from 5) and of accumulation
    buffers (`RUN_CELLS`, from 16 cells)."""
    full = config.full_scale
    polygons = tuple(
        Polygon(p.contours, p.intensity * full // 15, p.fill_rule) for p in scene.polygons
    )
    scene = Scene(scene.width, scene.height, polygons, background=scene.background * full // 15)
    plan = plan_scene(scene, config)
    whole = render_scene(plan, rows=0)
    edges = patch("edgeaa.render.render.RUN_EDGES", run_edges)
    columns = patch("edgeaa.render.render.RUN_COLUMNS", 5 * run_edges)
    with edges, columns, patch("edgeaa.render.render.RUN_CELLS", 16 * run_edges):
        banded = render_scene(plan, rows=min(rows, scene.height))
    threads = render_scene(plan, rows=min(rows, scene.height), workers=3)
    assert whole.bands == 1 and banded.bands == -(-scene.height // min(rows, scene.height))
    assert threads.workers == min(3, banded.bands)
    for render in (banded, threads):
        assert np.array_equal(whole.image, render.image)
        for name in ("rows_scanned", "cells_scanned", "pixel_stores"):
            assert getattr(whole, name) == getattr(render, name), name
    # the deltas in the image's rows (whole, also those just above or below it)
    assert threads.delta_count == banded.delta_count <= whole.delta_count


def test_bands_hold_each_edge_in_every_band_its_rows_meet():
    edges = np.array([5, 6, 7, 8])
    bands = split_bands(10, 4, edges, np.array([0, 3, 9, 2]), np.array([2, 5, 12, 2]))
    assert [(b.y0, b.y1, b.edges.tolist()) for b in bands] == [
        (0, 4, [5, 6, 8]),
        (4, 8, [6]),
        (8, 10, [7]),
    ]
    assert band_rows(1000, 1) == 1000 and band_rows(1000, 10**9) == 32


def test_workers_apply_to_the_model_bands_only(tmp_path, capsys):
    out = tmp_path / "out.png"
    for extra in (["--engine", "amaranth"], ["--no-skip"], ["--workers", "0"]):
        argv = ["render", "--builtin", "starburst", "--workers", "2", *extra, "-o", str(out)]
        try:
            code = main(argv)
        except SystemExit as exit_:  # argparse's refusal
            code = exit_.code
        assert code == 2 and not out.exists(), extra
        assert capsys.readouterr().err.count("\n") == 1
    assert main(["render", "--builtin", "starburst", "--workers", "2", "--stats", "--quiet"]) == 0
    assert "1 band of rows, 1 worker" in capsys.readouterr().out  # 256 rows: one band


def stripes(count: int, width: int) -> dict:
    """Long, slightly slanted stripes: x-major edges across the whole width, each over many
    bands' rows (the whole-image render held four int64 cells per stepped column)."""
    polygons = [
        {
            "points": [[1.5, 3 * k + 2.3], [width - 1.5, 3 * k + 23], [width - 1.5, 3 * k + 24.4],
                       [1.5, 3 * k + 3.7]],
            "intensity": (37 * k) % 256,
        }
        for k in range(count)
    ]  # fmt: skip
    return {"width": width, "height": 3 * count + 30, "background": 255, "polygons": polygons}


LAUNCHER = """import resource, subprocess, sys
subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL)
print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)"""


def peak_rss(*argv: str) -> int:
    """Peak RSS in bytes of a process running argv, started by a small one (a child forked
    from pytest's process would count pytest's pages as its own peak)."""
    env = dict(os.environ, PYTHONPATH=str(Path(edgeaa.__file__).parents[1]))
    done = subprocess.run(
        [sys.executable, "-c", LAUNCHER, *argv], env=env, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return int(done.stdout) * 1024


def test_peak_memory_of_a_big_scene_is_bounded_by_its_size(tmp_path):
    """`edgeaa render` of 200 stripes 1,600 px long (640,000 stepped columns) stays within
    the same program's peak on a tiny scene plus 1 kB an edge, 3 bytes a pixel (the image,
    its PNG) and 48 MiB (a band's engine arrays and the plan's chunks of pairs). Whole, the
    render held every column's cells: 292 MB here, against 93 MB in bands."""
    sizes = {}
    for name, data in (("tiny", stripes(2, 40)), ("big", stripes(200, 1600))):
        source = tmp_path / f"{name}.json"
        source.write_text(json.dumps(data))
        render = [sys.executable, "-m", "edgeaa", "render", str(source), "--quiet"]
        sizes[name] = (data, peak_rss(*render, "-o", str(tmp_path / f"{name}.png")))
    (big, peak), (_, base) = sizes["big"], sizes["tiny"]
    edges = 4 * len(big["polygons"])
    bound = base + 1000 * edges + 3 * big["width"] * big["height"] + (48 << 20)
    assert peak <= bound, f"peak RSS {peak / 2**20:.1f} MiB > {bound / 2**20:.1f} MiB"


def test_the_engines_progress_counts_a_bands_edges_across_its_runs():
    """In runs of two edges, the model's reports climb through the band's edges and end at
    its count, as one run's would (not each run's own count from zero)."""
    from edgeaa.render import builtin

    plan = plan_scene(builtin("text", EdgeConfig()), EdgeConfig())
    reports = []
    with patch("edgeaa.render.render.RUN_EDGES", 2):
        render_scene(
            plan, rows=0, progress=lambda done, total, stage: reports.append((done, total, stage))
        )
    model = [(done, total) for done, total, stage in reports if stage == "model"]
    totals = {total for _, total in model}
    assert len(totals) == 1 and len(model) > 4
    (total,) = totals
    done = [d for d, _ in model]
    assert done == sorted(done) and done[-1] == total and done[0] == 0
