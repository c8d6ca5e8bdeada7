"""The tile pipeline behind the stepper: accumulation memory and resolve, as the hardware
does them (`edgeaa.hdl.accumulator`, `edgeaa.hdl.resolve`), and their cycle model.

A tile is ``width`` x ``height`` pixels at an origin in engine pixels. Its stages take, in
order, a stream of *ops* (the accumulator's input):

* `TileStart` (origin, background): the tile's pixels become the background.
* `Beats`: delta beats of the stepper (`edgeaa.model.beat.DeltaBeat`), a cell a clock (two
  or four with two or four scan lanes, one a bank): a beat takes a clock per nonzero cell
  (per pair of cells with a nonzero one; with four, per cell of its busiest bank), one when
  it has none (`beat_clocks`). A cell is moved
  into the tile (origin subtracted); one left of it is added into its row's first column (the
  prefix sum carries it), one right of, above or below it is dropped, as
  `edgeaa.model.accumulate.resolve_rows` does. A row holding a nonzero delta is *touched*.
* `PolygonEnd` (intensity, I_out, fill rule): the resolve. Every touched row, in ascending
  order, is read cell by cell over its *scan span* (below) and cleared (the clear costs no
  extra pass), prefix-summed along +x, the fill rule applied (`fill`), the coverage rounded
  to intensity steps (`intensity_offset`, a shift) and composited over the tile's pixel
  (`composite`, the renderer's operator). Untouched rows are not read.
* `Flush`: the tile's pixels go out row by row, and the tile is the background again.

Channels (`TileConfig.channels`). A tile of 3 channels holds red, green and blue per
pixel, one of 4 alpha too (premultiplied: a transparent background). A colour
`PolygonEnd`'s paint is red, green, blue and alpha A (`PAINT`): its coverage q (in steps of
D) is first scaled by the alpha, q' = round(q A / full) half up (`alpha_coverage`; the
resolve's alpha stage, `alpha_steps`), then composites each channel towards its paint
(alpha's towards full scale), a `composite` per channel side by side with the same divisor
2 D; a `TileStart`'s background is a value per channel. One channel is grey: the paint is
the intensity, and there is no alpha stage.

Widths. A cell holds its sum modulo ``2**cell_bits`` (``cell_bits`` = the delta register +
``headroom_bits``): the prefix sum of a row is then exact while it lies within
``[-L, L)``, ``L = 2**(headroom_bits + 1) * ifix``, i.e. a winding-weighted coverage of
``[-2**(h+1), 2**(h+1))`` pixels (8 for the default h = 2; the planner's boundary edges give
``[0, 1]`` up to the estimate). The even-odd fold takes ``h + 1`` compare-subtract steps for
that range. The model checks the range and raises `TileOverflow` outside it.

Composite in integers (`composite_steps`, what the hardware computes): with ``n = q |I - b|``
the new pixel is ``b + floor((2 n + D) / (2 D))`` when ``I >= b``, else
``b - floor((2 n + D - 1) / (2 D))`` (the same half-up rounding of a negative quotient); the
quotient is at most ``|I - b|``, so ``intensity_bits`` restoring-division steps give it.
A polygon with ``D = 0`` changes no pixel.

Scan span (`TileModel.span`). ``lo`` and ``hi`` are the least and greatest column of the
polygon's kept cells (over all its rows). A touched row is read from ``lo`` to ``hi``, and on
to ``width - 1`` when its sum through ``hi`` is nonzero (modulo ``2**cell_bits``, as the
cells hold it). Exact: left of ``lo`` the row has no delta, so its prefix sum is 0; right of
``hi`` it has none either, so the prefix sum is the sum through ``hi`` there; a prefix sum of
0 gives coverage 0 under both fill rules and ``composite`` leaves the pixel as it is. The
pixels a scan does not reach keep their value: each pixel word holds a flag, written since
the tile started, and one not written reads as the background (`edgeaa.hdl.resolve`; the
flush clears the flags, so a tile start costs one clock, unless pixels were written since the
last flush: then it sweeps them, as a flush that sends nothing, `TileClock.take`).
A scan of ``lanes`` cells a clock (`edgeaa.model.pipeline.PipelineConfig.scan_lanes`) reads
whole beats of ``lanes`` columns (``x`` a multiple of ``lanes``): the span widened to them,
``lo`` down and ``hi`` up (exact for the same reasons), and a row stops at ``hi``'s beat only
when that beat is not the row's last.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .accumulate import FILL_RULES, alpha_coverage, composite, fill, intensity_offset
from .beat import CELL_FIELDS, CELLS, DeltaBeat
from .config import EdgeConfig

__all__ = [
    "CHANNELS",
    "OPS",
    "PAINT",
    "Beats",
    "Flush",
    "PolygonEnd",
    "TileConfig",
    "TileModel",
    "Scan",
    "TileOverflow",
    "TileStart",
    "Sweep",
    "alpha_steps",
    "beat_clocks",
    "composite_steps",
    "pack_paint",
    "tile_cells",
    "unpack_paint",
]

# The accumulator's input ops, by code (the hardware's ``op`` field); the resolve's input
# has ``cell`` in place of ``beat`` and ``end``.
OPS = ("beat", "end", "tile", "flush")
RESOLVE_OPS = ("cell", "tile", "flush")


CHANNELS = (1, 3, 4)  # a pixel's channels: grey; red, green and blue; and alpha
# A colour polygon's paint (the command's ``paint`` field, format version 2; `PolygonEnd`),
# red in the low bits, whatever the tile's channels: a 3-channel tile draws translucent
# paints too (its pixels stay opaque).
PAINT = ("red", "green", "blue", "alpha")


def pack_paint(values, bits: int) -> int:
    """Channel values (red first) as one integer, `bits` each, red in the low bits: the
    command's and the pixel's colour field."""
    return sum(int(v) << (k * bits) for k, v in enumerate(values))


def unpack_paint(packed: int, bits: int, channels: int = 3) -> tuple[int, ...]:
    return tuple((int(packed) >> (k * bits)) & ((1 << bits) - 1) for k in range(channels))


class TileOverflow(ValueError):
    """A prefix sum outside the range the tile's cells hold exactly."""


@dataclass(frozen=True)
class TileConfig:
    """The tile's geometry and cell width; `config` is the stepper's."""

    config: EdgeConfig = field(default_factory=EdgeConfig)
    width: int = 64
    height: int = 32
    headroom_bits: int = 2
    channels: int = 1  # 1: grey; 3: red, green, blue; 4: and alpha (`CHANNELS`)

    def __post_init__(self):
        if not isinstance(self.config, EdgeConfig):
            raise TypeError(f"config must be an EdgeConfig, not {self.config!r}")
        for name, low in (("width", 4), ("height", 2)):
            value = getattr(self, name)
            if not isinstance(value, int) or value < low or value & (value - 1):
                raise ValueError(f"tile {name} must be a power of two >= {low}, not {value!r}")
        if not isinstance(self.headroom_bits, int) or not 0 <= self.headroom_bits <= 8:
            raise ValueError(f"headroom_bits must be in [0, 8], not {self.headroom_bits!r}")
        if self.channels not in CHANNELS:
            raise ValueError(
                f"channels must be 1 (grey), 3 (RGB) or 4 (RGBA), not {self.channels!r}"
            )

    @property
    def x_bits(self) -> int:
        return self.width.bit_length() - 1

    @property
    def y_bits(self) -> int:
        return self.height.bit_length() - 1

    @property
    def cell_bits(self) -> int:
        """Bits of an accumulation cell (signed, wrapping)."""
        return self.config.register_widths()["delta"].bits + self.headroom_bits

    @property
    def winding_limit(self) -> int:
        """Prefix sums are exact within [-limit * ifix, limit * ifix)."""
        return 1 << (self.headroom_bits + 1)

    @property
    def pixels(self) -> int:
        return self.width * self.height


class TileStart(NamedTuple):
    x0: int  # engine pixels of the tile's first column and row
    y0: int
    background: int | tuple  # an intensity, or a value per channel (colour)


class Beats(NamedTuple):
    """Delta beats: ``cells[k, j]`` is (x, y, delta) of cell j of beat k."""

    cells: np.ndarray  # (n, 4, 3) int64

    @classmethod
    def of(cls, beats: list[DeltaBeat]) -> Beats:
        return cls(np.array([b.cells for b in beats], dtype=np.int64).reshape(-1, 4, 3))

    def __len__(self) -> int:
        return len(self.cells)


class PolygonEnd(NamedTuple):
    """A polygon's resolve: its coverage in steps of D = |intensity - I_out|, scaled by the
    paint's alpha (`alpha_coverage`), composites towards `paint` (`PAINT`: red, green, blue,
    alpha) in each channel, alpha's towards full scale (None: towards the intensity, grey)."""

    intensity: int
    i_out: int
    rule: str = "nonzero"
    paint: tuple | None = None


class Flush(NamedTuple):
    pass


class Sweep(NamedTuple):
    """What `TileModel.feed` returns for a `TileStart`: whether it clears pixels written
    since the last flush (``written``: the resolve then sweeps them, a beat a clock)."""

    written: bool


assert len(CELLS) == 4 and len(CELL_FIELDS) == 3  # the shape of `Beats.cells`


def tile_cells(tile: TileConfig, origin, x, y, delta):
    """Cells of a tile at `origin` for image cells (x, y, delta) (numpy arrays): (tx, ty,
    delta) of the kept ones, a cell left of the tile moved into its first column."""
    tx, ty = np.asarray(x) - origin[0], np.asarray(y) - origin[1]
    delta = np.asarray(delta)
    keep = (ty >= 0) & (ty < tile.height) & (tx < tile.width) & (delta != 0)
    return np.maximum(tx[keep], 0), ty[keep], delta[keep]


def beat_clocks(cells: np.ndarray, lanes: int = 1, tile: TileConfig | None = None, origin=(0, 0)):
    """Clocks the accumulator takes for each beat of `cells` (n, 4, 3) (the beat goes in the
    last of them; a beat with no nonzero cell takes one). One lane (one memory): one clock
    per nonzero cell. Two lanes (`edgeaa.model.pipeline.PipelineConfig.scan_lanes`: a memory
    bank per column parity): the cells go by pairs, (0, 1) then (2, 3), one clock for a pair
    with a nonzero cell (a pair of zeros is skipped), each cell into its own bank, or both
    into one cell (their deltas added), but two clocks (first cell, then second) when the
    pair *clashes*: both nonzero and kept in the tile at `origin` (`tile_cells`) at two
    cells of one bank. The stepper's beats never clash (a pair is two neighbouring columns
    of a row, or both moved into its first column). Four lanes (a bank per column modulo
    4): each clock every bank takes its lowest waiting kept cell, with the cells at that
    same cell (their deltas added), and the cells not kept go in the first clock; so a beat
    with a nonzero cell takes as many clocks as its busiest bank has different kept cells,
    at least one."""
    cells = np.asarray(cells).reshape(-1, 4, 3)
    nonzero = cells[:, :, 2] != 0
    if lanes == 1:
        return np.maximum(np.count_nonzero(nonzero, axis=1), 1)
    if lanes not in (2, 4) or tile is None:
        raise ValueError(f"beat_clocks takes 1 lane, or 2 or 4 with the tile, not {lanes!r}")
    tx, ty = cells[:, :, 0] - origin[0], cells[:, :, 1] - origin[1]
    kept = nonzero & (ty >= 0) & (ty < tile.height) & (tx < tile.width)
    col = np.maximum(tx, 0)
    if lanes == 4:
        return _busiest_bank_clocks(kept, col, ty)
    clocks = np.zeros(len(cells), dtype=np.int64)
    for a, b in ((0, 1), (2, 3)):
        clash = kept[:, a] & kept[:, b] & (col[:, a] % 2 == col[:, b] % 2)
        clash &= (col[:, a] != col[:, b]) | (ty[:, a] != ty[:, b])
        clocks += (nonzero[:, a] | nonzero[:, b]).astype(np.int64) + clash  # not bool's +
    return np.maximum(clocks, 1)


def _busiest_bank_clocks(kept, col, row) -> np.ndarray:
    """Four lanes' clocks a beat (`beat_clocks`): the most different kept cells in one bank
    (column modulo 4), at least one."""
    fresh = kept.copy()  # a kept cell no earlier kept cell of its beat is the same as
    for a in range(4):
        for b in range(a):
            fresh[:, a] &= ~(kept[:, b] & (col[:, b] == col[:, a]) & (row[:, b] == row[:, a]))
    busiest = np.zeros(len(kept), dtype=np.int64)
    for bank in range(4):
        busiest = np.maximum(busiest, np.count_nonzero(fresh & (col % 4 == bank), axis=1))
    return np.maximum(busiest, 1)


def composite_steps(below: int, q: int, intensity: int, d: int, bits: int) -> int:
    """`composite` as the resolve computes it: an unsigned numerator, a `bits`-step
    restoring division by 2 d, the quotient added or subtracted (q in [1, d])."""
    neg = intensity < below
    num = 2 * q * abs(intensity - below) + d - neg
    quotient = 0
    for j in reversed(range(bits)):
        if num >= (2 * d) << j:
            num -= (2 * d) << j
            quotient |= 1 << j
    return below - quotient if neg else below + quotient


def alpha_steps(q: int, alpha: int, bits: int) -> int:
    """`alpha_coverage` as the resolve computes it (no divider; docs/hardware.md, "Colour"):
    with full = 2**bits - 1, round(q A / full) half up = floor(y / full) for
    y = q A + 2**(bits - 1) - 1, and floor(y / full) = (y + (y >> bits) + 1) >> bits for
    every y below 2**bits * full (q and A at most full)."""
    y = q * alpha + (1 << (bits - 1)) - 1
    return (y + (y >> bits) + 1) >> bits


class Scan(NamedTuple):
    """What a `PolygonEnd` read (the cycle model's input): per touched row, the beats read
    (of `lanes` cells each) and whether the row stopped at ``hi`` on a zero sum (the
    accumulator then reads one more beat, and does not send it)."""

    runs: tuple[tuple[int, bool], ...] = ()
    lanes: int = 1

    @property
    def rows(self) -> int:
        return len(self.runs)

    @property
    def beats(self) -> int:
        return sum(n for n, _ in self.runs)

    @property
    def cells(self) -> int:
        return self.beats * self.lanes


class TileModel:
    """The tile's stages on integers: `feed` an op, get a frame (height x width) on Flush, the
    `Scan` on a PolygonEnd (of `scan_lanes` cells a beat: `PipelineConfig.scan_lanes`; the
    frames do not depend on it)."""

    def __init__(self, tile: TileConfig, scan_lanes: int = 1):
        lanes = scan_lanes
        if not isinstance(lanes, int) or lanes < 1 or lanes & (lanes - 1) or lanes > tile.width:
            raise ValueError(f"scan_lanes must be a power of two up to the width, not {lanes!r}")
        self.tile, self.scan_lanes = tile, scan_lanes
        big = tile.cell_bits + 24 > 62  # exact sums of up to 2**24 deltas in int64
        self._dtype = object if big else np.int64
        self.cells = np.zeros((tile.height, tile.width), dtype=self._dtype)
        self.touched = np.zeros(tile.height, dtype=bool)
        self.written = False  # the resolve wrote pixels since the last flush (`feed`)
        self.lo, self.hi = tile.width - 1, 0  # the polygon's kept columns (lo > hi: none)
        self.origin = (0, 0)
        self.background = 0
        shape = (tile.height, tile.width) + ((tile.channels,) if tile.channels > 1 else ())
        self.pixels = np.zeros(shape, dtype=np.int64)
        self._planes = self.pixels.reshape(tile.height, tile.width, tile.channels)  # a view

    def feed(self, op):
        """Apply one op; a `Flush` returns the frame, a `PolygonEnd` the rows it scanned, a
        `TileStart` its `Sweep`."""
        if isinstance(op, DeltaBeat):
            op = Beats.of([op])
        if isinstance(op, Beats):
            self._accumulate(op.cells)
            return None
        if isinstance(op, PolygonEnd):
            return self._resolve(op)
        if isinstance(op, TileStart):
            self.origin, self.background = (op.x0, op.y0), op.background
            self.pixels[:] = op.background
            swept, self.written = Sweep(self.written), False
            return swept
        if isinstance(op, Flush):
            frame = self.pixels.copy()
            self.pixels[:] = self.background
            self.written = False
            return frame
        raise TypeError(f"not a tile op: {op!r}")

    def run(self, ops) -> list[np.ndarray]:
        """The frames of every Flush in `ops`."""
        return [out for op in ops if isinstance(out := self.feed(op), np.ndarray)]

    def beat_clocks(self, cells: np.ndarray) -> np.ndarray:
        """`beat_clocks` of beats `cells` taken now (the tile's origin, its scan lanes)."""
        return beat_clocks(cells, self.scan_lanes, self.tile, self.origin)

    def _accumulate(self, cells: np.ndarray) -> None:
        cells = cells.reshape(-1, 3)
        tx, ty, delta = tile_cells(self.tile, self.origin, cells[:, 0], cells[:, 1], cells[:, 2])
        np.add.at(self.cells, (ty, tx), delta.astype(self._dtype))
        self.touched[ty] = True
        if len(tx):
            self.lo, self.hi = min(self.lo, int(tx.min())), max(self.hi, int(tx.max()))

    def span(self, row: int) -> tuple[int, int, bool]:
        """The columns `first .. last` an end reads of touched `row` (module docstring: whole
        beats of `scan_lanes`) and whether the read stops at ``hi``'s beat for a zero sum."""
        last, lanes = self.tile.width - 1, self.scan_lanes
        first, end = self.lo - self.lo % lanes, self.hi | (lanes - 1)
        if end == last:
            return first, last, False
        total = int(self.cells[row, : self.hi + 1].sum()) % (1 << self.tile.cell_bits)
        return first, last if total else end, not total

    def _resolve(self, end: PolygonEnd) -> Scan:
        if end.rule not in FILL_RULES:
            raise ValueError(f"fill rule must be one of {', '.join(FILL_RULES)}, not {end.rule!r}")
        F = self.tile.config.F
        d = abs(end.intensity - end.i_out)
        ifix = d << F
        limit = self.tile.winding_limit * ifix
        rows = np.flatnonzero(self.touched)
        runs = []
        channels, full = self.tile.channels, self.tile.config.full_scale
        targets = (end.intensity,) * channels
        if end.paint is not None:  # red, green, blue, alpha; alpha's channel towards full
            targets = (*end.paint[:3], full)[:channels]
        for row in rows:
            first, last, stop = self.span(row)
            runs.append(((last - first + 1) // self.scan_lanes, stop))
            sums = np.cumsum(self.cells[row])
            self.cells[row] = 0
            if d == 0:
                continue  # no intensity step: nothing changes
            if sums.min() < -limit or sums.max() >= limit:
                raise TileOverflow(
                    f"tile row {row}: a prefix sum of {int(max(sums.max(), -sums.min()))} is "
                    f"outside the {self.tile.cell_bits}-bit cells' exact range "
                    f"[-{limit}, {limit}) ({self.tile.winding_limit} ifix)"
                )
            read = slice(first, last + 1)  # outside it the sum is 0: the pixel stays
            q = intensity_offset(fill(sums[read], end.rule, ifix), F).astype(np.int64)
            if end.paint is not None:
                q = alpha_coverage(q, end.paint[3], full)
            for k, value in enumerate(targets):  # each channel, the same coverage
                below = self._planes[row, read, k]
                self._planes[row, read, k] = composite(below, q, value, d)
        self.written |= bool(runs)
        self.touched[:] = False
        self.lo, self.hi = self.tile.width - 1, 0
        return Scan(tuple(runs), self.scan_lanes)


# -- cycle model ----------------------------------------------------------------------------
#
# Clocks from 0; a transfer happens in a clock where valid and ready are both high. The ops
# are offered back to back (each from the clock after the previous one was taken) and the
# pixel sink is always ready. The accumulator takes a beat in `beat_clocks` clocks (its
# nonzero cells one a clock, or a pair a clock with two lanes), the beat's transfer in the
# last of them. An end taken in clock
# a reads the first touched beat of cells in a + 2 (the last beat's read-modify-write lands in
# a + 1) and offers it to the resolve in a + 3, then one beat of `Scan.lanes` cells per clock
# (the runs of `Scan`), the next read as a beat is taken; a row that stops at ``hi``'s beat
# leaves a clock with no beat after it (the read of the next beat, not sent). It takes the
# next op once the last beat is taken and the scan is over (the clock after its last read);
# with no touched row in a + 2. Tile and flush pass through its output register (offered in
# a + 1). The resolve takes a beat per clock; a beat taken in r writes its pixels in clock
# r + `resolve_latency`. A polygon's first
# cell, a tile and a flush wait until no cell is in flight (the pixels they read must be
# written). The resolve has two pixel memories: a flush taken in f hands it the one the
# resolve wrote, which it sends (pixel k in f + 2 + k // lanes, row by row, `lanes` pixels a
# beat: `edgeaa.model.pipeline.PipelineConfig.pixel_lanes`) while the resolve takes the next
# tile's ops and cells into the other; the next flush is taken from
# f + width * height / lanes + 1 (the last beat sent).

SCAN_START = 3  # end taken in a: its first cell offered in a + 3
EMPTY_END = 2  # end with no touched row taken in a: next op in a + 2
FLUSH_START = 2  # flush taken by the resolve in f: pixel 0 out in f + 2


PRODUCT_STAGES = (1, 2)  # clocks the resolve's I x I products take (`resolve_latency`)


def resolve_latency(tile: TileConfig, product_stages: int = 1) -> int:
    """Clocks from the resolve taking a cell to writing its pixel: prefix sum (with the pixel
    read), fill, (colour: the alpha stage,) offset and product (`product_stages` clocks, of
    `PRODUCT_STAGES`), one clock per quotient bit."""
    return tile.config.intensity_bits + 2 + product_stages + (tile.channels > 1)


@dataclass
class TileTiming:
    """When each op was taken (a `Beats` op: one clock per beat) and each pixel left."""

    accepts: list[int] = field(default_factory=list)  # accumulator input transfers
    cells: list[int] = field(default_factory=list)  # resolve input transfers of cells
    pixels: list[int] = field(default_factory=list)  # each pixel's output transfer
    frames: list[np.ndarray] = field(default_factory=list)
    rows_scanned: int = 0
    cells_scanned: int = 0
    beats_scanned: int = 0  # clocks of cells into the resolve: cells over the scan lanes

    @property
    def clocks(self) -> int:
        """First op to last transfer, inclusive."""
        return max([-1, *self.accepts, *self.cells, *self.pixels]) + 1


class TileClock:
    """The tile stages' clocks, op by op, for ops offered at any clock: `ready` is the first
    clock the accumulator can take the next op (it stays ready from then until it takes a
    non-beat op). `timing` collects the transfers; `acc_stall` and `resolve_busy` count
    clocks as the top's counters do (`edgeaa.hdl.pipeline.STATS`). `lanes`: the pixels a
    flush sends a clock (`edgeaa.model.pipeline.PipelineConfig.pixel_lanes`); a `Scan`'s
    runs are in beats of its own lanes (`PipelineConfig.scan_lanes`), one a clock;
    `product_stages`: the resolve's (`resolve_latency`)."""

    def __init__(self, tile: TileConfig, lanes: int = 1, product_stages: int = 1):
        self.tile, self.latency = tile, resolve_latency(tile, product_stages)
        self.lanes = lanes
        self.timing = TileTiming()
        self.ready = 0
        self.quiet = 0  # first clock no cell is in flight in the resolve
        self.free = 0  # first clock the resolve can take a flush (the last one is out)
        self.flush_from = 0  # the first clock of the last flush's reads
        self.scanning = self.acc_stall = self.resolve_ops = 0
        self.overlap = 0  # clocks the resolve took a cell or op while flushing
        self.holding = 0  # clocks a beat's cells were taken before its transfer
        self.swept = 0  # clocks of sweeps (a tile start's reads of written pixels)

    def beats(self, clocks, holds) -> None:
        """Beats transferred in `clocks` (ascending), beat k taken over its ``holds[k]``
        clocks (`beat_clocks`) up to its transfer, the first at or after `ready`."""
        clocks, holds = [int(c) for c in clocks], [int(h) for h in holds]
        assert len(clocks) == len(holds), "a hold per beat"
        if clocks:
            assert clocks[0] - holds[0] + 1 >= self.ready, "a beat before the accumulator is ready"
            self.timing.accepts.extend(clocks)
            self.holding += sum(holds) - len(holds)
            self.ready = clocks[-1] + 1

    def take(self, op, result, clock: int | None = None) -> int:
        """A non-beat op (`result`: what `TileModel.feed` returned for it) offered from
        `clock` (default: `ready`); returns the clock the accumulator takes it."""
        a = self.ready if clock is None else max(clock, self.ready)
        out, tile = self.timing, self.tile
        out.accepts.append(a)
        if isinstance(op, PolygonEnd):
            out.rows_scanned += result.rows
            out.cells_scanned += result.cells
            out.beats_scanned += result.beats
            if not result.beats:
                self.ready = a + EMPTY_END
                return a
            r = t = max(a + SCAN_START, self.quiet)
            for n, stop in result.runs:  # a row that stops at hi: its next clock sends nothing
                out.cells.extend(range(t, t + n))
                self._overlap(t, t + n)
                t += n + stop
            last, stop = out.cells[-1], result.runs[-1][1]
            # the first read in a + 2, the next ones as the cells are taken; SCAN ends after
            # the last read, or after the one as the last cell is taken (a row that stops)
            end = last + 1 if stop else (last if result.beats > 1 else a + SCAN_START)
            self.ready, self.quiet = max(last, end), last + 1 + self.latency
            self.scanning += end - (a + SCAN_START - 1)
            self.acc_stall += r - a - SCAN_START
            self.resolve_ops += result.beats
            return a
        flush = isinstance(op, Flush)
        sweep = flush or (isinstance(result, Sweep) and result.written)
        r = max(a + 1, self.free if sweep else 0, self.quiet)  # tile or flush: output register
        self.ready = r
        self.acc_stall += r - a - 1
        self.resolve_ops += 1
        self._overlap(r, r + 1)
        if sweep:  # the pixels' reads (and flags cleared), sent only by a flush
            beats = tile.pixels // self.lanes
            if flush:
                out.pixels.extend(
                    np.repeat(np.arange(beats) + r + FLUSH_START, self.lanes).tolist()
                )
                out.frames.append(result)
            else:
                self.swept += beats
            self.flush_from, self.free = r + 1, r + beats + 1
        return a

    def _overlap(self, start: int, stop: int) -> None:
        """Count the clocks of `start` .. `stop` - 1 (resolve takes) within the last flush's
        reads (`flush_from` .. `free` - 1; the sink always ready)."""
        self.overlap += max(0, min(stop, self.free) - max(start, self.flush_from))


def tile_cycles(tile: TileConfig, ops, lanes: int = 1, product_stages: int = 1) -> TileTiming:
    """The clock of every transfer of the tile stages (and their frames, from `TileModel`)
    for ops offered back to back, with `lanes` scan and pixel lanes and the resolve's
    `product_stages`."""
    model, clock = TileModel(tile, lanes), TileClock(tile, lanes, product_stages)
    for op in ops:
        result = model.feed(op)
        if isinstance(op, (Beats, DeltaBeat)):
            holds = model.beat_clocks((Beats.of([op]) if isinstance(op, DeltaBeat) else op).cells)
            clock.beats(clock.ready - 1 + np.cumsum(holds), holds)
        else:
            clock.take(op, result)
    return clock.timing
