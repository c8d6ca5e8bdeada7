"""Run time of the accumulation renderer against AGG and Skia on the same plans.

For each scene the plan (`edgeaa.render.plan_scene`) is made once; then, per repeat and in
turn, plan_scene (timed alone), `render_scene(plan)` (model engine, skipping on), the timing
model's `engines.cycles` on the edges sent, AGG (`edgeaa.analysis.compare.agg_scene`) and Skia
(`skia_scene`) on that same plan, after one untimed warm-up run each. Times are the
process's CPU seconds, the minimum over `--repeats` (the 2 cores are shared, so CPU time is
steadier than wall time; --json also holds the wall minima). The peers' times include
turning the plan into their paths and their 8-bit images back into integers, as
`edgeaa render` comparisons do.

render_scene's stages come from `Render.timings` (wall clock): ``select`` (its "plan" key:
which edges go to the engine, when given a plan), ``engine`` (edge commands, setup and the
deltas), ``accumulate`` (buffers, prefix sums, fill rule, compositing); ``other`` is the rest
of its wall time: the timing model's schedule and bookkeeping; the ``cycles() alone``
column times `engines.cycles` on Edge objects, which the renderer no longer calls. For set
(a) the engine stage's pieces are also timed alone: the edge commands as arrays
(`render.render.edge_arrays`), `edgeaa.model.edge.setup_batch`, and `engines.run_deltas`
(which runs setup_batch again, then the vectorized deltas). The stages' wall minima split the
render's CPU time in proportion; each share is of plan_scene + render_scene.

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
        [--sizes 128,256,512,1024,2048] [--skip a,b,c] [--pass-cells N] [--plot PNG] [--json]

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

from edgeaa.analysis.compare import agg_scene, skia_scene
from edgeaa.analysis.report import machine_info, machine_line, table
from edgeaa.model import EdgeConfig, accumulate
from edgeaa.model.edge import setup_batch
from edgeaa.render import builtin, plan_scene, render_scene
from edgeaa.render.builtin import TEXT, starburst, text_polygons
from edgeaa.render.engines import cycles, run_deltas
from edgeaa.render.render import edge_arrays
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


def timed(fn, *args):
    """(wall seconds, CPU seconds of this process, result) of one call, after a collection."""
    gc.collect()
    w, c = time.perf_counter(), time.process_time()
    result = fn(*args)
    return time.perf_counter() - w, time.process_time() - c, result


def time_scene(scene: Scene, config: EdgeConfig, repeats: int, parts: bool = False) -> dict:
    """Plan once per repeat (timed), render the same plan with edgeaa, AGG and Skia."""
    plan = plan_scene(scene, config)
    result = render_scene(plan)  # warm-up (and the counts)
    agg_scene(plan)
    skia_scene(plan)
    edges = [plan.edge(int(e), clip=True) for e in result.sent]
    arrays = edge_arrays(plan, result.sent, clip=True)
    calls = [
        ("plan", plan_scene, (scene, config)),
        ("render", render_scene, (plan,)),
        ("cycles", cycles, (config, edges)),
        ("agg", agg_scene, (plan,)),
        ("skia", skia_scene, (plan,)),
    ]
    if parts:  # the engine stage's pieces, each alone
        calls += [
            ("commands", edge_arrays, (plan, result.sent, True)),
            ("setups", lambda: setup_batch(config, *arrays.args(), arrays.clip), ()),
            ("run_deltas", run_deltas, (config, arrays, "model")),
        ]
    names = [name for name, _, _ in calls]
    wall = {k: [] for k in (*names, *STAGES)}
    cpu = {k: [] for k in names}
    for _ in range(repeats):
        for name, fn, arg in calls:
            w, c, r = timed(fn, *arg)
            wall[name].append(w)
            cpu[name].append(c)
            if name == "render":
                stages = {
                    "select": r.timings["plan"],
                    "engine": r.timings["engine"],
                    "accumulate": r.timings["accumulate"],
                }
                stages["other"] = r.seconds - sum(stages.values())
                for k, v in stages.items():
                    wall[k].append(v)
    row = {k: best(v) for k, v in cpu.items()}  # CPU seconds: steadier on a shared machine
    row["wall"] = {k: best(v) for k, v in wall.items()}
    row.update(
        scene=scene.name,
        width=scene.width,
        height=scene.height,
        scene_edges=int(plan.edge_count),
        sent=int(len(result.sent)),
        deltas=result.delta_count,
        cells=int(result.cells_scanned),
        rows=int(result.rows_scanned),
    )
    # Stages: wall minima from Render.timings, as shares of plan + render wall time; in CPU
    # seconds, the render's CPU time split in the same proportions.
    stage_wall = {k: row["wall"][k] for k in STAGES}
    whole = sum(stage_wall.values())
    for k in STAGES:
        row[k] = row["render"] * stage_wall[k] / whole
    row["ratio_agg"] = row["render"] / row["agg"]
    row["ratio_skia"] = row["render"] / row["skia"]
    row["ratio_agg_with_plan"] = (row["render"] + row["plan"]) / row["agg"]
    total = row["plan"] + row["render"]
    row["share"] = {k: row[k] / total for k in ("plan", *STAGES)}
    return row


def slope(xs, ys) -> float:
    """Least-squares slope of log y against log x."""
    return float(np.polyfit(np.log(np.asarray(xs, float)), np.log(np.asarray(ys, float)), 1)[0])


def ms(seconds: float) -> str:
    return f"{seconds * 1000:.1f}"


def timing_table(rows: list[dict], first: str, key) -> str:
    headers = [
        first,
        "edges (sent)",
        "plan ms",
        "render ms",
        "AGG ms",
        "Skia ms",
        "/AGG",
        "/Skia",
        "(plan+render)/AGG",
    ]
    body = [
        [
            str(key(r)),
            f"{r['scene_edges']} ({r['sent']})",
            ms(r["plan"]),
            ms(r["render"]),
            ms(r["agg"]),
            ms(r["skia"]),
            f"{r['ratio_agg']:.1f}",
            f"{r['ratio_skia']:.1f}",
            f"{r['ratio_agg_with_plan']:.1f}",
        ]
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


def parts_table(rows: list[dict]) -> str:
    """The engine stage's pieces, each timed alone (CPU ms), and per edge sent (us)."""
    headers = ["scene", "edge commands (plan.edge)", "setup() of every edge", "run_deltas"]
    headers += ["cycles()", "render"]
    body = []
    for r in rows:
        n = max(r["sent"], 1)
        body.append(
            [r["scene"]]
            + [
                f"{ms(r[k])} ({1e6 * r[k] / n:.1f} us/edge)"
                for k in ("commands", "setups", "run_deltas", "cycles", "render")
            ]
        )
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


def plot(out: dict, path: str) -> None:
    """Log-log figure: time against edges (b) and against image size (c)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    panels = [k for k in ("lines", "sizes") if k in out]
    fig, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 4.2), squeeze=False)
    styles = {"render": ("edgeaa render_scene", "C0"), "agg": ("AGG", "C1"), "skia": ("Skia", "C2")}
    for ax, key in zip(axes[0], panels, strict=True):
        if key == "lines":
            rows = out["lines"]
            xs = [r["sent"] for r in rows]
            for k, (label, colour) in styles.items():
                ax.loglog(xs, [1000 * r[k] for r in rows], "o-", color=colour, label=label)
            ax.loglog(
                xs,
                [1000 * (r["render"] + r["plan"]) for r in rows],
                "o--",
                color="C0",
                alpha=0.6,
                label="edgeaa plan_scene + render_scene",
            )
            ax.set_xlabel("edges sent (1 .. 16 lines of text)")
            ax.set_title("(b) time against edges", fontsize=10)
        else:
            for name, marker in (("starburst", "o"), ("text", "s")):
                rows = out["sizes"][name]
                xs = [r["size"] for r in rows]
                for k, (label, colour) in styles.items():
                    ax.loglog(
                        xs,
                        [1000 * r[k] for r in rows],
                        marker + ("-" if name == "starburst" else ":"),
                        color=colour,
                        label=f"{label}, {name}",
                    )
            ax.set_xlabel("image size N (starburst N x N, text N x N/8)")
            ax.set_title("(c) time against image size", fontsize=10)
        ticks = [r["sent"] for r in out["lines"]] if key == "lines" else [r["size"] for r in rows]
        ax.set_xticks(ticks)
        ax.xaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_ylabel("CPU ms (min of repeats)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(
        f"edgeaa accumulation renderer against AGG and Skia (pass {out['pass_cells']:,} cells)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        epilog="Tables are Markdown; --json prints one JSON object instead.",
    )
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per method (min kept)")
    parser.add_argument("--lines", default="1,2,4,8,16", help="line counts of set (b)")
    parser.add_argument("--sizes", default="128,256,512,1024,2048", help="image sizes of set (c)")
    parser.add_argument("--skip", default="", help="sets to leave out, e.g. 'b,c'")
    parser.add_argument(
        "--pass-cells",
        type=int,
        default=None,
        help="what-if: set edgeaa.model.accumulate.ROWS_PER_PASS_CELLS in this process "
        "(cells per accumulation pass; default: the renderer's own)",
    )
    parser.add_argument("--plot", metavar="PNG", help="also write a log-log figure of (b), (c)")
    parser.add_argument("--json", action="store_true", help="print JSON instead of tables")
    args = parser.parse_args()
    if args.pass_cells is not None:
        accumulate.ROWS_PER_PASS_CELLS = args.pass_cells
    lines = [int(v) for v in args.lines.split(",") if v]
    sizes = [int(v) for v in args.sizes.split(",") if v]
    skip = set(args.skip.split(",")) - {""}
    config = EdgeConfig()
    wide = config.with_(coord_bits=12)
    load = os.getloadavg()
    out: dict = {"machine": machine_info(), "config": str(config), "repeats": args.repeats}
    out["pass_cells"] = accumulate.ROWS_PER_PASS_CELLS

    def note(message):
        print(message, file=sys.stderr, flush=True)

    start = time.perf_counter()
    if "a" not in skip:
        out["builtins"] = []
        for name in ("text", "starburst"):
            note(f"(a) {name}")
            scene = builtin(name, config)
            out["builtins"].append(time_scene(scene, config, args.repeats, parts=True))
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
    if args.plot:
        plot(out, args.plot)
    if args.json:
        print(json.dumps(out, indent=1))
        return 0

    print(machine_line())
    print(f"config: {config}; repeats {args.repeats} (min kept); whole run {out['seconds']:.0f} s")
    what_if = " (set by --pass-cells)" if args.pass_cells is not None else ""
    print(f"accumulation pass: {accumulate.ROWS_PER_PASS_CELLS:,} cells{what_if}")
    print(f"load average at start {load[0]:.2f}, at end {out['load_average']['end'][0]:.2f}")
    if "builtins" in out:
        rows = out["builtins"]
        print("\n### (a) built-in scenes\n")
        print(timing_table(rows, "scene", lambda r: r["scene"]))
        print()
        print(stage_table(rows, "scene", lambda r: r["scene"]))
        print()
        print(parts_table(rows))
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
            if len(sizes) > 2:  # without the largest size too: where the slope bends
                for name, rows in out["sizes"].items():
                    series[f"{name}, without N = {sizes[-1]}"] = (sizes[:-1], rows[:-1])
            print(slope_table(series, "N (px)"))
            print("\n(against the pixel count N x N or N x N/8, each slope is half these)")
            for name, slopes in out["slope_size"].items():
                s = slopes["render"]
                verdict = "met" if s <= TARGET_SLOPE else "NOT met"
                print(f"target: {name} slope against N at most {TARGET_SLOPE}: {s:.2f} ({verdict})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
