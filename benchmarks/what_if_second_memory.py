"""What a second accumulation memory would give (issue 26), by the cycle model: not built.

The accumulator takes no beat while it scans a polygon's rows (`edgeaa.model.tile.TileClock`:
after an end in clock a, it is ready when the scan's last cell is sent). With two
accumulation memories used in turn, polygon n + 1 would accumulate into one while polygon
n's rows are scanned out of the other. This script models that by one change to the tile
stages' clocks (`SecondMemoryClock`): after an end, the accumulator is ready in a + 2 or when
the scan of the polygon before (whose memory the next polygon takes) has ended, whichever is
later. Everything else is the exact model's (`pipeline_cycles`): one scan at a time (a scan
starts once the resolve is quiet after the one before), tile and flush ops after the
resolve, the core's clocks. It is an optimistic estimate of such a design's clocks: the
second memory's own costs (which memory a beat or a scan reads, a clock to switch) are not
in it.

    python benchmarks/what_if_second_memory.py [--pipeline fast] [--scenes text,HUD]
        [--setup-units N]

Prints, per scene of `benchmarks/bench_pipeline.py`, the exact clocks and the clocks with
the second memory. --setup-units gives the pipeline that many setup units in both runs (16,
the most: each holds an edge 17 clocks and more, so about an edge a clock, the issue's
"setup of one edge every one or two clocks").
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from unittest import mock

from bench_pipeline import scenes  # this folder: the rate table's scenes

from edgeaa.model import pipeline_timing
from edgeaa.model.pipeline import PIPELINES, PipelineConfig
from edgeaa.model.tile import PolygonEnd, TileClock, TileConfig
from edgeaa.render import plan_scene
from edgeaa.render.pipeline import scene_commands


class SecondMemoryClock(TileClock):
    """`TileClock` with two accumulation memories used in turn: after a polygon's end the
    accumulator takes the next polygon's beats once the memory it writes (the one the
    polygon before this one used) has been scanned, not after this polygon's scan."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.scan_ends = [0, 0]  # the last two scans' ends: the other memory's is first

    def take(self, op, result, clock=None):
        taken = super().take(op, result, clock)
        if isinstance(op, PolygonEnd) and result.beats:
            other = self.scan_ends[-1]  # the memory the next polygon writes: scanned by then
            self.scan_ends = [other, self.ready]
            self.ready = max(taken + 2, other)
        return taken


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pipeline", default="fast", choices=list(PIPELINES))
    parser.add_argument("--scenes", default="", help="only the scenes whose name holds one")
    parser.add_argument("--setup-units", type=int, help="setup units (the pipeline's if not)")
    args = parser.parse_args()
    tile = TileConfig()
    pipeline = PipelineConfig.named(args.pipeline, tile)
    if args.setup_units is not None:
        try:
            pipeline = replace(pipeline, setup_units=args.setup_units)
        except ValueError as error:  # one line: what was wrong and what is allowed
            parser.error(str(error))
    wanted = [word for word in args.scenes.split(",") if word]
    name = f"{args.pipeline}, {pipeline.setup_units} setup units"
    print(f"| scene | {name}: clocks | with a second memory | fewer clocks |")
    print("|---|---:|---:|---:|")
    for scene in scenes(tile.config):
        if wanted and not any(word in scene.name for word in wanted):
            continue
        commands = scene_commands(plan_scene(scene, tile.config), tile)
        exact = pipeline_timing.pipeline_cycles(pipeline, commands).clocks
        with mock.patch.object(pipeline_timing, "TileClock", SecondMemoryClock):
            second = pipeline_timing.pipeline_cycles(pipeline, commands).clocks
        print(f"| {scene.name} | {exact:,} | {second:,} | {exact / second:.2f}x |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
