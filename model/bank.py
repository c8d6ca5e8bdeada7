"""The values the per-edge setup hands to the stepper: declared once, here.

The model's `EdgeSetup` computes them, the hardware's register bank (`edgeaa.hdl.setup_layout`)
declares one field per entry with the width of its register, the stepper loads them, and
every harness that compares the core's bank with the model (`bank_values`) walks the same
list, so a field added here reaches all of them.

The polygon core (accumulation deltas) also needs the end pieces
(`edgeaa.model.edge.EndPieces`, the `EdgeSetup.pieces` fields): they are in its bank only
(``pieces=True``, `edgeaa.model.beat.DELTAS`), so the line core keeps its bank.
"""

from __future__ import annotations

from typing import NamedTuple

from .config import EdgeConfig, RegisterWidth


class BankField(NamedTuple):
    """One field of the bank: its name (an `EdgeSetup` attribute, or an `EndPieces` one for
    ``pieces``), the entry of `EdgeConfig.register_widths` that sizes it, and whether it is a
    per-segment array."""

    name: str
    register: str
    array: str | None = None  # None: a scalar; "thresholds" (N - 1) or "intercepts" (N)
    pieces: bool = False  # an `EdgeSetup.pieces` field: in the polygon core's bank only

    def value(self, setup):
        """The field's value in an `EdgeSetup`."""
        return getattr(setup.pieces if self.pieces else setup, self.name)

    def length(self, config: EdgeConfig) -> int | None:
        """Elements of an array field (None for a scalar)."""
        n = config.segments
        if self.array is None:
            return None
        return max(n - 1, 0) if self.array == "thresholds" else n

    def width(self, config: EdgeConfig) -> RegisterWidth:
        return config.register_widths()[self.register]


BANK_FIELDS = (
    BankField("x", "x"),  # screen pixel of the first column's primary write
    BankField("y", "y"),
    BankField("remaining", "remaining"),  # columns - 1
    BankField("col_dx", "unit"),  # screen step of one column and of one row
    BankField("col_dy", "unit"),
    BankField("row_dx", "unit"),
    BankField("row_dy", "unit"),
    BankField("du", "du"),
    BankField("ifix", "ifix"),
    BankField("jq", "jq"),
    BankField("jr", "jr"),
    BankField("kq", "kq"),
    BankField("kr", "kr"),
    BankField("khq", "khq"),
    BankField("khr", "khr"),
    BankField("seg_thresholds", "seg_const", "thresholds"),
    BankField("seg_intercepts", "seg_const", "intercepts"),
    BankField("value_base", "value"),
    BankField("value_sign", "unit"),
    # the end pieces (`EndPieces`): heights in units of ifix per pixel, folded rows
    BankField("sigma", "unit", pieces=True),
    BankField("row0", "y", pieces=True),
    BankField("first_partial", "flag", pieces=True),
    BankField("last_partial", "flag", pieces=True),
    BankField("hs0", "height", pieces=True),
    BankField("end_row", "y", pieces=True),
    *(
        BankField(name, "height", pieces=True)
        for name in ("end_height", "total0", "total1", "rect0", "rect1", "band0", "band1")
    ),
)


def bank_fields(config: EdgeConfig, pieces: bool = False) -> tuple[BankField, ...]:
    """The fields present in `config`'s bank (array fields of length 0 left out; the end
    pieces only with `pieces`)."""
    return tuple(f for f in BANK_FIELDS if f.length(config) != 0 and (pieces or not f.pieces))


def bank_values(
    config: EdgeConfig, setup, pieces: bool = False
) -> dict[str, int | tuple[int, ...]]:
    """The bank contents of an `EdgeSetup` (or any object with the fields): name -> value,
    arrays as tuples, flags as 0 or 1 (the end pieces with `pieces`)."""
    out = {}
    for f in bank_fields(config, pieces):
        value = f.value(setup)
        out[f.name] = tuple(value) if f.array else int(value)
    return out
