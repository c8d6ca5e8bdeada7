# amaranth: UnusedElaboratable=no
"""The per-column loop of `edgeaa.model.step.run_edge`: one column per clock, no multiplier or
divider (`EdgeStepper`)."""

from __future__ import annotations

import types

from amaranth.hdl import Cat, Const, Module, Mux, Signal, Value, signed, unsigned
from amaranth.lib import stream, wiring
from amaranth.lib.wiring import In, Out

from ..model import timing
from ..model.bank import bank_fields, check_output
from ..model.beat import DELTA_STREAM
from ..model.config import EdgeConfig
from .deltas import delta_pipeline, delta_registers
from .layouts import check_config, const_mul, log2, output_layout, register_shape, setup_layout

__all__ = ["EdgeStepper"]

# Per-edge values carried along the output pipeline with each column (name -> register of the
# width table, or None for a one-bit flag); the stage registers are p{k}_{name}.
_LANE_CONSTS = {
    "x_": "x",
    "y_": "y",
    "neg": None,
    "base": "value",
    "ubase": None,  # unsigned(I), see `_stage_shapes`
    "row_dx_": "unit",
    "row_dy_": "unit",
    "v0": None,  # the value sum's jq term, F + I bits
    "above": None,
    "below": None,
    # observation only (areas): no load in the synthesised design
    "obs_jq": "jq",
    "obs_ifix": "ifix",
}

# The bank fields the loop steps: registers loaded from the bank (both outputs). The deltas
# stepper reads every other field from the bank payload while it steps the edge.
_LOOP_FIELDS = ("x", "y", "remaining", "jq", "jr")


class EdgeStepper(wiring.Component):
    """The per-column loop of `run_edge`: one column per clock, no multiplier or divider.

    ``setup`` (in stream, `setup_layout`): the per-edge constants and start state. Line
    writes: taken when the stepper is idle or in the clock it steps the current edge's last
    column, the stepper keeping a copy. Deltas: the stepper starts the edge (loads its loop
    registers) when the bank is valid and it is idle, reads the per-edge constants from the
    payload (which the stream holds stable while it is valid and not taken) and takes the
    bank in the clock it steps the edge's last column: the transfer means "edge done".
    ``writes`` (out stream, `write_layout`): one registered beat per column. With ``output =
    "deltas"`` the out stream is ``deltas`` (`delta_layout`, the column's accumulation
    deltas) and the column pipeline is `edgeaa.hdl.deltas`'s; ``out`` is the stream either
    way. The rest of this docstring describes the writes pipeline.

    Structure: the loop registers (``x, y, jq, jr, remaining``) step one column per clock;
    the column's writes are computed by a pipeline behind them, ``latency`` clocks deep
    (`edgeaa.model.timing.pipeline_depth`): stages ``p1 .. p{latency - 1}`` and the ``writes``
    output register. One enable moves everything: the loop and every stage advance in a clock
    where the output register is empty or taken (``~writes.valid | writes.ready``) and all
    hold otherwise, so a column stepped in clock ``c`` has its beat valid in clock
    ``c + latency`` when nothing stalls. Bubbles (invalid stages) move like columns; there is
    no combinational path from ``writes.ready`` to ``writes.valid`` and a stalled beat keeps
    its payload.

    Registers (attributes): one per `edgeaa.model.bank.bank_fields` entry, of the same name
    and width, loaded from the bank field (arrays as lists: ``seg_thresholds``,
    ``seg_intercepts``), and ``active`` (an edge is being stepped). With ``output =
    "deltas"`` only the loop's (``x, y, remaining, jq, jr``) are registers; the others are
    wires equal to the payload's fields.

    Observation points for the tests and the formal harness (attributes, not ports):

    * ``step`` is high in the clocks where the column held in the registers ``x, y, jq,
      jr`` is stepped: those registers are then the model's `StepState` of that column.
    * ``jsum`` and ``dq`` (None without segments): the column's ``jq + kq + carry`` and exit
      depth, wires of the width-table widths.
    * ``area_step`` is high in the clocks where the column held in the last pipeline stage
      moves into the output register; ``area0`` and ``area1`` are then its scaled areas (the
      model's `Write.area`, primary first; ``area1`` don't-care for a one-pixel column). Its
      beat is valid in the next clock. ``area_step`` pulses once per column, in step order.
    * ``stages[k]`` (``k = 0 .. latency - 2``): the registers of stage ``p{k + 1}``, a
      namespace with ``valid`` and ``last`` (it holds a column, the edge's last) and the
      values carried with the column (`_stage_shapes`: ``x_``, ``y_``, ``neg``, ``base``,
      ``ubase``, ``row_dx_``, ``row_dy_``, ``v0``, ``above``, ``below``, ``obs_jq``,
      ``obs_ifix``, and the estimate's: ``t_above``, ``t_below_inv`` with one segment;
      ``dq_``, ``thr_inv{j}``, ``icpt_neg{j}`` in p1 and ``t_clamped`` in p2 with more).
    * ``start``: high in the clocks the loop registers load from the bank (line writes: the
      bank's transfer; deltas: bank valid and the stepper idle).
    * ``derived``: per-edge constants derived from the bank at load (a dict name ->
      register; for deltas, wires of the payload; `derive` gives their defining
      expressions): while ``active``, each equals `derive` applied to the stepper's fields.

    Arithmetic (exact given the loop invariants ``jq < ifix``, ``jr < du``, ``khr < du``,
    ``ifix = I_d << F``): a mixed number ``q + r / du`` compares and adds as the
    concatenation ``Cat(r, q)``, the carry out of the remainder part being the model's carry.
    So the loop is one wide add per candidate (``jq + kq + carry`` and ``jq + kq + carry -
    ifix``, the row step being the sign of the second); the exit tests above/below are single
    compares of ``Cat(jr, jq)`` with per-edge constants (``J > ifix - K/2`` and ``J < K/2``);
    the triangle estimate folds the intercept into the exit depth's constant (N <= 1); and
    the output value ``I_B + sign * round(area / 2**F)`` is one add of ``sign * area`` to a
    per-edge constant, bits ``F .. F + I - 1`` of the sum.
    """

    def __init__(self, config: EdgeConfig, output: str = "writes"):
        self._config = check_config(config)
        self._output_name = check_output(output)
        stream_name = DELTA_STREAM if output == "deltas" else "writes"
        super().__init__(
            {
                "setup": In(stream.Signature(setup_layout(config, output))),
                stream_name: Out(stream.Signature(output_layout(config, output))),
            }
        )
        self.out = getattr(self, stream_name)  # the output stream, writes or deltas
        widths = config.register_widths()
        for field in bank_fields(config, output):
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
        self._start = Signal(name="start") if output == "deltas" else None
        self.idle = Signal()  # nothing in the loop or the pipeline (for the pipeline's top)
        self.step = Signal()
        self.latency = timing.pipeline_depth(config, output)
        # The deltas loop's own registers (`edgeaa.hdl.deltas`); empty for line writes.
        self.delta_regs = delta_registers(config) if output == "deltas" else {}
        self.jsum = Signal(register_shape(widths["jsum"]), name="jsum")
        self.dq = Signal(register_shape(widths["dq"]), name="dq") if config.segments else None
        self.stages = [
            types.SimpleNamespace(
                valid=Signal(name=f"p{k}_valid"),
                last=Signal(name=f"p{k}_last"),
                **{name: Signal(shape, name=f"p{k}_{name}") for name, shape in shapes.items()},
            )
            for k, shapes in enumerate(_stage_shapes(config), start=1)
        ]
        # The scaled A-side areas (primary, neighbour) of the column in the last stage.
        self.area_step = Signal()
        self.area0 = Signal(register_shape(widths["area"]), name="area0")
        self.area1 = Signal(register_shape(widths["area"]), name="area1")
        self.derived = {
            name: Signal(shape, name=name) for name, shape in _derived_shapes(config).items()
        }

    @property
    def config(self) -> EdgeConfig:
        return self._config

    @property
    def output(self) -> str:
        return self._output_name

    @property
    def start(self):
        """High in the clocks the loop registers load from the bank: the transfer for line
        writes, bank valid with the stepper idle for deltas (an expression for line writes,
        whose Verilog has no such wire)."""
        if self._start is None:
            return self.setup.valid & self.setup.ready
        return self._start

    def derive(self, regs) -> dict:
        """The derived per-edge constants as expressions of `regs` (the bank payload, or the
        stepper itself): the fields ``du, ifix, kq, kr, khq, khr, col_dx, col_dy, row_dx,
        row_dy, value_base, value_sign, seg_intercepts`` (``ifix``'s low F bits are zero)."""
        return _derive(self._config, regs)

    def elaborate(self, platform):
        m = Module()
        en, last = self._control(m)
        advance = self._advance(m)
        if self._output_name == "deltas":
            valids = delta_pipeline(m, self, en, last, advance)
            self._idle(m, valids)
            self._loop(m, advance, last)
            self._live(m)
            return m
        col = self._column(m)
        self._stage(m, 1, en, {"valid": self.active, "last": last, **col.consts, **col.p1})
        for index in range(2, self.latency):
            prev = self.stages[index - 2]
            carried = {name: getattr(prev, name) for name in ("valid", "last", *_LANE_CONSTS)}
            self._stage(m, index, en, {**carried, **self._p2(m, prev)})
        t_clamped = self._estimate(m)
        self._output(m, en, t_clamped)
        self._idle(m, [stage.valid for stage in self.stages])
        self._loop(m, advance, last)
        self._load(m)
        return m

    def _idle(self, m, valids) -> None:
        """``idle``: no edge stepped, no column in the pipeline or the output register."""
        busy = Cat(self.active, self.out.valid, *valids).any()
        m.d.comb += self.idle.eq(~busy)

    # -- control: one enable for the loop and the pipeline ----------------------------------

    def _control(self, m):
        en = Signal()  # the output register is empty or taken: everything advances
        last = Signal()
        setup, writes = self.setup, self.out
        m.d.comb += [
            en.eq(~writes.valid | writes.ready),
            last.eq(self.remaining == 0),
            self.step.eq(self.active & en),
        ]
        if self._start is None:
            m.d.comb += setup.ready.eq(~self.active | (self.step & last))
        else:  # deltas: start an edge when idle, take its bank when its last column steps
            m.d.comb += [
                self._start.eq(setup.valid & ~self.active),
                setup.ready.eq(self.step & last),
            ]
        return en, last

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

    # -- stage 0 (the stepping clock): exit tests and the values the stages carry ------------

    def _column(self, m):
        """The exit tests and the value sum's jq term of the column being stepped, and what
        stage p1 loads: the lane constants (``consts``) and the estimate's (``p1``)."""
        config = self._config
        widths = config.register_widths()
        F, I, n = config.F, config.intensity_bits, config.segments  # noqa: E741
        w, acc = widths["du"].bits, widths["jq"].bits
        vw = F + I  # the output value sum: bits F .. F + I - 1 are the value
        jq, k = self.jq, types.SimpleNamespace(**self.derived)
        j_cat = Cat(self.jr, jq)
        # The exit tests, exact: above iff J > ifix - K/2 = gq + gr/du, below iff J < K/2.
        above, below = Signal(), Signal()  # (0 without segments: one pixel per column)
        if n:
            span = w + acc
            m.d.comb += [
                above.eq((j_cat + k.g_inv)[span]),  # carry out of J + ~G: J > G
                below.eq(~(j_cat + k.kh_inv + 1)[span]),  # no carry out of J - K/2: J < K/2
            ]
        # The value sum's jq term: sign * jq + I_B 2**F + 2**(F-1) (minus 1 when sign < 0).
        neg = self.value_sign[-1]
        v0 = Signal(unsigned(vw))
        m.d.comb += v0.eq((jq ^ neg.replicate(vw)) + Cat(Const(1 << (F - 1), F), self.value_base))
        consts = {
            "x_": self.x,
            "y_": self.y,
            "neg": neg,
            "base": self.value_base,
            "ubase": k.ubase,
            "row_dx_": self.row_dx,
            "row_dy_": self.row_dy,
            "v0": v0,
            "above": above,
            "below": below,
            "obs_jq": jq,
            "obs_ifix": self.ifix,
        }
        p1 = {}
        if n:
            # Cat(jr, jq) + Cat(khr - du mod 2**w, khq - ifix): jq + khq + carry - ifix, the
            # exit depth above; Cat(jr, jq) + Cat(~khr, ~khq): jq - khq + borrow - 1, the
            # complement of the exit depth below (N == 1: both minus intercept << 2).
            dq_above = Signal(signed(acc + 3))
            dq_below_inv = Signal(signed(acc + 3))
            m.d.comb += [
                dq_above.eq((j_cat + Cat(k.exit_lo, k.above_hi).as_signed())[w:]),
                dq_below_inv.eq((j_cat + Cat(k.kh_inv[:w], k.below_hi).as_signed())[w:]),
            ]
            if n == 1:  # dq is an observation point only: the model's exit depth
                icpt = self.seg_intercepts[0] << 2
                m.d.comb += self.dq.eq(Mux(above, dq_above + icpt, ~dq_below_inv + icpt))
                # t = (d >> 2) - intercept = (d - (intercept << 2)) >> 2, the intercept folded
                # in the exit depth's constant; below, floor(-X / 4) = ~((X - 1) >> 2).
                p1 = {"t_above": dq_above >> 2, "t_below_inv": dq_below_inv >> 2}
            else:
                m.d.comb += self.dq.eq(Mux(above, dq_above, ~dq_below_inv))
                p1 = {
                    "dq_": self.dq,
                    **{f"thr_inv{j}": getattr(k, f"thr_inv{j}") for j in range(1, n)},
                    **{f"icpt_neg{j}": getattr(k, f"icpt_neg{j}") for j in range(n)},
                }
        return types.SimpleNamespace(consts=consts, p1=p1)

    # -- the pipeline registers ---------------------------------------------------------------

    def _stage(self, m, index: int, en, values: dict):
        """Load stage p{index}'s registers with `values` whenever the pipeline moves."""
        regs = self.stages[index - 1]
        assert set(values) == set(vars(regs)), (index, set(values) ^ set(vars(regs)))
        with m.If(en):
            for name, value in values.items():
                reg = getattr(regs, name)
                assert Value.cast(value).shape() == reg.shape(), (reg.name, value)
                m.d.sync += reg.eq(value)

    def _p2(self, m, p1):
        """The estimate's stage p2 (N >= 2 segments): the segment's slope from p1's exit
        depth, the triangle estimate clamped at 0."""
        n = self._config.segments
        acc = self._config.register_widths()["jq"].bits
        shift = 2 + log2(n)
        seg = Signal(range(n))
        # dq >= threshold: carry out of dq + ~threshold + 1 (dq >= 0 when it is used).
        ge = [(p1.dq_[: acc + 1] + getattr(p1, f"thr_inv{j}") + 1)[acc + 1] for j in range(1, n)]
        m.d.comb += seg.eq(sum(ge))
        t = Signal(register_shape(self._config.register_widths()["t"]), name="t")
        with m.Switch(seg):
            for j in range(n):
                with m.Case(j):
                    slope = const_mul(p1.dq_, 2 * j + 1) + getattr(p1, f"icpt_neg{j}")
                    m.d.comb += t.eq(slope >> shift)
        t_clamped = Signal(unsigned(len(t) - 1))  # t clamped at 0 has no sign bit
        m.d.comb += t_clamped.eq(Mux(t < 0, 0, t))
        return {"t_clamped": t_clamped}

    # -- the triangle estimate, clamped -------------------------------------------------------

    def _estimate(self, m):
        """The clamped triangle estimate of the column in the last stage."""
        widths = self._config.register_widths()
        n = self._config.segments
        t_clamped = Signal(unsigned(widths["t"].bits - 1), name="t_clamped")
        if n == 1:
            p1 = self.stages[0]
            t = Signal(register_shape(widths["t"]), name="t")
            m.d.comb += t.eq(Mux(p1.above, p1.t_above, ~p1.t_below_inv))
            m.d.comb += t_clamped.eq(Mux(t < 0, 0, t))
        elif n > 1:
            m.d.comb += t_clamped.eq(self.stages[1].t_clamped)
        return t_clamped

    # -- the last stage: areas (observation), values and lanes into the output register ------

    def _output(self, m, en, t_clamped):
        config = self._config
        F, I, n = config.F, config.intensity_bits, config.segments  # noqa: E741
        vw = F + I
        widths = config.register_widths()
        c = self.stages[-1]
        area0, area1 = self.area0, self.area1
        two = Signal()  # two writes: the neighbour is row + 1 (above) or row - 1 (below)
        lane1_below = Signal()
        m.d.comb += [
            two.eq(c.above | c.below),
            lane1_below.eq(~c.above & c.below),
            self.area_step.eq(c.valid & en),
        ]
        value0 = Signal(register_shape(widths["value"]), name="value0")
        value1 = Signal(register_shape(widths["value"]), name="value1")
        if n == 0:  # pw: one pixel per column, area jq
            m.d.comb += [area0.eq(c.obs_jq), value0.eq(c.v0[F:]), value1.eq(c.base)]
        else:
            with m.If(c.above):
                m.d.comb += [area0.eq(c.obs_jq - t_clamped), area1.eq(t_clamped)]
            with m.Elif(c.below):
                m.d.comb += [area0.eq(c.obs_jq + t_clamped), area1.eq(c.obs_ifix - t_clamped)]
            with m.Else():
                m.d.comb += [area0.eq(c.obs_jq), area1.eq(t_clamped)]
            # value = (v + sign * (+-t)) >> F with sign * X = (X ^ m) + m for m = [sign < 0].
            flip0 = Mux(c.above, ~c.neg, c.neg)  # lane 0: jq - t above, jq + t below
            flip1 = Mux(c.above, c.neg, ~c.neg)  # lane 1: t above, ifix - t below
            op0 = Signal(unsigned(vw))
            op1 = Signal(unsigned(vw))
            m.d.comb += [
                op0.eq(Mux(two, t_clamped ^ flip0.replicate(vw), 0)),
                op1.eq(t_clamped ^ flip1.replicate(vw)),
            ]
            # lane 1's constant: I_B 2**F + 2**(F-1) - [sign < 0], plus sign * ifix below.
            u = Cat(c.neg.replicate(F - 1), ~c.neg, Mux(c.above, c.base, c.ubase))
            sum0, sum1 = Signal(unsigned(vw)), Signal(unsigned(vw))
            m.d.comb += [
                sum0.eq(c.v0 + op0 + (two & flip0)),
                sum1.eq(u + op1 + flip1),
                value0.eq(sum0[F:]),
                value1.eq(sum1[F:]),
            ]
        lane1_x = Signal(register_shape(widths["x"]), name="lane1_x")
        lane1_y = Signal(register_shape(widths["y"]), name="lane1_y")
        m.d.comb += [
            lane1_x.eq(Mux(lane1_below, c.x_ - c.row_dx_, c.x_ + c.row_dx_)),
            lane1_y.eq(Mux(lane1_below, c.y_ - c.row_dy_, c.y_ + c.row_dy_)),
        ]
        with m.If(en):
            beat = self.writes.payload
            m.d.sync += [
                self.writes.valid.eq(c.valid),
                beat.lane0.x.eq(c.x_),
                beat.lane0.y.eq(c.y_),
                beat.lane0.value.eq(value0),
                beat.lane1.x.eq(lane1_x),
                beat.lane1.y.eq(lane1_y),
                beat.lane1.value.eq(value1),
                beat.lane1_valid.eq(two),
                beat.last.eq(c.last),
            ]

    # -- the loop registers and the bank load ------------------------------------------------

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

    def _load(self, m):
        """Load the bank: each `bank_fields` register from its field, and the derived
        constants."""
        bank = self.setup.payload
        with m.If(self.setup.valid & self.setup.ready):
            m.d.sync += self.active.eq(1)
            for field in bank_fields(self._config, self._output_name):
                reg = getattr(self, field.name)
                if field.array is None:
                    m.d.sync += reg.eq(bank[field.name])
                else:
                    m.d.sync += [r.eq(bank[field.name][j]) for j, r in enumerate(reg)]
            fields = _BankFields(bank, self._config.segments)
            for name, value in _derive(self._config, fields).items():
                m.d.sync += self.derived[name].eq(value)

    def _live(self, m):
        """Deltas: load the loop registers when an edge starts; every other field, and the
        derived constants, are wires of the bank payload, which the setup holds until the
        stepper takes it in the clock it steps the edge's last column (what the output
        pipeline needs after that clock travels in its stages)."""
        bank = self.setup.payload
        with m.If(self._start):
            m.d.sync += self.active.eq(1)
        for field in bank_fields(self._config, self._output_name):
            reg = getattr(self, field.name)
            if field.array is None:
                pairs = [(reg, bank[field.name])]
            else:
                pairs = [(r, bank[field.name][j]) for j, r in enumerate(reg)]
            for r, value in pairs:
                if field.name in _LOOP_FIELDS:
                    with m.If(self._start):
                        m.d.sync += r.eq(value)
                else:
                    m.d.comb += r.eq(value)
        for name, value in _derive(self._config, self).items():
            m.d.comb += self.derived[name].eq(value)


def _stage_shapes(config: EdgeConfig) -> list[dict]:
    """The registers of stages p1 .. p{D - 1} besides valid and last, name -> shape (D the
    pipeline depth): the lane constants in every stage, the estimate's in p1 (and p2)."""
    widths = config.register_widths()
    F, I, n = config.F, config.intensity_bits, config.segments  # noqa: E741
    acc = widths["jq"].bits
    other = {"neg": unsigned(1), "ubase": unsigned(I), "v0": unsigned(F + I)}
    other.update(above=unsigned(1), below=unsigned(1))
    consts = {
        name: register_shape(widths[key]) if key else other[name]
        for name, key in _LANE_CONSTS.items()
    }
    depth = timing.pipeline_depth(config)
    estimate = [{}, {}]  # the estimate's registers in p1, p2
    if n == 1:
        estimate[0] = {"t_above": signed(acc + 3), "t_below_inv": signed(acc + 3)}
    elif n > 1:
        derived = _derived_shapes(config)
        estimate[0] = {"dq_": register_shape(widths["dq"])}
        estimate[0].update({f"thr_inv{j}": derived[f"thr_inv{j}"] for j in range(1, n)})
        estimate[0].update({f"icpt_neg{j}": derived[f"icpt_neg{j}"] for j in range(n)})
        estimate[1] = {"t_clamped": unsigned(widths["t"].bits - 1)}
    # The estimate takes one stage with at most one segment, two with more; then the output
    # register. The timing model's depth must be that structure's.
    stages = 1 + (n > 1)
    if depth != stages + 1:
        raise ValueError(f"pipeline_depth {depth} is not the stepper's {stages + 1} stages")
    return [{**consts, **estimate[k]} for k in range(depth - 1)]


def _derived_shapes(config: EdgeConfig) -> dict:
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


class _BankFields:
    """The bank payload with the array fields as lists (like the stepper's registers)."""

    def __init__(self, bank, n: int):
        self._bank = bank
        self.seg_thresholds = [bank.seg_thresholds[j] for j in range(n - 1)] if n > 1 else []
        self.seg_intercepts = [bank.seg_intercepts[j] for j in range(n)] if n else []

    def __getattr__(self, name):
        return getattr(self._bank, name)


def _derive(config: EdgeConfig, regs) -> dict:
    """The derived per-edge constants of the stepper from the bank fields (`EdgeStepper`)."""
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
