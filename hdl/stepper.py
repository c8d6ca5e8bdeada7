# amaranth: UnusedElaboratable=no
"""The line stepper (`LineStepper`): the paper's intensity writes of `edgeaa.model.step.run_edge`,
one column per clock, no multiplier or divider, on the shared `edgeaa.hdl.column_loop.ColumnLoop`.
"""

from __future__ import annotations

import types

from amaranth.hdl import Cat, Const, Module, Mux, Signal, Value, signed, unsigned

from ..model.beat import WRITES
from ..model.config import EdgeConfig
from .column_loop import ColumnLoop, derived_shapes
from .layouts import const_mul, log2, register_shape, write_layout

__all__ = ["LineStepper"]

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


class LineStepper(ColumnLoop):
    """The line stepper: the paper's intensity writes of `run_edge`, one beat per column.

    ``setup`` (in stream, `setup_layout`): the per-edge constants and start state, taken
    when the stepper is idle or in the clock it steps the current edge's last column; the
    stepper copies every bank field into its registers (`edgeaa.model.bank.bank_fields`,
    same names and widths) and derives its per-edge constants (``derived``) at that load.
    ``writes`` (out stream, `write_layout`, also ``out``): one registered beat per column.

    Latency: the column's writes are computed by a pipeline behind the loop, ``latency``
    clocks deep (`edgeaa.model.beat.WRITES.pipeline_depth`: 2 with at most one segment, 3
    with more): stages ``p1 .. p{latency - 1}`` and the ``writes`` output register, all
    moved by the loop's one enable (`ColumnLoop`), so a column stepped in clock ``c`` has its
    beat valid in clock ``c + latency`` when nothing stalls. Bubbles move like columns; a
    stalled beat keeps its payload.

    Observation points for the tests and the formal harness (attributes, not ports), besides
    `ColumnLoop`'s:

    * ``dq`` (None without segments): the column's exit depth, a wire.
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
    * ``start``: the bank's transfer (the loop registers load).

    Arithmetic: the exit tests above/below are single compares of ``Cat(jr, jq)`` with
    per-edge constants (``J > ifix - K/2`` and ``J < K/2``); the triangle estimate folds the
    intercept into the exit depth's constant (N <= 1); and the output value ``I_B + sign *
    round(area / 2**F)`` is one add of ``sign * area`` to a per-edge constant, bits ``F ..
    F + I - 1`` of the sum.
    """

    def __init__(self, config: EdgeConfig):
        super().__init__(config, WRITES, write_layout(config))
        widths = config.register_widths()
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

    @property
    def start(self):
        """High in the clocks the loop registers load from the bank: its transfer (an
        expression, whose Verilog has no wire of its own)."""
        return self.setup.valid & self.setup.ready

    def _handshake(self, last) -> list:
        """The bank is taken (and copied) when the stepper is idle or steps the current
        edge's last column."""
        return [self.setup.ready.eq(~self.active | (self.step & last))]

    def elaborate(self, platform):
        m = Module()
        en, last = self._control(m)
        advance = self._advance(m)
        col = self._column(m)
        self._stage(m, 1, en, {"valid": self.active, "last": last, **col.consts, **col.p1})
        for index in range(2, self.latency):
            prev = self.stages[index - 2]
            carried = {name: getattr(prev, name) for name in ("valid", "last", *_LANE_CONSTS)}
            self._stage(m, index, en, {**carried, **_p2(m, self.config, prev)})
        t_clamped = _estimate(m, self.config, self.stages)
        self._output(m, en, t_clamped)
        self._idle(m, [stage.valid for stage in self.stages])
        self._loop(m, advance, last)
        self._load(m)
        return m

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


# -- the triangle estimate (module functions of the stepper's stages) -------------------------


def _p2(m, config: EdgeConfig, p1) -> dict:
    """The estimate's stage p2 (N >= 2 segments): the segment's slope from p1's exit depth,
    the triangle estimate clamped at 0."""
    n = config.segments
    acc = config.register_widths()["jq"].bits
    shift = 2 + log2(n)
    seg = Signal(range(n))
    # dq >= threshold: carry out of dq + ~threshold + 1 (dq >= 0 when it is used).
    ge = [(p1.dq_[: acc + 1] + getattr(p1, f"thr_inv{j}") + 1)[acc + 1] for j in range(1, n)]
    m.d.comb += seg.eq(sum(ge))
    t = Signal(register_shape(config.register_widths()["t"]), name="t")
    with m.Switch(seg):
        for j in range(n):
            with m.Case(j):
                slope = const_mul(p1.dq_, 2 * j + 1) + getattr(p1, f"icpt_neg{j}")
                m.d.comb += t.eq(slope >> shift)
    t_clamped = Signal(unsigned(len(t) - 1))  # t clamped at 0 has no sign bit
    m.d.comb += t_clamped.eq(Mux(t < 0, 0, t))
    return {"t_clamped": t_clamped}


def _estimate(m, config: EdgeConfig, stages):
    """The clamped triangle estimate of the column in the last stage."""
    widths = config.register_widths()
    n = config.segments
    t_clamped = Signal(unsigned(widths["t"].bits - 1), name="t_clamped")
    if n == 1:
        p1 = stages[0]
        t = Signal(register_shape(widths["t"]), name="t")
        m.d.comb += t.eq(Mux(p1.above, p1.t_above, ~p1.t_below_inv))
        m.d.comb += t_clamped.eq(Mux(t < 0, 0, t))
    elif n > 1:
        m.d.comb += t_clamped.eq(stages[1].t_clamped)
    return t_clamped


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
    depth = WRITES.pipeline_depth(config)
    estimate = [{}, {}]  # the estimate's registers in p1, p2
    if n == 1:
        estimate[0] = {"t_above": signed(acc + 3), "t_below_inv": signed(acc + 3)}
    elif n > 1:
        derived = derived_shapes(config)
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
