"""The core (`run`, `run_core`) and the polygon pipeline (`run_pipeline`) under Amaranth's
Python simulator, each a configuration of the one driver (`amaranth_runner.run_component`).

Slow (about 10k clocks per second) but needs no compiler: for small scenes, benchmarks
against the compiled path, and for checking that both simulators agree. Without a seed the
source offers the commands back to back and the sink is always ready, so beat clocks follow
`edgeaa.model.timing`. `run` returns the same `FastRun` record as
`edgeaa.sim.simulators.verilator_harness.run`, `run_pipeline` the `PipelineRun` of
`edgeaa.sim.simulators.pipeline_harness.run`.
"""

from __future__ import annotations

import random
from functools import partial

import numpy as np

from ...hdl import LineCore
from ...hdl.pipeline import STATS, EdgePipeline, command_const
from ...model import Clip, Edge, EdgeConfig
from ...model.beat import edge_columns
from ...model.pipeline import Command, PipelineConfig
from ...model.tile import TileConfig
from .amaranth_runner import Probe, SimulationHang, Sink, Source, Trace, row_decoder, run_component
from .commands import edge_command
from .pipeline_harness import (
    PipelineHang,
    PipelineRun,
    beat_columns,
    expected_pixels,
    pixel_drain_clocks,
    pixel_rows,
    stuck_limit,
)
from .verilator_harness import FastRun, drain_clocks


def random_clip_port(config: EdgeConfig, rng: random.Random) -> dict[str, int]:
    """Any value of the ``clip`` port (four bounds in [0, 2**W], possibly empty)."""
    top = 1 << config.coord_bits
    return {name: rng.randint(0, top) for name in Clip._fields}


def run_core(
    dut,
    config: EdgeConfig,
    edges: list[Edge],
    sink: str,
    *,
    decode,
    drain: int,
    seed: int | None = None,
    idle: float = 0.0,
    stall: float = 0.0,
    probes: tuple[Probe, ...] = (),
    final: tuple = (),
    progress=None,
    tag: str = "",
) -> Trace:
    """The core `dut` on `edges`: each command offered on ``edges`` with its window on
    ``clip`` (with a seed, any window in the other clocks: the core samples it with the edge
    only), the beats of its output stream `sink` decoded by `decode`; a run stops `drain`
    quiet clocks after the last expected beat (one per column) and is a hang after four
    times that with nothing moving (stretched by the idles and stalls)."""
    commands = [edge_command(config, edge) for edge in edges]
    source = Source(
        "edges",
        [command.payload for command in commands],
        side="clip",
        sides=[command.clip for command in commands],
        filler=partial(random_clip_port, config),
    )
    expected = int(edge_columns(config, edges).sum())
    return run_component(
        dut, [source], [Sink(sink, expected, decode)],
        drain=drain, stuck=int(4 * drain / ((1 - idle) * (1 - stall))),
        probes=probes, final=final, seed=seed, idle=idle, stall=stall, progress=progress, tag=tag,
    )  # fmt: skip


def run(config: EdgeConfig, edges: list[Edge], *, progress=None, top=LineCore) -> FastRun:
    """Simulate the core `top` (`LineCore` or `PolygonCore`) on `edges`;
    `progress(done, total)` is called as commands go in."""
    dut = top(config)
    beats = top.format
    stream = getattr(dut, beats.stream)
    decode = row_decoder(stream.payload.shape(), [".".join(path) for path in beats.paths])
    trace = run_core(
        dut, config, edges, beats.stream, decode=decode, drain=drain_clocks(config, beats),
        final=(dut.errors,), progress=progress,
    )  # fmt: skip
    rows = [(clock, *row) for clock, row in trace.beats[0]]
    array = np.array(rows, dtype=np.int64).reshape(-1, len(beats.paths) + 1)
    return FastRun(array, trace.clocks, trace.final[0], trace.seconds, beats)


def run_pipeline(
    pipeline: PipelineConfig | TileConfig,
    commands: list[Command],
    *,
    seed: int | None = None,
    idle: float = 0.0,
    stall: float = 0.0,
    progress=None,
) -> PipelineRun:
    """The polygon pipeline (`EdgePipeline`) on `commands`, as the compiled harness
    (`edgeaa.sim.simulators.pipeline_harness.run`) drives it: seeded random idle clocks on
    the source and back-pressure on the sink when `seed` is given; stops after the expected
    pixels and a drain, or raises `PipelineHang`. `progress(done, total)` as commands go in.
    `pipeline`: a `PipelineConfig`, or a `TileConfig` (the compact pipeline)."""
    dut = EdgePipeline(pipeline)
    tile = dut.tile
    source = Source("commands", [command_const(tile, c) for c in commands])
    lanes = dut.pipeline.pixel_lanes
    pixels = row_decoder(dut.pixels.payload.shape(), beat_columns(lanes))
    sink = Sink("pixels", expected_pixels(tile, commands) // lanes, pixels)
    counters = (dut.errors, dut.edge_errors, *(dut.stats[name] for name in STATS))
    tag = f"[pipeline seed={seed} idle={idle} stall={stall} {dut.pipeline}]"
    try:
        trace = run_component(
            dut, [source], [sink], drain=pixel_drain_clocks(tile),
            stuck=stuck_limit(tile, idle, stall), final=counters, seed=seed, idle=idle,
            stall=stall, progress=progress, tag=tag,
        )  # fmt: skip
    except SimulationHang as error:
        raise PipelineHang(str(error)) from None
    rows = [(clock, *pixel) for clock, pixel in trace.beats[0]]
    errors, edge_errors, *stats = trace.final
    return PipelineRun(
        pixel_rows(rows, lanes), trace.clocks, errors, edge_errors,
        dict(zip(STATS, stats, strict=True)), trace.seconds, engine="amaranth",
    )  # fmt: skip
