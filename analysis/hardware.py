"""Hardware figures for `edgeaa bench`: cycles per column, LUTs and Fmax of edgeaa's core.

Cycles per column are measured: the bench's own edges run through the compiled cycle-accurate
simulation (`edgeaa.sim.simulators.verilator_harness`) with an always-ready sink, from an
idle core, so setup latency and handovers count. LUTs and Fmax come from synthesis and place
and route for
iCE40 HX8K (`edgeaa.sim.synthesis`, the core inside the I/O harness, harness subtracted), cached
on disk per Verilog text because a run takes about a minute per core.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass

from ..hdl import LineCore, verilog
from ..model import MODES, Edge, EdgeConfig
from ..sim.simulators import verilator_harness
from ..sim.simulators.verilator import cache_dir

SYNTH_TARGET = "ice40"


@dataclass(frozen=True)
class HardwareFigures:
    cycles_per_column: float | None
    luts: int | None
    fmax_mhz: float | None
    target: str = ""


def cycles_per_column(config: EdgeConfig, edges: list[Edge]) -> float:
    """Clocks from the first command to the last beat, per column, in the compiled core."""
    run = verilator_harness.run(config, edges)  # one beat per column
    return (int(run.beats[-1, 0]) + 1) / len(run.beats)


def synth_figures(config: EdgeConfig, target: str = SYNTH_TARGET, seed: int = 1) -> dict:
    """LUTs and Fmax of the core (harness subtracted), synthesised once per Verilog text."""
    from ..sim.synthesis import synthesize

    key = hashlib.sha256(f"{verilog(config)}{target}{seed}".encode()).hexdigest()[:16]
    path = cache_dir().parent / "synth" / f"{key}.json"
    if path.exists():
        return json.loads(path.read_text())
    result = synthesize(LineCore(config), target, wrap=True, seed=seed)
    figures = {"luts": result.core_luts, "ffs": result.core_ffs, "fmax_mhz": result.fmax_mhz}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(figures))
    return figures


def hardware_figures(
    config: EdgeConfig, method: str, edges: list[Edge], *, synthesis: bool = True
) -> HardwareFigures | None:
    """The figures of `method` (edgeaa-<mode>) on `edges`; None for methods with no core."""
    mode = method.removeprefix("edgeaa-")
    if not method.startswith("edgeaa-") or mode not in MODES:
        return None
    config = config.with_(mode=mode)
    cycles = cycles_per_column(config, edges)
    if not synthesis:
        return HardwareFigures(cycles, None, None)
    figures = synth_figures(config)
    return HardwareFigures(cycles, figures["luts"], figures["fmax_mhz"], SYNTH_TARGET)
