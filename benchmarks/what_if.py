"""What changes would give (issue 26), by the cycle model: a second accumulation memory
(not built), other scan lanes or more setup units (configurations the pipeline takes).

The second memory is one patch to the exact model (`pipeline_cycles`, equal to the Verilated
pipeline clock for clock), so its estimate is the exact model's everywhere else; its own
costs (a clock to switch memories, a longer critical path) are not in it, so the figures are
optimistic.

- --second-memory (`SecondMemoryClock`): two accumulation memories used in turn, so polygon
  n + 1 accumulates into one while polygon n's rows are scanned out of the other. After an
  end in clock a the accumulator is ready in a + 2 or when the scan of the polygon before
  (whose memory the next polygon takes) has ended, whichever is later. One scan at a time as
  now (a scan starts once the resolve is quiet after the one before), tile and flush ops
  after the resolve.
- --scan-lanes N: the pipeline with N scan lanes (`PipelineConfig.scan_lanes`, at most its
  pixel lanes; four: the accumulation memory in four banks by column modulo 4, every bank
  taking a cell a clock, `edgeaa.model.tile.beat_clocks`), exact.
- --setup-units N: the pipeline with N setup units, in both runs (up to 16, each holding an
  edge 17 clocks and more, so about an edge a clock, the issue's "setup of one edge every
  one or two clocks").

    python benchmarks/what_if.py [--pipeline fast] [--scenes text,HUD] [--setup-units N]
        [--second-memory] [--scan-lanes 4]

Prints, per scene of `benchmarks/bench_pipeline.py`, the exact clocks of the pipeline as
built (with --setup-units), the clocks with the changes asked for, their ratio and the
changed pipeline's pixels a clock.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from unittest import mock

from bench_pipeline import scenes  # this folder: the rate table's scenes

from edgeaa.model import pipeline_timing
from edgeaa.model.pipeline import PIPELINES, SCAN_LANES, PipelineConfig
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


def _changed_clocks(pipeline, commands, second_memory: bool) -> int:
    if not second_memory:
        return pipeline_timing.pipeline_cycles(pipeline, commands).clocks
    with mock.patch.object(pipeline_timing, "TileClock", SecondMemoryClock):
        return pipeline_timing.pipeline_cycles(pipeline, commands).clocks


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pipeline", default="fast", choices=list(PIPELINES))
    parser.add_argument("--scenes", default="", help="only the scenes whose name holds one")
    parser.add_argument("--setup-units", type=int, help="setup units (the pipeline's if not)")
    parser.add_argument("--second-memory", action="store_true", help="a second accumulation memory")
    parser.add_argument(
        "--scan-lanes", type=int, choices=SCAN_LANES, help="scan lanes (the pipeline's if not)"
    )
    args = parser.parse_args()
    if not args.second_memory and args.scan_lanes is None:
        parser.error("nothing to change: give --second-memory, --scan-lanes or both")
    tile = TileConfig()
    pipeline = PipelineConfig.named(args.pipeline, tile)
    try:  # PipelineConfig says what was wrong and what is allowed, in one line
        if args.setup_units is not None:
            pipeline = replace(pipeline, setup_units=args.setup_units)
        changed = pipeline
        if args.scan_lanes is not None:
            changed = replace(pipeline, scan_lanes=args.scan_lanes)
    except ValueError as error:
        parser.error(str(error))
    changes = ["a second memory"] * args.second_memory
    changes += [f"{args.scan_lanes} scan lanes"] * (args.scan_lanes is not None)
    wanted = [word for word in args.scenes.split(",") if word]
    name = f"{args.pipeline}, {pipeline.setup_units} setup units"
    print(f"| scene | {name}: clocks | with {' and '.join(changes)} | fewer clocks | px/clock |")
    print("|---|---:|---:|---:|---:|")
    for scene in scenes(tile.config):
        if wanted and not any(word in scene.name for word in wanted):
            continue
        commands = scene_commands(plan_scene(scene, tile.config), tile)
        exact = pipeline_timing.pipeline_cycles(pipeline, commands).clocks
        clocks = _changed_clocks(changed, commands, args.second_memory)
        rate = scene.width * scene.height / clocks
        print(
            f"| {scene.name} | {exact:,} | {clocks:,} | {exact / clocks:.2f}x | {rate:.3f} |",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
