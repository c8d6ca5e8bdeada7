"""The golden side of every hardware comparison: the model's writes as the core's beats.

The core emits one beat per column with two lanes (the primary pixel, then the neighbour
when the column has two writes; the format is `edgeaa.model.beat.WRITES`), or for the polygon
core the column's four accumulation deltas (`DELTAS`). `expected_beats` turns model results
into that form, and `Scoreboard` checks observed beats against it in order and,
at the end, that nothing is missing (verilog-axis style: the run ends with "the scoreboard
is empty").
"""

from __future__ import annotations

from collections.abc import Iterable

from ...model import Edge, EdgeConfig, EdgeError
from ...model.beat import WRITES, Beat, BeatFormat, beats_from_array, beats_to_array, column_beats
from ...model.step import EdgeResult

__all__ = [
    "Beat",
    "Scoreboard",
    "beats_from_array",
    "beats_to_array",
    "edge_beats",
    "expected_beats",
]


def edge_beats(result: EdgeResult) -> list[Beat]:
    """One edge's model writes as beats, column by column."""
    return column_beats(result.columns)


def expected_beats(
    config: EdgeConfig, edges: Iterable[Edge], fmt: BeatFormat = WRITES
) -> tuple[list, int]:
    """All beats of a command stream, and how many commands the core must drop as bad.

    `fmt`: the core's output, `WRITES` (`Beat`, from `run_edge`) or `DELTAS`
    (`edgeaa.model.beat.DeltaBeat`, from `run_edge_deltas`). An edge with no column in its
    clip window has no beat (not even a `last` one) and is not dropped: it is not counted."""
    beats: list = []
    dropped = 0
    for edge in edges:
        try:
            beats.extend(fmt.edge_beats(config, edge))
        except EdgeError:
            dropped += 1
    return beats, dropped


class Scoreboard:
    """Checks beats in order against the expected ones; `finish` checks none is missing."""

    def __init__(self, expected: list[Beat], label: str = ""):
        self.expected = expected
        self.label = label
        self.seen = 0

    def check(self, beat: Beat, where: str = "") -> None:
        context = f"{self.label} {where}".strip()
        if self.seen >= len(self.expected):
            raise AssertionError(f"{context}: unexpected extra beat {beat} (duplicated pixel?)")
        want = self.expected[self.seen]
        if beat != want:
            raise AssertionError(f"{context}: beat {self.seen} is {beat}, the model says {want}")
        self.seen += 1

    @property
    def done(self) -> bool:
        return self.seen == len(self.expected)

    def finish(self) -> None:
        if not self.done:
            raise AssertionError(
                f"{self.label}: {len(self.expected) - self.seen} beats missing of "
                f"{len(self.expected)}; next expected {self.expected[self.seen]}"
            )
