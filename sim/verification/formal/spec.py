"""The model-side specification the formal checks compare the core with: Amaranth
expressions, in full width, of the model's fold (`fold`), clip window (`window`), bank
invariants (`axes`, `constants_ok`, `major_ok`) and one column of the stepping loop
(`column`). They read only the command, the window and bank-like records, never the core's
internals.
"""

from __future__ import annotations

import types

from amaranth.hdl import Mux, Value
from amaranth.lib import data

from ....model.column import advance, column_areas, output_value, pick_by_select
from ....model.config import EdgeConfig, RegisterWidth
from ....model.edge import fold as model_fold
from ....model.edge import window as model_window

__all__ = [
    "HdlArith",
    "all_",
    "axes",
    "column",
    "constants_ok",
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
    ``bounds`` check reports them (registers the proofs bound otherwise are not recorded)."""

    GROUPS = {"dq": "dq", "dr": "dq", "t": "t", "area": "area", "value": "value"}
    GROUPS |= {"jsum": "jsum", "jq": "next_acc", "jr": "next_acc"}

    def __init__(self, config: EdgeConfig):
        self.widths = config.register_widths()
        self.fits: dict[str, Value] = {}

    @staticmethod
    def select(cond, a, b):
        return Mux(cond, a, b)

    @staticmethod
    def not_(cond):
        return ~Value.cast(cond)

    @staticmethod
    def pick(index, values):
        return pick_by_select(Mux, index, values)

    def check(self, name: str, value, where=True):
        group = self.GROUPS.get(name)
        if group is not None and where is not False:
            condition = fits(value, self.widths[name])
            if where is not True:
                condition = implies(where, condition)
            held = self.fits.get(group)
            self.fits[group] = condition if held is None else held & condition
        return value


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
