"""cocotb testbench: the emitted Verilog polygon pipeline against the model, with random stalls.

Run through `edgeaa.sim.simulators.pipeline_cosim.cosimulate_pipeline`, which writes a job
file (tile, commands, seed, idle and stall probabilities, and the model's frames computed in
the calling process) and points ``EDGEAA_COSIM_JOB`` at it. Every clock, on the falling edge,
the bench drives the command source (random idle clocks) and the pixel sink (random
back-pressure); after the design settles it samples both handshakes. Every pixel is checked
as it arrives against the model's frame (value, position, ``last`` on a tile's final pixel),
a stalled pixel must hold its payload, the counters must equal the model's at the end, and
after the last expected pixel the sink must stay empty. The outcome goes to
``EDGEAA_COSIM_RESULT``.
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

from ...model.pipeline import Command

DRAIN_CLOCKS = 256  # clocks the sink must stay empty after the last expected pixel


def _pixel(dut) -> tuple[int, int, int, int]:
    return tuple(
        int(getattr(dut, f"pixels__payload__{name}").value) for name in ("x", "y", "value", "last")
    )


def _expected(frames: np.ndarray, k: int) -> tuple[int, int, int, int]:
    """Pixel k of the run: frame k // (w h), row by row."""
    _, height, width = frames.shape
    frame, rest = divmod(k, width * height)
    y, x = divmod(rest, width)
    return x, y, int(frames[frame, y, x]), int(rest == width * height - 1)


@cocotb.test()
async def pixels_match_model(dut):
    with open(os.environ["EDGEAA_COSIM_JOB"]) as file:
        job = json.load(file)
    commands = [Command(*row) for row in job["commands"]]
    frames = np.load(job["frames"])
    rng = random.Random(job["seed"])
    idle, stall = job["idle"], job["stall"]
    label = f"pipeline cosim seed={job['seed']} idle={idle} stall={stall}"
    result = {"pixels": 0, "clocks": 0, "expected_pixels": int(frames.size), "error": None}
    start = time.perf_counter()
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    dut.rst.value = 1
    dut.commands__valid.value = 0
    dut.pixels__ready.value = 0
    await ClockCycles(dut.clk, 2)
    dut.rst.value = 0
    index, offering, held, clock, seen, quiet = 0, False, None, 0, 0, 0
    try:
        while quiet < DRAIN_CLOCKS:
            await FallingEdge(dut.clk)
            clock += 1
            if clock > job["max_clocks"]:
                raise AssertionError(f"{label}: timed out after {clock} clocks, {seen} pixels")
            if not offering and index < len(commands) and rng.random() >= idle:
                for name, value in commands[index]._asdict().items():
                    getattr(dut, f"commands__payload__{name}").value = value
                offering = True
            dut.commands__valid.value = int(offering)
            ready = int(rng.random() >= stall)
            dut.pixels__ready.value = ready
            await ReadOnly()
            if offering and int(dut.commands__ready.value):
                offering, index = False, index + 1
            if int(dut.pixels__valid.value):
                pixel = _pixel(dut)
                if held is not None and pixel != held:
                    raise AssertionError(f"{label} clock {clock}: stalled {held} became {pixel}")
                if seen >= frames.size:
                    raise AssertionError(f"{label} clock {clock}: extra pixel {pixel}")
                if ready:
                    want = _expected(frames, seen)
                    if pixel != want:
                        raise AssertionError(
                            f"{label} clock {clock}: pixel {seen} is (x, y, value, last) "
                            f"{pixel}, the model's {want}"
                        )
                    seen, held = seen + 1, None
                else:
                    held = pixel
            elif held is not None:
                raise AssertionError(f"{label} clock {clock}: stalled pixel {held} withdrawn")
            done = seen == frames.size and index == len(commands)
            quiet = quiet + 1 if done else 0
        counters = (int(dut.errors.value), int(dut.edge_errors.value))
        if counters != (job["errors"], job["edge_errors"]):
            raise AssertionError(
                f"{label}: errors, edge_errors are {counters}, the model's "
                f"{(job['errors'], job['edge_errors'])}"
            )
    except Exception as failure:  # the pytest side reports whatever stopped the bench
        result["error"] = f"{type(failure).__name__}: {failure}"
        raise
    finally:
        result.update(pixels=seen, clocks=clock, seconds=time.perf_counter() - start)
        with open(os.environ["EDGEAA_COSIM_RESULT"], "w") as file:
            json.dump(result, file)
