"""Cycle model of the whole polygon pipeline (`edgeaa.hdl.pipeline.EdgePipeline`): the clock
each command is taken, each delta beat enters the accumulator and each pixel leaves, for
commands offered back to back (always valid) and an always-ready pixel sink; and the top's
stage counters (`edgeaa.hdl.pipeline.STATS`).

It composes the stages' own cycle models, command by command (`decode_commands`):

* the command stage (OUT/IN): a begin, a bad command or an unknown code is taken the clock it
  is offered; a tile or a flush when the accumulator is ready; an edge when the core's setup
  accepts it; an end (or the end a begin, tile or flush makes of a polygon with no end, one
  clock before it is taken in OUT) when the core is idle and the accumulator ready;
* the core (`edgeaa.model.timing.schedule`, with the pipeline's setup units), one run per
  polygon: the core is idle when a
  polygon begins (its end waited for that), so each polygon starts it afresh, its edges
  offered as the commands come (an unknown code between two edges delays the next one a
  clock);
* the accumulator and the resolve (`edgeaa.model.tile.TileClock`), op by op at the clocks
  they are offered.

The stall. The accumulator is not ready while it scans the previous polygon's rows or holds
a tile or flush op the resolve has not taken: from the polygon's begin it is ready from
`TileClock.ready` (T) on, and then takes the polygon's beats until its end (the only other
op, sent when the core is idle), each over `beat_clocks` clocks (a nonzero cell a clock, or
with two scan lanes a pair of cells with a nonzero one, with four a cell a bank,
`TileModel.beat_clocks`). So
the core sees a sink first ready in clock T that holds each beat that long:
`schedule(..., sink_ready=T, holds=...)`. The stepper's one enable freezes the loop and its
pipeline while a beat waits (`edgeaa.model.timing.beat_wait`), while the setup runs on until
its bank waits and the stepper loads a bank in a freeze only while its loop is idle. With
`PipelineConfig.beat_skid` a skid buffer sits between the core and the accumulator
(`schedule(..., skid=True)`, `edgeaa.model.timing.SinkClock`): a beat waits in the stepper
only while the buffer holds the beat before it, the beats' clocks are the accumulator's
takes, and the core is idle once the accumulator took its last beat.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .edge import EdgeError, setup
from .pipeline import Decoded, PipelineConfig, decode_commands, pipeline_config
from .tile import PolygonEnd, TileClock, TileConfig, TileModel, TileTiming
from .timing import schedule

__all__ = ["PipelineTiming", "pipeline_cycles"]

OTHER = "other"  # an unknown code inside a polygon: taken the clock it is offered


@dataclass
class PipelineTiming:
    """The transfers of a run: ``commands`` (the clock each command was taken), ``beats``
    (delta beats into the accumulator), ``tile`` (the accumulator's and the resolve's, pixels
    included) and the top's counters (``stats``, by `STATS` name) at the end."""

    commands: list[int] = field(default_factory=list)
    beats: list[int] = field(default_factory=list)
    tile: TileTiming = field(default_factory=TileTiming)
    stats: dict = field(default_factory=dict)

    @property
    def pixels(self) -> list[int]:
        return self.tile.pixels

    @property
    def clocks(self) -> int:
        """Clock 0 to the last transfer, inclusive."""
        return max([-1, *self.commands, *self.beats, self.tile.clocks - 1]) + 1


class _Top:
    """The walk of `pipeline_cycles`: the command stage's state and the stages' clocks."""

    def __init__(self, pipeline: PipelineConfig, count: int):
        self.tile = tile = pipeline.tile
        self.units = pipeline.setup_units
        self.deltas = pipeline.deltas  # the core's output: its depth
        self.skid = pipeline.beat_skid  # a skid buffer between the core and the accumulator
        self.model = TileModel(tile, pipeline.scan_lanes)
        self.clock = TileClock(tile, pipeline.pixel_lanes, pipeline.product_stages)
        self.taken = [0] * count
        self.offer = 0  # clock the next command is offered
        self.polygon: list | None = None  # the open polygon's (index, shape or OTHER)
        self.first = 0  # clock the open polygon's first command was offered
        self.busy = self.stall = 0  # the core's counters
        self.beats: list[int] = []

    def command(self, k: int, d: Decoded) -> None:
        """Take command `k` (the OUT and IN states of the command stage)."""
        if d.ended is not None:  # in IN: the end goes first, then the command in OUT
            self.offer = self.end(d.ended) + 1
        if self.polygon is not None and not isinstance(d.op, PolygonEnd):  # an edge or unknown
            if d.op is not None:
                self.model.feed(d.op)
            self.polygon.append((k, self.shape(d), d.op))
            return
        if isinstance(d.op, PolygonEnd):
            self.taken[k] = self.end(d.op)
        elif d.op is not None:  # a tile or a flush
            self.taken[k] = self.clock.take(d.op, self.model.feed(d.op), self.offer)
        else:  # a begin, or a bad command outside a polygon
            self.taken[k] = self.offer
            if d.error is None:
                self.polygon, self.first = [], self.offer + 1
        self.offer = self.taken[k] + 1

    def shape(self, d: Decoded):
        """An edge's (columns, clipped_start) (None: a bad command), or OTHER."""
        if d.edge is None:
            return OTHER
        try:
            st = setup(self.tile.config, d.edge)
        except EdgeError:
            return None
        return st.columns, st.clipped_start

    def end(self, end: PolygonEnd) -> int:
        """Close the open polygon (`core`); returns the clock its end is taken."""
        idle = self.core()
        return self.clock.take(end, self.model.feed(end), max(self.offer, idle))

    def core(self) -> int:
        """Run the open polygon's edges through the core (`schedule`, the sink first ready
        when the accumulator is): set their clocks and the next offer, count the core's busy
        and stalled clocks; returns the first clock the core is idle after them."""
        items, self.polygon = self.polygon or [], None
        shapes, idle, holds, extra = [], [], [], 0
        for _, shape, op in items:
            if shape is OTHER:
                extra += 1
            else:
                shapes.append(shape)
                idle.append(extra + (0 if idle else self.first))
                holds.append(self.model.beat_clocks(op.cells) if shape else ())
                extra = 0
        config = self.tile.config
        timings = iter(
            schedule(
                config,
                shapes,
                fmt=self.deltas,
                setup_units=self.units,
                idle=idle,
                sink_ready=self.clock.ready,
                holds=holds,
                skid=self.skid,
            )
        )
        last, free, stalled = self.first - 1, 0, 0
        edge_holds = iter(holds)
        for k, shape, _ in items:
            if shape is OTHER:
                last = self.taken[k] = last + 1
                continue
            t, hold = next(timings), next(edge_holds)
            last = self.taken[k] = t.accepted
            if t.beats:
                stop = t.beats[-1] + 1
                self.clock.beats(t.beats, hold)
                self.beats.extend(t.beats)
                stalled += t.waits
            else:  # dropped: the core is idle once its unit is free
                stop = t.released
            self.busy += max(0, stop - max(t.accepted + 1, free))  # the union of busy spans
            free = max(free, stop)
        self.stall += stalled
        self.offer = last + 1
        return free

    def result(self) -> PipelineTiming:
        if self.polygon is not None:  # a polygon the stream left open: its beats go in
            self.core()
        tile, clock = self.clock.timing, self.clock
        stats = {
            "core_busy": self.busy,
            "core_stall": self.stall,
            "acc_busy": len(tile.accepts) + clock.holding + clock.scanning,
            "acc_stall": clock.acc_stall,
            "resolve_busy": clock.resolve_ops
            + len(tile.pixels) // clock.lanes
            + clock.swept
            - clock.overlap,
            "resolve_stall": 0,
        }
        return PipelineTiming(self.taken, self.beats, tile, stats)


def pipeline_cycles(pipeline: PipelineConfig | TileConfig, commands) -> PipelineTiming:
    """The pipeline's clocks (a `PipelineConfig`, or a `TileConfig`: the compact one) for
    `commands` (`edgeaa.model.pipeline.Command`) offered back to back from clock 0, the pixel
    sink always ready (see the module docstring)."""
    pipeline = pipeline_config(pipeline)
    top = _Top(pipeline, len(commands))
    for k, decoded in enumerate(decode_commands(pipeline.tile, commands)):
        top.command(k, decoded)
    return top.result()
