# amaranth: UnusedElaboratable=no
"""The edge antialiaser core: a multi-cycle per-edge setup and a one-column-per-clock stepper.

`EdgeAntialiaser` reproduces `edgeaa.model.step.run_edge` bit for bit. It has two stages:

* **Setup** (in `EdgeAntialiaser` itself): a small state machine that folds the edge into the
  first octant and computes the `EdgeSetup` fields the loop needs, using two lanes of a
  sequential multiply-divide unit (Horner shift-add multiplication interleaved with radix-2
  restoring division, one bit per clock). Its latency is fixed per configuration, and
  ``W + 1`` clocks longer for an edge whose start the clip window cuts.
* **Stepping** (`EdgeStepper`): one column per clock with an always-ready sink, using only adds,
  subtracts, compares, fixed shifts and shift-add multiplies by the small odd constants of the
  segment estimate. Its loop registers are named and sized as in `EdgeConfig.register_widths`;
  the column's writes are computed in a pipeline behind the loop (``EdgeStepper.latency`` = 2
  or 3 registers from a column's step to its beat, `edgeaa.model.timing.pipeline_depth`).

The setup result is held in a register bank (the `setup` stream of the stepper); the next
edge's setup runs while the current edge steps, and the stepper loads the bank in the same
clock as it steps its last column, so edges at least ``setup_interval`` (``R + 4`` clocks,
`edgeaa.model.timing`) columns long leave back to back with no bubble.

Setup states (``a``: the clock a command is accepted; `edgeaa.model.timing` is the exact
cycle model): IDLE (``edges.ready``; accepts the command and samples ``clip`` with it), FOLD
(``a + 1``: the fold; a bad command is dropped here, IDLE again in ``a + 2``), WINDOW
(``a + 2``: the columns cut to the window, lane A loaded), RUN (``R = I + F + 1`` clocks from
``a + 3``, ``W + 1`` more when the window cuts the start; an edge with no column inside the
window leaves RUN after its second clock, IDLE again in ``a + 5``, no bank write), FINAL
(writes the bank as soon as it is free; IDLE the clock after). So the first beat of an edge
accepted by an idle core is valid ``setup_latency = I + F + 6 + D`` clocks after it is
accepted (``D = EdgeStepper.latency``).

Timing structure (for the clock rate; no path carries more than about one wide carry chain):
the accept clock registers the command with its deltas ``x1 - x0``, ``x0 - x1`` (and for y),
the "delta not positive" flags, the bad-command flag and the clip window; FOLD picks the major
axis with one compare of the magnitudes (every choice that depends on it is formed for both
axes and selected after it: the folded flags, ``du``, ``dv``, ``c0``, ``c1`` and the folded
window bounds ``lo``, ``hi``); WINDOW cuts ``[c0, c1]`` to ``[lo, hi]`` with one compare each
and forms the clipped start offset ``lo S - u0`` (one add) and ``v0`` in parallel; the column
count is formed in the first RUN clock and tested in the second; the lanes form their three
candidate remainders and quotients in parallel; ``kq, kr`` are registered when lane B is done,
before FINAL.

Ports (``W = coord_bits``, ``s = subpixel_bits``, ``I = intensity_bits``):

* ``edges`` (in stream): ``x0, y0, x1, y1`` unsigned ``W + s`` (sub-pixel units, as
  `edgeaa.model.Edge`), ``i_in, i_out`` unsigned ``I``, ``inside`` (0: left, 1: right).
* ``clip`` (in, `clip_layout`): ``x_min, y_min, x_max, y_max`` unsigned ``W + 1``, whole
  pixels, bounds included (`edgeaa.model.Clip`); sampled in the clock an edge is accepted,
  so it may change freely otherwise. Its init (an undriven port in simulation) is the full
  window ``(0, 0, 2**W, 2**W)``, which clips nothing. In Verilog: ``clip__x_min`` etc.
* ``writes`` (out stream, one beat per column): ``lane0`` and ``lane1``, each ``x, y`` signed
  ``W + 2`` and ``value`` unsigned ``I``; ``lane1_valid``; ``last`` (the edge's last column).
  Lane order is the model's write order: the primary pixel, then its neighbour. The fields of
  ``lane1`` are don't-care (but deterministic) when ``lane1_valid`` is 0.
* ``errors`` (out, ``errors_bits`` = 16 bits by default): bad commands dropped so far,
  saturating at ``2**errors_bits - 1``.
* ``error`` (out): high for one clock when a bad command is dropped.

Bad commands: the model's `validate` rejects a zero-length edge (P0 == P1) and I_in == I_out
(out-of-range coordinates or intensities cannot be expressed on ports of exactly the width).
The core accepts such a command, detects it in its first setup clock, drops it (no pixel is
written, the stepper is not disturbed), pulses ``error``, counts it in ``errors`` and is ready
for the next command two clocks after accepting the bad one.

Clipping (the model's `Edge.clip`): only the major axis is clipped. In the folded frame
(``u = step_major * p``) the window's major-axis bounds are ``lo, hi = min, max``, or
``-max, -min`` when the major axis steps down; the edge steps the columns
``first = max(c0, lo) .. last = min(c1, hi)``. A window that cuts the end only makes the
count smaller; one that cuts the start (``c0 < lo``) starts the edge at column ``lo``, whose
start offset ``e = lo S - u0`` is up to the edge's length, so lane A's first pass takes
``W + s + 2`` clocks instead of ``s + 1``. An edge with no column inside (``last < first``,
including a window with min > max) produces no beat and is not an error (``errors`` and
``error`` are unchanged). The minor axis is not clipped: a write may land outside the window.

Setup arithmetic (all exact; proofs in the comments of `EdgeAntialiaser.elaborate`):

* fold: ``du, dv = |major delta|, |minor delta|``; ``u0, v0, u1`` the folded coordinates;
  ``c0 = (2 u0 + S) >> (s + 1)``, ``c1 = (2 u1 + S - 1) >> (s + 1)`` (= the model's
  ``-((S - 2 u1) >> (s + 1))``).
* window: ``first = max(c0, lo)``, ``last = min(c1, hi)``, ``columns = last - first + 1``
  (none visible when ``<= 0``); ``e = first S - u0``: ``|e| <= S / 2`` when ``first = c0``,
  else ``S / 2 < e < du + S / 2``.
* lane A, pass 1 (``s + 1`` clocks, or ``W + s + 2`` for ``first > c0``):
  ``q', r' = divmod(2 |e| dv, du)`` (``q' <= 2 |e| < 2**(W + s + 2)``); fix the sign of ``e``
  to get ``q, r = divmod(2 e dv, du)``; then ``M = 2 v0 + S + q``, ``row0 = M >> (s + 1)``,
  ``m = M mod 2S`` and the model's ``mf = m du + r``.
* lane A, pass 2 (``I + F - s - 1`` clocks): ``jq, jr = divmod(|I_d| mf << (F - s - 1), du)``
  computed as Horner over the bits of ``|I_d|`` with multiplicand ``r`` and the quotient digit
  ``m`` added per set bit (``mf = m du + r``).
* lane B (``I + F - 1`` clocks, in parallel): ``khq, khr = divmod(|I_d| dv << (F - 1), du)``.
* when lane B is done (RUN, counter ``I + F - 1``): ``kq = 2 khq + (2 khr >= du)``,
  ``kr = 2 khr - du (2 khr >= du)`` (exactly the model's ``divmod(|I_d| dv << F, du)``);
  FINAL: the segment constants from ``kq`` (shift-adds) and, for the truncated accumulator,
  ``jr = kr = khr = 0``.
"""

from __future__ import annotations

import types

from amaranth.hdl import Cat, Const, Module, Mux, Signal, Value, signed, unsigned
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from ..model.config import EdgeConfig, RegisterWidth

__all__ = [
    "ERRORS_BITS",
    "EdgeAntialiaser",
    "EdgeStepper",
    "clip_layout",
    "edge_layout",
    "pixel_layout",
    "setup_layout",
    "verilog",
    "write_layout",
]

ERRORS_BITS = 16


def _check_config(config) -> EdgeConfig:
    if not isinstance(config, EdgeConfig):
        raise TypeError(f"config must be an EdgeConfig, not {config!r}")
    return config


def _shape(width: RegisterWidth):
    return signed(width.bits) if width.signed else unsigned(width.bits)


def _log2(n: int) -> int:
    return n.bit_length() - 1


def _const_mul(value, k: int):
    """``value * k`` for a small non-negative constant, as shifts and adds (no $mul cell)."""
    if k == 0:
        return Const(0, 1)
    terms = [value << i for i in range(k.bit_length()) if (k >> i) & 1]
    result = terms[0]
    for term in terms[1:]:
        result = result + term
    return result


# -- payload layouts -------------------------------------------------------------------------


def edge_layout(config: EdgeConfig) -> data.StructLayout:
    """One edge command: vertices in sub-pixel units, intensities and the inside side."""
    coord = unsigned(config.coord_bits + config.subpixel_bits)
    intensity = unsigned(config.intensity_bits)
    return data.StructLayout(
        {
            "x0": coord,
            "y0": coord,
            "x1": coord,
            "y1": coord,
            "i_in": intensity,
            "i_out": intensity,
            "inside": unsigned(1),
        }
    )


def clip_layout(config: EdgeConfig) -> data.StructLayout:
    """The clip window (`edgeaa.model.Clip`): whole pixels, bounds included, each bound in
    ``[0, 2**coord_bits]``; ``x_max = y_max = 2**coord_bits`` and zero minima clip nothing."""
    bound = unsigned(config.coord_bits + 1)
    return data.StructLayout({"x_min": bound, "y_min": bound, "x_max": bound, "y_max": bound})


def _full_clip(config: EdgeConfig) -> dict[str, int]:
    """The ``clip`` value that clips nothing (`edgeaa.model.Clip.full`): the port's init."""
    top = 1 << config.coord_bits
    return {"x_min": 0, "y_min": 0, "x_max": top, "y_max": top}


def pixel_layout(config: EdgeConfig) -> data.StructLayout:
    widths = config.register_widths()
    return data.StructLayout(
        {"x": _shape(widths["x"]), "y": _shape(widths["y"]), "value": _shape(widths["value"])}
    )


def write_layout(config: EdgeConfig) -> data.StructLayout:
    """One output beat: the writes of one column (one or two pixels)."""
    pixel = pixel_layout(config)
    return data.StructLayout(
        {"lane0": pixel, "lane1": pixel, "lane1_valid": unsigned(1), "last": unsigned(1)}
    )


def setup_layout(config: EdgeConfig) -> data.StructLayout:
    """The register bank handed from the setup to the stepper (the model's `EdgeSetup`)."""
    widths = config.register_widths()
    n = config.segments
    step = signed(2)
    fields = {"x": _shape(widths["x"]), "y": _shape(widths["y"])}
    fields["remaining"] = _shape(widths["remaining"])  # columns - 1
    fields.update(col_dx=step, col_dy=step, row_dx=step, row_dy=step)
    for name in ("du", "ifix", "jq", "jr", "kq", "kr", "khq", "khr"):
        fields[name] = _shape(widths[name])
    const = _shape(widths["seg_const"])
    if n > 1:
        fields["seg_thresholds"] = data.ArrayLayout(const, n - 1)
    if n:
        fields["seg_intercepts"] = data.ArrayLayout(const, n)
    fields["value_base"] = _shape(widths["value"])
    fields["value_sign"] = signed(2)
    return data.StructLayout(fields)


# -- the stepper -----------------------------------------------------------------------------

# Registers of the stepper loaded from the bank field of the same name.
_BANK_REGISTERS = (
    *("x", "y", "remaining", "col_dx", "col_dy", "row_dx", "row_dy"),
    *("du", "ifix", "jq", "jr", "kq", "kr", "khq", "khr", "value_base", "value_sign"),
)


class EdgeStepper(wiring.Component):
    """The per-column loop of `run_edge`: one column per clock, no multiplier or divider.

    ``setup`` (in stream, `setup_layout`): the per-edge constants and start state; taken when
    the stepper is idle or in the clock it steps the current edge's last column.
    ``writes`` (out stream, `write_layout`): one registered beat per column.

    Structure: the loop registers (``x, y, jq, jr, remaining``) step one column per clock;
    the column's writes are computed by a pipeline behind them, ``latency`` clocks deep
    (`pipeline_depth`): stages ``p1 .. p{latency - 1}`` and the ``writes`` output register.
    One enable moves everything: the loop and every stage advance in a clock where the output
    register is empty or taken (``~writes.valid | writes.ready``) and all hold otherwise, so a
    column stepped in clock ``c`` has its beat valid in clock ``c + latency`` when nothing
    stalls. Bubbles (invalid stages) move like columns; there is no combinational path from
    ``writes.ready`` to ``writes.valid`` and a stalled beat keeps its payload.

    Observation points (attributes, not ports):

    * ``step`` is high in the clocks where the column held in the registers ``x, y, jq, jr``
      is stepped: those registers are then the model's `StepState` of that column.
    * ``area_step`` is high in the clocks where the column held in the last pipeline stage
      moves into the output register; ``area0`` and ``area1`` are then its scaled areas (the
      model's `Write.area`, primary first; ``area1`` don't-care for a one-pixel column). Its
      beat is valid in the next clock. ``area_step`` pulses once per column, in step order.
    * ``stage_valid[k]``, ``stage_last[k]``: stage ``p{k + 1}`` holds a column (of which the
      edge's last), ``k = 0 .. latency - 2``.
    * The loop also keeps per-edge constants derived from the bank at load (``derived``, a
      dict name -> register; `derive` gives their defining expressions): while ``active``,
      each equals `derive` applied to the stepper's own registers.

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

    def __init__(self, config: EdgeConfig):
        self._config = _check_config(config)
        super().__init__(
            {
                "setup": In(stream.Signature(setup_layout(config))),
                "writes": Out(stream.Signature(write_layout(config))),
            }
        )
        widths = config.register_widths()
        regs = ("x", "y", "remaining", "du", "ifix", "jq", "jr", "kq", "kr", "khq", "khr")
        for name in regs:
            setattr(self, name, Signal(_shape(widths[name]), name=name))
        const = _shape(widths["seg_const"])
        n = config.segments
        self.seg_thresholds = [Signal(const, name=f"seg_threshold{j}") for j in range(1, n)]
        self.seg_intercepts = [Signal(const, name=f"seg_intercept{j}") for j in range(n)]
        self.value_base = Signal(_shape(widths["value"]))
        self.value_sign = Signal(signed(2))
        self.col_dx = Signal(signed(2))
        self.col_dy = Signal(signed(2))
        self.row_dx = Signal(signed(2))
        self.row_dy = Signal(signed(2))
        self.active = Signal()
        self.step = Signal()
        self.latency = _pipeline_depth(config)
        self.stage_valid = [Signal(name=f"p{k}_valid") for k in range(1, self.latency)]
        self.stage_last = [Signal(name=f"p{k}_last") for k in range(1, self.latency)]
        # The scaled A-side areas (primary, neighbour) of the column in the last stage.
        self.area_step = Signal()
        self.area0 = Signal(_shape(widths["area"]), name="area0")
        self.area1 = Signal(_shape(widths["area"]), name="area1")
        self.derived = {
            name: Signal(shape, name=name) for name, shape in _derived_shapes(config).items()
        }

    @property
    def config(self) -> EdgeConfig:
        return self._config

    def derive(self, regs) -> dict:
        """The derived per-edge constants as expressions of `regs` (the bank payload, or the
        stepper itself): the fields ``du, ifix, kq, kr, khq, khr, col_dx, col_dy, row_dx,
        row_dy, value_base, value_sign, seg_intercepts`` (``ifix``'s low F bits are zero)."""
        return _derive(self._config, regs)

    def elaborate(self, platform):
        m = Module()
        config = self._config
        widths = config.register_widths()
        F, I, n = config.F, config.intensity_bits, config.segments  # noqa: E741
        w, acc = widths["du"].bits, widths["jq"].bits  # remainder and quotient widths
        vw = F + I  # the output value sum: bits F .. F + I - 1 are the value
        x, y, jq, jr = self.x, self.y, self.jq, self.jr
        k = types.SimpleNamespace(**self.derived)
        writes, setup = self.writes, self.setup
        depth = self.latency

        def wire(name, key=None):
            return Signal(_shape(widths[key or name]), name=name)

        # -- control: one enable for the loop and the pipeline -------------------------------
        en = Signal()  # the output register is empty or taken: everything advances
        last = Signal()
        load = Signal()
        m.d.comb += [
            en.eq(~writes.valid | writes.ready),
            last.eq(self.remaining == 0),
            self.step.eq(self.active & en),
            setup.ready.eq(~self.active | (self.step & last)),
            load.eq(setup.valid & setup.ready),
        ]

        # -- advance one column: J += K with the remainder carried; step a row when J >= 1 ---
        # carry = jr + kr >= du is the carry out of jr + (kr - du mod 2**w). The quotient's
        # candidates jq + kq (+ 1) and jq + kq - ifix (+ 1) are formed in parallel with it
        # (carry select); the row step is the sign of jsum - ifix.
        j_cat = Cat(jr, jq)
        r_wrap = Signal(unsigned(w + 1))  # jr + kr - du (+ 2**w when no carry)
        r_plain = Signal(unsigned(w))
        carry = Signal()
        jsum = wire("jsum")
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
            jsum.eq(Mux(carry, sums[1], sums[0])),
            row_step.eq(~Mux(carry, rows[1][-1], rows[0][-1])),
        ]
        j_next = Signal(unsigned(acc))
        m.d.comb += j_next.eq(
            Mux(carry, Mux(row_step, rows[1], sums[1]), Mux(row_step, rows[0], sums[0]))
        )

        # -- stage 0 (the stepping clock): from the loop registers -----------------------------
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

        # The model's exit depth of the column (an observation point: see `dq` in the table).
        if n:
            # Cat(jr, jq) + Cat(khr - du mod 2**w, khq - ifix): jq + khq + carry - ifix, the
            # exit depth above; Cat(jr, jq) + Cat(~khr, ~khq): jq - khq + borrow - 1, the
            # complement of the exit depth below (N == 1: both minus intercept << 2).
            dq = wire("dq")
            dq_above = Signal(signed(acc + 3))
            dq_below_inv = Signal(signed(acc + 3))
            m.d.comb += [
                dq_above.eq((j_cat + Cat(k.exit_lo, k.above_hi).as_signed())[w:]),
                dq_below_inv.eq((j_cat + Cat(k.kh_inv[:w], k.below_hi).as_signed())[w:]),
            ]
            if n == 1:  # an observation point only: the model's exit depth
                icpt = self.seg_intercepts[0] << 2
                m.d.comb += dq.eq(Mux(above, dq_above + icpt, ~dq_below_inv + icpt))
            else:
                m.d.comb += dq.eq(Mux(above, dq_above, ~dq_below_inv))

        # -- the pipeline registers ------------------------------------------------------------
        def stage(name, shape, value):
            """A register of the next stage loaded with `value` whenever the pipeline moves."""
            reg = Signal(shape, name=name)
            with m.If(en):
                m.d.sync += reg.eq(value)
            return reg

        valid = self.active
        is_last = last
        stages = []
        for index in range(depth - 1):
            valid = stage(f"p{index + 1}_valid_d", unsigned(1), valid)
            is_last = stage(f"p{index + 1}_last_d", unsigned(1), is_last)
            m.d.comb += [self.stage_valid[index].eq(valid), self.stage_last[index].eq(is_last)]
            stages.append(valid)

        def carry_along(prefix, values: dict, stages_: int) -> dict:
            """`values` delayed through `stages_` pipeline registers."""
            out = dict(values)
            for index in range(stages_):
                out = {
                    name: stage(f"p{index + 1}_{prefix}{name}", Value.cast(v).shape(), v)
                    for name, v in out.items()
                }
            return out

        # Per-edge constants that the later stages need (carried with the column).
        lane_consts = carry_along(
            "",
            {
                "x_": x,
                "y_": y,
                "neg": neg,
                "base": self.value_base,
                "ubase": k.ubase,
                "row_dx_": self.row_dx,
                "row_dy_": self.row_dy,
                "v0": v0,
                "above": above,
                "below": below,
                # observation only (areas): no load in the synthesised design
                "obs_jq": jq,
                "obs_ifix": self.ifix,
            },
            depth - 1,
        )
        c = types.SimpleNamespace(**lane_consts)

        # -- the triangle estimate, clamped ---------------------------------------------------
        t = wire("t") if n else None
        t_clamped = Signal(unsigned(widths["t"].bits - 1), name="t_clamped")
        if n == 1:
            # t = (d >> 2) - intercept = (d - (intercept << 2)) >> 2, the intercept folded in
            # the exit depth's constant; below, floor(-X / 4) = ~((X - 1) >> 2).
            p1 = carry_along(
                "",
                {"t_above": dq_above >> 2, "t_below_inv": dq_below_inv >> 2},
                1,
            )
            m.d.comb += t.eq(Mux(c.above, p1["t_above"], ~p1["t_below_inv"]))
            m.d.comb += t_clamped.eq(Mux(t < 0, 0, t))
        elif n > 1:
            shift = 2 + _log2(n)
            # stage 1: the exit depth of the column and the per-edge segment constants.
            p1 = carry_along(
                "",
                {
                    "dq_": dq,
                    **{f"thr_inv{j}": getattr(k, f"thr_inv{j}") for j in range(1, n)},
                    **{f"icpt_neg{j}": getattr(k, f"icpt_neg{j}") for j in range(n)},
                },
                1,
            )
            dq1 = p1["dq_"]
            seg = Signal(range(n))
            # dq >= threshold: carry out of dq + ~threshold + 1 (dq >= 0 when it is used).
            ge = [(dq1[: acc + 1] + p1[f"thr_inv{j}"] + 1)[acc + 1] for j in range(1, n)]
            m.d.comb += seg.eq(sum(ge))
            with m.Switch(seg):
                for j in range(n):
                    with m.Case(j):
                        slope = _const_mul(dq1, 2 * j + 1) + p1[f"icpt_neg{j}"]
                        m.d.comb += t.eq(slope >> shift)
            t_c = stage("p2_t_clamped", unsigned(widths["t"].bits - 1), Mux(t < 0, 0, t))
            m.d.comb += t_clamped.eq(t_c)

        # -- the last stage: areas (observation), values and lanes into the output register ----
        area0, area1 = self.area0, self.area1
        two = Signal()  # two writes: the neighbour is row + 1 (above) or row - 1 (below)
        lane1_below = Signal()
        m.d.comb += [
            two.eq(c.above | c.below),
            lane1_below.eq(~c.above & c.below),
            self.area_step.eq(stages[-1] & en),
        ]
        value0, value1 = wire("value0", "value"), wire("value1", "value")
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
        lane1_x, lane1_y = wire("lane1_x", "x"), wire("lane1_y", "y")
        m.d.comb += [
            lane1_x.eq(Mux(lane1_below, c.x_ - c.row_dx_, c.x_ + c.row_dx_)),
            lane1_y.eq(Mux(lane1_below, c.y_ - c.row_dy_, c.y_ + c.row_dy_)),
        ]
        with m.If(en):
            beat = writes.payload
            m.d.sync += [
                writes.valid.eq(stages[-1]),
                beat.lane0.x.eq(c.x_),
                beat.lane0.y.eq(c.y_),
                beat.lane0.value.eq(value0),
                beat.lane1.x.eq(lane1_x),
                beat.lane1.y.eq(lane1_y),
                beat.lane1.value.eq(value1),
                beat.lane1_valid.eq(two),
                beat.last.eq(self.stage_last[-1]),
            ]

        # -- the loop registers -----------------------------------------------------------------
        with m.If(self.step):
            m.d.sync += [
                jr.eq(Mux(carry, r_wrap[:w], r_plain)),
                jq.eq(j_next),
                x.eq(Mux(row_step, x + k.diag_dx, x + self.col_dx)),
                y.eq(Mux(row_step, y + k.diag_dy, y + self.col_dy)),
                self.remaining.eq(self.remaining - 1),
            ]
            with m.If(last):
                m.d.sync += self.active.eq(0)

        with m.If(load):
            bank = setup.payload
            m.d.sync += self.active.eq(1)
            for name in _BANK_REGISTERS:
                m.d.sync += getattr(self, name).eq(getattr(bank, name))
            for j, reg in enumerate(self.seg_thresholds):
                m.d.sync += reg.eq(bank.seg_thresholds[j])
            for j, reg in enumerate(self.seg_intercepts):
                m.d.sync += reg.eq(bank.seg_intercepts[j])
            for name, value in _derive(config, _BankFields(bank, n)).items():
                m.d.sync += self.derived[name].eq(value)
        return m


def _pipeline_depth(config: EdgeConfig) -> int:
    """Clocks from a column's step to its beat: 2 (N <= 1 segments) or 3 (N >= 2)."""
    return 2 if config.segments <= 1 else 3


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
        shift = 2 + _log2(n)
        for j in range(1, n):
            values[f"thr_inv{j}"] = ~Cat(regs.seg_thresholds[j - 1], Const(0, 1))
        for j in range(n):
            values[f"icpt_neg{j}"] = -(regs.seg_intercepts[j] << shift)
    return values


# -- the top level: setup state machine + stepper --------------------------------------------


class _MulDivLane:
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
        self.r = Signal(_shape(widths["jr"]), name=f"{name}_r")
        self.a = Signal(unsigned(a_bits), name=f"{name}_a")
        self.x = Signal(_shape(widths["du"]), name=f"{name}_x")
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


class EdgeAntialiaser(wiring.Component):
    """The edge antialiaser: edge commands in, one beat of pixel writes per column out.

    See the module docstring for the ports, the bad-command rule, clipping and the setup
    arithmetic. ``setup_latency`` is the fixed number of clocks from the clock an edge is
    accepted to the clock its first beat is valid, with the stepper idle, for an edge whose
    start the window does not cut (``start_clip_cycles`` more when it does;
    `edgeaa.model.timing`).
    """

    def __init__(self, config: EdgeConfig, *, errors_bits: int = ERRORS_BITS):
        self._config = _check_config(config)
        if isinstance(errors_bits, bool) or not isinstance(errors_bits, int) or errors_bits < 1:
            raise TypeError(f"errors_bits must be a positive integer, not {errors_bits!r}")
        self._errors_bits = errors_bits
        super().__init__(
            {
                "edges": In(stream.Signature(edge_layout(config))),
                "clip": In(clip_layout(config), init=_full_clip(config)),
                "writes": Out(stream.Signature(write_layout(config))),
                "errors": Out(unsigned(errors_bits)),
                "error": Out(unsigned(1)),
            }
        )
        self.stepper = EdgeStepper(config)

    @property
    def errors_bits(self) -> int:
        return self._errors_bits

    @property
    def config(self) -> EdgeConfig:
        return self._config

    @property
    def run_cycles(self) -> int:
        """Clocks of the multiply-divide phase (RUN) of an edge not clipped at its start:
        lane A's two passes and its fix-up clock, ``I + F + 1``."""
        config = self._config
        return config.intensity_bits + config.F + 1

    @property
    def start_clip_cycles(self) -> int:
        """Extra RUN clocks of an edge whose first column the clip window moved: lane A's
        first pass takes ``W + s + 2`` clocks instead of ``s + 1``, i.e. ``W + 1`` more."""
        return self._config.coord_bits + 1

    @property
    def setup_latency(self) -> int:
        """Clocks from accepting an edge (clock a, idle core) to its first beat, for an edge
        not clipped at its start (``start_clip_cycles`` more when it is).

        FOLD in clock a + 1, WINDOW in a + 2, RUN in a + 3 .. a + R + 2 (R = `run_cycles`),
        FINAL (bank write) in a + R + 3, stepper load in a + R + 4, column 0 stepped in
        a + R + 5, its beat valid ``D = stepper.latency`` clocks later (the output pipeline),
        in a + R + 5 + D.
        """
        return self.run_cycles + 5 + self.stepper.latency

    @property
    def setup_interval(self) -> int:
        """The fewest clocks between two accepted edges (accept, FOLD, WINDOW, RUN, FINAL),
        ``run_cycles + 4``, for edges not clipped at their start."""
        return self.run_cycles + 4

    def elaborate(self, platform):
        m = Module()
        config = self._config
        widths = config.register_widths()
        W, s, F = config.coord_bits, config.subpixel_bits, config.F
        I = config.intensity_bits  # noqa: E741
        S = 1 << s
        n = config.segments
        m.submodules.stepper = stepper = self.stepper
        wiring.connect(m, stepper.writes, wiring.flipped(self.writes))
        bank = stepper.setup

        # -- the accepted command ------------------------------------------------------------
        # The deltas and their negations are registered with the command when it is accepted,
        # and so are the "not positive" flags of the deltas, the bad-command flag and the
        # clip window.
        cmd = Signal(edge_layout(config))
        clip = Signal(clip_layout(config), name="clip_r")
        coord = W + s
        incoming = self.edges.payload
        dx_r, ndx_r = (
            Signal(signed(coord + 1), name="dx_r"),
            Signal(signed(coord + 1), name="ndx_r"),
        )
        dy_r, ndy_r = (
            Signal(signed(coord + 1), name="dy_r"),
            Signal(signed(coord + 1), name="ndy_r"),
        )
        dx_le0, dy_le0 = Signal(name="dx_le0"), Signal(name="dy_le0")  # x1 <= x0, y1 <= y0
        bad = Signal()  # the accepted command is bad: zero length, or I_in == I_out
        same = (incoming.x0 == incoming.x1) & (incoming.y0 == incoming.y1)
        accept = [
            bad.eq(same | (incoming.i_in == incoming.i_out)),
            cmd.eq(incoming),
            clip.eq(self.clip),
            dx_r.eq(incoming.x1 - incoming.x0),
            ndx_r.eq(incoming.x0 - incoming.x1),
            dy_r.eq(incoming.y1 - incoming.y0),
            ndy_r.eq(incoming.y0 - incoming.y1),
            dx_le0.eq(incoming.x1 <= incoming.x0),
            dy_le0.eq(incoming.y1 <= incoming.y0),
        ]

        # -- fold (combinational from `cmd`, registered at the end of the FOLD clock) --------
        dx, dy = Signal(signed(coord + 1)), Signal(signed(coord + 1))
        adx, ady = Signal(unsigned(coord)), Signal(unsigned(coord))
        nadx, nady = Signal(signed(coord + 1)), Signal(signed(coord + 1))  # -|dx|, -|dy|
        f_x_major = Signal()
        dp, dq = Signal(signed(coord + 1)), Signal(signed(coord + 1))
        f_major_neg, f_minor_neg = Signal(), Signal()
        f_diff = Signal(signed(I + 1))
        f_id = Signal(unsigned(I))
        m.d.comb += [
            dx.eq(dx_r),
            dy.eq(dy_r),
            adx.eq(Mux(dx < 0, ndx_r, dx)),
            ady.eq(Mux(dy < 0, ndy_r, dy)),
            nadx.eq(Mux(dx < 0, dx, ndx_r)),
            nady.eq(Mux(dy < 0, dy, ndy_r)),
            f_x_major.eq((adx + nady) >= 0),  # |dx| >= |dy|
            dp.eq(Mux(f_x_major, dx, dy)),
            dq.eq(Mux(f_x_major, dy, dx)),
            f_major_neg.eq(Mux(f_x_major, dx_le0, dy_le0)),  # the model: dp > 0 steps up
            f_minor_neg.eq(dq < 0),
            f_diff.eq(cmd.i_in - cmd.i_out),
            f_id.eq(Mux(f_diff < 0, -f_diff, f_diff)),
        ]

        # The columns and the window along the major axis: every candidate (x or y major, each
        # with its own sign) is formed in parallel with the major-axis test, which picks one.
        # c0 = floor(u0 / S + 1/2) and c1 = ceil(u1 / S - 1/2) = floor((2 u1 + S - 1) / 2S)
        # (arithmetic shifts floor); the window's bounds fold like u: (lo, hi) = (min, max),
        # or (-max, -min) when the major axis steps down.
        def first_column(p0, le0):
            return Mux(le0, (S - (p0 << 1)) >> (s + 1), ((p0 << 1) + S) >> (s + 1))

        def last_column(p1, le0):
            return Mux(le0, ((S - 1) - (p1 << 1)) >> (s + 1), ((p1 << 1) + (S - 1)) >> (s + 1))

        f_c0, f_c1 = Signal(signed(W + 2)), Signal(signed(W + 2))
        f_lo, f_hi = Signal(signed(W + 2)), Signal(signed(W + 2))
        m.d.comb += [
            f_c0.eq(Mux(f_x_major, first_column(cmd.x0, dx_le0), first_column(cmd.y0, dy_le0))),
            f_c1.eq(Mux(f_x_major, last_column(cmd.x1, dx_le0), last_column(cmd.y1, dy_le0))),
            f_lo.eq(
                Mux(
                    f_x_major,
                    Mux(dx_le0, -clip.x_max, clip.x_min),
                    Mux(dy_le0, -clip.y_max, clip.y_min),
                )
            ),
            f_hi.eq(
                Mux(
                    f_x_major,
                    Mux(dx_le0, -clip.x_min, clip.x_max),
                    Mux(dy_le0, -clip.y_min, clip.y_max),
                )
            ),
        ]

        # Orientation: a swap or one mirror flips left and right (the model's det).
        # Both candidates (x or y major) are formed in parallel with the major-axis test.
        f_value_base, f_value_neg = Signal(unsigned(I)), Signal()
        candidates = []
        for major_x, major_le0, minor_neg_ in ((0, dy_le0, dx < 0), (1, dx_le0, dy < 0)):
            det_neg = (not major_x) ^ major_le0 ^ minor_neg_
            inside_is_a = (cmd.inside == 0) ^ det_neg
            candidates.append(
                (
                    Mux(inside_is_a, cmd.i_out, cmd.i_in),
                    # value_sign = +1 iff I_A >= I_B; I_A = I_in iff inside is A.
                    Mux(inside_is_a, f_diff < 0, f_diff > 0),
                )
            )
        m.d.comb += [
            f_value_base.eq(Mux(f_x_major, candidates[1][0], candidates[0][0])),
            f_value_neg.eq(Mux(f_x_major, candidates[1][1], candidates[0][1])),
        ]

        # -- folded registers (FOLD), the window cut (WINDOW) --------------------------------
        x_major, major_neg, minor_neg = Signal(), Signal(), Signal()
        du, dv = Signal(_shape(widths["du"]), name="du"), Signal(_shape(widths["du"]), name="dv")
        neg_du = Signal(signed(widths["du"].bits + 1), name="neg_du")  # -du
        # first, last: c0, c1 from FOLD, cut to the window [lo, hi] in WINDOW.
        first = Signal(signed(W + 2), name="first")
        last = Signal(signed(W + 2), name="last")
        lo, hi = Signal(signed(W + 2), name="lo"), Signal(signed(W + 2), name="hi")
        start_clip = Signal(name="start_clip")  # the window moved the first column: c0 < lo
        v0_r = Signal(signed(coord + 1), name="v0_r")
        columns = Signal(signed(W + 3), name="columns")  # last - first + 1, <= 0: none visible
        e_neg = Signal()
        i_d = Signal(unsigned(I))
        value_base = Signal(unsigned(I))
        value_neg = Signal()
        row0 = Signal(signed(W + 2))

        # FOLD: e = c0 S - u0 (|e| <= S/2) depends on the low bits of u0 = +-p0 only: both
        # candidates (x or y major, each with its own sign) are formed in parallel with the
        # major-axis test, which picks one; |e| and the sign are registered.
        def start_offset(u0):
            """e = c0 S - u0 for c0 = floor(u0 / S + 1/2): in (-S/2, S/2]."""
            return ((((u0 << 1) + S) >> (s + 1)) << s) - u0

        e_cands, e_mag_cands = [], []
        for p0, le0 in ((cmd.y0, dy_le0), (cmd.x0, dx_le0)):
            e_cand = Signal(signed(s + 2), name=f"e_cand{len(e_cands)}")
            e_mag_cand = Signal(unsigned(max(s, 1)), name=f"e_mag_cand{len(e_cands)}")
            m.d.comb += [
                e_cand.eq(Mux(le0, start_offset(-p0), start_offset(p0))),
                e_mag_cand.eq(Mux(e_cand < 0, -e_cand, e_cand)),
            ]
            e_cands.append(e_cand)
            e_mag_cands.append(e_mag_cand)
        e = Signal(signed(s + 2))
        e_mag = Signal(unsigned(max(s, 1)))
        e_mag_r = Signal(unsigned(max(s, 1)), name="e_mag_r")
        m.d.comb += [
            e.eq(Mux(f_x_major, e_cands[1], e_cands[0])),
            e_mag.eq(Mux(f_x_major, e_mag_cands[1], e_mag_cands[0])),
        ]

        # WINDOW: from the registers of FOLD.
        w_start_clip = Signal()
        w_cut_end = Signal()
        # lo S - u0, the offset of column lo's centre from u0 (low W + s + 1 bits): the start
        # row's offset when the window moved the first column (then in (S/2, du + S/2)).
        w_p0 = Mux(x_major, cmd.x0, cmd.y0)
        offset = Signal(unsigned(W + s + 1), name="clip_offset")
        r_q0 = Mux(x_major, cmd.y0, cmd.x0)
        r_v0 = Signal(signed(coord + 1), name="v0")
        m.d.comb += [
            w_start_clip.eq(first < lo),
            w_cut_end.eq(last > hi),
            offset.eq(Mux(major_neg, (lo << s) + w_p0, (lo << s) - w_p0)),
            r_v0.eq(Mux(minor_neg, -r_q0, r_q0)),
        ]

        # -- the multiply-divide lanes -------------------------------------------------------
        pass1_bits = s + 1  # 2 |e| <= S
        pass1_long = W + s + 2  # 2 e < 2 du + S when the window moved the first column
        pass2_bits = I + F - s - 1  # |I_d| << (F - s - 1)
        # Lane A's quotient holds floor(2 e dv / du) <= 2 e < 2**(W + s + 2) after pass 1.
        lane_a = _MulDivLane(
            "lane_a", config, max(pass1_long, pass2_bits), s + 1, q_bits=pass1_long
        )
        lane_b = _MulDivLane("lane_b", config, I + F - 1, 0)  # |I_d| << (F - 1)
        run_cycles = self.run_cycles  # pass 1, fix-up, pass 2 of lane A
        long_run_cycles = run_cycles + self.start_clip_cycles
        counter = Signal(range(long_run_cycles))
        # The fix-up clock and the last RUN clock (constant compares, selected by start_clip).
        fixup = Mux(start_clip, counter == pass1_long, counter == pass1_bits)
        run_done = Mux(start_clip, counter == long_run_cycles - 1, counter == run_cycles - 1)
        # Both lanes start with X = dv: dv - du and dv - 2 du from |dx| and |dy| directly
        # (lane B in FOLD; lane A copies them from lane B in WINDOW).
        f_dv = Mux(f_x_major, ady, adx)
        f_dv_du = Mux(f_x_major, ady + nadx, adx + nady)
        f_dv_2du = Mux(f_x_major, ady + (nadx << 1), adx + (nady << 1))
        # Lane A's pass-1 multiplier, W + s + 2 bits: 2 (lo S - u0), or 2 |e| followed by
        # W + 1 zero bits (which the fix-up at counter s + 1 leaves unused).
        multiplier = Mux(w_start_clip, offset << 1, e_mag_r << (W + 2))

        # Fix-up (at counter s + 1, or W + s + 2 when start-clipped): lane A holds
        # q', r' = divmod(2 |e| dv, du) for e = first S - u0 (e > S/2 when start-clipped,
        # |e| <= S/2 otherwise). With 2 e dv = q du + r (floor division),
        # 2 num + den = du (2 v0 + S + q) + r, 0 <= r < du, so row0 = floor((2 v0 + S + q) / 2S)
        # and mf = m du + r, m = (2 v0 + S + q) mod 2S.
        # A negative e has |e| <= S/2, so q' <= S: its negation is formed on s + 2 bits only
        # (a short carry chain ahead of the add of big_m).
        q_neg = Signal(signed(s + 3))
        q_fix = Signal(signed(pass1_long + 1))
        r_fix = Signal(_shape(widths["du"]))
        r_fix_du = Signal(signed(widths["du"].bits + 1))  # r_fix - du
        r_fix_2du = Signal(signed(widths["du"].bits + 2))  # r_fix - 2 du
        big_m = Signal(signed(coord + 4))
        flip = e_neg & (lane_a.r != 0)
        q_small = lane_a.q[: s + 2]
        m.d.comb += [
            q_neg.eq(Mux(flip, -q_small - 1, -q_small)),
            q_fix.eq(Mux(e_neg, q_neg, lane_a.q[:pass1_long])),
            r_fix.eq(Mux(flip, du - lane_a.r, lane_a.r)),
            r_fix_du.eq(r_fix + neg_du),
            r_fix_2du.eq(r_fix + (neg_du << 1)),
            big_m.eq((v0_r << 1) + S + q_fix),
        ]

        # -- final: the bank contents --------------------------------------------------------
        # kq, kr = divmod(|I_d| dv << F, du) from lane B's result, registered in the clock
        # after lane B's last step (RUN, counter I + F - 1): FINAL reads the registers.
        k_bit = Signal()
        kq = Signal(_shape(widths["kq"]), name="kq")
        kr = Signal(_shape(widths["kr"]), name="kr")
        khr_less = Signal(signed(widths["khr"].bits + 2))  # 2 khr - du
        m.d.comb += [
            khr_less.eq((lane_b.r << 1) + neg_du),
            k_bit.eq(~khr_less[-1]),  # 2 khr >= du
        ]
        truncated = config.accumulator == "truncated"
        major, minor = Signal(signed(W + 2)), Signal(signed(W + 2))
        m.d.comb += [
            major.eq(Mux(major_neg, -first, first)),
            minor.eq(Mux(minor_neg, -row0, row0)),
        ]
        major_step = Mux(major_neg, Const(-1, signed(2)), Const(1, signed(2)))
        minor_step = Mux(minor_neg, Const(-1, signed(2)), Const(1, signed(2)))
        zero = Const(0, signed(2))
        final = [
            bank.payload.x.eq(Mux(x_major, major, minor)),
            bank.payload.y.eq(Mux(x_major, minor, major)),
            bank.payload.remaining.eq(columns - 1),
            bank.payload.col_dx.eq(Mux(x_major, major_step, zero)),
            bank.payload.col_dy.eq(Mux(x_major, zero, major_step)),
            bank.payload.row_dx.eq(Mux(x_major, zero, minor_step)),
            bank.payload.row_dy.eq(Mux(x_major, minor_step, zero)),
            bank.payload.du.eq(du),
            bank.payload.ifix.eq(i_d << F),
            bank.payload.jq.eq(lane_a.q),
            bank.payload.jr.eq(0 if truncated else lane_a.r),
            bank.payload.kq.eq(kq),
            bank.payload.kr.eq(0 if truncated else kr),
            bank.payload.khq.eq(lane_b.q),
            bank.payload.khr.eq(0 if truncated else lane_b.r),
            bank.payload.value_base.eq(value_base),
            bank.payload.value_sign.eq(Mux(value_neg, Const(-1, signed(2)), Const(1, signed(2)))),
        ]
        if n:  # thresholds j K / 2N and intercepts K (8 j (j + 1) + 1) / 64 N^2 (shift-adds)
            log2n = _log2(n)
            for j in range(1, n):
                final.append(
                    bank.payload.seg_thresholds[j - 1].eq(_const_mul(kq, j) >> (log2n + 1))
                )
            for j in range(n):
                constant = _const_mul(kq, 8 * j * (j + 1) + 1) >> (6 + 2 * log2n)
                final.append(bank.payload.seg_intercepts[j].eq(constant))

        # -- the setup state machine ---------------------------------------------------------
        lane_a_step = lane_a.step(m, neg_du, "lane_a")
        lane_b_step = lane_b.step(m, neg_du, "lane_b")
        with m.If(bank.ready):
            m.d.sync += bank.valid.eq(0)
        m.d.sync += self.error.eq(0)
        with m.FSM(name="setup"):
            with m.State("IDLE"):
                m.d.comb += self.edges.ready.eq(1)
                with m.If(self.edges.valid):
                    m.d.sync += accept
                    m.next = "FOLD"
            with m.State("FOLD"):
                with m.If(bad):
                    m.d.sync += self.error.eq(1)
                    with m.If(self.errors != (1 << self._errors_bits) - 1):
                        m.d.sync += self.errors.eq(self.errors + 1)
                    m.next = "IDLE"
                with m.Else():
                    m.d.sync += [
                        x_major.eq(f_x_major),
                        major_neg.eq(f_major_neg),
                        minor_neg.eq(f_minor_neg),
                        du.eq(Mux(f_x_major, adx, ady)),
                        dv.eq(f_dv),
                        neg_du.eq(Mux(f_x_major, nadx, nady)),
                        first.eq(f_c0),
                        last.eq(f_c1),
                        lo.eq(f_lo),
                        hi.eq(f_hi),
                        i_d.eq(f_id),
                        value_base.eq(f_value_base),
                        value_neg.eq(f_value_neg),
                        e_neg.eq(e < 0),
                        e_mag_r.eq(e_mag),
                        counter.eq(0),
                        *lane_b.load(f_id << (F - 1), I + F - 1, f_dv, f_dv_du, f_dv_2du),
                    ]
                    m.next = "WINDOW"
            with m.State("WINDOW"):
                # Cut [c0, c1] to the window; lane A's first pass starts at column `first`.
                m.d.sync += [
                    first.eq(Mux(w_start_clip, lo, first)),
                    last.eq(Mux(w_cut_end, hi, last)),
                    start_clip.eq(w_start_clip),
                    e_neg.eq(e_neg & ~w_start_clip),  # e > S/2 when the start moved
                    v0_r.eq(r_v0),
                    *lane_a.load(multiplier, pass1_long, lane_b.x, lane_b.x_du, lane_b.x_2du),
                ]
                m.next = "RUN"
            with m.State("RUN"):
                m.d.sync += counter.eq(counter + 1)
                with m.If(counter == 0):
                    m.d.sync += columns.eq(last - first + 1)
                with m.If(fixup):
                    digit = big_m[: s + 1]
                    m.d.sync += [
                        row0.eq(big_m >> (s + 1)),
                        *lane_a.load(
                            i_d << (F - s - 1),
                            pass2_bits,
                            r_fix,
                            r_fix_du,
                            r_fix_2du,
                            digit,
                            digit + 2,
                        ),
                    ]
                with m.Else():
                    m.d.sync += lane_a_step
                with m.If(counter < I + F - 1):
                    m.d.sync += lane_b_step
                with m.If(counter == I + F - 1):  # lane B is done
                    m.d.sync += [
                        kq.eq((lane_b.q << 1) + k_bit),
                        kr.eq(Mux(k_bit, khr_less, lane_b.r << 1)),
                    ]
                with m.If(run_done):
                    m.next = "FINAL"
                # No column inside the window: the edge ends here, nothing is written.
                with m.If((counter == 1) & (columns[-1] | (columns == 0))):
                    m.next = "IDLE"
            with m.State("FINAL"), m.If(~bank.valid | bank.ready):
                m.d.sync += [bank.valid.eq(1), *final]
                m.next = "IDLE"
        return m


# -- Verilog ---------------------------------------------------------------------------------


def _leaves(value, path):
    """(path, value) of each leaf field of a `data.View` payload (or the value itself)."""
    if isinstance(value, data.View):
        layout = data.Layout.cast(value.shape())
        for name, _field in layout:
            yield from _leaves(value[name], (*path, str(name)))
    else:
        yield path, value


def verilog(config: EdgeConfig, *, name: str = "edgeaa_core", flat: bool = True) -> str:
    """The core as Verilog (`amaranth.back.verilog.convert`, ``emit_src=False``).

    Port names are the signature paths joined by ``__``. With `flat` (the default) every
    payload field is its own port, e.g. ``edges__payload__x0``,
    ``writes__payload__lane1__value``, ``writes__payload__last``; a thin wrapper module named
    `name` connects them to the core (instantiated as ``core``). Without `flat` the core is
    converted directly and each payload is one vector port (``edges__payload``), whose fields
    appear only as internal wires.

    Lint: ``verilator --lint-only -Wall`` is clean with six waivers, all about the style of
    generated code; `edgeaa.sim.simulators.verilator.LINT_WAIVER_REASONS` lists them with
    their reasons.
    """
    from amaranth.back import verilog as back_verilog

    core = EdgeAntialiaser(config)
    if not flat:
        return back_verilog.convert(core, name=name, emit_src=False)
    m = Module()
    m.submodules.core = core
    ports = []  # (name, signal, None): the direction follows from what drives the signal
    for path, member, value in core.signature.flatten(core):
        for leaf_path, leaf in _leaves(value, tuple(map(str, path))):
            port = Signal(leaf.shape(), name="__".join(leaf_path))
            m.d.comb += leaf.eq(port) if member.flow == In else port.eq(leaf)
            ports.append((port.name, port, None))
    return back_verilog.convert(m, name=name, ports=ports, emit_src=False)
