# amaranth: UnusedElaboratable=no
"""The per-edge setup of the core (`EdgeSetupUnit`): an edge command in, one bank of stepper
constants out (the model's `edgeaa.model.edge.setup`).

In: an ``edges`` beat (`edge_layout`) and the ``clip`` window sampled with it. Out: the
``bank`` stream (`setup_layout`), valid from the clock the bank is complete until the stepper
takes it; the setup accepts its next command in that clock. A bad command (zero length or
I_in == I_out, as the model's `validate`) gives no bank: it pulses ``error`` and counts in
``errors``, and the setup is ready again two clocks after accepting it. An edge with no column
inside the window gives no bank and is not an error.

Latency: fixed per configuration, ``W + 1`` clocks longer for an edge whose start the window
cuts (`edgeaa.model.timing` owns the numbers: `run_cycles`, `final_cycles`, `setup_interval`;
the unit checks at construction that its lane passes add up to `run_cycles`). The arithmetic
is two lanes of a sequential multiply-divide unit (Horner shift-add multiplication
interleaved with radix-2 restoring division, one bit per clock); the states, clock by clock,
and the derivation of each step: docs/hardware.md, "The setup unit, clock by clock".
"""

from __future__ import annotations

import types

from amaranth.hdl import Cat, Const, Module, Mux, Signal, Value, signed, unsigned
from amaranth.lib import stream, wiring
from amaranth.lib.wiring import In, Out

from ..model import timing
from ..model.bank import check_output
from ..model.config import EdgeConfig
from .layouts import (
    check_config,
    clip_layout,
    const_mul,
    edge_layout,
    full_clip,
    log2,
    register_shape,
    setup_layout,
    signed_widened,
)
from .pieces import (
    final_pieces,
    id_product_clear,
    id_product_steps,
    kq_product_steps,
    pieces_registers,
    run_end_loads,
    total0_steps,
)

__all__ = ["ERRORS_BITS", "EdgeSetupUnit", "MulDivLane", "accept_values"]

ERRORS_BITS = 16
STATES = ("IDLE", "FOLD", "WINDOW", "RUN", "FINAL", "HOLD")


def accept_values(config: EdgeConfig, command) -> dict:
    """The registers the setup loads from a command when it accepts it, name -> value of
    `command` (an `edge_layout` view): the bad-command flag, the deltas and their negations
    and the "delta not positive" flags. The setup loads them from the incoming payload; the
    formal harness checks them against the latched command."""
    same = (command.x0 == command.x1) & (command.y0 == command.y1)
    return {
        "bad": same | (command.i_in == command.i_out),  # zero length, or I_in == I_out
        "dx_r": command.x1 - command.x0,
        "ndx_r": command.x0 - command.x1,
        "dy_r": command.y1 - command.y0,
        "ndy_r": command.y0 - command.y1,
        "dx_le0": command.x1 <= command.x0,
        "dy_le0": command.y1 <= command.y0,
    }


def _registers(config: EdgeConfig) -> types.SimpleNamespace:
    """The setup's registers besides the command, the lanes and the accepted deltas."""
    widths = config.register_widths()
    W, s, I = config.coord_bits, config.subpixel_bits, config.intensity_bits  # noqa: E741
    coord = W + s
    long_run = timing.run_cycles(config, clipped_start=True)

    def reg(name, shape=1):
        return Signal(shape, name=name)

    return types.SimpleNamespace(
        x_major=reg("x_major"),
        major_neg=reg("major_neg"),
        minor_neg=reg("minor_neg"),
        du=reg("du", register_shape(widths["du"])),
        dv=reg("dv", register_shape(widths["du"])),
        neg_du=reg("neg_du", signed(widths["du"].bits + 1)),  # -du
        # first, last: c0, c1 from FOLD, cut to the window [lo, hi] in WINDOW.
        first=reg("first", signed(W + 2)),
        last=reg("last", signed(W + 2)),
        lo=reg("lo", signed(W + 2)),
        hi=reg("hi", signed(W + 2)),
        start_clip=reg("start_clip"),  # the window moved the first column: c0 < lo
        v0_r=reg("v0_r", signed(coord + 1)),
        columns=reg("columns", signed(W + 3)),  # last - first + 1, <= 0: none visible
        e_neg=reg("e_neg"),
        e_mag_r=reg("e_mag_r", unsigned(max(s, 1))),
        i_d=reg("i_d", unsigned(I)),
        value_base=reg("value_base", unsigned(I)),
        value_neg=reg("value_neg"),
        row0=reg("row0", signed(W + 2)),
        counter=reg("counter", range(long_run)),
        kq=reg("kq", register_shape(widths["kq"])),
        kr=reg("kr", register_shape(widths["kr"])),
    )


class EdgeSetupUnit(wiring.Component):
    """The per-edge setup: edge commands in, one bank of stepper constants per good edge out.

    ``edges`` (in stream, `edge_layout`), ``clip`` (in, `clip_layout`, sampled with the
    command), ``bank`` (out stream, `setup_layout`: valid in HOLD, ``next_bank`` of the held
    registers),
    ``errors`` (saturating count of bad commands) and ``error`` (a one-clock pulse per bad
    command). States and arithmetic: docs/hardware.md, "The setup unit, clock by clock".

    Observation points for the formal harness (attributes, not ports; all created here):

    * ``cmd``, ``clip_r``: the latched command and the window sampled with it;
    * ``accepted``: the other registers loaded at accept, name -> register; each equals
      `accept_values` of ``cmd`` until the next accept;
    * ``regs``: the fold, window and RUN registers (`_registers`: ``x_major``, ``major_neg``,
      ``minor_neg``, ``du``, ``dv``, ``neg_du``, ``first``, ``last``, ``lo``, ``hi``,
      ``start_clip``, ``v0_r``, ``columns``, ``e_neg``, ``e_mag_r``, ``i_d``,
      ``value_base``, ``value_neg``, ``row0``, ``counter``, ``kq``, ``kr``);
    * ``lane_a``, ``lane_b``: the two multiply-divide lanes (`MulDivLane`: ``q``, ``r``,
      ``a``, ``x``, ``digit``, ``x_du``, ``x_2du``, ``digit2``);
    * ``in_idle``, ``in_fold``, ``in_window``, ``in_run``, ``in_final``, ``in_hold``: the
      state;
    * ``next_bank`` (`setup_layout`): the bank's payload, combinational, complete from
      FINAL's last clock on (``final_cycles`` clocks: `edgeaa.model.timing.final_cycles`).
    """

    def __init__(
        self, config: EdgeConfig, *, errors_bits: int = ERRORS_BITS, output: str = "writes"
    ):
        self._config = check_config(config)
        self._output = check_output(output)
        if isinstance(errors_bits, bool) or not isinstance(errors_bits, int) or errors_bits < 1:
            raise TypeError(f"errors_bits must be a positive integer, not {errors_bits!r}")
        self._errors_bits = errors_bits
        super().__init__(
            {
                "edges": In(stream.Signature(edge_layout(config))),
                "clip": In(clip_layout(config), init=full_clip(config)),
                "bank": Out(stream.Signature(setup_layout(config, output))),
                "errors": Out(unsigned(errors_bits)),
                "error": Out(unsigned(1)),
            }
        )
        W, s, F = config.coord_bits, config.subpixel_bits, config.F
        I = config.intensity_bits  # noqa: E741
        self.cmd = Signal(edge_layout(config), name="cmd")
        self.clip_r = Signal(clip_layout(config), name="clip_r")
        self.accepted = {  # one register per `accept_values` entry, shaped like its value
            name: Signal(Value.cast(value).shape(), name=name)
            for name, value in accept_values(config, self.cmd).items()
        }
        self.regs = _registers(config)
        # The lane pass lengths (structure; their total is the timing model's RUN length).
        self.pass1_bits = s + 1  # 2 |e| <= S
        self.pass1_long = W + s + 2  # 2 e < 2 du + S when the window moved the first column
        self.pass2_bits = I + F - s - 1  # |I_d| << (F - s - 1)
        if self.pass1_bits + 1 + self.pass2_bits != timing.run_cycles(config):
            raise ValueError("lane A's passes and fix-up are not the timing model's RUN")
        if self.pass1_long - self.pass1_bits != timing.start_clip_cycles(config):
            raise ValueError("lane A's long first pass is not the timing model's extra clocks")
        # Lane A's quotient holds floor(2 e dv / du) <= 2 e < 2**(W + s + 2) after pass 1.
        a_bits = max(self.pass1_long, self.pass2_bits)
        self.lane_a = MulDivLane("lane_a", config, a_bits, s + 1, q_bits=self.pass1_long)
        self.lane_b = MulDivLane("lane_b", config, I + F - 1, 0)  # |I_d| << (F - 1)
        for state in STATES:
            setattr(self, f"in_{state.lower()}", Signal(name=f"in_{state.lower()}"))
        self.next_bank = Signal(setup_layout(config, output), name="next_bank")
        # The end pieces of the deltas core (`edgeaa.hdl.pieces`); None for line writes.
        self.pieces = pieces_registers(config) if output == "deltas" else None
        # FINAL's clocks: one, or one a bit of w0 for the deltas core's total0 product.
        self.final_cycles = 1 if self.pieces is None else len(self.pieces.w0)
        if self.final_cycles != timing.final_cycles(config, output):
            raise ValueError("FINAL's clocks are not the timing model's")

    @property
    def config(self) -> EdgeConfig:
        return self._config

    @property
    def errors_bits(self) -> int:
        return self._errors_bits

    @property
    def output(self) -> str:
        """The core's output this setup serves: ``"writes"`` or ``"deltas"`` (end pieces)."""
        return self._output

    def elaborate(self, platform):
        m = Module()
        accept = self._accept()
        fold = self._fold(m)
        window = self._window(m)
        lanes = self._lanes(m)
        self._final(m)
        if self.pieces is not None:
            window.append(self.pieces.cut_end.eq(r_cut_end(self.regs)))
            window += [self.pieces.k_me.eq(0), self.pieces.k_mg.eq(0)]
            final_pieces(m, self)
        self._fsm(m, accept, fold, window, lanes)
        return m

    # -- the accepted command ----------------------------------------------------------------

    def _accept(self) -> list:
        """IDLE's loads: the command, the window and `accept_values` of the command (the
        deltas and their negations are registered with it, off FOLD's paths)."""
        incoming = self.edges.payload
        values = accept_values(self._config, incoming)
        return [
            self.cmd.eq(incoming),
            self.clip_r.eq(self.clip),
            *(self.accepted[name].eq(value) for name, value in values.items()),
        ]

    # -- fold (combinational from `cmd`, registered at the end of the FOLD clock) ------------

    def _fold(self, m) -> list:
        """FOLD's loads: the folded registers, ``c0, c1`` (as first, last), the folded
        window, |e| and its sign, and lane B."""
        config = self._config
        W, s, F = config.coord_bits, config.subpixel_bits, config.F
        I = config.intensity_bits  # noqa: E741
        coord = W + s
        cmd, acc, r = self.cmd, self.accepted, self.regs
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
            low=Mux(f_x_major, self.clip_r.x_min, self.clip_r.y_min),
            high=Mux(f_x_major, self.clip_r.x_max, self.clip_r.y_max),
            du=Signal(unsigned(coord), name="f_du"),
            dv=Signal(unsigned(coord), name="f_dv"),
            neg_du=Signal(signed(coord + 1), name="f_neg_du"),
        )
        m.d.comb += [
            f.du.eq(Mux(f_x_major, adx, ady)),
            f.dv.eq(Mux(f_x_major, ady, adx)),
            f.neg_du.eq(Mux(f_x_major, nadx, nady)),
        ]
        f_c0, f_c1, f_lo, f_hi, e_neg, e_mag = self._fold_columns(m, f)
        value_base, value_neg = self._orientation(f, f_diff)
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
            *self.lane_b.load(
                f_id << (F - 1), I + F - 1, f.dv, f.dv + f.neg_du, f.dv + (f.neg_du << 1)
            ),
        ]

    def _fold_columns(self, m, f):
        """c0, c1, the folded window bounds lo, hi, and the sign and magnitude of e."""
        config = self._config
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

    def _orientation(self, f, f_diff):
        """I_B and the sign of I_A - I_B: a swap or one mirror flips left and right (the
        model's det)."""
        cmd = self.cmd
        det_neg = ~f.x_major ^ f.le0 ^ f.minor_neg
        inside_is_a = (cmd.inside == 0) ^ det_neg
        # value_sign = +1 iff I_A >= I_B; I_A = I_in iff inside is A. FOLD loads it only for a
        # good command (I_in != I_out), so "I_A < I_B" is "I_in < I_out" or its negation.
        return Mux(inside_is_a, cmd.i_out, cmd.i_in), ~(inside_is_a ^ (f_diff < 0))

    # -- WINDOW: from the registers of FOLD --------------------------------------------------

    def _window(self, m) -> list:
        """WINDOW's loads: [c0, c1] cut to the window, v0, and lane A's first pass, which
        starts at column `first`."""
        config = self._config
        W, s = config.coord_bits, config.subpixel_bits
        cmd, r, lane_b = self.cmd, self.regs, self.lane_b
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
        r_q0 = Mux(r.x_major, cmd.y0, cmd.x0)
        r_v0 = Signal(signed(W + s + 1), name="v0")
        m.d.comb += [
            w_start_clip.eq(r.first < r.lo),
            w_cut_end.eq(r_cut_end(r)),
            offset.eq(lo_s + Mux(r.major_neg, w_p0, ~Cat(w_p0, 0))),
            r_v0.eq(Mux(r.minor_neg, -r_q0, r_q0)),
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
            *self.lane_a.load(multiplier, self.pass1_long, lane_b.x, lane_b.x_du, lane_b.x_2du),
        ]

    # -- RUN: the multiply-divide lanes ------------------------------------------------------

    def _lanes(self, m) -> types.SimpleNamespace:
        """The lanes' steps, lane A's fix-up (loads of its second pass) and the end of RUN."""
        config = self._config
        s, F = config.subpixel_bits, config.F
        I = config.intensity_bits  # noqa: E741
        S = 1 << s
        r, lane_a, lane_b = self.regs, self.lane_a, self.lane_b
        run_cycles = timing.run_cycles(config)  # pass 1, fix-up, pass 2 of lane A
        long_run_cycles = timing.run_cycles(config, clipped_start=True)
        counter = r.counter
        # Fix-up (at counter s + 1, or W + s + 2 when start-clipped): lane A holds
        # q', r' = divmod(2 |e| dv, du) for e = first S - u0 (e > S/2 when start-clipped,
        # |e| <= S/2 otherwise). With 2 e dv = q du + r (floor division),
        # 2 num + den = du (2 v0 + S + q) + r, 0 <= r < du, so row0 = floor((2 v0 + S + q) / 2S)
        # and mf = m du + r, m = (2 v0 + S + q) mod 2S.
        # A negative e has |e| <= S/2, so q' <= S: its negation is formed on s + 2 bits only
        # (a short carry chain ahead of the add of big_m).
        widths = config.register_widths()
        q_neg = Signal(signed(s + 3))
        q_fix = Signal(signed(self.pass1_long + 1))
        r_fix = Signal(register_shape(widths["du"]))
        r_fix_du = Signal(signed(widths["du"].bits + 1))  # r_fix - du
        r_fix_2du = Signal(signed(widths["du"].bits + 2))  # r_fix - 2 du
        big_m = Signal(signed(config.coord_bits + s + 4))
        flip = r.e_neg & (lane_a.r != 0)
        q_small = lane_a.q[: s + 2]
        m.d.comb += [
            q_neg.eq(Mux(flip, -q_small - 1, -q_small)),
            q_fix.eq(Mux(r.e_neg, q_neg, lane_a.q[: self.pass1_long])),
            r_fix.eq(Mux(flip, r.du - lane_a.r, lane_a.r)),
            r_fix_du.eq(r_fix + r.neg_du),
            r_fix_2du.eq(r_fix + (r.neg_du << 1)),
            big_m.eq((r.v0_r << 1) + S + q_fix),
        ]
        digit = big_m[: s + 1]
        pass2 = (r_fix, r_fix_du, r_fix_2du, digit, digit + 2)
        # kq, kr = divmod(|I_d| dv << F, du) from lane B's result, registered in the clock
        # after lane B's last step (RUN, counter I + F - 1): FINAL reads the registers.
        k_bit = Signal()
        khr_less = Signal(signed(widths["khr"].bits + 2))  # 2 khr - du
        m.d.comb += [
            khr_less.eq((lane_b.r << 1) + r.neg_du),
            k_bit.eq(~khr_less[-1]),  # 2 khr >= du
        ]
        return types.SimpleNamespace(
            # The fix-up clock and the last RUN clock (constant compares, by start_clip).
            fixup=Mux(r.start_clip, counter == self.pass1_long, counter == self.pass1_bits),
            done=Mux(r.start_clip, counter == long_run_cycles - 1, counter == run_cycles - 1),
            fixup_loads=[
                r.row0.eq(big_m >> (s + 1)),
                *lane_a.load(r.i_d << (F - s - 1), self.pass2_bits, *pass2),
            ],
            a_step=lane_a.step(m, r.neg_du, "lane_a"),
            b_step=lane_b.step(m, r.neg_du, "lane_b"),
            b_bits=I + F - 1,  # lane B is done at counter I + F - 1
            # the first I clocks of pass 2 (or before the fix-up): |I_d|'s bits
            id_bits=Mux(
                r.start_clip,
                counter <= self.pass1_long + I,
                counter <= self.pass1_bits + I,
            ),
            k_bit=k_bit,
            k_loads=[
                r.kq.eq((lane_b.q << 1) + k_bit),
                r.kr.eq(Mux(k_bit, khr_less, lane_b.r << 1)),
            ],
        )

    # -- FINAL: the bank contents ------------------------------------------------------------

    def _final(self, m):
        """``next_bank``, the bank's payload, from the registers and both lanes' results."""
        config = self._config
        W, F, n = config.coord_bits, config.F, config.segments
        r, lane_a, lane_b, nb = self.regs, self.lane_a, self.lane_b, self.next_bank
        truncated = config.accumulator == "truncated"
        major, minor = Signal(signed(W + 2)), Signal(signed(W + 2))
        m.d.comb += [
            major.eq(Mux(r.major_neg, -r.first, r.first)),
            minor.eq(Mux(r.minor_neg, -r.row0, r.row0)),
        ]
        plus, minus, zero = Const(1, signed(2)), Const(-1, signed(2)), Const(0, signed(2))
        major_step = Mux(r.major_neg, minus, plus)
        minor_step = Mux(r.minor_neg, minus, plus)
        m.d.comb += [
            nb.x.eq(Mux(r.x_major, major, minor)),
            nb.y.eq(Mux(r.x_major, minor, major)),
            nb.remaining.eq(r.columns - 1),
            nb.col_dx.eq(Mux(r.x_major, major_step, zero)),
            nb.col_dy.eq(Mux(r.x_major, zero, major_step)),
            nb.row_dx.eq(Mux(r.x_major, zero, minor_step)),
            nb.row_dy.eq(Mux(r.x_major, minor_step, zero)),
            nb.du.eq(r.du),
            nb.ifix.eq(r.i_d << F),
            nb.jq.eq(lane_a.q),
            nb.jr.eq(0 if truncated else lane_a.r),
            nb.kq.eq(r.kq),
            nb.kr.eq(0 if truncated else r.kr),
            nb.khq.eq(lane_b.q),
            nb.khr.eq(0 if truncated else lane_b.r),
            nb.value_base.eq(r.value_base),
            nb.value_sign.eq(Mux(r.value_neg, minus, plus)),
        ]
        if n:  # thresholds j K / 2N and intercepts K (8 j (j + 1) + 1) / 64 N^2 (shift-adds)
            log2n = log2(n)
            for j in range(1, n):
                m.d.comb += nb.seg_thresholds[j - 1].eq(const_mul(r.kq, j) >> (log2n + 1))
            for j in range(n):
                constant = const_mul(r.kq, 8 * j * (j + 1) + 1) >> (6 + 2 * log2n)
                m.d.comb += nb.seg_intercepts[j].eq(constant)

    # -- the state machine -------------------------------------------------------------------

    def _fsm(self, m, accept, fold, window, lanes):
        bank, edges = self.bank, self.edges
        # The bank is ``next_bank`` of the registers HOLD keeps: no register of its own. The
        # next command is accepted in the clock the stepper takes the bank (the registers it
        # reads and the ones the command loads change on the same clock edge).
        m.d.comb += [
            bank.payload.eq(self.next_bank),
            bank.valid.eq(self.in_hold),
            edges.ready.eq(self.in_idle | (self.in_hold & bank.ready)),
        ]
        m.d.sync += self.error.eq(0)
        with m.FSM(name="setup") as fsm:
            with m.State("IDLE"):
                self._take(m, accept)
            with m.State("FOLD"):
                with m.If(self.accepted["bad"]):
                    m.d.sync += self.error.eq(1)
                    with m.If(self.errors != (1 << self._errors_bits) - 1):
                        m.d.sync += self.errors.eq(self.errors + 1)
                    m.next = "IDLE"
                with m.Else():
                    m.d.sync += fold
                    m.next = "WINDOW"
            with m.State("WINDOW"):
                m.d.sync += window
                m.next = "RUN"
            with m.State("RUN"):
                self._run(m, lanes)
            with m.State("FINAL"):  # next_bank complete in its last clock
                if self.pieces is None:
                    m.next = "HOLD"
                else:  # the y-major total0 product, one bit of w0 a clock
                    m.d.sync += total0_steps(self)
                    with m.If(self.regs.counter == self.final_cycles - 1):
                        m.next = "HOLD"
            with m.State("HOLD"):
                with m.If(bank.ready):
                    m.next = "IDLE"
                self._take(m, accept)
        for state in STATES:
            m.d.comb += getattr(self, f"in_{state.lower()}").eq(fsm.ongoing(state))

    def _take(self, m, accept):
        """Accept the command offered while ``edges.ready`` is high (IDLE, or HOLD's last
        clock)."""
        with m.If(self.edges.valid & self.edges.ready):
            m.d.sync += accept
            m.next = "FOLD"

    def _run(self, m, lanes):
        r = self.regs
        counter = r.counter
        m.d.sync += counter.eq(counter + 1)
        with m.If(counter == 0):
            m.d.sync += r.columns.eq(r.last - r.first + 1)
        with m.If(lanes.fixup):
            m.d.sync += lanes.fixup_loads
        with m.Else():
            m.d.sync += lanes.a_step
        if self.pieces is not None:  # the products by |I_d|: its bits lead lane A's pass 2
            with m.If(lanes.fixup):
                m.d.sync += id_product_clear(self)
            with m.Elif(lanes.id_bits):
                m.d.sync += id_product_steps(self, self.lane_a.a[-1])
        with m.If(counter < lanes.b_bits):
            m.d.sync += lanes.b_step
        b_done = counter == lanes.b_bits
        with m.If(b_done):  # lane B is done
            m.d.sync += lanes.k_loads
        if self.pieces is not None:  # the products by kq, one quotient digit a clock, then
            # k_bit (one adder each: the digit is picked before it)
            with m.If(counter <= lanes.b_bits):
                twice = Mux(b_done, 0, self.lane_b.twice)
                once = Mux(b_done, lanes.k_bit, self.lane_b.once)
                m.d.sync += kq_product_steps(self, twice, once)
        with m.If(lanes.done):
            m.next = "FINAL"
            if self.pieces is not None:  # kq, row0 and the column count are known
                m.d.sync += run_end_loads(self)
        # No column inside the window: the edge ends here, nothing is written.
        with m.If((counter == 1) & (r.columns[-1] | (r.columns == 0))):
            m.next = "IDLE"


def r_cut_end(r):
    """WINDOW's test that the window cuts the edge's end (c1 > hi), from FOLD's registers."""
    return r.last > r.hi


class MulDivLane:
    """Registers of one lane of the sequential multiply-divide unit.

    One clock of `step` performs ``V = 2 V + b X`` (b the next bit of the multiplier, MSB first)
    while keeping ``V = Q du + R`` with ``0 <= R < du``: with ``R < du`` and ``X <= du`` the new
    remainder candidate ``2 R + b X`` is below ``3 du``, so the quotient digit is 0, 1 or 2.
    ``digit`` (when b is set) adds a known multiple of ``du`` to ``V``
    (``V = 2 V + b (digit du + X)``). Trailing zero multiplier bits make it a plain restoring
    division, so ``n`` clocks give ``divmod(A X 2**k, du)`` for an ``n - k`` bit ``A``.

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

    def load(self, a, a_bits: int, x, x_du, x_2du, digit=0, digit2=2):
        """Start on the `a_bits`-bit multiplier `a` followed by ``self.a_bits - a_bits`` zero
        bits: after ``self.a_bits`` steps ``q, r = divmod(a (digit du + x) 2**k, du)``.
        `x_du`, `x_2du` and `digit2` must be ``x - du``, ``x - 2 du`` and ``digit + 2``."""
        return [
            self.q.eq(0),
            self.r.eq(0),
            self.a.eq(a << (self.a_bits - a_bits)),
            self.x.eq(x),
            self.x_du.eq(x_du),
            self.x_2du.eq(x_2du),
            self.digit.eq(digit),
            self.digit2.eq(digit2),
        ]

    def step(self, m: Module, neg_du, name: str):
        """Add the step's combinational logic to `m` (`neg_du` is ``-du``); return its
        register updates."""
        bit = self.a[-1]
        width = len(self.r) + 3
        total = Signal(unsigned(len(self.r) + 2), name=f"{name}_total")  # 2 R + b X
        less_du = Signal(signed(width), name=f"{name}_less_du")  # 2 R + b X - du
        less_2du = Signal(signed(width), name=f"{name}_less_2du")  # 2 R + b X - 2 du
        m.d.comb += [
            total.eq((self.r << 1) + Mux(bit, self.x, 0)),
            less_du.eq((self.r << 1) + Mux(bit, self.x_du, neg_du)),
            less_2du.eq((self.r << 1) + Mux(bit, self.x_2du, neg_du << 1)),
        ]
        twice, once = ~less_2du[-1], ~less_du[-1]
        self.twice, self.once = twice, once  # the step's quotient digit d (2, 1 or 0)
        # 2 Q + b digit + d: the low bits (where b digit + d lands) for each d, and the high
        # bits of 2 Q plus the carry out of the low bits (Q's high part, or it plus one).
        low_bits = len(self.digit2) + 1
        q_low = self.q[: low_bits - 1] << 1
        lows = [
            q_low + Mux(bit, self.digit, 0),
            q_low + Mux(bit, self.digit, 0) + 1,
            q_low + Mux(bit, self.digit2, 2),
        ]
        low = Signal(unsigned(low_bits + 1), name=f"{name}_q_low")
        m.d.comb += low.eq(Mux(twice, lows[2], Mux(once, lows[1], lows[0])))
        q_high = self.q[low_bits - 1 :]
        return [
            self.a.eq(self.a << 1),
            self.r.eq(Mux(twice, less_2du, Mux(once, less_du, total))),
            self.q.eq(Cat(low[:low_bits], Mux(low[low_bits], q_high + 1, q_high))),
        ]
