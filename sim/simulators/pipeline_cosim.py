"""The emitted polygon pipeline's Verilog under Verilator through cocotb: `cosimulate_pipeline`
builds `edgeaa.hdl.pipeline.pipeline_verilog` once per Verilog text (cached) with cocotb 2's
runner and runs the bench `edgeaa.sim.simulators.cocotb_pipeline_bench` on a command list
with random source idles and sink stalls. The model's frames and counters
(`edgeaa.model.pipeline.command_ops`, `edgeaa.model.tile.TileModel`) are computed here and
handed to the bench, which checks every pixel as it arrives; a difference raises
`edgeaa.sim.simulators.verilator.CosimError` with the bench's message.
"""

from __future__ import annotations

import contextlib
import json
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...hdl.pipeline import pipeline_verilog
from ...model.pipeline import Command, command_ops
from ...model.tile import TileConfig, TileModel
from .pipeline_harness import stuck_limit
from .verilator import CosimError, cocotb_build, environment, verilator_env

TOP = "edgeaa_pipeline"


@dataclass(frozen=True)
class PipelineCosim:
    pixels: int  # pixels checked against the model
    clocks: int
    seconds: float  # simulation wall time, build excluded


def cosimulate_pipeline(
    tile: TileConfig, commands: list[Command], *, seed: int, idle: float = 0.0, stall: float = 0.0
) -> PipelineCosim:
    """Run `commands` through the Verilated pipeline under cocotb and check every pixel and
    the counters against the model."""
    build_dir = cocotb_build(
        pipeline_verilog(tile, name=TOP), TOP, "-O1"
    )  # few clocks: a fast build
    model = command_ops(tile, commands)
    frames = TileModel(tile).run(model.ops)
    stacked = np.array(frames, dtype=np.int64).reshape(-1, tile.height, tile.width)
    from cocotb_tools.runner import get_runner

    with tempfile.TemporaryDirectory(prefix="edgeaa-pipeline-cosim-") as tmp:
        job_path, result_path = Path(tmp) / "job.json", Path(tmp) / "result.json"
        np.save(Path(tmp) / "frames.npy", stacked)
        busy = 60 * len(commands) + 8 * stacked.size
        job = {
            "commands": [list(c) for c in commands],
            "frames": str(Path(tmp) / "frames.npy"),
            "seed": seed,
            "idle": idle,
            "stall": stall,
            "errors": model.errors,
            "edge_errors": model.edge_errors,
            "max_clocks": busy + stuck_limit(tile, idle, stall),
        }
        job_path.write_text(json.dumps(job))
        env = verilator_env()
        env.update(EDGEAA_COSIM_JOB=str(job_path), EDGEAA_COSIM_RESULT=str(result_path))
        # cocotb's runner exits when a test fails; the bench's report says why
        with environment(env), contextlib.suppress(SystemExit):
            get_runner("verilator").test(
                test_module="edgeaa.sim.simulators.cocotb_pipeline_bench",
                hdl_toplevel=TOP,
                hdl_toplevel_lang="verilog",
                build_dir=build_dir,
                test_dir=tmp,
                extra_env=env,
                log_file=Path(tmp) / "sim.log",
            )
        if not result_path.exists():
            log = (Path(tmp) / "sim.log").read_text()[-3000:]
            raise CosimError(f"the pipeline bench did not report (seed {seed}); log tail:\n{log}")
        result = json.loads(result_path.read_text())
    if result["error"]:
        raise CosimError(result["error"])
    return PipelineCosim(result["pixels"], result["clocks"], result["seconds"])
