"""The accumulation buffer and its resolve: signed-area deltas in, coverage out.

Every edge of a polygon adds its deltas (`step.run_edge_deltas`, `vector.run_edges_deltas`)
into the cells of a buffer; the prefix sum of a row along +x is then, in every cell, the
polygon's coverage times the winding, scaled by ifix = |I_d| << F (docs/algorithm.md
section 13). The fill rule turns the sum into a coverage in [0, ifix] and the coverage rounds
to an intensity offset in [0, |I_d|] with a shift: no multiply.

A buffer covers a window of the image. A delta left of the window belongs to every cell of
its row in the window (the prefix sum carries it), so it is added into the window's first
column; deltas right of, above or below the window change no cell in it and are dropped.
Only rows holding a delta are scanned: a row without one sums to zero everywhere.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .column import ArrayArith

FILL_RULES = ("nonzero", "evenodd")
# Cells of one pass's buffer: 512 KiB at int64 stays in cache (a 32 MiB pass ran the 2048 px
# starburst 2.9 times slower, benchmarks/bench_accumulation.py).
ROWS_PER_PASS_CELLS = 1 << 16


@dataclass(frozen=True)
class Window:
    """Image pixels x0 .. x1 - 1, y0 .. y1 - 1 a buffer covers."""

    x0: int
    y0: int
    x1: int
    y1: int

    @property
    def width(self) -> int:
        return max(self.x1 - self.x0, 0)


def nonzero_coverage(arith, sums, ifix):
    """Non-zero: |sum| clamped at a full pixel."""
    return arith.min(arith.abs(sums), ifix)


def evenodd_coverage(arith, sums, ifix):
    """Even-odd: the sum folded with period 2 ifix (winding 2 is empty again)."""
    folded = sums % (2 * ifix)
    return arith.select(folded > ifix, 2 * ifix - folded, folded)


def fill_coverage(arith, sums, evenodd, ifix):
    """The fill rule on an arithmetic (`edgeaa.model.column`'s: `IntArith` on ints,
    `ArrayArith` on arrays, the formal spec's `HdlArith` on Amaranth values, where `evenodd` is
    a signal): coverage in [0, ifix] from winding-weighted sums."""
    odd = evenodd_coverage(arith, sums, ifix)
    return arith.select(evenodd, odd, nonzero_coverage(arith, sums, ifix))


def fill(sums, rule: str, ifix: int):
    """`fill_coverage` on numpy arrays for one rule of `FILL_RULES` (only that rule computed)."""
    rules = {"nonzero": nonzero_coverage, "evenodd": evenodd_coverage}
    if rule not in rules:
        raise ValueError(f"fill rule must be one of {', '.join(FILL_RULES)}, not {rule!r}")
    return rules[rule](ArrayArith, np.asarray(sums), ifix)


def intensity_offset(coverage, frac_bits: int):
    """round(coverage / 2**F) half up: the number of intensity steps of |I_d| covered."""
    return (coverage + (1 << (frac_bits - 1))) >> frac_bits


def _rdiv(num, den):
    """num / den rounded half up, den > 0, in integers."""
    return (2 * num + den) // (2 * den)


def composite(below, q, intensity: int, d: int):
    """Coverage q / d (q in [0, d]) of intensity over `below`: below + round(q (I - below) / d)
    half up, in integers (the renderer's and the resolve stage's operator)."""
    return below + _rdiv(q * (intensity - below), d)


@dataclass
class Resolved:
    """Rows of a window with their coverage (units of ifix per pixel)."""

    rows: np.ndarray  # image rows (ascending)
    coverage: np.ndarray  # (len(rows), window width)
    cells_scanned: int


def alpha_coverage(q, alpha: int, full: int):
    """A translucent paint's coverage: q (in steps of full scale) times alpha / full,
    rounded half up (`edgeaa.render.paint.Canvas`; the resolve's alpha stage,
    `edgeaa.model.tile.alpha_steps`)."""
    return _rdiv(q * alpha, full)


def resolve_rows(
    window: Window, x: np.ndarray, y: np.ndarray, delta: np.ndarray, rule: str, ifix: int
):
    """Accumulate the deltas at image cells (x, y) into the window, prefix-sum each touched
    row and apply the fill rule. Yields `Resolved` blocks of rows (at most
    ROWS_PER_PASS_CELLS cells each), so a large window never needs one huge buffer."""
    keep = (y >= window.y0) & (y < window.y1) & (x < window.x1)
    x, y, delta = np.maximum(x[keep], window.x0) - window.x0, y[keep], delta[keep]
    if not len(y) or window.width == 0:
        return
    dtype = np.int64 if delta.dtype != object else object
    rows, row_of = np.unique(y, return_inverse=True)
    per_pass = max(1, ROWS_PER_PASS_CELLS // window.width)
    order = np.argsort(row_of, kind="stable")
    bounds = np.searchsorted(row_of[order], np.arange(0, len(rows) + per_pass, per_pass))
    for k, lo in enumerate(range(0, len(rows), per_pass)):
        hi = min(lo + per_pass, len(rows))
        pick = order[bounds[k] : bounds[k + 1]]
        buffer = np.zeros((hi - lo, window.width), dtype=dtype)
        # the buffer's own type: np.add.at is ten times slower on mixed types
        np.add.at(buffer, (row_of[pick] - lo, x[pick]), delta[pick].astype(dtype, copy=False))
        sums = np.cumsum(buffer, axis=1)
        yield Resolved(rows[lo:hi], fill(sums, rule, ifix), buffer.size)
