# amaranth: UnusedElaboratable=no
"""The per-edge setup of the core (`EdgeSetupUnit`): an edge command in, one bank of stepper
constants out (the model's `edgeaa.model.edge.setup`).

In: an ``edges`` beat (`edge_layout`) and the ``clip`` window sampled with it. Out: the
``bank`` stream (`setup_layout`), valid from the clock the bank is complete until the stepper
takes it; the setup accepts its next command in that clock (a `SetupArray`'s unit in IDLE
after it: ``accept_in_hold``). A bad command (zero length or
I_in == I_out, as the model's `validate`) gives no bank: it pulses ``error`` and counts in
``errors``, and the setup is ready again two clocks after accepting it. An edge with no column
inside the window gives no bank and is not an error.

Latency: fixed per configuration, ``W + 1`` clocks longer for an edge whose start the window
cuts (`edgeaa.model.timing` owns the numbers: `run_schedule`, `run_cycles`, `final_cycles`,
`setup_interval`; the unit's RUN follows `run_schedule`). The arithmetic is two lanes of a
sequential multiply-divide unit (Horner shift-add multiplication interleaved with radix-2
restoring division, one bit per step; one step a clock, or two chained in the fast core,
``lane_steps=2``); the states, clock by clock, and the derivation of each step:
docs/hardware.md, "The setup unit, clock by clock".

Parts: the FOLD and WINDOW loads (`edgeaa.hdl.setup_fold`), the lanes and their RUN schedule
(`edgeaa.hdl.lanes`), and for the polygon core the end pieces (`EdgeSetupUnit(config,
pieces=EndPieces(config))`, `edgeaa.hdl.pieces`), which add their fields to the bank and hook
into WINDOW, RUN and FINAL (``ceil((s + 2) / 2)`` clocks instead of one);
`EdgeSetupUnit(config)` is the line core's setup.
"""

from __future__ import annotations

import types

from amaranth.hdl import Const, Module, Mux, Signal, Value, signed, unsigned
from amaranth.lib import stream, wiring
from amaranth.lib.wiring import In, Out

from ..model import timing
from ..model.config import EdgeConfig
from .lanes import MulDivLane, lane_plan
from .layouts import (
    check_config,
    clip_layout,
    const_mul,
    edge_layout,
    full_clip,
    log2,
    register_shape,
    setup_layout,
)
from .pieces import NO_END_PIECES
from .setup_fold import fold_loads, window_loads

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


def _registers(config: EdgeConfig, long_run: int) -> types.SimpleNamespace:
    """The setup's registers besides the command, the lanes and the accepted deltas
    (`long_run`: RUN's clocks for a start-clipped edge, the counter's range)."""
    widths = config.register_widths()
    W, s, I = config.coord_bits, config.subpixel_bits, config.intensity_bits  # noqa: E741
    coord = W + s

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
    * ``pieces``: the end-pieces part (`edgeaa.hdl.pieces.EndPieces`, its registers and
      hooks) of a polygon core's setup; `edgeaa.hdl.pieces.NO_END_PIECES` for the line core.
    * ``next_bank`` (`setup_layout`): the bank's payload, combinational, complete from
      FINAL's last clock on (``final_cycles`` clocks: `edgeaa.model.timing.final_cycles`).
    """

    def __init__(
        self,
        config: EdgeConfig,
        *,
        errors_bits: int = ERRORS_BITS,
        pieces=None,
        accept_in_hold: bool = True,
        lane_steps: int = 1,
    ):
        self._config = check_config(config)
        # A lone unit accepts its next command in the clock the stepper takes its bank; a
        # `SetupArray`'s never does (it is offered commands only when free), so its ready
        # need not wait for the stepper's: a long combinational path less.
        self._accept_in_hold = accept_in_hold
        # The end pieces (`edgeaa.hdl.pieces.EndPieces`) extend the bank and hook into WINDOW,
        # RUN and FINAL; the line core's setup has none.
        self.pieces = NO_END_PIECES if pieces is None else pieces
        # RUN's clocks: the lanes take `lane_steps` steps a clock (`edgeaa.hdl.lanes`; two in
        # the fast core, `edgeaa.model.beat.DELTAS_FAST`)
        self.schedule = timing.run_schedule(config, lane_steps, self.pieces.in_bank)
        bank = setup_layout(config, self.pieces.in_bank)
        if isinstance(errors_bits, bool) or not isinstance(errors_bits, int) or errors_bits < 1:
            raise TypeError(f"errors_bits must be a positive integer, not {errors_bits!r}")
        self._errors_bits = errors_bits
        super().__init__(
            {
                "edges": In(stream.Signature(edge_layout(config))),
                "clip": In(clip_layout(config), init=full_clip(config)),
                "bank": Out(stream.Signature(bank)),
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
        plan = self.schedule
        self.regs = _registers(config, plan.run + plan.start_clip)
        # The lane pass lengths in multiplier bits (`plan` has their clocks).
        self.pass1_bits = s + 1  # 2 |e| <= S
        self.pass1_long = W + s + 2  # 2 e < 2 du + S when the window moved the first column
        self.pass2_bits = I + F - s - 1  # |I_d| << (F - s - 1)
        # Lane A's quotient holds floor(2 e dv / du) <= 2 e < 2**(W + s + 2) after pass 1.
        a_bits = max(plan.pass1_pad + self.pass1_long, plan.pass2_pad + self.pass2_bits)
        self.lane_a = MulDivLane("lane_a", config, a_bits, s + 1, q_bits=self.pass1_long)
        b_bits = plan.lane_b_pad + I + F - 1  # |I_d| << (F - 1)
        self.lane_b = MulDivLane("lane_b", config, b_bits, 0)
        for state in STATES:
            setattr(self, f"in_{state.lower()}", Signal(name=f"in_{state.lower()}"))
        self.next_bank = Signal(bank, name="next_bank")
        # FINAL's clocks: one, or one per two bits of w0 for the end pieces' total0 product (the
        # core checks them against the timing model of its output).
        self.final_cycles = self.pieces.final_cycles

    @property
    def config(self) -> EdgeConfig:
        return self._config

    @property
    def errors_bits(self) -> int:
        return self._errors_bits

    def elaborate(self, platform):
        m = Module()
        accept = self._accept()
        fold = fold_loads(m, self)
        window = window_loads(m, self)
        lanes = lane_plan(m, self)
        self._final(m)
        window += self.pieces.window_loads(self)
        self.pieces.next_bank(m, self)
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
        hold_ready = self.in_hold & bank.ready if self._accept_in_hold else 0
        m.d.comb += [
            bank.payload.eq(self.next_bank),
            bank.valid.eq(self.in_hold),
            edges.ready.eq(self.in_idle | hold_ready),
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
                self.pieces.final(m, self)
            with m.State("HOLD"):
                with m.If(bank.ready):
                    m.next = "IDLE"
                if self._accept_in_hold:
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
        if lanes.a_holds is None:
            with m.Else():
                m.d.sync += lanes.a_step
        else:
            with m.Elif(~lanes.a_holds):
                m.d.sync += lanes.a_step
        self.pieces.lane_a_steps(m, self, lanes)
        with m.If(counter < lanes.b_clocks):
            m.d.sync += lanes.b_step
        b_done = counter == lanes.b_clocks
        with m.If(b_done):  # lane B is done
            m.d.sync += lanes.k_loads
        self.pieces.lane_b_steps(m, self, lanes, b_done)
        with m.If(lanes.done):
            m.next = "FINAL"
            self.pieces.run_end(m, self)
        # No column inside the window: the edge ends here, nothing is written.
        with m.If((counter == 1) & (r.columns[-1] | (r.columns == 0))):
            m.next = "IDLE"
