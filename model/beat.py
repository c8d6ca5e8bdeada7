"""The stepper's output beat: one per column, declared once for the model, the core and every
harness.

A beat carries the writes of one column in two lanes, in the model's write order: ``lane0``
the primary pixel, ``lane1`` its neighbour when the column has two writes (``lane1_valid``),
and ``last`` on the edge's last column. Everything else is derived from the names here:

* `Beat`, the Python value (``lane1`` None for a one-write column), and `column_beats`, the
  model's columns as beats;
* the core's payload (`edgeaa.hdl.write_layout`): the struct ``lane0 {x, y, value}``,
  ``lane1 {...}``, ``lane1_valid``, ``last``; its Verilog ports are `WRITES.port_name` of each
  `PAYLOAD_PATHS` entry;
* the array encoding: int64 rows of `BEAT_COLUMNS` (`beats_to_array`, `beats_from_array`); a
  simulation run records the clock of each beat in front (`RUN_COLUMNS`).
* `edge_columns`: how many beats each edge of a command stream gives (0 for an edge the core
  drops as bad or whose clip window holds none of its columns).

The polygon core's accumulation deltas have their own beat, declared the same way below
(`DeltaBeat`, `DELTA_PAYLOAD_PATHS`). `WRITES` and `DELTAS` are the two outputs, declared once
(`BeatFormat`: stream, payload, decoders, bank fields, pipeline depth and FINAL clocks): what
differs between the line core and the polygon core lives in these two objects.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from .bank import BankField, bank_fields
from .config import EdgeConfig
from .edge import Edge, EdgeError, setup
from .step import run_edge, run_edge_deltas

LANES = ("lane0", "lane1")
PIXEL_FIELDS = ("x", "y", "value")  # x, y signed (register "x", "y"), value unsigned

# Leaf fields of the payload, in array order: lane 0, lane 1's valid flag, lane 1, last.
PAYLOAD_PATHS: tuple[tuple[str, ...], ...] = (
    *((LANES[0], name) for name in PIXEL_FIELDS),
    ("lane1_valid",),
    *((LANES[1], name) for name in PIXEL_FIELDS),
    ("last",),
)
BEAT_COLUMNS = tuple("_".join(path) for path in PAYLOAD_PATHS)
RUN_COLUMNS = ("clock", *BEAT_COLUMNS)
COLUMN = {name: index for index, name in enumerate(BEAT_COLUMNS)}

Pixel = tuple[int, int, int]  # x, y, value


class Beat(NamedTuple):
    lane0: Pixel
    lane1: Pixel | None  # None: the column has one write
    last: bool  # the edge's last column


def port_name(path: Sequence[str], stream: str) -> str:
    """The Verilog port of a payload leaf of `stream` (`edgeaa.hdl.verilog` joins paths with
    ``__``)."""
    return "__".join((stream, "payload", *path))


def column_beats(columns: Sequence[Sequence]) -> list[Beat]:
    """One edge's columns of model writes (`EdgeResult.columns`) as beats."""
    beats = []
    for index, column in enumerate(columns):
        lanes = [(w.x, w.y, w.value) for w in column]
        lane1 = lanes[1] if len(lanes) > 1 else None
        beats.append(Beat(lanes[0], lane1, index == len(columns) - 1))
    return beats


def beat_from_fields(get: Callable[[tuple[str, ...]], int]) -> Beat:
    """A beat from its payload leaves: `get(path)` returns the integer of a `PAYLOAD_PATHS`
    entry (x and y signed). Serves every harness that samples the core's ports."""

    def pixel(lane: str) -> Pixel:
        x, y, value = (int(get((lane, name))) for name in PIXEL_FIELDS)
        return (x, y, value)

    lane1 = pixel(LANES[1]) if get(("lane1_valid",)) else None
    return Beat(pixel(LANES[0]), lane1, bool(get(("last",))))


def edge_columns(config: EdgeConfig, edges: Iterable[Edge]) -> np.ndarray:
    """Beats (visible columns) of each edge: 0 for a bad command and for an edge whose clip
    window holds none of its columns (neither ends with a `last` beat)."""
    counts = []
    for edge in edges:
        try:
            counts.append(setup(config, edge).columns)
        except EdgeError:
            counts.append(0)
    return np.array(counts, dtype=np.int64)


def beat_row(beat: Beat) -> list[int]:
    """A beat as one row of `BEAT_COLUMNS` (lane 1 zero when it is not valid)."""
    lane1 = (0, 0, 0) if beat.lane1 is None else beat.lane1
    return [*beat.lane0, int(beat.lane1 is not None), *lane1, int(beat.last)]


def beats_to_array(beats: Iterable[Beat]) -> np.ndarray:
    """Beats as int64 rows of `BEAT_COLUMNS`."""
    rows = [beat_row(beat) for beat in beats]
    return np.array(rows, dtype=np.int64).reshape(-1, len(BEAT_COLUMNS))


def beats_from_array(rows: np.ndarray) -> list[Beat]:
    """Rows of `BEAT_COLUMNS` (or of `RUN_COLUMNS`, the clock dropped) as beats."""
    rows = np.asarray(rows)
    if rows.ndim == 2 and rows.shape[1] == len(RUN_COLUMNS):
        rows = rows[:, 1:]

    def pixel(row, lane: str) -> Pixel:
        x, y, value = (row[COLUMN[f"{lane}_{name}"]] for name in PIXEL_FIELDS)
        return (x, y, value)

    return [
        Beat(
            pixel(r, "lane0"),
            pixel(r, "lane1") if r[COLUMN["lane1_valid"]] else None,
            bool(r[COLUMN["last"]]),
        )
        for r in rows.astype(np.int64).tolist()
    ]


# -- the accumulation-delta beat (the polygon core's) ------------------------------------------
#
# One beat per stepped column: the four cells of `edgeaa.model.step.run_edge_deltas`, in the
# order `edgeaa.model.column.delta_cells` gives them (zeros included), ``nonzero`` (bit k:
# cell k's delta is not zero) and ``last`` on the edge's last column. ``nonzero`` is a
# function of the deltas, sent so that the accumulator, which takes the nonzero cells, does
# not form it behind the beat's register (Fmax: docs/hardware.md, "The nonzero flags in the
# beat, and a Booth FINAL").
# The core's payload (`edgeaa.hdl.delta_layout`) is the struct
# ``cell0 {x, y, delta}`` .. ``cell3 {...}``, ``nonzero``, ``last``; its Verilog ports are
# ``port_name(path, DELTA_STREAM)``. Array rows: `DELTA_BEAT_COLUMNS` (`DELTA_RUN_COLUMNS` with
# the clock in front).

DELTA_STREAM = "deltas"
CELLS = ("cell0", "cell1", "cell2", "cell3")
CELL_FIELDS = ("x", "y", "delta")  # each signed, sized by the register of the same name
DELTA_PAYLOAD_PATHS: tuple[tuple[str, ...], ...] = (
    *((cell, name) for cell in CELLS for name in CELL_FIELDS),
    ("nonzero",),
    ("last",),
)
DELTA_FLAG_BITS = {"nonzero": len(CELLS), "last": 1}  # the payload's leaves besides the cells
DELTA_BEAT_COLUMNS = tuple("_".join(path) for path in DELTA_PAYLOAD_PATHS)
DELTA_RUN_COLUMNS = ("clock", *DELTA_BEAT_COLUMNS)

Cell = tuple[int, int, int]  # x, y, delta


class DeltaBeat(NamedTuple):
    cells: tuple[Cell, Cell, Cell, Cell]
    last: bool  # the edge's last column
    nonzero: int  # bit k: cell k's delta is not zero (`nonzero_mask`)


def nonzero_mask(cells: Sequence[Cell]) -> int:
    """The beat's ``nonzero`` field of its cells: bit k set when cell k's delta is not 0."""
    return sum(1 << k for k, (_, _, delta) in enumerate(cells) if delta != 0)


def delta_column_beats(columns: Sequence[Sequence]) -> list[DeltaBeat]:
    """One edge's columns of `run_edge_deltas` (tuples of four `Delta`) as beats, each
    ``nonzero`` formed from its cells."""
    beats = []
    for index, column in enumerate(columns):
        cells = tuple((d.x, d.y, d.delta) for d in column)
        beats.append(DeltaBeat(cells, index == len(columns) - 1, nonzero_mask(cells)))
    return beats


def delta_beat_from_fields(get: Callable[[tuple[str, ...]], int]) -> DeltaBeat:
    """A delta beat from its payload leaves (`get(path)` of a `DELTA_PAYLOAD_PATHS` entry),
    ``nonzero`` as sent (a core's beat is compared with the model's whole)."""
    cells = tuple(tuple(int(get((cell, name))) for name in CELL_FIELDS) for cell in CELLS)
    return DeltaBeat(cells, bool(get(("last",))), int(get(("nonzero",))))


def delta_beat_row(beat: DeltaBeat) -> list[int]:
    cells = [value for cell in beat.cells for value in cell]
    return cells + [int(beat.nonzero), int(beat.last)]


def delta_beats_to_array(beats: Iterable[DeltaBeat]) -> np.ndarray:
    rows = [delta_beat_row(beat) for beat in beats]
    return np.array(rows, dtype=np.int64).reshape(-1, len(DELTA_BEAT_COLUMNS))


def delta_beats_from_array(rows: np.ndarray) -> list[DeltaBeat]:
    """Rows of `DELTA_BEAT_COLUMNS` (or `DELTA_RUN_COLUMNS`, the clock dropped) as beats."""
    rows = np.asarray(rows)
    if rows.ndim == 2 and rows.shape[1] == len(DELTA_RUN_COLUMNS):
        rows = rows[:, 1:]
    width = len(CELL_FIELDS)
    return [
        DeltaBeat(
            tuple(tuple(r[k * width : (k + 1) * width]) for k in range(len(CELLS))),
            bool(r[-1]),
            r[-2],
        )
        for r in rows.astype(np.int64).tolist()
    ]


@dataclass(frozen=True, eq=False)
class BeatFormat:
    """One output of the core, declared once: its stream's name, payload leaves in array
    order, the register sizing each leaf (None: a one-bit flag), the decoders to Python
    beats, the encoder to array rows, the model's columns of an edge (`run_edge`'s or
    `run_edge_deltas`) and its beats of them (`edge_beats`); and what the output asks of the core:
    whether its bank carries the end pieces (`pieces`), whether its stepper reads the bank
    live and takes it when it steps the edge's last column (`live_bank`; else it copies the
    bank when it loads it), its pipeline depth and its setup's FINAL clocks
    (`edgeaa.model.timing` reads both here)."""

    stream: str
    paths: tuple[tuple[str, ...], ...]
    registers: dict[str, str | None]  # leaf name -> width-table register (None: flags)
    from_fields: Callable
    from_array: Callable
    to_array: Callable
    from_columns: Callable
    model_columns: Callable[[EdgeConfig, Edge], Sequence]  # the model's columns of an edge
    pieces: bool  # the bank carries the end pieces (`BankField.pieces`)
    live_bank: bool  # the stepper reads the held bank and takes it at the edge's end
    depth: Callable[[EdgeConfig], int]  # clocks from a column's step to its beat
    final: Callable[[EdgeConfig], int]  # clocks of the setup's FINAL state
    lane_steps: int = 1  # the setup lanes' steps a clock in RUN (`edgeaa.hdl.lanes`)

    @property
    def run_columns(self) -> tuple[str, ...]:
        return ("clock", *("_".join(path) for path in self.paths))

    def edge_beats(self, config: EdgeConfig, edge: Edge) -> list:
        """The model's beats of one edge (`EdgeError` for a bad command)."""
        return self.from_columns(self.model_columns(config, edge))

    def pipeline_depth(self, config: EdgeConfig) -> int:
        return self.depth(config)

    def final_cycles(self, config: EdgeConfig) -> int:
        return self.final(config)

    def bank_fields(self, config: EdgeConfig) -> tuple[BankField, ...]:
        """The fields of this output's bank (`edgeaa.model.bank.bank_fields`)."""
        return bank_fields(config, pieces=self.pieces)

    def port_name(self, path: Sequence[str]) -> str:
        """The Verilog port of a payload leaf of this output's stream."""
        return port_name(path, self.stream)


WRITES = BeatFormat(
    "writes",
    PAYLOAD_PATHS,
    {"x": "x", "y": "y", "value": "value", "lane1_valid": None, "last": None},
    beat_from_fields,
    beats_from_array,
    beats_to_array,
    column_beats,
    lambda config, edge: run_edge(config, edge).columns,
    pieces=False,
    live_bank=False,
    # the output register behind one estimate stage (at most one segment) or two
    depth=lambda config: 2 if config.segments <= 1 else 3,
    final=lambda config: 1,
)
"""The line core's output: the paper's intensity writes, two lanes a column."""

DELTAS = BeatFormat(
    DELTA_STREAM,
    DELTA_PAYLOAD_PATHS,
    {"x": "x", "y": "y", "delta": "delta", "nonzero": None, "last": None},
    delta_beat_from_fields,
    delta_beats_from_array,
    delta_beats_to_array,
    delta_column_beats,
    run_edge_deltas,
    pieces=True,
    live_bank=True,
    # p1 (the piece's depth), p2 (the estimate and covers), p3 (the upper and lower rows'
    # areas: the cut of the cells' carry chains, for Fmax), the output register (the cells)
    depth=lambda config: 4,
    # FINAL forms the y-major total0 product two bits of w0 (s + 2 bits) a clock
    final=lambda config: (config.subpixel_bits + 3) // 2,
)
"""The polygon core's output: the accumulation deltas, four cells a column."""

DELTAS_FAST = replace(
    DELTAS,
    # FINAL registers the y-major total0's multiplicand, then multiplies (`edgeaa.hdl.pieces`)
    final=lambda config: 2,
    # two multiply-divide steps a clock (radix 4): RUN in about half the clocks
    lane_steps=2,
    # the stepper copies the bank as it starts an edge: the setup unit is free C clocks
    # sooner, and the next edge starts as the last column of this one steps
    live_bank=False,
)
"""The fast pipeline's core output (`PipelineConfig.fast_core`): the same stream, beats and
bank from a setup whose FINAL takes two clocks (its product by a multiplier: the ECP5's DSP
blocks) and whose lanes take two steps a clock (`edgeaa.hdl.lanes`: RUN 11 clocks instead of
20 in the default configuration); its stepper copies the bank as it starts an edge."""


def format_of(stream: str) -> BeatFormat:
    """The output whose stream is named `stream` (a job file names it across processes)."""
    for fmt in (WRITES, DELTAS):
        if fmt.stream == stream:
            return fmt
    raise ValueError(f"no output stream named {stream!r}: writes or deltas")
