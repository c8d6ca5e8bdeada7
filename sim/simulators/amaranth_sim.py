"""The core (`run`) and the polygon pipeline (`run_pipeline`) under Amaranth's Python
simulator, driven like the compiled harnesses.

Slow (about 10k clocks per second) but needs no compiler: for small scenes, benchmarks
against the compiled path, and for checking that both simulators agree. The source offers
the commands back to back and the sink is always ready, so beat clocks follow
`edgeaa.model.timing`. Returns the same `FastRun` record as
`edgeaa.sim.simulators.verilator_harness.run`.
"""

from __future__ import annotations

import random
import time

import numpy as np
from amaranth.sim import Simulator

from ...hdl import LineCore
from ...hdl.pipeline import STATS, EdgePipeline, command_layout
from ...model import Edge, EdgeConfig
from ...model.pipeline import Command
from ...model.tile import TileConfig
from ..verification.commands import edge_command
from .pipeline_harness import (
    PIXEL_COLUMNS,
    PipelineHang,
    PipelineRun,
    expected_pixels,
    pixel_drain_clocks,
    stuck_limit,
)
from .verilator_harness import FastRun, drain_clocks


def payload_leaf(payload, path: tuple[str, ...]) -> int:
    """A leaf of the sampled output payload (a `data.Const` of `write_layout` or
    `delta_layout`)."""
    for name in path:
        payload = payload[name]
    return int(payload)


def run(config: EdgeConfig, edges: list[Edge], *, progress=None, top=LineCore) -> FastRun:
    """Simulate the core `top` (`LineCore` or `PolygonCore`) on `edges`; `progress(done,
    total)` is called as commands go in."""
    dut = top(config)
    paths = top.format.paths
    commands = [edge_command(config, edge) for edge in edges]
    drain = drain_clocks(config, top.format)  # clocks with no beat before the run may end
    rows: list[list[int]] = []
    clocks = errors = 0

    async def bench(ctx):
        nonlocal clocks, errors
        ctx.set(dut.out.ready, 1)
        index, quiet = 0, 0
        while index < len(commands) or quiet < drain:
            offering = index < len(commands)
            ctx.set(dut.edges.valid, offering)
            if offering:  # the clip window is sampled with the edge: present both
                ctx.set(dut.edges.payload, commands[index].payload)
                ctx.set(dut.clip, commands[index].clip)
            _, _, taken, valid, beat = await ctx.tick().sample(  # clk, rst first
                dut.edges.ready, dut.out.valid, dut.out.payload
            )
            if offering and taken:
                index += 1
                if progress is not None:
                    progress(index, len(commands))
            if valid:
                rows.append([clocks, *(payload_leaf(beat, path) for path in paths)])
            quiet = 0 if (valid or index < len(commands)) else quiet + 1
            clocks += 1
        ctx.set(dut.edges.valid, 0)
        errors = ctx.get(dut.errors)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    start = time.perf_counter()
    sim.run()
    seconds = time.perf_counter() - start
    beats = np.array(rows, dtype=np.int64).reshape(-1, len(paths) + 1)
    return FastRun(beats, clocks, errors, seconds, top.format)


def run_pipeline(
    tile: TileConfig,
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
    pixels and a drain, or raises `PipelineHang`. `progress(done, total)` as commands go in."""
    dut = EdgePipeline(tile)
    layout = command_layout(tile)
    payloads = [layout.const(c._asdict()) for c in commands]
    rng = random.Random(seed) if seed is not None else None
    expected, drain = expected_pixels(tile, commands), pixel_drain_clocks(tile)
    limit = stuck_limit(tile, idle, stall)
    rows: list[tuple[int, ...]] = []
    counters: dict = {}
    clocks = 0

    async def bench(ctx):
        nonlocal clocks
        index = quiet = stuck = 0
        while index < len(payloads) or len(rows) < expected or quiet < drain:
            if stuck >= limit:
                raise PipelineHang(f"{len(rows)} of {expected} pixels in {clocks:,} clocks")
            offer = index < len(payloads) and (rng is None or rng.random() >= idle)
            ctx.set(dut.commands.valid, offer)
            if offer:
                ctx.set(dut.commands.payload, payloads[index])
            ready = rng is None or rng.random() >= stall
            ctx.set(dut.pixels.ready, ready)
            *_, taken, valid, pixel = await ctx.tick().sample(
                dut.commands.ready, dut.pixels.valid, dut.pixels.payload
            )
            accepted, out = bool(offer and taken), bool(valid and ready)
            index += accepted
            if accepted and progress is not None:
                progress(index, len(payloads))
            if out:
                rows.append((clocks, int(pixel.x), int(pixel.y), int(pixel.value), int(pixel.last)))
            clocks += 1
            quiet = 0 if (out or len(rows) < expected or index < len(payloads)) else quiet + 1
            stuck = 0 if (out or accepted) else stuck + 1
        counters["errors"], counters["edge_errors"] = ctx.get(dut.errors), ctx.get(dut.edge_errors)
        counters["stats"] = {name: ctx.get(dut.stats[name]) for name in STATS}

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    start = time.perf_counter()
    sim.run()
    seconds = time.perf_counter() - start
    pixels = np.array(rows, dtype=np.int64).reshape(-1, len(PIXEL_COLUMNS))
    return PipelineRun(
        pixels, clocks, counters["errors"], counters["edge_errors"], counters["stats"], seconds,
        engine="amaranth",
    )  # fmt: skip
