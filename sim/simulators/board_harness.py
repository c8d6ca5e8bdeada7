# amaranth: UnusedElaboratable=no
"""The board's logic (`edgeaa.hdl.board.BoardCore`) compiled by Verilator with the generated
harness (`edgeaa.sim.simulators.harness`): a page number in, every active pixel of the video
out, with its three TMDS words, the clock and whether a page was being drawn.

This is the board top less what only the FPGA has (`ULX3STop`: the PLL, the page sequence,
the 10:1 serializers and their ODDRX1F): the frames are taken before serialization, as the
pixel bytes the video reads from the framebuffer and the TMDS words made of them.

A run starts from reset, asks for one page and records `frames` whole video frames (the
drawing takes about 1.5 of them); `BoardRun.last_frame` is the last one, refused unless the
page was drawn before it began (not torn) and its TMDS words are the DVI algorithm's
(`edgeaa.model.video`) for its pixels, line by line, on all three channels.
"""

from __future__ import annotations

import functools
import hashlib
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...hdl.board import BoardCore
from ...hdl.core import flat_verilog
from ...model.video import TMDSState, tmds_encode
from . import harness

TOP = "edgeaa_board"
VIDEO_COLUMNS = ("clock", "x", "y", "value", "tmds0", "tmds1", "tmds2", "drawing")
PAGE_FORMAT = harness.StreamFormat("page", ((),))
VIDEO_FORMAT = harness.StreamFormat("video", tuple((name,) for name in VIDEO_COLUMNS[1:]))


def compact_zero_init(source: str, least: int = 1024) -> str:
    """Yosys writes a memory's initial value one assignment a word; a zero framebuffer of
    307,200 bytes would be as many lines for Verilator to compile. Each initial block of at
    least `least` zero words of one memory, in order from 0, becomes the same as a loop."""
    pattern = re.compile(
        r"^( *)initial begin\n((?:\1  (\S+)\[\d+\] = \d+'h0+;\n)+)\1end\n", re.MULTILINE
    )

    def loop(match: re.Match) -> str:
        indent, body, name = match.group(1), match.group(2), match.group(3)
        lines = body.splitlines()
        wanted = [f"{indent}  {name}[{k}]" for k in range(len(lines))]
        if len(lines) < least or [line.split(" =")[0] for line in lines] != wanted:
            return match.group(0)
        bits = lines[0].split("= ")[1].split("'")[0]
        i = f"{name.lstrip(chr(92))}_init"
        return (
            f"{indent}integer {i};\n{indent}initial for ({i} = 0; {i} < {len(lines)}; "
            f"{i} = {i} + 1) {name}[{i}] = {bits}'h0;\n"
        )

    return pattern.sub(loop, source)


@dataclass(frozen=True)
class BoardRun:
    rows: np.ndarray  # int64 rows, `VIDEO_COLUMNS`
    clocks: int
    drawn: int  # pages drawn by the end
    frames: int  # video frames begun (the timer's counter)
    seconds: float
    width: int
    height: int

    @property
    def drawn_by(self) -> int:
        """The clock of the first active pixel shown after the page was drawn (the drawing
        ended in the clocks before it; 0: no pixel was shown while drawing)."""
        drawing = np.flatnonzero(self.rows[:, VIDEO_COLUMNS.index("drawing")])
        if not len(drawing) or drawing[-1] + 1 >= len(self.rows):
            return 0
        return int(self.rows[drawing[-1] + 1, 0])

    def last_frame(self) -> np.ndarray:
        """The last whole frame's bytes, (height, width); RuntimeError unless it is whole,
        in raster order, after the page was drawn, and its TMDS words are the reference's."""
        n = self.width * self.height
        if len(self.rows) < n or len(self.rows) % n:
            raise RuntimeError(f"{len(self.rows)} pixels are not whole {self.width} x "
                               f"{self.height} frames")  # fmt: skip
        rows = self.rows[-n:]
        col = {name: rows[:, k] for k, name in enumerate(VIDEO_COLUMNS)}
        y, x = np.divmod(np.arange(n), self.width)
        wrong = np.flatnonzero((col["x"] != x) | (col["y"] != y))
        if len(wrong):
            i = wrong[0]
            raise RuntimeError(f"pixel {i} of the last frame is at ({col['x'][i]}, "
                               f"{col['y'][i]}), not ({x[i]}, {y[i]})")  # fmt: skip
        if col["drawing"].any() or self.drawn != 1:
            raise RuntimeError("the page was still being drawn in the last frame")
        values = col["value"].reshape(self.height, self.width)
        check_tmds(values, [col[f"tmds{k}"].reshape(values.shape) for k in range(3)])
        return values


@functools.cache
def _tmds_table() -> dict:
    """(disparity, byte) -> (word, next disparity) of `tmds_encode`, from every disparity it
    reaches: a frame's 307,200 words looked up rather than encoded."""
    table, seen, todo = {}, {0}, [0]
    while todo:
        cnt = todo.pop()
        for byte in range(256):
            state = TMDSState(cnt)
            table[cnt, byte] = tmds_encode(state, 1, byte, 0), state.cnt
            if state.cnt not in seen:
                seen.add(state.cnt)
                todo.append(state.cnt)
    return table


def tmds_line(line) -> list[int]:
    """The words of one line of bytes from the disparity 0 of the blanking before it."""
    table, cnt, words = _tmds_table(), 0, []
    for byte in line:
        word, cnt = table[cnt, byte]
        words.append(word)
    return words


def check_tmds(values: np.ndarray, channels: list[np.ndarray]) -> None:
    """Each line's words on every channel are the DVI encoder's for its bytes (grey: the same
    byte on the three; the disparity restarts in each line's blanking)."""
    for y, line in enumerate(values):
        want = np.array(tmds_line(line.tolist()))
        for k, words in enumerate(channels):
            bad = np.flatnonzero(words[y] != want)
            if len(bad):
                x = bad[0]
                raise RuntimeError(
                    f"TMDS channel {k}, pixel ({x}, {y}): word {words[y][x]:#012b}, the "
                    f"encoder's for byte {line[x]} there is {want[x]:#012b}"
                )


def _core_key(core: BoardCore, pages) -> tuple:
    """What the Verilog depends on beyond the sources: the tile and the pages' commands."""
    digest = hashlib.sha256(repr([list(page) for page in pages]).encode()).hexdigest()[:16]
    return ("board", core.tile, core.origin, core.timing, digest)


@functools.cache
def _top(core: BoardCore) -> harness.HarnessTop:
    return harness.harness_top(core, TOP, PAGE_FORMAT, VIDEO_FORMAT)


def build(core: BoardCore, pages, *, optimize: str = harness.OPTIMIZE) -> Path:
    """Compile `core` (made from `pages`) and the harness, cached by the sources and the
    pages; returns the executable."""

    def verilog() -> str:
        return compact_zero_init(flat_verilog(core, TOP, annotated=False))

    return harness.build((*_core_key(core, pages), optimize), _top(core), verilog, optimize)


def frames_for(plan, core: BoardCore) -> int:
    """Frames to record for `plan`'s page: those its drawing may span by the pipeline's upper
    clock estimate (`edgeaa.render.pipeline.clock_estimate`; the HUD pages draw in 0.65 of
    it), and one whole frame after. A page drawn later still is refused by `last_frame`."""
    from ...render.pipeline import clock_estimate

    clocks, _ = clock_estimate(plan, core.tile)
    return -(-clocks // core.timing.frame_clocks) + 1


def run(core: BoardCore, pages, page: int, frames: int) -> BoardRun:
    """Reset, ask for `page`, record `frames` whole frames of video."""
    if not 0 <= page < len(pages):
        raise ValueError(f"page {page} of {len(pages)} pages (0 to {len(pages) - 1})")
    timing = core.timing
    done = harness.run_harness(
        build(core, pages),
        _top(core),
        np.array([[page]]),
        seed=0,
        idle=0.0,
        stall=0.0,
        expected=frames * timing.width * timing.height,
        drain=1,
        max_quiet=2 * timing.frame_clocks,
    )
    counters = done.counters
    return BoardRun(
        done.rows, done.clocks, counters["drawn"], counters["frames"], done.seconds,
        timing.width, timing.height,
    )  # fmt: skip
