"""cocotb testbench: the emitted Verilog core against the model, with random stalls.

Run through `edgeaa.sim.simulators.verilator.cosimulate`, which
writes a job file (configuration, edges,
seed, idle and stall probabilities, and the model's expected beats computed in the calling
process) and points ``EDGEAA_COSIM_JOB`` at it. Every clock, on the falling edge, the bench
drives the source (random idle cycles; each edge's window on ``clip`` while the edge is
offered) and the sink (random back-pressure); after the design settles it samples both
handshakes. Every beat is checked against the scoreboard as it arrives, stalled beats must
hold their payload, and after the last expected beat the sink must stay empty. The outcome
goes to ``EDGEAA_COSIM_RESULT``.

The job's ``stream`` names the core's output stream (`edgeaa.model.beat.format_of`):
``writes`` (the line core's two-lane beats of `run_edge`) or ``deltas`` (the polygon core's
four-cell beats of `run_edge_deltas`); the ports, the payload's decoding and the beats follow
from its format.
"""

from __future__ import annotations

import json
import os
import random
import time

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, ReadOnly

from ...model import Clip, Edge, EdgeConfig
from ...model.beat import BeatFormat, format_of, port_name
from ..verification.commands import edge_command
from ..verification.scoreboard import Scoreboard

DRAIN_CLOCKS = 64  # clocks the sink must stay empty after the last expected beat


def _job_edge(fields: dict) -> Edge:
    """An edge of the job file (JSON turned its clip tuple into a list)."""
    clip = fields.get("clip")
    return Edge(**{**fields, "clip": None if clip is None else Clip(*clip)})


def _drive_command(dut, command) -> None:
    """Present one command: its ``edges`` payload and its ``clip`` window (sampled with it)."""
    for name, value in command.payload.items():
        getattr(dut, f"edges__payload__{name}").value = value
    for name, value in command.clip.items():
        getattr(dut, f"clip__{name}").value = value


def _read_beat(dut, fmt: BeatFormat, config: EdgeConfig):
    """The output payload as a beat of `fmt` (signed leaves by their width-table register)."""
    widths = config.register_widths()

    def leaf(path: tuple[str, ...]) -> int:
        value = getattr(dut, port_name(path, fmt.stream)).value
        register = fmt.registers[path[-1]]
        signed = register is not None and widths[register].signed
        return value.to_signed() if signed else int(value)

    return fmt.from_fields(leaf)


@cocotb.test()
async def edges_match_model(dut):
    with open(os.environ["EDGEAA_COSIM_JOB"]) as file:
        job = json.load(file)
    config = EdgeConfig(**job["config"])
    fmt = format_of(job["stream"])
    out_valid, out_ready = (getattr(dut, f"{fmt.stream}__{name}") for name in ("valid", "ready"))
    edges = [_job_edge(fields) for fields in job["edges"]]
    rng = random.Random(job["seed"])
    idle, stall = job["idle"], job["stall"]
    label = f"cosim {fmt.stream} seed={job['seed']} idle={idle} stall={stall}"
    expected = fmt.from_array(np.load(job["expected_beats"]))
    dropped = job["dropped"]
    board = Scoreboard(expected, label)
    commands = [edge_command(config, edge) for edge in edges]

    result = {"beats": 0, "clocks": 0, "expected_beats": len(expected), "error": None}
    start = time.perf_counter()
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    dut.rst.value = 1
    dut.edges__valid.value = 0
    out_ready.value = 0
    await ClockCycles(dut.clk, 2)
    dut.rst.value = 0

    index = 0  # next command to offer
    offering = False
    held = None  # a beat seen valid but not taken: it must come back unchanged
    clock = 0
    idle_after_done = 0
    limit = 1000 + 4 * (len(expected) + len(edges) * 200) / max(1e-9, (1 - stall) * (1 - idle))
    try:
        while idle_after_done < DRAIN_CLOCKS:
            await FallingEdge(dut.clk)
            clock += 1
            if clock > limit:
                raise AssertionError(f"{label}: timed out after {clock} clocks, {board.seen} beats")
            if not offering and index < len(commands) and rng.random() >= idle:
                _drive_command(dut, commands[index])
                offering = True
            dut.edges__valid.value = int(offering)
            ready = int(rng.random() >= stall)
            out_ready.value = ready
            await ReadOnly()
            if offering and int(dut.edges__ready.value):
                offering = False
                index += 1
            if int(out_valid.value):
                beat = _read_beat(dut, fmt, config)
                if held is not None and beat != held:
                    raise AssertionError(
                        f"{label} clock {clock}: stalled beat {held} became {beat}"
                    )
                if ready:
                    board.check(beat, f"clock {clock}")
                    held = None
                else:
                    held = beat
            elif held is not None:
                raise AssertionError(f"{label} clock {clock}: stalled beat {held} was withdrawn")
            if board.done and index == len(commands):
                idle_after_done += 1
        board.finish()
        if held is not None:  # a beat offered after the last expected one, never taken
            raise AssertionError(f"{label}: unexpected extra beat {held} after the last one")
        errors = int(dut.errors.value)
        if errors != dropped:
            raise AssertionError(
                f"{label}: errors counter is {errors}, {dropped} bad commands sent"
            )
    except Exception as failure:  # the pytest side reports whatever stopped the bench
        result["error"] = f"{type(failure).__name__}: {failure}"
        raise
    finally:
        result.update(
            beats=board.seen, clocks=clock, seconds=time.perf_counter() - start, dropped=dropped
        )
        with open(os.environ["EDGEAA_COSIM_RESULT"], "w") as file:
            json.dump(result, file)
