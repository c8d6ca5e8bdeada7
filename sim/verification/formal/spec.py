"""The model-side specification the formal checks compare the core with: Amaranth
expressions, in full width, of the model's fold (`fold`), clip window (`window`), bank
invariants (`axes`, `constants_ok`, `major_ok`) and one column of the stepping loop
(`column`). They read only the command, the window and bank-like records, never the core's
internals.
"""

from __future__ import annotations

import types

from amaranth.hdl import Mux, Signal, Value, signed
from amaranth.lib import data

from ....model.bank import BANK_FIELDS
from ....model.column import (
    advance,
    column_areas,
    column_deltas,
    delta_cells,
    output_value,
    pick_by_select,
    piece_end,
)
from ....model.config import EdgeConfig, RegisterWidth
from ....model.edge import fold as model_fold
from ....model.edge import window as model_window

__all__ = [
    "HdlArith",
    "all_",
    "axes",
    "column",
    "constants_ok",
    "deltas_column",
    "deltas_setup",
    "fields",
    "fits",
    "fold",
    "implies",
    "major_ok",
    "window",
]


def fits(value, width: RegisterWidth):
    return (value >= width.min) & (value <= width.max)


def all_(conditions):
    result = Value.cast(1)
    for condition in conditions:
        result = result & condition
    return result


def implies(a, b):
    return ~a | b


def fields(view, layout) -> types.SimpleNamespace:
    """A namespace of the fields of a `data.View` (array fields as lists)."""
    out = {}
    for name, fld in layout:
        value = view[name]
        if isinstance(fld.shape, data.ArrayLayout):
            value = [value[j] for j in range(fld.shape.length)]
        out[name] = value
    return types.SimpleNamespace(**out)


class HdlArith:
    """The model's arithmetic (`edgeaa.model.column`) on Amaranth values, in full width:
    selects are `Mux`, and each register check becomes a condition in `fits`, grouped as the
    ``bounds`` check reports them (registers the proofs bound otherwise are not recorded).

    With a module `m`, every select and every checked register is a comb wire of its value's
    shape (named ``prefix`` and the register), so that a value used several times is one
    node: the deltas arithmetic reuses its heights and clamps so much that, inlined, the
    expression tree grows to hundreds of thousands of cells."""

    GROUPS = {"dq": "dq", "dr": "dq", "t": "t", "area": "area", "value": "value"}
    GROUPS |= {"jsum": "jsum", "jq": "next_acc", "jr": "next_acc"}
    GROUPS |= {"height": "height", "delta": "delta"}  # the accumulation deltas' registers

    def __init__(self, config: EdgeConfig, m=None, prefix: str = "spec"):
        self.widths = config.register_widths()
        self.fits: dict[str, Value] = {}
        self.m, self.prefix = m, prefix

    def wire(self, value, name: str = "sel"):
        """`value` itself, or with a module a comb wire of its shape that equals it."""
        if self.m is None:
            return value
        value = Value.cast(value)
        wire = Signal(value.shape(), name=f"{self.prefix}_{name}")
        self.m.d.comb += wire.eq(value)
        return wire

    def select(self, cond, a, b):
        return self.wire(Mux(cond, a, b))

    @staticmethod
    def not_(cond):
        return ~Value.cast(cond)

    def pick(self, index, values):
        return pick_by_select(self.select, index, values)

    def abs(self, value):
        return self.select(value < 0, -value, value)

    def min(self, a, b):
        return self.select(a > b, b, a)

    def check(self, name: str, value, where=True):
        group = self.GROUPS.get(name)
        if group is not None and where is not False:
            condition = fits(value, self.widths[name])
            if where is not True:
                condition = implies(where, condition)
            held = self.fits.get(group)
            self.fits[group] = condition if held is None else held & condition
        return self.wire(value, name)


def fold(config: EdgeConfig, cmd) -> types.SimpleNamespace:
    """The model's `setup` fold of a command (`edgeaa.model.edge.fold`; no division), with
    what the core forms from it: the start offset ``e = c0 S - u0``, its magnitude, the
    unclipped column count and the bad-command test."""
    f = model_fold(
        HdlArith(config), config, cmd.x0, cmd.y0, cmd.x1, cmd.y1, cmd.i_in, cmd.i_out,
        cmd.inside == 0,
    )  # fmt: skip
    e = (f.c0 << config.subpixel_bits) - f.u0
    bad = ((cmd.x0 == cmd.x1) & (cmd.y0 == cmd.y1)) | (cmd.i_in == cmd.i_out)
    return types.SimpleNamespace(
        **vars(f),
        q0=Mux(f.x_major, cmd.y0, cmd.x0),
        columns=f.c1 - f.c0 + 1,
        e=e,
        e_mag=Mux(e < 0, -e, e),
        bad=bad,
    )


def window(config: EdgeConfig, fold, clip) -> types.SimpleNamespace:
    """The model's cut of a folded command's columns to its clip window
    (`edgeaa.model.edge.window`): the folded bounds ``lo, hi``, the columns ``first .. last``
    (``columns`` of them, none when <= 0), whether the start moved, and lane A's first-pass
    multiplier ``2 (first S - u0)`` as the core loads it (``W + s + 2`` bits; ``2 |e|``
    followed by ``W + 1`` zero bits when the start did not move)."""
    W, s = config.coord_bits, config.subpixel_bits
    w = model_window(HdlArith(config), fold, clip)
    bits = W + s + 2
    offset = ((w.first << s) - fold.u0) << 1
    multiplier = Mux(w.start_clip, offset[:bits], (fold.e_mag << (W + 2))[:bits])
    return types.SimpleNamespace(
        **vars(w),
        columns=w.last - w.first + 1,
        multiplier=multiplier,
        bits=bits,
    )


def axes(b) -> types.SimpleNamespace:
    """Major/minor coordinates and steps of a bank-like record (screen coordinates)."""
    x_major = b.col_dx != 0
    major = Mux(x_major, b.x, b.y)
    minor = Mux(x_major, b.y, b.x)
    col_step = Mux(x_major, b.col_dx, b.col_dy)
    row_step = Mux(x_major, b.row_dy, b.row_dx)
    end = major + Mux(col_step < 0, -b.remaining, b.remaining)
    steps_ok = all_(
        [
            b.col_dx != -2,
            b.col_dy != -2,
            b.row_dx != -2,
            b.row_dy != -2,
            x_major == (b.col_dy == 0),
            x_major == (b.row_dx == 0),
            x_major == (b.row_dy != 0),
        ]
    )
    return types.SimpleNamespace(
        x_major=x_major,
        major=major,
        minor=minor,
        col_step=col_step,
        row_step=row_step,
        end=end,
        steps_ok=steps_ok,
    )


def constants_ok(config: EdgeConfig, b) -> dict[str, Value]:
    """Invariants of the per-edge constants and the accumulator of a bank-like record."""
    F, n = config.F, config.segments
    i_d = b.ifix >> F
    k_bit = (b.khr << 1) >= b.du
    out = {
        "du_nonzero": b.du != 0,
        "ifix_form": (b.ifix[:F] == 0) & (i_d != 0),
        "jq_below_ifix": b.jq < b.ifix,
        "jr_below_du": b.jr < b.du,
        "kr_below_du": b.kr < b.du,
        "khr_below_du": b.khr < b.du,
        "kq_at_most_ifix": (b.kq < b.ifix) | ((b.kq == b.ifix) & (b.kr == 0)),
        "value_range": ((b.value_sign == 1) & (b.value_base + i_d <= config.full_scale))
        | ((b.value_sign == -1) & (b.value_base >= i_d)),
    }
    if config.accumulator == "exact":
        out["half_increment"] = (b.kq == (b.khq << 1) + k_bit) & (
            b.kr == (b.khr << 1) - Mux(k_bit, b.du, 0)
        )
    else:
        out["half_increment"] = all_(
            [b.jr == 0, b.kr == 0, b.khr == 0, (b.kq - (b.khq << 1)) >> 1 == 0]
        )
    if n:
        log2n = n.bit_length() - 1
        conds = [b.seg_thresholds[j - 1] == ((b.kq * j) >> (log2n + 1)) for j in range(1, n)]
        conds += [
            b.seg_intercepts[j] == ((b.kq * (8 * j * (j + 1) + 1)) >> (6 + 2 * log2n))
            for j in range(n)
        ]
        out["segment_constants"] = all_(conds)
    return out


def major_ok(config: EdgeConfig, axes) -> Value:
    top = 1 << config.coord_bits
    return all_([axes.steps_ok, axes.major >= 0, axes.major <= top, axes.end >= 0, axes.end <= top])


def column(config: EdgeConfig, b, axes) -> types.SimpleNamespace:
    """One column of the model (`edgeaa.model.column`: the areas, the output values and the
    loop step) on the registers of a bank-like record, in full width, with ``fits``: each
    group of the model's registers fits its width where the model assigns it."""
    a = HdlArith(config)
    areas = column_areas(a, config, b, b.jq, b.jr)
    value0 = output_value(a, config, b, areas.area0)
    value1 = output_value(a, config, b, areas.area1, areas.two)
    step = advance(a, b, b.x, b.y, b.jq, b.jr)
    below = Value.cast(areas.below)
    top = 1 << config.coord_bits
    major_next = axes.major + axes.col_step
    a.fits["next_major"] = (major_next >= -1) & (major_next <= top + 1)
    out = {}
    if config.segments:
        out = {name: getattr(areas, name) for name in ("above", "below_raw", "dq", "borrow", "t")}
        out["dq_above"] = areas.dq_above
    return types.SimpleNamespace(
        **out,
        area0=areas.area0,
        area1=Value.cast(areas.area1),
        jsum=step.jsum,
        two=Value.cast(areas.two),
        below=below,
        value0=value0,
        value1=value1,
        # The neighbour: row + 1 along the stepping direction, or row - 1 when the edge
        # enters from below.
        x1=Mux(below, b.x - b.row_dx, b.x + b.row_dx),
        y1=Mux(below, b.y - b.row_dy, b.y + b.row_dy),
        fits=a.fits,
        row_step=step.row_step,
        minor_next=axes.minor + Mux(step.row_step, axes.row_step, 0),
        minor1=axes.minor + Mux(below, -axes.row_step, axes.row_step),
    )


class Sign:
    """A 2-bit signed value (a winding sign) whose product with a value is a select: exactly
    the product for each of -2 .. 1, without the full-width multiplier the model's ``sigma *
    value`` would otherwise be (one the solver cannot see through)."""

    def __init__(self, value):
        self.value = Value.cast(value)
        assert self.value.shape() == signed(2), self.value.shape()

    def __mul__(self, other):
        other = Value.cast(other)
        sign = self.value
        return Mux(sign == 1, other, Mux(sign == -1, -other, Mux(sign == 0, 0, -(other << 1))))

    __rmul__ = __mul__


def deltas_setup(b) -> types.SimpleNamespace:
    """A bank-like record of the polygon core (`DELTAS.bank_fields(config)`) as the model's
    `EdgeSetup` the deltas functions read: its fields, ``x_major``, ``major_neg_x`` and
    ``pieces`` (the `EndPieces` fields, the winding sign as a `Sign`)."""
    x_major = b.col_dx != 0
    pieces = {f.name: getattr(b, f.name) for f in BANK_FIELDS if f.pieces}
    pieces["sigma"] = Sign(pieces["sigma"])
    return types.SimpleNamespace(
        **vars(b),
        x_major=x_major,
        major_neg_x=x_major & (b.col_dx < 0),
        pieces=types.SimpleNamespace(**pieces),
    )


def deltas_column(config: EdgeConfig, b, row, first_col, m=None, prefix="spec"):
    """One column of `run_edge_deltas` on the loop state of a deltas bank-like record (its
    ``x, y, jq, jr, remaining`` and ``hs``; `row` the loop's folded row, `first_col` the
    column is the edge's first), in full width: the model's `piece_end`, `column_deltas`,
    `delta_cells` and `advance`, with the piece start of the next column (``hs_next``) and
    ``fits``: each of the model's registers (``height``, ``t``, ``delta`` and the loop's)
    fits its width where the model checks it. With a module `m` its selects and registers
    are wires named `prefix` (`HdlArith`): pass one, the expressions are too large inlined."""
    a = HdlArith(config, m, prefix)
    st = deltas_setup(b)
    p = st.pieces
    first = Value.cast(first_col) & p.first_partial
    last = (b.remaining == 0) & p.last_partial
    he, adj = piece_end(a, st, last, b.jq, b.jr, row)
    d = column_deltas(a, config, st, first, last, b.hs, he, adj, b.jq)
    cells = delta_cells(a, st, b.x, b.y, d)
    step = advance(a, st, b.x, b.y, b.jq, b.jr)
    hs_next = a.check("height", he - Mux(step.row_step, st.ifix, 0))
    return types.SimpleNamespace(
        first=first,
        last=last,
        he=he,
        adj=adj,
        up=Value.cast(d.up),
        t=Value.cast(d.t),
        cells=cells,
        step=step,
        hs_next=hs_next,
        fits=a.fits,
    )


def whole_column_start(b):
    """floor(J - K/2) of a record's accumulator (``jq, jr``): where the piece of a column
    the loop enters whole starts (the model's `end_pieces` ``hs0`` of a whole first column)."""
    return b.jq - b.khq - (b.jr < b.khr)


def pieces_ok(config: EdgeConfig, b, *, start=True) -> dict[str, Value]:
    """Invariants of the end pieces of a deltas bank-like record: the winding sign is +-1,
    P1's height in its row within [0, ifix), a partial first column's piece starts within
    (-ifix, 2 ifix) and (with `start`: ``jq, jr`` are the first column's) a whole first
    column's where the loop enters it (`whole_column_start`); the totals and bands of the
    partial columns within what the deltas' width needs."""
    out = {
        "sigma": (b.sigma == 1) | (b.sigma == -1),
        "end_height": (b.end_height >= 0) & (b.end_height < b.ifix),
        "partial_start": implies(b.first_partial, (b.hs0 > -b.ifix) & (b.hs0 < (b.ifix << 1))),
    }
    if start:
        out["whole_start"] = implies(~b.first_partial, b.hs0 == whole_column_start(b))
    # What the deltas' width needs of the partial columns' totals and bands: x-major edges
    # have no band and totals within [0, 2**acc) (the model's K/2 bound is a product of two
    # per-edge values), y-major edges bands within [0, ifix] (their cells are clamped to it).
    acc = config.register_widths()["jq"].bits
    x_major = b.col_dx != 0
    totals = [(total >= 0) & (total < (1 << acc)) for total in (b.total0, b.total1)]
    bands = [(band >= 0) & (band <= b.ifix) for band in (b.band0, b.band1)]
    out["x_major_pieces"] = implies(x_major, all_([b.band0 == 0, b.band1 == 0, *totals]))
    out["y_major_bands"] = implies(~x_major, all_(bands))
    return out


def end_pieces(config: EdgeConfig, fold, window, cmd, b) -> dict[str, Value]:
    """The end pieces of a deltas bank-like record `b` against the model's `end_pieces` of
    the command's fold and window, for the fields that are selects and small products of
    them (`edgeaa.model.edge.end_pieces`, restated here on Amaranth values: it is written
    on Python ints, with ``if``; the totals and rectangles, products of per-edge values, are
    bounded by their widths only). ``row0`` is the bank's start row (its minor axis)."""
    s, F, S = config.subpixel_bits, config.F, config.subpixel_scale
    rows = config.register_widths()["y"].bits
    half = fold.i_d << (F - s - 1)
    v1 = fold.v0 + fold.dv
    end_row = ((v1 << 1) + S) >> (s + 1)
    first_partial = ~window.start_clip
    start = Mux(first_partial, half * ((fold.v0 << 1) - ((b.row0 << 1) - 1) * S), 0)
    inside_left = cmd.inside == 0
    b_axes = axes(b)
    return {
        "sigma": b.sigma == Mux((cmd.y1 > cmd.y0) == inside_left, 1, -1),
        # (modulo the register: the start row of an edge whose start the window moved is
        # not bounded by induction, see `bounds`)
        "row0": (b_axes.minor - Mux(b_axes.row_step < 0, -b.row0, b.row0))[:rows] == 0,
        "partial": (b.first_partial == first_partial)
        & (b.last_partial == (window.last == fold.c1)),
        "end_row": b.end_row == end_row,
        "end_height": b.end_height == half * ((v1 << 1) - ((end_row << 1) - 1) * S),
        "hs0": b.hs0 == Mux(first_partial, start, whole_column_start(b)),
    }
