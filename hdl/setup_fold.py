"""The setup's FOLD and WINDOW loads (`edgeaa.hdl.setup.EdgeSetupUnit`): the model's
`edgeaa.model.edge.fold` and `window` in hardware.

`fold_loads` (combinational from the latched command, registered at the end of the FOLD
clock): the octant fold, ``c0, c1`` (as ``first, last``), the folded window, ``|e|`` and its
sign, the orientation and lane B's load. `window_loads` (from FOLD's registers): the columns
cut to the window, ``v0`` and lane A's first pass. Each takes the setup unit (its command,
window, registers and lanes) and returns the register loads; docs/hardware.md, "The setup
unit, clock by clock", derives each step.
"""

from __future__ import annotations

import types

from amaranth.hdl import Cat, Const, Mux, Signal, signed, unsigned

from .layouts import signed_widened

__all__ = ["fold_loads", "r_cut_end", "window_loads"]


def fold_loads(m, unit) -> list:
    """FOLD's loads: the folded registers, ``c0, c1`` (as first, last), the folded
    window, |e| and its sign, and lane B."""
    config = unit.config
    W, s, F = config.coord_bits, config.subpixel_bits, config.F
    I = config.intensity_bits  # noqa: E741
    coord = W + s
    cmd, acc, r = unit.cmd, unit.accepted, unit.regs
    dx, dy = Signal(signed(coord + 1)), Signal(signed(coord + 1))
    adx, ady = Signal(unsigned(coord)), Signal(unsigned(coord))
    nadx, nady = Signal(signed(coord + 1)), Signal(signed(coord + 1))  # -|dx|, -|dy|
    f_x_major = Signal()
    f_diff = Signal(signed(I + 1))
    f_id = Signal(unsigned(I))
    m.d.comb += [
        dx.eq(acc["dx_r"]),
        dy.eq(acc["dy_r"]),
        adx.eq(Mux(dx < 0, acc["ndx_r"], dx)),
        ady.eq(Mux(dy < 0, acc["ndy_r"], dy)),
        nadx.eq(Mux(dx < 0, dx, acc["ndx_r"])),
        nady.eq(Mux(dy < 0, dy, acc["ndy_r"])),
        f_x_major.eq((adx + nady) >= 0),  # |dx| >= |dy|
        f_diff.eq(cmd.i_in - cmd.i_out),
        f_id.eq(Mux(f_diff < 0, -f_diff, f_diff)),
    ]
    # The major axis's operands are picked first (after the compare); everything that
    # depends on the axis is then formed once from them.
    f = types.SimpleNamespace(
        x_major=f_x_major,
        le0=Mux(f_x_major, acc["dx_le0"], acc["dy_le0"]),
        minor_neg=Mux(f_x_major, dy < 0, dx < 0),
        p0=Mux(f_x_major, cmd.x0, cmd.y0),
        p1=Mux(f_x_major, cmd.x1, cmd.y1),
        low=Mux(f_x_major, unit.clip_r.x_min, unit.clip_r.y_min),
        high=Mux(f_x_major, unit.clip_r.x_max, unit.clip_r.y_max),
        du=Signal(unsigned(coord), name="f_du"),
        dv=Signal(unsigned(coord), name="f_dv"),
        neg_du=Signal(signed(coord + 1), name="f_neg_du"),
    )
    m.d.comb += [
        f.du.eq(Mux(f_x_major, adx, ady)),
        f.dv.eq(Mux(f_x_major, ady, adx)),
        f.neg_du.eq(Mux(f_x_major, nadx, nady)),
    ]
    f_c0, f_c1, f_lo, f_hi, e_neg, e_mag = _fold_columns(m, unit, f)
    value_base, value_neg = _orientation(unit, f, f_diff)
    return [
        r.x_major.eq(f_x_major),
        r.major_neg.eq(f.le0),  # the model: dp > 0 steps up
        r.minor_neg.eq(f.minor_neg),
        r.du.eq(f.du),
        r.dv.eq(f.dv),
        r.neg_du.eq(f.neg_du),
        r.first.eq(f_c0),
        r.last.eq(f_c1),
        r.lo.eq(f_lo),
        r.hi.eq(f_hi),
        r.i_d.eq(f_id),
        r.value_base.eq(value_base),
        r.value_neg.eq(value_neg),
        r.e_neg.eq(e_neg),
        r.e_mag_r.eq(e_mag),
        r.counter.eq(0),
        # Lane B starts with X = dv (lane A copies X and its differences in WINDOW).
        *unit.lane_b.load(
            f_id << (F - 1),
            I + F - 1,
            f.dv,
            f.dv + f.neg_du,
            f.dv + (f.neg_du << 1),
            pad=unit.schedule.lane_b_pad,
        ),
    ]


def _fold_columns(m, unit, f):
    """c0, c1, the folded window bounds lo, hi, and the sign and magnitude of e."""
    config = unit.config
    W, s = config.coord_bits, config.subpixel_bits
    S = 1 << s
    coord = W + s
    neg = f.le0

    # u = +-p is (p ^ neg) + neg on coord + 1 bits (~p = -p - 1); each sum below takes the
    # "+ neg" with its constant, so it is one carry chain after the axis's operands.
    # c0 = floor(u0 / S + 1/2) = (u0 + S/2) >> s; c1 = ceil(u1 / S - 1/2)
    # = floor((2 u1 + S - 1) / 2S) = (u1 + S/2 - 1) >> s (2 u1 + S - 1 is odd for s > 0). The
    # window's bounds fold like u: (lo, hi) = (min, max), or (-max, -min) when the major
    # axis steps down.
    def folded(p, width):
        p = Cat(p, Const(0, width + 1 - len(p))).as_signed()
        return Mux(neg, ~p, p)

    k1 = S // 2 - 1 if s else 0  # c1 = u1 when s = 0
    c0_sum = Signal(signed(coord + 2), name="f_c0_sum")  # u0 + S/2
    f_c0, f_c1 = Signal(signed(W + 2)), Signal(signed(W + 2))
    f_lo, f_hi = Signal(signed(W + 2)), Signal(signed(W + 2))
    m.d.comb += [
        c0_sum.eq(folded(f.p0, coord) + Mux(neg, S // 2 + 1, S // 2)),
        f_c0.eq(c0_sum >> s),
        f_c1.eq((folded(f.p1, coord) + Mux(neg, k1 + 1, k1)) >> s),
        f_lo.eq(Mux(neg, ~signed_widened(f.high), f.low) + neg),
        f_hi.eq(Mux(neg, ~signed_widened(f.low), f.high) + neg),
    ]
    # e = c0 S - u0 = S/2 - t in (-S/2, S/2] for t = (u0 + S/2) mod S, the sum's low bits:
    # negative when t > S/2, |e| = t - S/2 (t's low s - 1 bits) then, else S/2 - t.
    t = c0_sum[:s]
    e_neg = Signal()
    e_mag = Signal(unsigned(max(s, 1)))
    if s:
        m.d.comb += [
            e_neg.eq(t[-1] & (t[:-1] != 0)),
            e_mag.eq(Mux(e_neg, t[:-1], S // 2 - t)),
        ]
    return f_c0, f_c1, f_lo, f_hi, e_neg, e_mag


def _orientation(unit, f, f_diff):
    """I_B and the sign of I_A - I_B: a swap or one mirror flips left and right (the
    model's det)."""
    cmd = unit.cmd
    det_neg = ~f.x_major ^ f.le0 ^ f.minor_neg
    inside_is_a = (cmd.inside == 0) ^ det_neg
    # value_sign = +1 iff I_A >= I_B; I_A = I_in iff inside is A. FOLD loads it only for a
    # good command (I_in != I_out), so "I_A < I_B" is "I_in < I_out" or its negation.
    return Mux(inside_is_a, cmd.i_out, cmd.i_in), ~(inside_is_a ^ (f_diff < 0))


def window_loads(m, unit) -> list:
    """WINDOW's loads: [c0, c1] cut to the window, v0, and lane A's first pass, which
    starts at column `first`."""
    config = unit.config
    W, s = config.coord_bits, config.subpixel_bits
    cmd, r, lane_b = unit.cmd, unit.regs, unit.lane_b
    w_start_clip = Signal()
    w_cut_end = Signal()
    # lo S - u0, the offset of column lo's centre from u0 (low W + s + 1 bits): the start
    # row's offset when the window moved the first column (then in (S/2, du + S/2)).
    w_p0 = Mux(r.x_major, cmd.x0, cmd.y0)
    offset = Signal(unsigned(W + s + 1), name="clip_offset")
    # One carry chain: lo S + p0, or lo S + ~p0 + 1 (~p0 = -p0 - 1 modulo the offset's
    # bits), the + 1 in lo S's low bit, which is zero.
    step_up = ~r.major_neg
    lo_s = Cat(step_up, Const(0, s - 1), r.lo) if s else r.lo + step_up
    r_v0 = Signal(signed(W + s + 1), name="v0")
    m.d.comb += [
        w_start_clip.eq(r_start_clip(r)),
        w_cut_end.eq(r_cut_end(r)),
        offset.eq(lo_s + Mux(r.major_neg, w_p0, ~Cat(w_p0, 0))),
        r_v0.eq(w_v0(unit)),
    ]
    # Lane A's pass-1 multiplier, W + s + 2 bits: 2 (lo S - u0), or 2 |e| followed by
    # W + 1 zero bits (which the fix-up at counter s + 1 leaves unused).
    multiplier = Mux(w_start_clip, offset << 1, r.e_mag_r << (W + 2))
    return [
        r.first.eq(Mux(w_start_clip, r.lo, r.first)),
        r.last.eq(Mux(w_cut_end, r.hi, r.last)),
        r.start_clip.eq(w_start_clip),
        r.e_neg.eq(r.e_neg & ~w_start_clip),  # e > S/2 when the start moved
        r.v0_r.eq(r_v0),
        *unit.lane_a.load(
            multiplier,
            unit.pass1_long,
            lane_b.x,
            lane_b.x_du,
            lane_b.x_2du,
            pad=unit.schedule.pass1_pad,
        ),
    ]


def w_v0(unit):
    """WINDOW's v0 (``v0_r``, which it loads): the start's minor coordinate, folded."""
    r, cmd = unit.regs, unit.cmd
    q0 = Mux(r.x_major, cmd.y0, cmd.x0)
    return Mux(r.minor_neg, -q0, q0)


def r_start_clip(r):
    """WINDOW's test that the window moves the edge's first column (c0 < lo), from FOLD's
    registers."""
    return r.first < r.lo


def r_cut_end(r):
    """WINDOW's test that the window cuts the edge's end (c1 > hi), from FOLD's registers."""
    return r.last > r.hi
