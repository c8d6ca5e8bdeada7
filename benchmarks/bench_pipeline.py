"""The polygon pipeline in hardware: clocks per scene, where they go, and simulation speed.

For each built-in scene (default configuration, tile 64 x 32 unless --tile) the scene's
pipeline commands (`edgeaa.render.pipeline.scene_commands`) run through the Verilated
`EdgePipeline` (`edgeaa.sim.simulators.pipeline_harness`, build excluded, sink always ready)
and the image is compared with the model's. Printed per scene: commands, the pipeline's
clocks, the whole pipeline's cycle model's (`edgeaa.model.pipeline_timing`, plus the
harness's drain: equal, or the model is wrong), the stepper alone's clocks on the same edges
(`edgeaa.model.timing`, the edges the renderer sends once, without tiling), each stage's
busy and stall counters as shares of the clocks, pixels out, and simulated clocks per second
of wall time, beside the stepper-only harness's rate on the scene's edges in the same process
(the ratio is the steadier figure on a shared machine).

    python benchmarks/bench_pipeline.py [--tile 64x32] [--repeats 3] [--json]
"""

from __future__ import annotations

import argparse
import json
import re
import sys

import numpy as np

from edgeaa.hdl.core import PolygonCore
from edgeaa.hdl.pipeline import STATS
from edgeaa.model import EdgeConfig
from edgeaa.model.pipeline_timing import pipeline_cycles
from edgeaa.model.tile import TileConfig
from edgeaa.render import builtin, plan_scene, render_scene
from edgeaa.render.builtin import BUILTINS
from edgeaa.render.pipeline import image_from_frames, scene_commands
from edgeaa.sim.simulators import pipeline_harness, verilator_harness


def measure(name: str, tile: TileConfig, repeats: int) -> dict:
    config = tile.config
    plan = plan_scene(builtin(name, config), config)
    model = render_scene(plan)
    commands = scene_commands(plan, tile)
    pipeline_harness.build(tile)
    runs = [pipeline_harness.run(tile, commands) for _ in range(repeats)]
    run = min(runs, key=lambda r: r.seconds)
    image = image_from_frames(plan, tile, run.frames(tile))
    drain = pipeline_harness.pixel_drain_clocks(tile)
    model_clocks = pipeline_cycles(tile, commands).clocks + drain
    edges = [plan.edge(int(e), clip=True) for e in model.sent]
    verilator_harness.build(config, top=PolygonCore)
    core = min(
        (verilator_harness.run(config, edges, top=PolygonCore) for _ in range(repeats)),
        key=lambda r: r.seconds,
    )
    return {
        "scene": name,
        "commands": len(commands),
        "clocks": run.clocks,
        "model_clocks": model_clocks,
        "stepper_cycles": model.cycles,
        "pixels": len(run.pixels),
        "image_equal": bool(np.array_equal(image, model.image)),
        "stats": dict(run.stats),
        "mclocks_per_s": run.clocks_per_second / 1e6,
        "core_mclocks_per_s": core.clocks_per_second / 1e6,
    }


def table(rows: list[dict], tile: TileConfig) -> str:
    head = ["scene", "commands", "pipeline clocks", "cycle model", "stepper alone", "pixels"]
    head += ["same image"]
    head += [f"{name} %" for name in STATS] + ["M clocks/s", "vs stepper harness"]
    lines = [
        f"tile {tile.width} x {tile.height}, {tile.config}",
        "",
        "| " + " | ".join(head) + " |",
        "|" + "---|" * len(head),
    ]
    for r in rows:
        shares = [f"{100 * r['stats'][name] / r['clocks']:.1f}" for name in STATS]
        model = "exact" if r["model_clocks"] == r["clocks"] else f"{r['model_clocks']:,} (WRONG)"
        cells = [r["scene"], f"{r['commands']:,}", f"{r['clocks']:,}", model]
        cells += [
            f"{r['stepper_cycles']:,}",
            f"{r['pixels']:,}",
            "yes" if r["image_equal"] else "NO",
            *shares,
        ]
        ratio = r["mclocks_per_s"] / r["core_mclocks_per_s"]
        cells += [f"{r['mclocks_per_s']:.2f}", f"{ratio:.2f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tile", default="64x32", help="tile WIDTHxHEIGHT")
    parser.add_argument("--repeats", type=int, default=3, help="runs per scene (fastest kept)")
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    args = parser.parse_args()
    match = re.fullmatch(r"(\d+)x(\d+)", args.tile)
    if not match:
        parser.error(f"--tile: expected WIDTHxHEIGHT, not {args.tile!r}")
    tile = TileConfig(EdgeConfig(), int(match[1]), int(match[2]))
    rows = []
    for name in BUILTINS:
        print(f"{name} ...", file=sys.stderr, flush=True)
        rows.append(measure(name, tile, args.repeats))
    print(json.dumps(rows, indent=1) if args.json else table(rows, tile))
    exact = all(r["model_clocks"] == r["clocks"] for r in rows)
    return 0 if exact and all(r["image_equal"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
