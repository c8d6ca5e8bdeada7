"""Run time of the accumulation renderer against AGG and Skia on the same plans.

For each scene the plan (`edgeaa.render.plan_scene`) is made once and timed on its own; then
`render_scene(plan)` (model engine, skipping on), AGG (`edgeaa.render.compare.agg_scene`)
and Skia (`skia_scene`) draw that same plan, interleaved, each timed `--repeats` times after
one untimed warm-up run; the minimum is kept (the machine is shared). render_scene's own
stages come from `Render.timings`: ``select`` (its "plan" key: which edges go to the engine,
when given a plan), ``engine`` (edge commands and their deltas), ``accumulate`` (buffers,
prefix sums, fill rule, compositing); ``other`` is the rest of its wall time, which is the
timing model's `engines.cycles` (measured alone in the ``cycles`` column) and bookkeeping.
Each stage is the minimum over the repeats, its share taken of plan_scene + render_scene.

Three sets of scenes:

(a) the built-in ``text`` and ``starburst`` (default configuration);
(b) 1, 2, 4, 8, 16 lines of the built-in text's string at 28 px (DejaVu Sans, 36 px apart,
    black on white, image 512 px wide): the edges grow with the lines; the slope of log
    time against log edges sent is fitted by least squares;
(c) one scene at image sizes 128 .. 2048 px: the starburst scaled (N x N, radius 200 N / 256)
    and the text line scaled (N x N / 8, font 28 N / 512 px); the slope of log time against
    log N. This set uses coord_bits = 12: the scaled starburst spans 1.56 N px, more than the
    default 2048 px range at N = 2048.

    python benchmarks/bench_accumulation.py [--repeats 5] [--lines 1,2,4,8,16]
        [--sizes 128,256,512,1024,2048] [--json]

Targets (reported, not enforced): edgeaa within 5x AGG on the built-in text; slopes at most
1.1.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import sys
import time

import numpy as np

from edgeaa.analysis.report import machine_info, machine_line, table
from edgeaa.model import EdgeConfig
from edgeaa.render import builtin, plan_scene, render_scene
from edgeaa.render.builtin import TEXT, starburst, text_polygons
from edgeaa.render.compare import agg_scene, skia_scene
from edgeaa.render.engines import cycles
from edgeaa.render.scene import DEFAULT_TOLERANCE, Scene

TARGET_RATIO = 5.0  # edgeaa / AGG on the built-in text
TARGET_SLOPE = 1.1
LINE_PITCH = 36.0  # px between baselines in set (b)
STAGES = ("select", "engine", "accumulate", "other")


def lines_scene(lines: int, full: int = 255) -> Scene:
    """`lines` lines of TEXT at 28 px, black on white, 512 px wide."""
    polygons = []
    for k in range(lines):
        glyphs, _ = text_polygons(TEXT, 28.0, 14.0, 34.0 + k * LINE_PITCH, 0, DEFAULT_TOLERANCE)
        polygons.extend(glyphs)
    height = int(LINE_PITCH * lines + 12)
    return Scene(512, height, tuple(polygons), background=full, name=f"text x{lines}")


def scaled_text(size: int, full: int = 255) -> Scene:
    """The text line in an N x N/8 image, everything scaled by N / 512."""
    f = size / 512
    glyphs, _ = text_polygons(TEXT, 28.0 * f, 14.0 * f, 42.0 * f, 0, DEFAULT_TOLERANCE)
    return Scene(size, max(size // 8, 1), glyphs, background=full, name=f"text {size}")


def scaled_starburst(size: int, full: int = 255) -> Scene:
    return starburst(full, size=size, radius=200.0 * size / 256)


def best(values) -> float:
    return float(min(values))


def time_scene(scene: Scene, config: EdgeConfig, repeats: int) -> dict:
    """Plan once per repeat (timed), render the same plan with edgeaa, AGG and Skia."""
    plan = plan_scene(scene, config)
    result = render_scene(plan)  # warm-up (and the counts)
    agg_scene(plan)
    skia_scene(plan)
    edges = [plan.edge(int(e), clip=True) for e in result.sent]
    samples = {k: [] for k in ("plan", "render", "agg", "skia", "cycles", *STAGES)}
    for _ in range(repeats):
        gc.collect()
        t = time.perf_counter()
        plan_scene(scene, config)
        samples["plan"].append(time.perf_counter() - t)
        gc.collect()
        t = time.perf_counter()
        r = render_scene(plan)
        samples["render"].append(time.perf_counter() - t)
        stages = {
            "select": r.timings["plan"],
            "engine": r.timings["engine"],
            "accumulate": r.timings["accumulate"],
        }
        stages["other"] = r.seconds - sum(stages.values())
        for k, v in stages.items():
            samples[k].append(v)
        gc.collect()
        t = time.perf_counter()
        cycles(config, edges)
        samples["cycles"].append(time.perf_counter() - t)
        gc.collect()
        t = time.perf_counter()
        agg_scene(plan)
        samples["agg"].append(time.perf_counter() - t)
        gc.collect()
        t = time.perf_counter()
        skia_scene(plan)
        samples["skia"].append(time.perf_counter() - t)
    row = {k: best(v) for k, v in samples.items()}
    row.update(
        scene=scene.name,
        width=scene.width,
        height=scene.height,
        scene_edges=int(plan.edge_count),
        sent=int(len(result.sent)),
        deltas=int(len(result.deltas)),
        cells=int(result.cells_scanned),
        rows=int(result.rows_scanned),
    )
    row["ratio_agg"] = row["render"] / row["agg"]
    row["ratio_skia"] = row["render"] / row["skia"]
    row["ratio_agg_with_plan"] = (row["render"] + row["plan"]) / row["agg"]
    whole = row["plan"] + row["render"]
    row["share"] = {k: row[k] / whole for k in ("plan", *STAGES)}
    return row


def slope(xs, ys) -> float:
    """Least-squares slope of log y against log x."""
    return float(np.polyfit(np.log(np.asarray(xs, float)), np.log(np.asarray(ys, float)), 1)[0])


def ms(seconds: float) -> str:
    return f"{seconds * 1000:.1f}"


def timing_table(rows: list[dict], first: str, key) -> str:
    headers = [
        first, "edges (sent)", "plan ms", "render ms", "AGG ms", "Skia ms", "/AGG", "/Skia",
        "(plan+render)/AGG",
    ]  # fmt: skip
    body = [
        [
            str(key(r)), f"{r['scene_edges']} ({r['sent']})", ms(r["plan"]), ms(r["render"]),
            ms(r["agg"]), ms(r["skia"]), f"{r['ratio_agg']:.1f}", f"{r['ratio_skia']:.1f}",
            f"{r['ratio_agg_with_plan']:.1f}",
        ]  # fmt: skip
        for r in rows
    ]
    return table(headers, body)


def stage_table(rows: list[dict], first: str, key) -> str:
    headers = [first, "plan", "select", "engine", "accumulate", "other", "cycles() alone"]
    headers += ["cells scanned", "pixels"]
    body = []
    for r in rows:
        cells = [str(key(r))]
        cells += [f"{ms(r[k])} ({100 * r['share'][k]:.0f} %)" for k in ("plan", *STAGES)]
        cells += [ms(r["cycles"]), f"{r['cells']:,}", f"{r['width'] * r['height']:,}"]
        body.append(cells)
    return table(headers, body)


def slope_table(series: dict[str, tuple[list, list[dict]]], against: str) -> str:
    headers = ["series", f"against {against}", "render", "engine", "accumulate", "other"]
    headers += ["plan", "AGG", "Skia"]
    body = []
    for name, (xs, rows) in series.items():
        cells = [name, f"{min(xs)} .. {max(xs)}"]
        for k in ("render", "engine", "accumulate", "other", "plan", "agg", "skia"):
            cells.append(f"{slope(xs, [r[k] for r in rows]):.2f}")
        body.append(cells)
    return table(headers, body)


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        epilog="Tables are Markdown; --json prints one JSON object instead.",
    )
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per method (min kept)")
    parser.add_argument("--lines", default="1,2,4,8,16", help="line counts of set (b)")
    parser.add_argument("--sizes", default="128,256,512,1024,2048", help="image sizes of set (c)")
    parser.add_argument("--skip", default="", help="sets to leave out, e.g. 'b,c'")
    parser.add_argument("--json", action="store_true", help="print JSON instead of tables")
    args = parser.parse_args()
    lines = [int(v) for v in args.lines.split(",") if v]
    sizes = [int(v) for v in args.sizes.split(",") if v]
    skip = set(args.skip.split(",")) - {""}
    config = EdgeConfig()
    wide = config.with_(coord_bits=12)
    load = os.getloadavg()
    out: dict = {"machine": machine_info(), "config": str(config), "repeats": args.repeats}

    def note(message):
        print(message, file=sys.stderr, flush=True)

    start = time.perf_counter()
    if "a" not in skip:
        out["builtins"] = []
        for name in ("text", "starburst"):
            note(f"(a) {name}")
            out["builtins"].append(time_scene(builtin(name, config), config, args.repeats))
    if "b" not in skip:
        out["lines"] = []
        for n in lines:
            note(f"(b) {n} lines")
            row = time_scene(lines_scene(n, config.full_scale), config, args.repeats)
            row["lines"] = n
            out["lines"].append(row)
    if "c" not in skip:
        out["sizes"] = {"starburst": [], "text": []}
        for n in sizes:
            for name, make in (("starburst", scaled_starburst), ("text", scaled_text)):
                note(f"(c) {name} {n}")
                row = time_scene(make(n, wide.full_scale), wide, args.repeats)
                row["size"] = n
                out["sizes"][name].append(row)
    out["seconds"] = time.perf_counter() - start
    out["load_average"] = {"start": load, "end": os.getloadavg()}
    if "lines" in out and len(lines) > 1:
        rows = out["lines"]
        out["slope_edges"] = {
            k: slope([r["sent"] for r in rows], [r[k] for r in rows])
            for k in ("render", "engine", "accumulate", "other", "plan", "agg", "skia")
        }
    if "sizes" in out and len(sizes) > 1:
        out["slope_size"] = {
            name: {
                k: slope(sizes, [r[k] for r in rows])
                for k in ("render", "engine", "accumulate", "other", "plan", "agg", "skia")
            }
            for name, rows in out["sizes"].items()
        }
    if args.json:
        print(json.dumps(out, indent=1))
        return 0

    print(machine_line())
    print(f"config: {config}; repeats {args.repeats} (min kept); whole run {out['seconds']:.0f} s")
    print(f"load average at start {load[0]:.2f}, at end {out['load_average']['end'][0]:.2f}")
    if "builtins" in out:
        rows = out["builtins"]
        print("\n### (a) built-in scenes\n")
        print(timing_table(rows, "scene", lambda r: r["scene"]))
        print()
        print(stage_table(rows, "scene", lambda r: r["scene"]))
        text = rows[0]
        verdict = "met" if text["ratio_agg"] <= TARGET_RATIO else "NOT met"
        print(
            f"\ntarget: edgeaa within {TARGET_RATIO:g}x AGG on the built-in text: "
            f"{text['ratio_agg']:.1f}x ({verdict})"
        )
    if "lines" in out:
        rows = out["lines"]
        print("\n### (b) lines of text\n")
        print(timing_table(rows, "lines", lambda r: r["lines"]))
        print()
        print(stage_table(rows, "lines", lambda r: r["lines"]))
        if len(lines) > 1:
            print()
            xs = [r["sent"] for r in rows]
            print(slope_table({"lines of text": (xs, rows)}, "edges sent"))
            s = out["slope_edges"]["render"]
            verdict = "met" if s <= TARGET_SLOPE else "NOT met"
            print(f"\ntarget: slope against edges at most {TARGET_SLOPE}: {s:.2f} ({verdict})")
    if "sizes" in out:
        print(f"\n### (c) image size (config: {wide})\n")
        for name, rows in out["sizes"].items():
            print(f"{name}:\n")
            print(timing_table(rows, "N", lambda r: f"{r['width']}x{r['height']}"))
            print()
            print(stage_table(rows, "N", lambda r: f"{r['width']}x{r['height']}"))
            print()
        if len(sizes) > 1:
            series = {name: (sizes, rows) for name, rows in out["sizes"].items()}
            print(slope_table(series, "N (px)"))
            for name, slopes in out["slope_size"].items():
                s = slopes["render"]
                verdict = "met" if s <= TARGET_SLOPE else "NOT met"
                print(f"target: {name} slope against N at most {TARGET_SLOPE}: {s:.2f} ({verdict})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
