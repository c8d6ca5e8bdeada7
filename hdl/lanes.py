"""The setup's multiply-divide lanes (`MulDivLane`) and their RUN schedule (`lane_plan`):
lane A's start-row pass, fix-up and accumulator pass, lane B's slope pass, and the ``kq, kr``
loads after lane B (`edgeaa.hdl.setup.EdgeSetupUnit` runs them). A lane takes one step a
clock, or two (radix 4: ``EdgeSetupUnit(lane_steps=2)``, the fast core's); the schedule of
their clocks and leading zero steps is `edgeaa.model.timing.run_schedule`, which the timing
model's RUN length comes from.
"""

from __future__ import annotations

import types

from amaranth.hdl import Cat, Module, Mux, Signal, signed, unsigned

from ..model.config import EdgeConfig
from .layouts import register_shape

__all__ = ["MulDivLane", "lane_plan"]


def lane_plan(m, unit) -> types.SimpleNamespace:
    """The lanes' steps, lane A's fix-up (loads of its second pass) and the end of RUN."""
    config = unit.config
    s, F = config.subpixel_bits, config.F
    S = 1 << s
    r, lane_a, lane_b = unit.regs, unit.lane_a, unit.lane_b
    plan = unit.schedule  # `edgeaa.model.timing.run_schedule`: clocks and leading zeros
    counter = r.counter
    # Fix-up (at counter `plan.pass1`, or `plan.pass1_long` when start-clipped: s + 1 and
    # W + s + 2 at one step a clock): lane A holds
    # q', r' = divmod(2 |e| dv, du) for e = first S - u0 (e > S/2 when start-clipped,
    # |e| <= S/2 otherwise). With 2 e dv = q du + r (floor division),
    # 2 num + den = du (2 v0 + S + q) + r, 0 <= r < du, so row0 = floor((2 v0 + S + q) / 2S)
    # and mf = m du + r, m = (2 v0 + S + q) mod 2S.
    # A negative e has |e| <= S/2, so q' <= S: its negation is formed on s + 2 bits only
    # (a short carry chain ahead of the add of big_m).
    widths = config.register_widths()
    q_neg = Signal(signed(s + 3))
    q_fix = Signal(signed(unit.pass1_long + 1))
    r_fix = Signal(register_shape(widths["du"]))
    r_fix_du = Signal(signed(widths["du"].bits + 1))  # r_fix - du
    r_fix_2du = Signal(signed(widths["du"].bits + 2))  # r_fix - 2 du
    big_m = Signal(signed(config.coord_bits + s + 4))
    flip = r.e_neg & (lane_a.r != 0)
    q_small = lane_a.q[: s + 2]
    m.d.comb += [
        q_neg.eq(Mux(flip, -q_small - 1, -q_small)),
        q_fix.eq(Mux(r.e_neg, q_neg, lane_a.q[: unit.pass1_long])),
        r_fix.eq(Mux(flip, r.du - lane_a.r, lane_a.r)),
        r_fix_du.eq(r_fix + r.neg_du),
        r_fix_2du.eq(r_fix + (r.neg_du << 1)),
        big_m.eq((r.v0_r << 1) + S + q_fix),
    ]
    digit = big_m[: s + 1]
    pass2 = (r_fix, r_fix_du, r_fix_2du, digit, digit + 2)
    # kq, kr = divmod(|I_d| dv << F, du) from lane B's result, registered in the clock
    # after lane B's last step (RUN, counter `plan.lane_b`: I + F - 1 at one step a clock):
    # RUN's last clock and FINAL read the registers.
    k_bit = Signal()
    khr_less = Signal(signed(widths["khr"].bits + 2))  # 2 khr - du
    m.d.comb += [
        khr_less.eq((lane_b.r << 1) + r.neg_du),
        k_bit.eq(~khr_less[-1]),  # 2 khr >= du
    ]
    long, short = plan.pass1_long, plan.pass1  # the fix-up's counter, by start_clip
    # the short first pass's last clock takes one step (the window did not move the start)
    single = (~r.start_clip & (counter == short - 1)) if plan.pass1_single else None
    ids, after = plan.id_clocks, plan.pass2 + plan.tail  # RUN's last, after the fix-up
    return types.SimpleNamespace(
        # The fix-up clock and the last RUN clock (constant compares, by start_clip).
        fixup=Mux(r.start_clip, counter == long, counter == short),
        done=Mux(r.start_clip, counter == long + after, counter == short + after),
        # lane A's tail (`RunSchedule.tail`): it holds after pass 2 (None: no tail)
        a_holds=(
            Mux(r.start_clip, counter > long + plan.pass2, counter > short + plan.pass2)
            if plan.tail
            else None
        ),
        fixup_loads=[
            r.row0.eq(big_m >> (s + 1)),
            *lane_a.load(r.i_d << (F - s - 1), unit.pass2_bits, *pass2, pad=plan.pass2_pad),
        ],
        a_step=lane_a.step(m, r.neg_du, "lane_a", plan.steps, single),
        b_step=lane_b.step(m, r.neg_du, "lane_b", plan.steps),
        b_clocks=plan.lane_b,  # lane B is done at this counter
        # pass 2's clocks with |I_d|'s bits (its first), and the last of them
        id_bits=Mux(r.start_clip, counter <= long + ids, counter <= short + ids),
        id_last=Mux(r.start_clip, counter == long + ids, counter == short + ids),
        k_bit=k_bit,
        k_loads=[
            r.kq.eq((lane_b.q << 1) + k_bit),
            r.kr.eq(Mux(k_bit, khr_less, lane_b.r << 1)),
        ],
    )


class MulDivLane:
    """Registers of one lane of the sequential multiply-divide unit.

    Each step performs ``V = 2 V + b X`` (b the next bit of the multiplier, MSB first)
    while keeping ``V = Q du + R`` with ``0 <= R < du``: with ``R < du`` and ``X <= du`` the new
    remainder candidate ``2 R + b X`` is below ``3 du``, so the quotient digit is 0, 1 or 2.
    ``digit`` (when b is set) adds a known multiple of ``du`` to ``V``
    (``V = 2 V + b (digit du + X)``). Trailing zero multiplier bits make it a plain restoring
    division, so ``n`` steps give ``divmod(A X 2**k, du)`` for an ``n - k`` bit ``A``.

    The three candidates ``2 R + b X - d du`` (d = 0, 1, 2) are formed in parallel from
    per-pass constants (``x_du = X - du``, ``x_2du = X - 2 du``; ``-du``, ``-2 du`` when b is
    clear): the digit is the largest d whose candidate is not negative. The quotient's three
    candidates ``2 Q + b digit + d`` are formed in parallel too (``digit2 = digit + 2``).
    """

    def __init__(
        self, name: str, config: EdgeConfig, a_bits: int, digit_bits: int, q_bits: int = 0
    ):
        widths = config.register_widths()
        self.a_bits = a_bits
        self.q = Signal(unsigned(max(widths["jq"].bits, q_bits)), name=f"{name}_q")
        self.r = Signal(register_shape(widths["jr"]), name=f"{name}_r")
        self.a = Signal(unsigned(a_bits), name=f"{name}_a")
        self.x = Signal(register_shape(widths["du"]), name=f"{name}_x")
        self.digit = Signal(unsigned(max(digit_bits, 1)), name=f"{name}_digit")
        du_bits = widths["du"].bits
        self.x_du = Signal(signed(du_bits + 1), name=f"{name}_x_du")  # X - du, in [-du, 0]
        self.x_2du = Signal(signed(du_bits + 2), name=f"{name}_x_2du")  # X - 2 du
        self.digit2 = Signal(unsigned(max(digit_bits, 1) + 1), name=f"{name}_digit2")

    def load(self, a, a_bits: int, x, x_du, x_2du, digit=0, digit2=2, pad: int = 0):
        """Start on the `a_bits`-bit multiplier `a` after `pad` leading zero bits and followed
        by ``self.a_bits - a_bits - pad`` zero bits: after ``self.a_bits`` steps ``q, r =
        divmod(a (digit du + x) 2**k, du)`` (a leading zero step leaves ``q = r = 0``).
        `x_du`, `x_2du` and `digit2` must be ``x - du``, ``x - 2 du`` and ``digit + 2``."""
        return [
            self.q.eq(0),
            self.r.eq(0),
            self.a.eq(a << (self.a_bits - a_bits - pad)),
            self.x.eq(x),
            self.x_du.eq(x_du),
            self.x_2du.eq(x_2du),
            self.digit.eq(digit),
            self.digit2.eq(digit2),
        ]

    def step(self, m: Module, neg_du, name: str, steps: int = 1, single=None):
        """Add `steps` (1 or 2) chained steps' combinational logic to `m` (`neg_du` is
        ``-du``); return their register updates. With two, `single` (None: never) makes a
        clock take the first step only. ``digits``: each step's quotient digit, ``(twice,
        once)`` (d = 2, 1 or 0)."""
        first = self._one_step(m, (self.r, self.q, self.a), neg_du, name)
        self.digits = [first.digit]
        after = first
        if steps == 2:
            held = (Signal.like(self.r, name=f"{name}_r1"), Signal.like(self.q, name=f"{name}_q1"))
            m.d.comb += [held[0].eq(first.r), held[1].eq(first.q)]
            second = self._one_step(m, (*held, first.a), neg_du, f"{name}_2")
            self.digits.append(second.digit)
            if single is None:
                after = second
            else:
                after = types.SimpleNamespace(
                    r=Mux(single, first.r, second.r),
                    q=Mux(single, first.q, second.q),
                    a=Mux(single, first.a, second.a),
                )
        return [self.a.eq(after.a), self.r.eq(after.r), self.q.eq(after.q)]

    def _one_step(self, m: Module, state, neg_du, name: str) -> types.SimpleNamespace:
        """One step from `state` (``r, q, a``): the next ``r, q, a`` and the digit."""
        r, q, a = state
        bit = a[-1]
        width = len(r) + 3
        total = Signal(unsigned(len(r) + 2), name=f"{name}_total")  # 2 R + b X
        less_du = Signal(signed(width), name=f"{name}_less_du")  # 2 R + b X - du
        less_2du = Signal(signed(width), name=f"{name}_less_2du")  # 2 R + b X - 2 du
        m.d.comb += [
            total.eq((r << 1) + Mux(bit, self.x, 0)),
            less_du.eq((r << 1) + Mux(bit, self.x_du, neg_du)),
            less_2du.eq((r << 1) + Mux(bit, self.x_2du, neg_du << 1)),
        ]
        twice, once = ~less_2du[-1], ~less_du[-1]
        # 2 Q + b digit + d: the low bits (where b digit + d lands) for each d, and the high
        # bits of 2 Q plus the carry out of the low bits (Q's high part, or it plus one).
        low_bits = len(self.digit2) + 1
        q_low = q[: low_bits - 1] << 1
        lows = [
            q_low + Mux(bit, self.digit, 0),
            q_low + Mux(bit, self.digit, 0) + 1,
            q_low + Mux(bit, self.digit2, 2),
        ]
        low = Signal(unsigned(low_bits + 1), name=f"{name}_q_low")
        m.d.comb += low.eq(Mux(twice, lows[2], Mux(once, lows[1], lows[0])))
        q_high = q[low_bits - 1 :]
        return types.SimpleNamespace(
            a=(a << 1)[: len(a)],
            r=Mux(twice, less_2du, Mux(once, less_du, total)),
            q=Cat(low[:low_bits], Mux(low[low_bits], q_high + 1, q_high)),
            digit=(twice, once),
        )
