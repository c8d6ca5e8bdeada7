"""The stepper's output beat: one per column, declared once for the model, the core and every
harness.

A beat carries the writes of one column in two lanes, in the model's write order: ``lane0``
the primary pixel, ``lane1`` its neighbour when the column has two writes (``lane1_valid``),
and ``last`` on the edge's last column. Everything else is derived from the names here:

* `Beat`, the Python value (``lane1`` None for a one-write column), and `column_beats`, the
  model's columns as beats;
* the core's payload (`edgeaa.hdl.write_layout`): the struct ``lane0 {x, y, value}``,
  ``lane1 {...}``, ``lane1_valid``, ``last``; its Verilog ports are `port_name` of each
  `PAYLOAD_PATHS` entry;
* the array encoding: int64 rows of `BEAT_COLUMNS` (`beats_to_array`, `beats_from_array`); a
  simulation run records the clock of each beat in front (`RUN_COLUMNS`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import NamedTuple

import numpy as np

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


def port_name(path: Sequence[str], stream: str = "writes") -> str:
    """The Verilog port of a payload leaf (`edgeaa.hdl.verilog` joins paths with ``__``)."""
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


def payload_row(get: Callable[[tuple[str, ...]], int]) -> list[int]:
    """The payload's leaves as one row of `BEAT_COLUMNS`, as sampled (lane 1 included when it
    is not valid: its don't-care values are deterministic and the harnesses compare them)."""
    return [int(get(path)) for path in PAYLOAD_PATHS]


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
