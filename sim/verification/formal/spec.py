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

from ....model.config import EdgeConfig, RegisterWidth

__all__ = [
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


def fold(config: EdgeConfig, cmd) -> types.SimpleNamespace:
    """The model's `setup` fold of a command (full-width expressions, no division)."""
    s, scale = config.subpixel_bits, config.subpixel_scale
    dx, dy = cmd.x1 - cmd.x0, cmd.y1 - cmd.y0
    adx, ady = Mux(dx < 0, -dx, dx), Mux(dy < 0, -dy, dy)
    x_major = adx >= ady
    p0, q0, p1 = (
        Mux(x_major, cmd.x0, cmd.y0),
        Mux(x_major, cmd.y0, cmd.x0),
        Mux(x_major, cmd.x1, cmd.y1),
    )
    dp, dq = Mux(x_major, dx, dy), Mux(x_major, dy, dx)
    major_neg, minor_neg = dp <= 0, dq < 0
    u0, v0, u1 = Mux(major_neg, -p0, p0), Mux(minor_neg, -q0, q0), Mux(major_neg, -p1, p1)
    c0 = ((u0 << 1) + scale) >> (s + 1)
    c1 = -((scale - (u1 << 1)) >> (s + 1))
    e = (c0 << s) - u0
    diff = cmd.i_in - cmd.i_out
    i_d = Mux(diff < 0, -diff, diff)
    det_pos = x_major ^ major_neg ^ minor_neg  # the model's det == +1
    inside_is_a = (cmd.inside == 0) == det_pos
    i_a, i_b = Mux(inside_is_a, cmd.i_in, cmd.i_out), Mux(inside_is_a, cmd.i_out, cmd.i_in)
    bad = ((cmd.x0 == cmd.x1) & (cmd.y0 == cmd.y1)) | (cmd.i_in == cmd.i_out)
    return types.SimpleNamespace(
        x_major=x_major,
        major_neg=major_neg,
        minor_neg=minor_neg,
        u0=u0,
        du=Mux(x_major, adx, ady),
        dv=Mux(x_major, ady, adx),
        q0=q0,
        v0=v0,
        c0=c0,
        c1=c1,
        columns=c1 - c0 + 1,
        e=e,
        e_mag=Mux(e < 0, -e, e),
        i_d=i_d,
        value_base=i_b,
        value_neg=i_a < i_b,
        bad=bad,
    )


def window(config: EdgeConfig, fold, clip) -> types.SimpleNamespace:
    """The model's cut of a folded command's columns to its clip window (`setup`): the folded
    bounds ``lo, hi``, the columns ``first .. last`` (``columns`` of them, none when <= 0),
    whether the start moved, and lane A's first-pass multiplier ``2 (first S - u0)`` as the
    core loads it (``W + s + 2`` bits; ``2 |e|`` followed by ``W + 1`` zero bits when the
    start did not move)."""
    W, s = config.coord_bits, config.subpixel_bits
    neg = fold.major_neg
    lo = Mux(
        fold.x_major,
        Mux(neg, -clip.x_max, clip.x_min),
        Mux(neg, -clip.y_max, clip.y_min),
    )
    hi = Mux(
        fold.x_major,
        Mux(neg, -clip.x_min, clip.x_max),
        Mux(neg, -clip.y_min, clip.y_max),
    )
    start_clip = fold.c0 < lo
    first = Mux(start_clip, lo, fold.c0)
    last = Mux(fold.c1 > hi, hi, fold.c1)
    bits = W + s + 2
    offset = ((first << s) - fold.u0) << 1
    multiplier = Mux(start_clip, offset[:bits], (fold.e_mag << (W + 2))[:bits])
    return types.SimpleNamespace(
        lo=lo,
        hi=hi,
        start_clip=start_clip,
        first=first,
        last=last,
        columns=last - first + 1,
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
    """The model's `column_areas`, `output_value` and loop step in full width."""
    widths = config.register_widths()
    F, n = config.F, config.segments
    ok = {}  # name -> the full-width value fits its register
    out = {}
    if n == 0:
        two, below, t = Value.cast(0), Value.cast(0), Value.cast(0)
        area0, area1 = b.jq, Value.cast(0)
    else:
        rsum_a = b.jr + b.khr
        carry_a = rsum_a >= b.du
        dq_a = b.jq + b.khq + carry_a - b.ifix
        dr_a = rsum_a - Mux(carry_a, b.du, 0)
        above = (dq_a > 0) | ((dq_a == 0) & (dr_a != 0))
        borrow = b.khr < b.jr
        dq_b = b.khq - b.jq - borrow
        dr_b = b.khr - b.jr + Mux(borrow, b.du, 0)
        below_raw = (dq_b > 0) | ((dq_b == 0) & (dr_b != 0))
        below = ~above & below_raw
        two = above | below
        dq = Mux(above, dq_a, dq_b)
        shift = 2 + n.bit_length() - 1
        if n == 1:
            t = (dq >> shift) - b.seg_intercepts[0]
        else:
            seg = sum(dq >= threshold for threshold in b.seg_thresholds)
            t = ((dq * (2 * n - 1)) >> shift) - b.seg_intercepts[n - 1]
            for j in reversed(range(n - 1)):
                t = Mux(seg == j, ((dq * (2 * j + 1)) >> shift) - b.seg_intercepts[j], t)
        t_clamped = Mux(t < 0, 0, t)
        area0 = Mux(above, b.jq - t_clamped, Mux(below, b.jq + t_clamped, b.jq))
        area1 = Mux(above, t_clamped, b.ifix - t_clamped)
        ok["dq"] = fits(dq_a, widths["dq"]) & fits(dr_a, widths["dr"])
        ok["dq"] &= implies(~above, fits(dq_b, widths["dq"]) & fits(dr_b, widths["dr"]))
        ok["t"] = implies(two, fits(t, widths["t"]))
        out.update(above=above, below_raw=below_raw, dq=dq, dq_above=dq_a, borrow=borrow, t=t)

    def value(area):
        rounded = (area + (1 << (F - 1))) >> F
        return Mux(b.value_sign < 0, b.value_base - rounded, b.value_base + rounded)

    value0, value1 = value(area0), value(area1)
    ok["area"] = fits(area0, widths["area"]) & implies(two, fits(area1, widths["area"]))
    ok["value"] = fits(value0, widths["value"]) & implies(two, fits(value1, widths["value"]))
    # The neighbour: row + 1 along the stepping direction, or row - 1 when the edge enters
    # from below.
    x1 = Mux(below, b.x - b.row_dx, b.x + b.row_dx)
    y1 = Mux(below, b.y - b.row_dy, b.y + b.row_dy)
    # The loop step.
    rsum = b.jr + b.kr
    carry = rsum >= b.du
    jsum = b.jq + b.kq + carry
    row_step = jsum >= b.ifix
    jq_next = Mux(row_step, jsum - b.ifix, jsum)
    jr_next = rsum - Mux(carry, b.du, 0)
    ok["jsum"] = fits(jsum, widths["jsum"])
    ok["next_acc"] = fits(jq_next, widths["jq"]) & fits(jr_next, widths["jr"])
    top = 1 << config.coord_bits
    major_next = axes.major + axes.col_step
    ok["next_major"] = (major_next >= -1) & (major_next <= top + 1)
    minor_next = axes.minor + Mux(row_step, axes.row_step, 0)
    minor1 = axes.minor + Mux(below, -axes.row_step, axes.row_step)
    return types.SimpleNamespace(
        **out,
        area0=area0,
        area1=area1,
        jsum=jsum,
        two=two,
        below=below,
        value0=value0,
        value1=value1,
        x1=x1,
        y1=y1,
        fits=ok,
        row_step=row_step,
        minor_next=minor_next,
        minor1=minor1,
    )
