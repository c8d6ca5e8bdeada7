"""The core under Amaranth's Python simulator, driven like the compiled harness.

Slow (about 10k clocks per second) but needs no compiler: for small scenes, benchmarks
against the compiled path, and for checking that both simulators agree. The source offers
the commands back to back and the sink is always ready, so beat clocks follow
`edgeaa.model.timing`. Returns the same `FastRun` record as
`edgeaa.sim.simulators.verilator_harness.run`.
"""

from __future__ import annotations

import time

import numpy as np
from amaranth.sim import Simulator

from ...hdl import EdgeAntialiaser
from ...model import Edge, EdgeConfig
from ...model.beat import BEAT_FORMATS
from ..verification.commands import edge_command
from .verilator_harness import FastRun, drain_clocks


def payload_leaf(payload, path: tuple[str, ...]) -> int:
    """A leaf of the sampled output payload (a `data.Const` of `write_layout` or
    `delta_layout`)."""
    for name in path:
        payload = payload[name]
    return int(payload)


def run(config: EdgeConfig, edges: list[Edge], *, progress=None, output: str = "writes") -> FastRun:
    """Simulate the core (with `output`: ``"writes"`` or ``"deltas"``) on `edges`;
    `progress(done, total)` is called as commands go in."""
    dut = EdgeAntialiaser(config, output=output)
    paths = BEAT_FORMATS[output].paths
    commands = [edge_command(config, edge) for edge in edges]
    drain = drain_clocks(config, output)  # clocks with no beat before the run may end
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
    return FastRun(beats, clocks, errors, seconds, output)
