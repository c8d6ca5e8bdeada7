"""The polygon pipeline in hardware: display rate per scene, where the clocks go, and
simulation speed (issue 26).

Scenes (default configuration, tile 64 x 32 unless --tile), each through every named pipeline
configuration (`edgeaa.model.pipeline.PIPELINES`: compact, one setup unit; fast, four, a
flush of two pixels a clock and a scan of two cells a clock; or --pipelines): the built-ins;
a 640 x 480 HUD
page (`hud_scene`: 20 lines of 12 px DejaVu Sans Mono, a frame, a ring and a pitch ladder);
one line of serif text (`edgeaa.render.corpus.font_scene`) in STIX, DejaVu Serif and cmr10
(fonts matplotlib ships) at 9 to 32 px; and 1920 x 1080 with 40 large polygons
(`polygons_1080p`, seeded). For each, the scene's pipeline commands
(`edgeaa.render.pipeline.scene_commands`) go through the whole pipeline's cycle model
(`edgeaa.model.pipeline_timing.pipeline_cycles`, exact: tested against the Verilated
pipeline) and through the Verilated `EdgePipeline` (`edgeaa.sim.simulators.pipeline_harness`,
build excluded, sink always ready), whose image is compared with the renderer's and whose
clocks with the model's plus the harness's drain (equal, or the model is wrong).

The rate table: clocks (the cycle model's), pixels per clock, the floor (the flush's beats,
the pixels flushed over the pixel lanes, `PipelineConfig.pixel_lanes`, or the scan's beats,
the cells the resolve scans, `TileTiming.cells_scanned`, over the scan lanes,
`PipelineConfig.scan_lanes`: `TileTiming.beats_scanned`, whichever is more: each beat of
pixels and each beat of cells takes a clock, and with the resolve's second pixel memory a
flush runs beside the next tile's scan) and the clocks' ratio to it, frames per second at
the configuration's measured Fmax on its device (`FMAX`: compact on the iCE40 HX8K, fast on
the ECP5 25F; docs/hardware.md), and AGG's and Skia's time on one CPU core for the same
polygons in the same run (aggdraw, and skia-python's raster surface with analytic
antialiasing: the scene drawn into an 8-bit image, paths and paints built beforehand, the
fastest of --repeats draws) and the FPGA's time over AGG's. The stage table: each stage's
busy and stall counters as shares of the clocks, the stepper alone's clocks on the edges the
renderer sends once (`edgeaa.model.timing`), and simulated clocks per second beside the
stepper-only harness's on the same edges (the ratio is the steadier figure on a shared
machine).
--write puts both tables into docs/hardware.md between its markers.

    python benchmarks/bench_pipeline.py [--tile 64x32] [--pipelines compact,fast]
        [--scenes NAME,...] [--repeats 3] [--json] [--write]

--scenes keeps the scenes whose name contains one of the given (case-insensitive; "HUD,
STIX"); --write needs every scene.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import random
import re
import sys
import time
from pathlib import Path

import numpy as np
from doc_tables import write_section  # this folder: the script's own

from edgeaa.hdl.core import PolygonCore
from edgeaa.hdl.pipeline import STATS
from edgeaa.model import EdgeConfig
from edgeaa.model.pipeline import PIPELINES, PipelineConfig
from edgeaa.model.pipeline_timing import pipeline_cycles
from edgeaa.model.tile import TileConfig
from edgeaa.render import builtin, plan_scene, render_scene
from edgeaa.render.builtin import BUILTINS, glyph_polygons
from edgeaa.render.corpus import font_file, font_scene
from edgeaa.render.pipeline import image_from_frames, scene_commands
from edgeaa.render.scene import Polygon, Scene
from edgeaa.sim.simulators import pipeline_harness, verilator_harness

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "hardware.md"
# Each configuration's device and measured Fmax (MHz, the median over nextpnr seeds 1 to 5:
# compact on the iCE40 HX8K, fast on the ECP5 25F; docs/hardware.md, "The piece end in one
# carry chain, the intercept in the depth's operand").
FMAX = {"compact": ("iCE40 HX8K", 49.15), "fast": ("ECP5 25F", 54.3)}
SERIF_FONTS = ("STIXGeneral", "DejaVuSerif", "cmr10")
FONT_SIZES = (9, 12, 16, 24, 32)


def _circle(cx: float, cy: float, r: float, n: int, reverse: bool = False) -> tuple:
    angles = [2 * math.pi * k / n for k in range(n)]
    points = [(cx + r * math.cos(a), cy + r * math.sin(a)) for a in angles]
    return tuple(points[::-1] if reverse else points)


def _bar(cx: float, cy: float, width: float, height: float, angle: float) -> tuple:
    c, s = math.cos(angle), math.sin(angle)
    corners = ((-width / 2, -height / 2), (width / 2, -height / 2))
    corners += ((width / 2, height / 2), (-width / 2, height / 2))
    return tuple((cx + x * c - y * s, cy + x * s + y * c) for x, y in corners)


def hud_scene(full: int = 255) -> Scene:
    """640 x 480, bright on dark: a 2 px frame on pixel boundaries, a ring (radius 150 px,
    2.5 px wide, 96 sides), a pitch ladder of 9 bars 2 px thick tilted 4 degrees, and 20
    lines of 12 px DejaVu Sans Mono (one polygon per glyph), all off the pixel grid but the
    frame."""
    dark, bright = round(full * 24 / 255), full
    outer = ((3.5, 3.5), (636.5, 3.5), (636.5, 476.5), (3.5, 476.5))
    inner = ((5.5, 5.5), (5.5, 474.5), (634.5, 474.5), (634.5, 5.5))  # reversed: a hole
    ring = (_circle(420.3, 240.2, 150, 96), _circle(420.3, 240.2, 147.5, 96, reverse=True))
    polygons = [Polygon((outer, inner), bright, "nonzero", "frame")]
    polygons.append(Polygon(ring, bright, "nonzero", "ring"))
    for k in range(9):
        bar = _bar(420.3, 240.2 + (k - 4) * 28, 220 if k == 4 else 120, 2.0, math.radians(4))
        polygons.append(Polygon((bar,), bright, "nonzero", f"ladder {k}"))
    mono = font_file("DejaVuSansMono")
    for line in range(20):
        text = f"{line:02d} ALT {12500 - 37 * line:5d} SPD {250 + 3 * line:3d} "
        text += f"HDG {(275 + 11 * line) % 360:03d}"
        glyphs, _, _ = glyph_polygons(mono, text, 12, 12.3, 24.37 + 22 * line, bright)
        polygons.extend(glyphs)
    return Scene(640, 480, tuple(polygons), background=dark, name="HUD 640x480")


def polygons_1080p(full: int = 255, count: int = 40, seed: int = 1080) -> Scene:
    """1920 x 1080, `count` filled polygons of 5 to 12 vertices, star-shaped around random
    centres (radius 120 to 420 px, each vertex at 0.5 to 1 of it), cut to 10 px around the
    image, random intensities over mid grey; seeded."""
    rng = random.Random(seed)
    polygons = []
    for k in range(count):
        cx, cy, r = rng.uniform(0, 1920), rng.uniform(0, 1080), rng.uniform(120, 420)
        angles = sorted(rng.uniform(0, 2 * math.pi) for _ in range(rng.randint(5, 12)))
        points = []
        for a in angles:
            x = cx + r * rng.uniform(0.5, 1) * math.cos(a)
            y = cy + r * rng.uniform(0.5, 1) * math.sin(a)
            points.append((min(max(x, -10.3), 1930.3), min(max(y, -10.3), 1090.3)))
        polygons.append(Polygon((tuple(points),), rng.randint(0, full), "nonzero", f"{k}"))
    return Scene(1920, 1080, tuple(polygons), background=full // 2, name="1080p 40 polygons")


def scenes(config: EdgeConfig) -> list[Scene]:
    out = [builtin(name, config) for name in BUILTINS]
    out.append(hud_scene(config.full_scale))
    for font in SERIF_FONTS:
        out += [font_scene(font, size, config.full_scale)[0] for size in FONT_SIZES]
    out.append(polygons_1080p(config.full_scale))
    return out


def agg_seconds(plan, repeats: int) -> float:
    """AGG (aggdraw) drawing the plan's polygons (quantized, as edgeaa draws them) into an
    8-bit image, on one core: the fastest of `repeats` draws, the paths built beforehand."""
    import aggdraw
    from PIL import Image

    from edgeaa.analysis.compare import agg_path, to8

    scene, full = plan.scene, plan.config.full_scale
    jobs = [
        (agg_path(plan, i), aggdraw.Brush(to8(poly.intensity, full)))
        for i, poly in enumerate(plan.polygons)
    ]
    pen = aggdraw.Pen(0, 0, 0)  # width 0: no 1/4 px widening (edgeaa.analysis.peers)
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        image = Image.new("L", (scene.width, scene.height), to8(scene.background, full))
        draw = aggdraw.Draw(image)
        for path, brush in jobs:
            draw.path(path, pen, brush)
        draw.flush()
        best = min(best, time.perf_counter() - start)
    return best


def skia_seconds(plan, repeats: int) -> float:
    """Skia (skia-python, raster surface, analytic antialiasing) drawing the plan's polygons
    as `edgeaa.analysis.compare.skia_scene` does, into an 8-bit grey surface, on one core:
    the fastest of `repeats` draws, the paths and paints built beforehand."""
    import skia

    from edgeaa.analysis.compare import polygon_points

    scene, full = plan.scene, plan.config.full_scale
    jobs = []
    for i, poly in enumerate(plan.polygons):
        path = skia.Path()
        for pts in polygon_points(plan, i):
            path.moveTo(*(pts[0] + 0.5))
            for p in pts[1:]:
                path.lineTo(*(p + 0.5))
            path.close()
        even = poly.rule == "evenodd"
        path.setFillType(skia.PathFillType.kEvenOdd if even else skia.PathFillType.kWinding)
        v = round(poly.intensity * 255 / full)
        jobs.append((path, skia.Paint(AntiAlias=True, Color=skia.ColorSetRGB(v, v, v))))
    info = skia.ImageInfo.Make(
        scene.width,
        scene.height,
        skia.ColorType.kGray_8_ColorType,
        skia.AlphaType.kOpaque_AlphaType,
    )
    surface = skia.Surface.MakeRaster(info)
    b = round(scene.background * 255 / full)
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        canvas = surface.getCanvas()
        canvas.clear(skia.ColorSetRGB(b, b, b))
        for path, paint in jobs:
            canvas.drawPath(path, paint)
        surface.flushAndSubmit()
        best = min(best, time.perf_counter() - start)
    return best


def measure(scene: Scene, tile: TileConfig, pipelines: list[str], repeats: int) -> list[dict]:
    """One row per configuration in `pipelines` (the CPU peers measured once for all)."""
    config = tile.config
    plan = plan_scene(scene, config)
    model = render_scene(plan)
    commands = scene_commands(plan, tile)
    edges = [plan.edge(int(e), clip=True) for e in model.sent]
    core = min(
        (verilator_harness.run(config, edges, top=PolygonCore) for _ in range(repeats)),
        key=lambda r: r.seconds,
    )
    peers = {"agg_seconds": agg_seconds(plan, repeats), "skia_seconds": skia_seconds(plan, repeats)}
    rows = []
    for name in pipelines:
        pipeline = PipelineConfig.named(name, tile)
        timing = pipeline_cycles(pipeline, commands)
        run = min(
            (pipeline_harness.run(pipeline, commands) for _ in range(repeats)),
            key=lambda r: r.seconds,
        )
        image = image_from_frames(plan, tile, run.frames(tile))
        flushed, lanes, scan = len(timing.pixels), pipeline.pixel_lanes, pipeline.scan_lanes
        rows.append(
            {
                "scene": scene.name,
                "pipeline": name,
                "setup_units": pipeline.setup_units,
                "pixel_lanes": lanes,
                "scan_lanes": scan,
                "size": f"{scene.width}x{scene.height}",
                "pixels": scene.width * scene.height,
                "commands": len(commands),
                "clocks": timing.clocks,
                "flushed": flushed,
                "scanned": timing.tile.cells_scanned,
                # a beat of `lanes` pixels a clock; a beat of `scan` scanned cells a clock
                "floor": max(flushed // lanes, timing.tile.beats_scanned),
                "verilator_clocks": run.clocks,
                "drain": pipeline_harness.pixel_drain_clocks(tile),
                "stepper_cycles": model.cycles,
                "pixels_out": len(run.pixels),
                "image_equal": bool(np.array_equal(image, model.image)),
                "stats": dict(run.stats),
                **peers,
                "mclocks_per_s": run.clocks_per_second / 1e6,
                "core_mclocks_per_s": core.clocks_per_second / 1e6,
            }
        )
    return rows


def exact(r: dict) -> bool:
    return r["clocks"] + r["drain"] == r["verilator_clocks"]


def rate_table(rows: list[dict]) -> list[str]:
    head = ["scene", "size", "pipeline", "clocks", "px/clock"]
    head += ["floor (flushed / lanes; scanned / scan lanes)"]
    head += ["clocks/floor", "fps at Fmax", "AGG (ms)", "Skia (ms)", "FPGA/AGG"]
    head += ["Verilator: image, clocks"]
    lines = ["| " + " | ".join(head) + " |", "|---|---|---|" + "---:|" * (len(head) - 4) + "---|"]
    for r in rows:
        seconds = r["clocks"] / (FMAX[r["pipeline"]][1] * 1e6)
        check = ("same" if r["image_equal"] else "DIFFERENT") + ", "
        check += "exact" if exact(r) else f"{r['verilator_clocks']:,} (MODEL WRONG)"
        cells = [r["scene"], r["size"], r["pipeline"], f"{r['clocks']:,}"]
        cells.append(f"{r['pixels'] / r['clocks']:.3f}")
        lanes = f" / {r['pixel_lanes']}" if r["pixel_lanes"] > 1 else ""
        scan = f" / {r['scan_lanes']}" if r["scan_lanes"] > 1 else ""
        floor = f"{r['floor']:,} ({r['flushed']:,}{lanes}; {r['scanned']:,}{scan})"
        cells += [floor, f"{r['clocks'] / r['floor']:.2f}", f"{1 / seconds:.1f}"]
        cells += [f"{1e3 * r['agg_seconds']:.2f}", f"{1e3 * r['skia_seconds']:.2f}"]
        cells += [f"{seconds / r['agg_seconds']:.1f}", check]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def stage_table(rows: list[dict]) -> list[str]:
    head = ["scene", "pipeline", "commands", "stepper alone"] + [f"{name} %" for name in STATS]
    head += ["M clocks/s", "vs stepper harness"]
    lines = ["| " + " | ".join(head) + " |", "|---|---|" + "---:|" * (len(head) - 2)]
    for r in rows:
        clocks = r["verilator_clocks"]
        shares = [f"{100 * r['stats'][name] / clocks:.1f}" for name in STATS]
        ratio = r["mclocks_per_s"] / r["core_mclocks_per_s"]
        cells = [r["scene"], r["pipeline"], f"{r['commands']:,}", f"{r['stepper_cycles']:,}"]
        cells += shares
        cells += [f"{r['mclocks_per_s']:.2f}", f"{ratio:.2f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tile", default="64x32", help="tile WIDTHxHEIGHT")
    parser.add_argument(
        "--pipelines",
        default=",".join(PIPELINES),
        help=f"named configurations, comma-separated (default {','.join(PIPELINES)})",
    )
    parser.add_argument(
        "--scenes", help="only the scenes whose name contains one of these (comma-separated)"
    )
    parser.add_argument("--repeats", type=int, default=3, help="runs per scene (fastest kept)")
    parser.add_argument("--json", action="store_true", help="print JSON instead of tables")
    parser.add_argument("--write", action="store_true", help="write the tables into the docs")
    args = parser.parse_args()
    match = re.fullmatch(r"(\d+)x(\d+)", args.tile)
    if not match:
        parser.error(f"--tile: expected WIDTHxHEIGHT, not {args.tile!r}")
    if args.repeats < 1:
        parser.error(f"--repeats: at least 1, not {args.repeats}")
    pipelines = args.pipelines.split(",")
    if not pipelines or any(name not in PIPELINES for name in pipelines):
        parser.error(f"--pipelines: names of {', '.join(PIPELINES)}, not {args.pipelines!r}")
    if args.scenes is not None and args.write:
        parser.error("--write: the tables are of every scene; leave out --scenes")
    tile = TileConfig(EdgeConfig(), int(match[1]), int(match[2]))
    chosen = scenes(tile.config)
    if args.scenes is not None:
        wanted = [w.strip().lower() for w in args.scenes.split(",") if w.strip()]
        chosen = [s for s in chosen if any(w in s.name.lower() for w in wanted)]
        if not chosen:
            parser.error(f"--scenes: no scene's name contains any of {args.scenes!r}")
    for name in pipelines:
        pipeline_harness.build(PipelineConfig.named(name, tile))
    verilator_harness.build(tile.config, top=PolygonCore)
    rows = []
    for scene in chosen:
        print(f"{scene.name} ...", file=sys.stderr, flush=True)
        rows += measure(scene, tile, pipelines, args.repeats)
    machine = f"{platform.processor() or platform.machine()}, Python {platform.python_version()}"
    command = " ".join(["python benchmarks/bench_pipeline.py", *sys.argv[1:]])
    title = [f"`{command}` ({time.strftime('%Y-%m-%d')}, {machine}; tile {args.tile}, "]
    fmax = "; ".join(f"{n} {FMAX[n][1]} MHz on the {FMAX[n][0]}" for n in pipelines)
    title[0] += f"{tile.config}; Fmax {fmax}):"
    rate, stages = [*title, "", *rate_table(rows)], [*title, "", *stage_table(rows)]
    print(json.dumps(rows, indent=1) if args.json else "\n".join([*rate, "", *stages[2:]]))
    if args.write:
        write_section(DOC, "pipeline rate", rate)
        write_section(DOC, "pipeline stages", stages)
        print(f"wrote {DOC.relative_to(ROOT)}", file=sys.stderr)
    return 0 if all(exact(r) and r["image_equal"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
