"""The model renderer stage by stage against AGG and Skia, on content the project did not write
(issue 28; `benchmarks/bench_render.py` measures the simulators' clocks, this the renderer).

Scenes: the built-ins; DejaVu Sans, STIX and cmr10 (the fonts matplotlib ships) at 9 to 96 px
(`render.corpus.font_scene`); an icon sheet (matplotlib's eight toolbar icons at 48 px, side by
side); a page of 10 px text (DejaVu Sans, 500 to 4,000 glyphs); a map of Voronoi cells (1,250
to 5,000 polygons, one intensity each). For each, in one process, per stage, the CPU seconds
(`time.process_time`, the median over `--repeats`: the cores are shared) and, in a run of
its own, the peak memory the stage allocates as tracemalloc sees it (Python objects and numpy
arrays; the render's engine and accumulation together; AGG's and Skia's C++ buffers are not
seen, only what their drivers allocate in Python and numpy):

- flatten: the scene from its source (font outlines and SVG paths flattened; the map's
  cells from shapely; the built-ins as `edgeaa render --builtin` makes them);
- parse: the scene as a JSON scene file (its polygons' contours): `scene_from_json`, as `edgeaa
  render` reads a file;
- plan: `plan_scene`; engine and accumulate: `render_scene`'s stages on that plan (the
  edges chosen, cut into bands and stepped into deltas; then buffers, prefix sums, fill rule
  and compositing, the resolve included), each the process CPU time the render measures
  around it (`Render.cpu`, summed over the bands);
- write: the PNG (`render.cli.write_png`);
- AGG (`analysis.compare.agg_scene`) and Skia (`skia_scene`) on the same plan: their paths
  built from the quantized vertices, rasterized, their 8-bit image read back.

And the peak resident memory (ru_maxrss) of `edgeaa render SCENE.json -o OUT.png` and of AGG
and Skia drawing the same polygons from the same file (`benchmarks/peer_draw.py`, which imports
only json, the peer and PIL), each in a process of its own, end to end: the figure the issue's
target (at most twice AGG's) is about.

edgeaa's end to end is plan + engine + accumulate + write (what `edgeaa render` does after
loading the scene), its rasterizing engine + accumulate; both against AGG's time, as
geometric means over the scenes. The slopes are least-squares fits of log CPU time against
log edges (the page) and log polygons (the map).

    python benchmarks/bench_stages.py [--repeats 3] [--quick] [--only WORD] [--json FILE]
        [--write-docs]

The process keeps freed memory for reuse as `edgeaa render` does (`keep_freed_memory`), and
AGG and Skia run in it too. --only runs the scenes whose name holds WORD (for profiling;
no slopes, no docs).

--write-docs replaces the section between the markers in docs/results.md with the tables.
"""

from __future__ import annotations

import argparse
import gc
import io
import json
import logging
import math
import os
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

import edgeaa
from edgeaa.analysis.compare import agg_scene, skia_scene
from edgeaa.analysis.report import machine_line, table
from edgeaa.model import EdgeConfig
from edgeaa.render import builtin, plan_scene, render_scene
from edgeaa.render.builtin import glyph_polygons
from edgeaa.render.cli import write_png
from edgeaa.render.corpus import ICONS, font_file, font_scene, icon_scene
from edgeaa.render.render import keep_freed_memory
from edgeaa.render.scene import Polygon, Scene, scene_from_json

STAGES = ("flatten", "parse", "plan", "engine", "accumulate", "write", "agg", "skia")
FONTS = ("DejaVuSans", "STIXGeneral", "cmr10")
SIZES = (9, 16, 32, 96)
PAGE_GLYPHS = (500, 1000, 2000, 4000)
MAP_CELLS = (1250, 2500, 5000)
PAGE_TEXT = "The quick brown fox jumps over the lazy dog; SPHINX OF BLACK QUARTZ, 0123456789. "
BEGIN, END = "<!-- bench_stages: begin -->", "<!-- bench_stages: end -->"
DOCS = Path(__file__).resolve().parents[1] / "docs" / "results.md"
PEERS = ("agg", "skia")  # `peer_draw.py`'s drawers
PEER_DRAW = Path(__file__).resolve().with_name("peer_draw.py")


def icon_sheet(size: int = 48) -> Scene:
    """Every toolbar icon at `size` px, side by side."""
    polygons, x = [], 0
    for name in ICONS:
        icon = icon_scene(name, size)
        for poly in icon.polygons:
            moved = tuple(tuple((px + x, py) for px, py in c) for c in poly.contours)
            polygons.append(Polygon(moved, poly.intensity, poly.fill_rule, poly.name))
        x += icon.width
    return Scene(x, size + 2, tuple(polygons), background=255, name=f"icon sheet {size}px")


def page(glyphs: int, size: float = 10.0, width: int = 1000) -> Scene:
    """`glyphs` glyphs of DejaVu Sans at `size` px in lines across a `width` px page."""
    path, polygons, pos, y = font_file("DejaVuSans"), [], 0, 1.2 * size
    cache: dict[str, tuple] = {}
    while len(polygons) < glyphs:
        x = 2.3
        while x < width - 2 * size and len(polygons) < glyphs:
            ch = PAGE_TEXT[pos % len(PAGE_TEXT)]
            pos += 1
            if ch not in cache:  # the glyph at the origin, moved below
                shapes, end, _ = glyph_polygons(path, ch, size, 0.0, 0.0, 0)
                cache[ch] = (shapes, end)
            shapes, end = cache[ch]
            for poly in shapes:
                moved = tuple(tuple((px + x, py + y) for px, py in c) for c in poly.contours)
                polygons.append(Polygon(moved, 0, "nonzero", poly.name))
            x += end
        y += 1.3 * size
    height = math.ceil(y)
    return Scene(width, height, tuple(polygons), background=255, name=f"page {glyphs} glyphs")


def map_scene(cells: int, seed: int = 3) -> Scene:
    """Voronoi cells of `cells` seeded random points in a square of 1,000 cells per 512^2 px."""
    from shapely.geometry import MultiPoint, box
    from shapely.ops import voronoi_diagram

    side = int(512 * math.sqrt(cells / 1000))
    rng = np.random.default_rng(seed)
    diagram = voronoi_diagram(
        MultiPoint(rng.uniform(0, side, (cells, 2)).tolist()), envelope=box(0, 0, side, side)
    )
    frame = box(0.3, 0.2, side - 0.7, side - 0.8)
    polygons = []
    for k, cell in enumerate(diagram.geoms):
        cell = cell.intersection(frame)
        if cell.geom_type == "Polygon" and not cell.is_empty:
            ring = tuple(cell.exterior.coords[:-1])
            polygons.append(Polygon((ring,), 40 + (37 * k) % 200, "nonzero", f"cell {k}"))
    return Scene(side, side, tuple(polygons), background=255, name=f"map {cells} cells")


def scene_json(scene: Scene) -> str:
    polygons = [
        {"contours": [list(map(list, c)) for c in p.contours], "intensity": p.intensity}
        for p in scene.polygons
    ]
    return json.dumps(
        {"width": scene.width, "height": scene.height, "background": scene.background,
         "polygons": polygons}
    )  # fmt: skip


def measure(fn, memory: bool):
    """(CPU seconds, result) of one call; with `memory`, (peak bytes traced, result) instead
    (tracemalloc slows the call down, so the two are separate runs)."""
    gc.collect()
    if memory:
        tracemalloc.start()
        result = fn()
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        return peak, result
    c = time.process_time()
    result = fn()
    return time.process_time() - c, result


# Runs argv and prints its peak RSS: a small process of its own starts it, since a child
# forked from this one (hundreds of MB by now) would count this one's pages as its own peak.
LAUNCHER = """import resource, subprocess, sys
subprocess.run(sys.argv[1:], check=True, stdout=subprocess.DEVNULL)
print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)"""


def peak_rss(argv: list[str]) -> int:
    """Peak resident memory (bytes) of a process running `argv` (ru_maxrss, KiB on Linux, of
    the launcher's only child). Raises if it fails."""
    env = dict(os.environ, PYTHONPATH=str(Path(edgeaa.__file__).parents[1]))
    done = subprocess.run(
        [sys.executable, "-c", LAUNCHER, *argv], env=env, capture_output=True, text=True
    )
    if done.returncode:
        raise RuntimeError(f"{' '.join(argv)} failed: {done.stderr[-500:]}")
    return int(done.stdout) * 1024


def process_peaks(scene: Scene) -> dict[str, int]:
    """Peak RSS of `edgeaa render SCENE.json -o OUT.png` and of AGG and Skia drawing the same
    polygons from the same file (`peer_draw.py`), each a process of its own, end to end:
    Python, its imports, reading the scene, rasterizing, writing the PNG."""
    with tempfile.TemporaryDirectory() as folder:
        source, out = Path(folder) / "scene.json", str(Path(folder) / "out.png")
        source.write_text(scene_json(scene))
        render = [sys.executable, "-m", "edgeaa", "render", str(source), "-o", out, "--quiet"]
        peaks = {"edgeaa": peak_rss(render)}
        for peer in PEERS:
            peaks[peer] = peak_rss([sys.executable, str(PEER_DRAW), peer, str(source), out])
    return peaks


def run_scene(make, config: EdgeConfig, repeats: int) -> dict:
    """Every stage of one scene: CPU seconds, the median over `repeats`, then one run for
    the peak memory each stage allocates."""
    times: dict[str, list[float]] = {s: [] for s in STAGES}
    for memory in [False] * repeats + [True]:
        got = {}
        got["flatten"], scene = measure(make, memory)
        text = scene_json(scene)
        got["parse"], _ = measure(lambda: scene_from_json(text), memory)  # noqa: B023
        got["plan"], plan = measure(lambda: plan_scene(scene, config), memory)  # noqa: B023
        value, result = measure(lambda: render_scene(plan), memory)  # noqa: B023
        # the render's own CPU per stage; choosing the edges and the bands counts as engine
        got["accumulate"] = value if memory else result.cpu["accumulate"]
        got["engine"] = value if memory else value - result.cpu["accumulate"]
        full, bits, sink = config.full_scale, config.intensity_bits, io.BytesIO()
        got["write"], _ = measure(lambda: write_png(result.image, full, bits, sink), memory)  # noqa: B023
        got["agg"], _ = measure(lambda: agg_scene(plan), memory)  # noqa: B023
        got["skia"], _ = measure(lambda: skia_scene(plan), memory)  # noqa: B023
        if memory:
            mem = got
            continue
        for stage in STAGES:
            times[stage].append(got[stage])
    return {
        "scene": scene.name, "edges": plan.edge_count, "polygons": len(scene.polygons),
        "pixels": scene.width * scene.height, "bands": result.bands,
        "cpu": {stage: float(np.median(values)) for stage, values in times.items()},
        "mem": mem, "rss": process_peaks(scene),
    }  # fmt: skip


def edgeaa_total(row: dict) -> float:
    return sum(row["cpu"][s] for s in ("plan", "engine", "accumulate", "write"))


def raster(row: dict) -> float:
    return row["cpu"]["engine"] + row["cpu"]["accumulate"]


def geomean(values) -> float:
    return float(np.exp(np.mean(np.log(values))))


def slope(xs, ys) -> float:
    return float(np.polyfit(np.log(xs), np.log(np.maximum(ys, 1e-6)), 1)[0])


def stage_table(rows: list[dict]) -> str:
    headers = ["scene", "edges", *STAGES, "end to end / AGG", "raster / AGG"]
    body = [
        [r["scene"], f"{r['edges']:,}"]
        + [f"{1000 * r['cpu'][s]:.1f}" for s in STAGES]
        + [f"{edgeaa_total(r) / r['cpu']['agg']:.1f}", f"{raster(r) / r['cpu']['agg']:.1f}"]
        for r in rows
    ]
    return table(headers, body)


def memory_table(rows: list[dict]) -> str:
    stages = [s for s in STAGES if s != "accumulate"]  # the render is one figure
    headers = ["scene", *(("render" if s == "engine" else s) for s in stages)]
    body = [[r["scene"]] + [f"{r['mem'][s] / 2**20:.1f}" for s in stages] for r in rows]
    return table(headers, body)


def rss_table(rows: list[dict]) -> str:
    headers = ["scene", "edgeaa render MiB", "AGG MiB", "Skia MiB", "edgeaa / AGG"]
    body = [
        [r["scene"]]
        + [f"{r['rss'][k] / 2**20:.1f}" for k in ("edgeaa", *PEERS)]
        + [f"{r['rss']['edgeaa'] / r['rss']['agg']:.2f}"]
        for r in rows
    ]
    return table(headers, body)


def slope_table(series: dict[str, tuple[str, list[dict]]]) -> str:
    headers = ["series", "against", *STAGES]
    body = []
    for name, (key, rows) in series.items():
        xs = [r[key] for r in rows]
        body.append([name, key] + [f"{slope(xs, [r['cpu'][s] for r in rows]):.2f}" for s in STAGES])
    return table(headers, body)


def report(rows: list[dict], series: dict) -> str:
    ends = [edgeaa_total(r) / r["cpu"]["agg"] for r in rows]
    rasters = [raster(r) / r["cpu"]["agg"] for r in rows]
    memory = [r["rss"]["edgeaa"] / r["rss"]["agg"] for r in rows]
    return "\n\n".join(
        [
            machine_line(),
            "CPU milliseconds per stage (median over the repeats):\n\n" + stage_table(rows),
            "Peak memory each stage allocates (tracemalloc), MiB:\n\n" + memory_table(rows),
            "Peak RSS of each program in a process of its own, end to end (ru_maxrss):\n\n"
            + rss_table(rows),
            "Log-log slopes of CPU time:\n\n" + slope_table(series),
            f"Geometric means over the {len(rows)} scenes: end to end {geomean(ends):.1f} x "
            f"AGG (target 3), rasterizing {geomean(rasters):.1f} x AGG (target 1.5); peak RSS "
            f"{geomean(memory):.2f} x AGG's (the most {max(memory):.2f}; target 2).",
        ]
    )


def write_docs(text: str) -> None:
    docs = DOCS.read_text()
    command = "python benchmarks/bench_stages.py --write-docs"
    section = f"{BEGIN}\n\n`{command}`:\n\n```text\n{text}\n```\n\n{END}"
    if BEGIN in docs:
        head, rest = docs.split(BEGIN, 1)
        docs = head + section + rest.split(END, 1)[1]
    else:
        docs += f"\n## The renderer stage by stage against AGG and Skia (issue 28)\n\n{section}\n"
    DOCS.write_text(docs)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="fewer and smaller scenes")
    parser.add_argument("--json", help="write the figures to this file")
    parser.add_argument("--write-docs", action="store_true")
    parser.add_argument("--only", help="only the scenes whose name holds this")
    args = parser.parse_args()
    keep_freed_memory()  # as `edgeaa render` does
    logging.getLogger("fontTools").setLevel(logging.ERROR)  # cmr10's old timestamps
    config = EdgeConfig()
    sizes, glyphs, cells = (
        (SIZES[:2], PAGE_GLYPHS[:2], MAP_CELLS[:2])
        if args.quick
        else (SIZES, PAGE_GLYPHS, MAP_CELLS)
    )
    makers = [lambda n=n: builtin(n, config) for n in ("text", "starburst")]
    makers += [lambda f=f, s=s: font_scene(f, s)[0] for f in FONTS for s in sizes]
    makers.append(icon_sheet)
    pages = [lambda g=g: page(g) for g in glyphs]
    maps = [lambda c=c: map_scene(c) for c in cells]
    if args.only:
        chosen = [make for make in makers + pages + maps if args.only in make().name]
        if not chosen:
            parser.error(f"--only {args.only!r}: no scene's name holds it")
        for make in chosen:
            row = run_scene(make, config, args.repeats)
            print(stage_table([row]), rss_table([row]), sep="\n\n", flush=True)
        return 0
    rows = []
    for make in makers + pages + maps:
        rows.append(run_scene(make, config, args.repeats))
        print(rows[-1]["scene"], f"{edgeaa_total(rows[-1]):.3f} s", flush=True)
    series = {
        "page": ("edges", rows[len(makers) : len(makers) + len(pages)]),
        "map": ("polygons", rows[len(makers) + len(pages) :]),
    }
    text = report(rows, series)
    print(text)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    if args.write_docs:
        write_docs(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
