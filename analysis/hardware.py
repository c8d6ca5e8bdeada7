"""The hook for hardware figures in `edgeaa bench`: cycles per column, LUTs, Fmax.

`hardware_figures(config, method)` returns None until a hardware figures module exists;
the bench prints "-" in those columns. To fill them, provide the module
`edgeaa.sim.figures` with a function

    core_figures(config: EdgeConfig) -> dict | None

returning ``{"cycles_per_column": float, "luts": int, "fmax_mhz": float, "target": str}``
for the core of that configuration (mode and accumulator included), or None. The stepping
stage of `edgeaa.hdl.core` sustains one column per clock, so cycles per column is 1 for
edges of at least `setup_latency - 2` columns (see `edgeaa.model.timing`). Only edgeaa's
own methods have a hardware core; every other method returns None.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

from ..model import MODES, EdgeConfig

FIGURES_MODULE = "edgeaa.sim.figures"


@dataclass(frozen=True)
class HardwareFigures:
    cycles_per_column: float | None
    luts: int | None
    fmax_mhz: float | None
    target: str = ""


def hardware_figures(config: EdgeConfig, method: str) -> HardwareFigures | None:
    mode = method.removeprefix("edgeaa-")
    if not method.startswith("edgeaa-") or mode not in MODES:
        return None
    try:
        module = importlib.import_module(FIGURES_MODULE)
    except ModuleNotFoundError as error:
        if error.name in (FIGURES_MODULE, FIGURES_MODULE.rsplit(".", 1)[0]):
            return None
        raise
    figures = module.core_figures(config.with_(mode=mode))
    if figures is None:
        return None
    return HardwareFigures(
        figures.get("cycles_per_column"),
        figures.get("luts"),
        figures.get("fmax_mhz"),
        figures.get("target", ""),
    )
