# amaranth: UnusedElaboratable=no
"""The core (line writes or accumulation deltas) compiled by Verilator with the generated
harness (`edgeaa.sim.simulators.harness`): edge commands in, every beat out with its clock.

A command row is `edgeaa.sim.simulators.commands.COMMAND_FIELDS` (the ``edges`` payload, then
the ``clip`` window presented while the edge is offered); a beat row is
`edgeaa.model.beat.RUN_COLUMNS` for the line core (`LineCore`), `DELTA_RUN_COLUMNS` for the
polygon core (`PolygonCore`): the clock, then the payload leaves, x, y and delta
sign-extended. A run ends `drain_clocks` quiet clocks after the last command is taken; a core
that takes no command and sends no beat for `stuck_limit` clocks while commands are left
raises `HarnessHang`.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...hdl import LineCore, core_verilog
from ...model import Edge, EdgeConfig
from ...model.beat import WRITES, BeatFormat
from ...model.timing import setup_latency, start_clip_cycles
from . import harness
from .commands import COMMAND_FIELDS, COMMAND_FORMAT, edge_command

TOP = "edgeaa_core"


@functools.cache
def core_top(config: EdgeConfig, top=LineCore) -> harness.HarnessTop:
    """The core `top` (`LineCore` or `PolygonCore`) as the harness drives it:
    `COMMAND_FORMAT` in, its beat format out."""
    return harness.harness_top(top(config), TOP, COMMAND_FORMAT, top.format)


@dataclass(frozen=True)
class FastRun:
    beats: np.ndarray  # int64 rows, see the module docstring
    clocks: int  # clocks simulated, including the drain
    errors: int  # the core's bad-command counter at the end
    seconds: float  # harness wall time (simulation only, build excluded)
    fmt: BeatFormat = WRITES  # the core's output: the beats' format

    @property
    def clocks_per_second(self) -> float:
        return self.clocks / self.seconds if self.seconds else 0.0

    def as_beats(self) -> list:
        """The rows as `Beat` (or `DeltaBeat` for the polygon core) values."""
        return self.fmt.from_array(self.beats)


def build(config: EdgeConfig, *, optimize: str = harness.OPTIMIZE, top=LineCore) -> Path:
    """Compile the core `top` + harness once per (Verilog, harness, flags); returns the
    executable."""
    return harness.build(
        ("core", config, top, optimize),
        core_top(config, top),
        lambda: core_verilog(top(config), name=TOP),
        optimize,
    )


def edge_commands(config: EdgeConfig, edges: list[Edge]) -> np.ndarray:
    """The command file: one int32 row per edge, `COMMAND_FIELDS` (payload, then clip)."""
    rows = np.empty((len(edges), len(COMMAND_FIELDS)), dtype=np.int32)
    for i, edge in enumerate(edges):
        rows[i] = edge_command(config, edge).row()
    return rows


def drain_clocks(config: EdgeConfig, fmt: BeatFormat = WRITES) -> int:
    """Clocks with no beat, after the last command is accepted, before a run may end: more
    than the longest wait for the first beat of an edge (one clipped at its start) of the
    core whose output is `fmt`."""
    return setup_latency(config, fmt) + start_clip_cycles(config, fmt) + 16


def stuck_limit(config: EdgeConfig, fmt: BeatFormat = WRITES, idle=0.0, stall=0.0) -> int:
    """Clocks with no edge taken and no beat out after which a run is a hang: four times the
    longest such wait of a working core (`drain_clocks`: a start-clipped edge's setup),
    stretched by the random idle and stall clocks."""
    return int(4 * (drain_clocks(config, fmt) + 256) / ((1 - idle) * (1 - stall)))


def run(
    config: EdgeConfig,
    edges: list[Edge],
    *,
    seed: int = 0,
    idle: float = 0.0,
    stall: float = 0.0,
    exe: Path | None = None,
    top=LineCore,
) -> FastRun:
    """Simulate the core `top` (`LineCore` or `PolygonCore`) on `edges`; `idle`/`stall` are
    probabilities per clock. `exe` is the harness `build(config, top=top)` made, if the
    caller has it already (a worker with a shipped build)."""
    harness.check_probabilities(idle, stall)
    fmt = top.format
    done = harness.run_harness(
        exe or build(config, top=top),
        core_top(config, top),
        edge_commands(config, edges),
        seed=seed,
        idle=idle,
        stall=stall,
        drain=drain_clocks(config, fmt),
        max_quiet=stuck_limit(config, fmt, idle, stall),
    )
    return FastRun(done.rows, done.clocks, done.counters["errors"], done.seconds, fmt)
