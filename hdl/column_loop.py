# amaranth: UnusedElaboratable=no
"""The column loop both steppers share (`ColumnLoop`): the loop of `edgeaa.model.step.run_edge`,
one column per clock, no multiplier or divider.

`ColumnLoop` holds the bank's fields (registers or wires of the bank payload, as the stepper
chooses), the loop registers ``x, y, jq, jr, remaining``, ``active``, ``step`` and the
per-edge constants derived from the bank (`derive`); it forms the one enable of the loop and
the pipeline behind it and ``J += K`` with the remainder carried (`_advance`). The two
steppers add their column pipeline and their handover of the bank:
`edgeaa.hdl.stepper.LineStepper` (the paper's intensity writes; it copies the bank) and
`edgeaa.hdl.deltas.DeltaStepper` (the accumulation deltas; it reads the held bank live, or
copies it in the fast pipeline's core).
"""

from __future__ import annotations

import types

from amaranth.hdl import Cat, Const, Mux, Signal, signed, unsigned
from amaranth.lib import stream, wiring
from amaranth.lib.wiring import In, Out

from ..model.beat import BeatFormat
from ..model.config import EdgeConfig
from .layouts import check_config, log2, register_shape, setup_layout

__all__ = ["BankView", "ColumnLoop", "derived_shapes", "derived_values"]


class ColumnLoop(wiring.Component):
    """The shared column loop of a stepper whose output is `fmt` (its stream, its bank's
    fields, its pipeline depth ``latency``) with beats of `layout`.

    Ports: ``setup`` (in stream, `setup_layout` with the end pieces when `fmt` has them) and
    the output stream named ``fmt.stream`` (also ``out``). One enable moves everything: the
    loop and every stage advance in a clock where the output register is empty or taken
    (``~out.valid | out.ready``) and all hold otherwise; there is no combinational path from
    ``out.ready`` to ``out.valid``.

    Attributes: one per `fmt.bank_fields` entry, of the same name and width (arrays as lists:
    ``seg_thresholds``, ``seg_intercepts``), ``active`` (an edge is being stepped), ``idle``
    (nothing in the loop or the pipeline), and the observation points ``step`` (high in the
    clocks where the column held in ``x, y, jq, jr`` is stepped: those are then the model's
    `StepState` of that column), ``jsum`` (the column's ``jq + kq + carry``) and ``derived``
    (per-edge constants, name -> signal; while ``active`` each equals `derive` of the
    fields).

    Arithmetic (exact given the loop invariants ``jq < ifix``, ``jr < du``, ``khr < du``,
    ``ifix = I_d << F``): a mixed number ``q + r / du`` compares and adds as the
    concatenation ``Cat(r, q)``, the carry out of the remainder part being the model's carry,
    so the loop is one wide add per candidate (``jq + kq + carry`` and ``jq + kq + carry -
    ifix``, the row step being the sign of the second).

    A subclass gives ``start`` (the clocks the loop registers load) and `_handshake` (the
    bank's ``ready``), and elaborates its pipeline with `_control`, `_advance`, `_loop` and
    `_idle`.
    """

    def __init__(self, config: EdgeConfig, fmt: BeatFormat, layout):
        self._config = check_config(config)
        self.format = fmt
        super().__init__(
            {
                "setup": In(stream.Signature(setup_layout(config, fmt.pieces))),
                fmt.stream: Out(stream.Signature(layout)),
            }
        )
        self.out = getattr(self, fmt.stream)  # the output stream, writes or deltas
        widths = config.register_widths()
        for field in fmt.bank_fields(config):
            shape = register_shape(field.width(config))
            if field.array is None:
                setattr(self, field.name, Signal(shape, name=field.name))
            else:
                first = 1 if field.array == "thresholds" else 0  # threshold j = 1 .. N - 1
                regs = [
                    Signal(shape, name=f"{field.name[:-1]}{first + j}")
                    for j in range(field.length(config))
                ]
                setattr(self, field.name, regs)
        if config.segments <= 1:  # absent arrays (`bank_fields` leaves out length 0)
            self.seg_thresholds = []
        if config.segments == 0:
            self.seg_intercepts = []
        self.active = Signal()
        self.idle = Signal()  # nothing in the loop or the pipeline (for the pipeline's top)
        self.step = Signal()
        self.latency = fmt.pipeline_depth(config)
        self.jsum = Signal(register_shape(widths["jsum"]), name="jsum")
        self.derived = {
            name: Signal(shape, name=name) for name, shape in derived_shapes(config).items()
        }

    @property
    def config(self) -> EdgeConfig:
        return self._config

    def derive(self, regs) -> dict:
        """The derived per-edge constants as expressions of `regs` (the bank payload, or the
        stepper itself): the fields ``du, ifix, kq, kr, khq, khr, col_dx, col_dy, row_dx,
        row_dy, value_base, value_sign, seg_intercepts`` (``ifix``'s low F bits are zero)."""
        return derived_values(self._config, regs)

    def _idle(self, m, valids) -> None:
        """``idle``: no edge stepped, no column in the pipeline or the output register."""
        busy = Cat(self.active, self.out.valid, *valids).any()
        m.d.comb += self.idle.eq(~busy)

    # -- control: one enable for the loop and the pipeline ----------------------------------

    def _control(self, m):
        en = Signal()  # the output register is empty or taken: everything advances
        last = Signal()
        m.d.comb += [
            en.eq(~self.out.valid | self.out.ready),
            last.eq(self.remaining == 0),
            self.step.eq(self.active & en),
        ]
        m.d.comb += self._handshake(last)
        return en, last

    def _handshake(self, last) -> list:
        """The bank stream's ``ready`` (and the stepper's own start, if any)."""
        raise NotImplementedError

    # -- advance one column: J += K with the remainder carried; step a row when J >= 1 -------

    def _advance(self, m):
        """The loop's next ``jq, jr`` and the row step (a namespace of wires).

        carry = jr + kr >= du is the carry out of jr + (kr - du mod 2**w). The quotient's
        candidates jq + kq (+ 1) and jq + kq - ifix (+ 1) are formed in parallel with it
        (carry select); the row step is the sign of jsum - ifix."""
        widths = self._config.register_widths()
        w, acc = widths["du"].bits, widths["jq"].bits  # remainder and quotient widths
        jq, jr, k = self.jq, self.jr, types.SimpleNamespace(**self.derived)
        r_wrap = Signal(unsigned(w + 1))  # jr + kr - du (+ 2**w when no carry)
        r_plain = Signal(unsigned(w))
        carry = Signal()
        sums = [Signal(unsigned(acc + 1), name=f"jsum_c{c}") for c in (0, 1)]
        rows = [Signal(signed(acc + 2), name=f"jrow_c{c}") for c in (0, 1)]  # jsum - ifix
        row_step = Signal()
        m.d.comb += [
            r_wrap.eq(jr + k.kr_du),
            r_plain.eq(jr + self.kr),
            carry.eq(r_wrap[w]),
            sums[0].eq(jq + self.kq),
            sums[1].eq(jq + self.kq + 1),
            rows[0].eq(jq + k.kq_ifix),
            rows[1].eq(jq + k.kq_ifix + 1),
            self.jsum.eq(Mux(carry, sums[1], sums[0])),
            row_step.eq(~Mux(carry, rows[1][-1], rows[0][-1])),
        ]
        j_next = Signal(unsigned(acc))
        m.d.comb += j_next.eq(
            Mux(carry, Mux(row_step, rows[1], sums[1]), Mux(row_step, rows[0], sums[0]))
        )
        jr_next = Mux(carry, r_wrap[:w], r_plain)
        return types.SimpleNamespace(jq=j_next, jr=jr_next, row_step=row_step)

    # -- the bank's copy ---------------------------------------------------------------------

    def _load(self, m):
        """Copy the bank when it is taken: each `bank_fields` register from its field, and
        the derived constants (a stepper that copies the bank: the line stepper, and the
        deltas stepper of a format without ``live_bank``)."""
        bank = self.setup.payload
        with m.If(self.setup.valid & self.setup.ready):
            m.d.sync += self.active.eq(1)
            for field in self.format.bank_fields(self._config):
                reg = getattr(self, field.name)
                if field.array is None:
                    m.d.sync += reg.eq(bank[field.name])
                else:
                    m.d.sync += [r.eq(bank[field.name][j]) for j, r in enumerate(reg)]
            fields = BankView(bank, self._config.segments)
            for name, value in derived_values(self._config, fields).items():
                m.d.sync += self.derived[name].eq(value)

    # -- the loop registers -----------------------------------------------------------------

    def _loop(self, m, advance, last):
        k = types.SimpleNamespace(**self.derived)
        with m.If(self.step):
            m.d.sync += [
                self.jr.eq(advance.jr),
                self.jq.eq(advance.jq),
                self.x.eq(Mux(advance.row_step, self.x + k.diag_dx, self.x + self.col_dx)),
                self.y.eq(Mux(advance.row_step, self.y + k.diag_dy, self.y + self.col_dy)),
                self.remaining.eq(self.remaining - 1),
            ]
            with m.If(last):
                m.d.sync += self.active.eq(0)


def derived_shapes(config: EdgeConfig) -> dict:
    widths = config.register_widths()
    w, acc, n = widths["du"].bits, widths["jq"].bits, config.segments
    shapes = {
        "kr_du": unsigned(w),  # kr - du mod 2**w
        "kq_ifix": signed(acc + 1),  # kq - ifix
        "diag_dx": signed(2),  # col_dx + row_dx
        "diag_dy": signed(2),
        "ubase": unsigned(config.intensity_bits),  # I_B + sign * I_d = I_A
    }
    if n:
        shapes["g_inv"] = unsigned(w + acc)  # ~Cat(gr, gq), G = ifix - K/2 = gq + gr / du
        shapes["kh_inv"] = unsigned(w + acc)  # ~Cat(khr, khq)
        shapes["exit_lo"] = unsigned(w)  # khr - du mod 2**w
        shapes["above_hi"] = signed(acc + 3)  # khq - ifix (- intercept << 2 when N == 1)
        shapes["below_hi"] = signed(acc + 3)  # ~khq (+ intercept << 2 when N == 1)
    if n > 1:
        for j in range(1, n):
            shapes[f"thr_inv{j}"] = unsigned(acc + 1)  # ~threshold_j
        for j in range(n):
            shapes[f"icpt_neg{j}"] = signed(acc + 6)  # -(intercept_j << (2 + log2 N))
    return shapes


class BankView:
    """The bank payload with the array fields as lists (like the stepper's registers)."""

    def __init__(self, bank, n: int):
        self._bank = bank
        self.seg_thresholds = [bank.seg_thresholds[j] for j in range(n - 1)] if n > 1 else []
        self.seg_intercepts = [bank.seg_intercepts[j] for j in range(n)] if n else []

    def __getattr__(self, name):
        return getattr(self._bank, name)


def derived_values(config: EdgeConfig, regs) -> dict:
    """The derived per-edge constants of the stepper from the bank fields (`ColumnLoop`)."""
    F, n = config.F, config.segments
    widths = config.register_widths()
    w, acc = widths["du"].bits, widths["jq"].bits
    i_d = regs.ifix[F:]  # ifix = I_d << F
    khr_nz = regs.khr != 0
    values = {
        "kr_du": (regs.kr - regs.du)[:w],
        "kq_ifix": Cat(regs.kq[:F], regs.kq[F:] - i_d).as_signed(),
        "diag_dx": regs.col_dx + regs.row_dx,
        "diag_dy": regs.col_dy + regs.row_dy,
        "ubase": Mux(regs.value_sign < 0, regs.value_base - i_d, regs.value_base + i_d),
    }
    if n:
        # G = ifix - K/2 = gq + gr / du with 0 <= gr < du: J > G is Cat(jr, jq) > Cat(gr, gq).
        gq = regs.ifix - regs.khq - khr_nz
        gr = Mux(khr_nz, regs.du - regs.khr, 0)
        values["g_inv"] = ~Cat(gr[:w], gq[:acc])
        values["kh_inv"] = ~Cat(regs.khr, regs.khq)
        values["exit_lo"] = (regs.khr - regs.du)[:w]
        if n == 1:
            folded = regs.khq - (regs.seg_intercepts[0] << 2)  # khq - (intercept << 2)
        else:
            folded = Cat(regs.khq, Const(0, 1)).as_signed()  # khq, signed: ~ is -khq - 1
        # folded - ifix, computed on the bits above F only (ifix's low F bits are zero)
        values["above_hi"] = Cat(folded[:F], folded[F:].as_signed() - i_d).as_signed()
        values["below_hi"] = ~folded
    if n > 1:
        shift = 2 + log2(n)
        for j in range(1, n):
            values[f"thr_inv{j}"] = ~Cat(regs.seg_thresholds[j - 1], Const(0, 1))
        for j in range(n):
            values[f"icpt_neg{j}"] = -(regs.seg_intercepts[j] << shift)
    return values
