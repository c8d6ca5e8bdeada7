# amaranth: UnusedElaboratable=no
"""The edge antialiaser core: a multi-cycle per-edge setup and a one-column-per-clock stepper.

`EdgeAntialiaser` reproduces `edgeaa.model.step.run_edge` bit for bit. It has two stages:

* **Setup** (in `EdgeAntialiaser` itself): a small state machine that folds the edge into the
  first octant and computes the `EdgeSetup` fields the loop needs, using two lanes of a
  sequential multiply-divide unit (Horner shift-add multiplication interleaved with radix-2
  restoring division, one bit per clock). Its latency is fixed per configuration.
* **Stepping** (`EdgeStepper`): one column per clock with an always-ready sink, using only adds,
  subtracts, compares, fixed shifts and shift-add multiplies by the small odd constants of the
  segment estimate. Its registers are named and sized as in `EdgeConfig.register_widths`.

The setup result is held in a register bank (the `setup` stream of the stepper); the next
edge's setup runs while the current edge steps, and the stepper loads the bank in the same
clock as it steps its last column, so edges at least ``setup_latency - 2`` columns long leave
back to back with no bubble.

Ports (``W = coord_bits``, ``s = subpixel_bits``, ``I = intensity_bits``):

* ``edges`` (in stream): ``x0, y0, x1, y1`` unsigned ``W + s`` (sub-pixel units, as
  `edgeaa.model.Edge`), ``i_in, i_out`` unsigned ``I``, ``inside`` (0: left, 1: right).
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

Setup arithmetic (all exact; proofs in the comments of `EdgeAntialiaser.elaborate`):

* fold: ``du, dv = |major delta|, |minor delta|``; ``u0, v0, u1`` the folded coordinates;
  ``c0 = (2 u0 + S) >> (s + 1)``, ``c1 = -((S - 2 u1) >> (s + 1))``, ``e = c0 S - u0``
  (``|e| <= S / 2``).
* lane A, pass 1 (``s + 1`` clocks): ``q', r' = divmod(2 |e| dv, du)``; fix the sign of ``e``
  to get ``q, r = divmod(2 e dv, du)``; then ``M = 2 v0 + S + q``, ``row0 = M >> (s + 1)``,
  ``m = M mod 2S`` and the model's ``mf = m du + r``.
* lane A, pass 2 (``I + F - s - 1`` clocks): ``jq, jr = divmod(|I_d| mf << (F - s - 1), du)``
  computed as Horner over the bits of ``|I_d|`` with multiplicand ``r`` and the quotient digit
  ``m`` added per set bit (``mf = m du + r``).
* lane B (``I + F - 1`` clocks, in parallel): ``khq, khr = divmod(|I_d| dv << (F - 1), du)``.
* last clock: ``kq = 2 khq + (2 khr >= du)``, ``kr = 2 khr - du (2 khr >= du)`` (exactly the
  model's ``divmod(|I_d| dv << F, du)``), the segment constants from ``kq`` (shift-adds) and,
  for the truncated accumulator, ``jr = kr = khr = 0``.
"""

from __future__ import annotations

from amaranth.hdl import Const, Module, Mux, Signal, signed, unsigned
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from ..model.config import EdgeConfig, RegisterWidth

__all__ = [
    "ERRORS_BITS",
    "EdgeAntialiaser",
    "EdgeStepper",
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
    ``writes`` (out stream, `write_layout`): one registered beat per column. When ``writes`` is
    stalled the stepper holds its state and the beat (valid stays high, payload stable).

    ``step`` (an attribute, not a port) is high in the clocks where the column held in the
    registers ``x, y, jq, jr`` is stepped: the model's `StepState` of that column; ``area0``
    and ``area1`` are then its scaled areas (the model's `Write.area`, primary first).
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
        # The column's scaled A-side areas (primary, neighbour): the model's `Write.area`.
        self.area0 = Signal(_shape(widths["area"]), name="area0")
        self.area1 = Signal(_shape(widths["area"]), name="area1")

    @property
    def config(self) -> EdgeConfig:
        return self._config

    def elaborate(self, platform):
        m = Module()
        config = self._config
        widths = config.register_widths()
        F, n = config.F, config.segments  # noqa: N806
        x, y, jq, jr = self.x, self.y, self.jq, self.jr
        du, ifix = self.du, self.ifix

        def wire(name, key=None):
            return Signal(_shape(widths[key or name]), name=name)

        # -- the column's writes (the model's `column_areas`) --------------------------------
        area0, area1 = self.area0, self.area1
        lane1_valid = Signal()
        lane1_below = Signal()  # the neighbour is row - 1 (else row + 1)
        if n == 0:  # pw: one pixel per column
            m.d.comb += area0.eq(jq)
        else:
            # d = J + K/2 - ifix (exit through the far boundary), exact with the remainder.
            rsum_a = Signal(unsigned(widths["du"].bits + 1))
            carry_a = Signal()
            dq_above, dr_above = wire("dq_above", "dq"), wire("dr_above", "dr")
            m.d.comb += [
                rsum_a.eq(jr + self.khr),
                carry_a.eq(rsum_a >= du),
                dq_above.eq(jq + self.khq + carry_a - ifix),
                dr_above.eq(rsum_a - Mux(carry_a, du, 0)),
            ]
            above = (dq_above > 0) | ((dq_above == 0) & (dr_above != 0))
            # d = K/2 - J (entry through the near boundary).
            borrow = Signal()
            dq_below, dr_below = wire("dq_below", "dq"), wire("dr_below", "dr")
            m.d.comb += [
                borrow.eq(self.khr < jr),
                dq_below.eq(self.khq - jq - borrow),
                dr_below.eq(self.khr - jr + Mux(borrow, du, 0)),
            ]
            below = (dq_below > 0) | ((dq_below == 0) & (dr_below != 0))
            dq = wire("dq")
            m.d.comb += dq.eq(Mux(above, dq_above, dq_below))

            # Triangle estimate: on segment j, ((2j + 1) d >> (2 + log2 N)) - intercept_j.
            t = wire("t")
            shift = 2 + _log2(n)
            if n == 1:
                m.d.comb += t.eq((dq >> shift) - self.seg_intercepts[0])
            else:
                seg = Signal(range(n))
                m.d.comb += seg.eq(sum(dq >= threshold for threshold in self.seg_thresholds))
                with m.Switch(seg):
                    for j in range(n):
                        with m.Case(j):
                            slope = _const_mul(dq, 2 * j + 1) >> shift
                            m.d.comb += t.eq(slope - self.seg_intercepts[j])
            t_clamped = Signal(unsigned(widths["t"].bits - 1))
            m.d.comb += t_clamped.eq(Mux(t < 0, 0, t))
            with m.If(above):
                m.d.comb += [area0.eq(jq - t_clamped), area1.eq(t_clamped), lane1_valid.eq(1)]
            with m.Elif(below):
                m.d.comb += [
                    area0.eq(jq + t_clamped),
                    area1.eq(ifix - t_clamped),
                    lane1_valid.eq(1),
                    lane1_below.eq(1),
                ]
            with m.Else():  # one pixel; area1 and lane 1 are don't-care
                m.d.comb += [area0.eq(jq), area1.eq(t_clamped)]

        def output_value(area, name):
            value = wire(name, "value")
            rounded = (area + (1 << (F - 1))) >> F
            m.d.comb += value.eq(
                Mux(self.value_sign < 0, self.value_base - rounded, self.value_base + rounded)
            )
            return value

        value0, value1 = output_value(area0, "value0"), output_value(area1, "value1")
        lane1_x, lane1_y = wire("lane1_x", "x"), wire("lane1_y", "y")
        m.d.comb += [
            lane1_x.eq(Mux(lane1_below, x - self.row_dx, x + self.row_dx)),
            lane1_y.eq(Mux(lane1_below, y - self.row_dy, y + self.row_dy)),
        ]

        # -- advance one column: J += K with the remainder carried; step a row when J >= 1 ---
        rsum = Signal(unsigned(widths["du"].bits + 1))
        carry = Signal()
        jsum = wire("jsum")
        row_step = Signal()
        m.d.comb += [
            rsum.eq(jr + self.kr),
            carry.eq(rsum >= du),
            jsum.eq(jq + self.kq + carry),
            row_step.eq(jsum >= ifix),
        ]
        zero = Const(0, signed(2))

        # -- control: a registered output beat, stalled by back-pressure ---------------------
        writes, setup = self.writes, self.setup
        last = Signal()
        load = Signal()
        m.d.comb += [
            last.eq(self.remaining == 0),
            self.step.eq(self.active & (~writes.valid | writes.ready)),
            setup.ready.eq(~self.active | (self.step & last)),
            load.eq(setup.valid & setup.ready),
        ]
        with m.If(self.step):
            beat = writes.payload
            m.d.sync += [
                writes.valid.eq(1),
                beat.lane0.x.eq(x),
                beat.lane0.y.eq(y),
                beat.lane0.value.eq(value0),
                beat.lane1.x.eq(lane1_x),
                beat.lane1.y.eq(lane1_y),
                beat.lane1.value.eq(value1),
                beat.lane1_valid.eq(lane1_valid),
                beat.last.eq(last),
                jr.eq(rsum - Mux(carry, du, 0)),
                jq.eq(Mux(row_step, jsum - ifix, jsum)),
                x.eq(x + self.col_dx + Mux(row_step, self.row_dx, zero)),
                y.eq(y + self.col_dy + Mux(row_step, self.row_dy, zero)),
                self.remaining.eq(self.remaining - 1),
            ]
            with m.If(last):
                m.d.sync += self.active.eq(0)
        with m.Elif(writes.ready):
            m.d.sync += writes.valid.eq(0)

        with m.If(load):
            bank = setup.payload
            m.d.sync += self.active.eq(1)
            for name in _BANK_REGISTERS:
                m.d.sync += getattr(self, name).eq(getattr(bank, name))
            for j, reg in enumerate(self.seg_thresholds):
                m.d.sync += reg.eq(bank.seg_thresholds[j])
            for j, reg in enumerate(self.seg_intercepts):
                m.d.sync += reg.eq(bank.seg_intercepts[j])
        return m


# -- the top level: setup state machine + stepper --------------------------------------------


class _MulDivLane:
    """Registers of one lane of the sequential multiply-divide unit.

    One clock of `step` performs ``V = 2 V + b X`` (b the next bit of the multiplier, MSB first)
    while keeping ``V = Q du + R`` with ``0 <= R < du``: with ``R < du`` and ``X <= du`` the new
    remainder candidate ``2 R + b X`` is below ``3 du``, so the quotient digit is 0, 1 or 2 and
    two comparisons find it. ``digit`` (when b is set) adds a known multiple of ``du`` to ``V``
    (``V = 2 V + b (digit du + X)``). Trailing zero multiplier bits make it a plain restoring
    division, so ``n`` clocks give ``divmod(A X 2**k, du)`` for an ``n - k`` bit ``A``.
    """

    def __init__(self, name: str, config: EdgeConfig, a_bits: int, digit_bits: int):
        widths = config.register_widths()
        self.a_bits = a_bits
        self.q = Signal(_shape(widths["jq"]), name=f"{name}_q")
        self.r = Signal(_shape(widths["jr"]), name=f"{name}_r")
        self.a = Signal(unsigned(a_bits), name=f"{name}_a")
        self.x = Signal(_shape(widths["du"]), name=f"{name}_x")
        self.digit = Signal(unsigned(max(digit_bits, 1)), name=f"{name}_digit")

    def load(self, a, a_bits: int, x, digit=0):
        """Start on the `a_bits`-bit multiplier `a` followed by ``self.a_bits - a_bits`` zero
        bits: after ``self.a_bits`` steps ``q, r = divmod(a (digit du + x) 2**k, du)``."""
        return [
            self.q.eq(0),
            self.r.eq(0),
            self.a.eq(a << (self.a_bits - a_bits)),
            self.x.eq(x),
            self.digit.eq(digit),
        ]

    def step(self, m: Module, du, name: str):
        """Add the step's combinational logic to `m`; return its register updates."""
        bit = self.a[-1]
        total = Signal(unsigned(len(self.r) + 2), name=f"{name}_total")
        twice = Signal()
        once = Signal()
        m.d.comb += [
            total.eq((self.r << 1) + Mux(bit, self.x, 0)),
            twice.eq(total >= (du << 1)),
            once.eq(total >= du),
        ]
        digit = Mux(twice, 2, Mux(once, 1, 0))
        return [
            self.a.eq(self.a << 1),
            self.r.eq(total - Mux(twice, du << 1, Mux(once, du, 0))),
            self.q.eq((self.q << 1) + Mux(bit, self.digit, 0) + digit),
        ]


class EdgeAntialiaser(wiring.Component):
    """The edge antialiaser: edge commands in, one beat of pixel writes per column out.

    See the module docstring for the ports, the bad-command rule and the setup arithmetic.
    ``setup_latency`` is the fixed number of clocks from the clock an edge is accepted to the
    clock its first beat is valid, with the stepper idle (`edgeaa.model.timing`).
    """

    def __init__(self, config: EdgeConfig, *, errors_bits: int = ERRORS_BITS):
        self._config = _check_config(config)
        if isinstance(errors_bits, bool) or not isinstance(errors_bits, int) or errors_bits < 1:
            raise TypeError(f"errors_bits must be a positive integer, not {errors_bits!r}")
        self._errors_bits = errors_bits
        super().__init__(
            {
                "edges": In(stream.Signature(edge_layout(config))),
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
        """Clocks of the multiply-divide phase: lane A's two passes and its fix-up clock."""
        config = self._config
        return config.intensity_bits + config.F + 1

    @property
    def setup_latency(self) -> int:
        """Clocks from accepting an edge (clock a, idle core) to its first beat.

        FOLD in clock a + 1, RUN in a + 2 .. a + R + 1 (R = `run_cycles`), FINAL (bank write)
        in a + R + 2, stepper load in a + R + 3, column 0 stepped in a + R + 4, its registered
        beat valid in a + R + 5.
        """
        return self.run_cycles + 5

    def elaborate(self, platform):
        m = Module()
        config = self._config
        widths = config.register_widths()
        W, s, F = config.coord_bits, config.subpixel_bits, config.F  # noqa: N806
        I = config.intensity_bits  # noqa: N806, E741
        S = 1 << s  # noqa: N806
        n = config.segments
        m.submodules.stepper = stepper = self.stepper
        wiring.connect(m, stepper.writes, wiring.flipped(self.writes))
        bank = stepper.setup

        # -- the accepted command ------------------------------------------------------------
        cmd = Signal(edge_layout(config))

        # -- fold (combinational from `cmd`, registered at the end of the FOLD clock) --------
        coord = W + s
        dx, dy = Signal(signed(coord + 1)), Signal(signed(coord + 1))
        adx, ady = Signal(unsigned(coord)), Signal(unsigned(coord))
        f_x_major = Signal()
        dp, dq = Signal(signed(coord + 1)), Signal(signed(coord + 1))
        p0, q0, p1 = Signal(unsigned(coord)), Signal(unsigned(coord)), Signal(unsigned(coord))
        f_major_neg, f_minor_neg = Signal(), Signal()
        u0, v0, u1 = (Signal(signed(coord + 1), name=name) for name in ("u0", "v0", "u1"))
        c0, c1 = Signal(signed(W + 2)), Signal(signed(W + 2))
        f_columns = Signal(unsigned(W + 1))
        e = Signal(signed(s + 2))
        e_mag = Signal(unsigned(max(s, 1)))
        f_diff = Signal(signed(I + 1))
        f_id = Signal(unsigned(I))
        bad = Signal()
        m.d.comb += [
            dx.eq(cmd.x1 - cmd.x0),
            dy.eq(cmd.y1 - cmd.y0),
            adx.eq(Mux(dx < 0, -dx, dx)),
            ady.eq(Mux(dy < 0, -dy, dy)),
            f_x_major.eq(adx >= ady),
            dp.eq(Mux(f_x_major, dx, dy)),
            dq.eq(Mux(f_x_major, dy, dx)),
            p0.eq(Mux(f_x_major, cmd.x0, cmd.y0)),
            q0.eq(Mux(f_x_major, cmd.y0, cmd.x0)),
            p1.eq(Mux(f_x_major, cmd.x1, cmd.y1)),
            f_major_neg.eq(dp <= 0),  # the model: step_major = 1 if dp > 0 else -1
            f_minor_neg.eq(dq < 0),
            u0.eq(Mux(f_major_neg, -p0, p0)),
            v0.eq(Mux(f_minor_neg, -q0, q0)),
            u1.eq(Mux(f_major_neg, -p1, p1)),
            # c0 = floor(u0 / S + 1/2), c1 = ceil(u1 / S - 1/2): arithmetic shifts floor.
            c0.eq(((u0 << 1) + S) >> (s + 1)),
            c1.eq(-((S - (u1 << 1)) >> (s + 1))),
            f_columns.eq(c1 - c0 + 1),
            # e = c0 S - u0 lies in (-S/2, S/2]: the offset of column c0's centre from u0.
            e.eq((c0 << s) - u0),
            e_mag.eq(Mux(e < 0, -e, e)),
            f_diff.eq(cmd.i_in - cmd.i_out),
            f_id.eq(Mux(f_diff < 0, -f_diff, f_diff)),
            bad.eq(((cmd.x0 == cmd.x1) & (cmd.y0 == cmd.y1)) | (cmd.i_in == cmd.i_out)),
        ]
        # Orientation: a swap or one mirror flips left and right (the model's det).
        det_neg = ~f_x_major ^ f_major_neg ^ f_minor_neg
        f_inside_is_a = (cmd.inside == 0) ^ det_neg

        # -- folded registers ----------------------------------------------------------------
        x_major, major_neg, minor_neg = Signal(), Signal(), Signal()
        du, dv = Signal(_shape(widths["du"]), name="du"), Signal(_shape(widths["du"]), name="dv")
        v0_r = Signal(signed(coord + 1), name="v0_r")
        c0_r = Signal(signed(W + 2), name="c0_r")
        columns = Signal(unsigned(W + 1))
        e_neg = Signal()
        i_d = Signal(unsigned(I))
        value_base = Signal(unsigned(I))
        value_neg = Signal()
        row0 = Signal(signed(W + 2))

        # -- the multiply-divide lanes -------------------------------------------------------
        pass1_bits = s + 1  # 2 |e| <= S
        pass2_bits = I + F - s - 1  # |I_d| << (F - s - 1)
        lane_a = _MulDivLane("lane_a", config, max(pass1_bits, pass2_bits), s + 1)
        lane_b = _MulDivLane("lane_b", config, I + F - 1, 0)  # |I_d| << (F - 1)
        run_cycles = self.run_cycles  # pass 1, fix-up, pass 2 of lane A
        fixup_cycle = pass1_bits
        counter = Signal(range(run_cycles))

        # Fix-up (at `fixup_cycle`): lane A holds q', r' = divmod(2 |e| dv, du). With
        # 2 e dv = q du + r (floor division), 2 num + den = du (2 v0 + S + q) + r, 0 <= r < du,
        # so row0 = floor((2 v0 + S + q) / 2S) and mf = m du + r, m = (2 v0 + S + q) mod 2S.
        q_fix = Signal(signed(s + 3))
        r_fix = Signal(_shape(widths["du"]))
        big_m = Signal(signed(coord + 4))
        with m.If(e_neg & (lane_a.r != 0)):
            m.d.comb += [q_fix.eq(-lane_a.q - 1), r_fix.eq(du - lane_a.r)]
        with m.Elif(e_neg):
            m.d.comb += [q_fix.eq(-lane_a.q), r_fix.eq(0)]
        with m.Else():
            m.d.comb += [q_fix.eq(lane_a.q), r_fix.eq(lane_a.r)]
        m.d.comb += big_m.eq((v0_r << 1) + S + q_fix)

        # -- final: the bank contents --------------------------------------------------------
        k_bit = Signal()
        kq = Signal(_shape(widths["kq"]), name="kq")
        kr = Signal(_shape(widths["kr"]), name="kr")
        khr_twice = Signal(unsigned(widths["khr"].bits + 1))
        m.d.comb += [
            khr_twice.eq(lane_b.r << 1),
            k_bit.eq(khr_twice >= du),
            kq.eq((lane_b.q << 1) + k_bit),
            kr.eq(khr_twice - Mux(k_bit, du, 0)),
        ]
        truncated = config.accumulator == "truncated"
        major, minor = Signal(signed(W + 2)), Signal(signed(W + 2))
        m.d.comb += [
            major.eq(Mux(major_neg, -c0_r, c0_r)),
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
        lane_a_step = lane_a.step(m, du, "lane_a")
        lane_b_step = lane_b.step(m, du, "lane_b")
        with m.If(bank.ready):
            m.d.sync += bank.valid.eq(0)
        m.d.sync += self.error.eq(0)
        with m.FSM(name="setup"):
            with m.State("IDLE"):
                m.d.comb += self.edges.ready.eq(1)
                with m.If(self.edges.valid):
                    m.d.sync += cmd.eq(self.edges.payload)
                    m.next = "FOLD"
            with m.State("FOLD"):
                with m.If(bad):
                    m.d.sync += self.error.eq(1)
                    with m.If(self.errors != (1 << self._errors_bits) - 1):
                        m.d.sync += self.errors.eq(self.errors + 1)
                    m.next = "IDLE"
                with m.Else():
                    inside_is_a = f_inside_is_a
                    m.d.sync += [
                        x_major.eq(f_x_major),
                        major_neg.eq(f_major_neg),
                        minor_neg.eq(f_minor_neg),
                        du.eq(Mux(f_x_major, adx, ady)),
                        dv.eq(Mux(f_x_major, ady, adx)),
                        v0_r.eq(v0),
                        c0_r.eq(c0),
                        columns.eq(f_columns),
                        e_neg.eq(e < 0),
                        i_d.eq(f_id),
                        value_base.eq(Mux(inside_is_a, cmd.i_out, cmd.i_in)),
                        # value_sign = +1 iff I_A >= I_B; I_A = I_in iff inside is A.
                        value_neg.eq(Mux(inside_is_a, f_diff < 0, f_diff > 0)),
                        counter.eq(0),
                        *lane_a.load(e_mag << 1, pass1_bits, Mux(f_x_major, ady, adx)),
                        *lane_b.load(f_id << (F - 1), I + F - 1, Mux(f_x_major, ady, adx)),
                    ]
                    m.next = "RUN"
            with m.State("RUN"):
                m.d.sync += counter.eq(counter + 1)
                with m.If(counter == fixup_cycle):
                    m.d.sync += [
                        row0.eq(big_m >> (s + 1)),
                        *lane_a.load(i_d << (F - s - 1), pass2_bits, r_fix, big_m[: s + 1]),
                    ]
                with m.Else():
                    m.d.sync += lane_a_step
                with m.If(counter < I + F - 1):
                    m.d.sync += lane_b_step
                with m.If(counter == run_cycles - 1):
                    m.next = "FINAL"
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
    generated code; `edgeaa.sim.verilator.LINT_WAIVER_REASONS` lists them with their reasons.
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
