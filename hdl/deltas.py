"""The delta stepper (`DeltaStepper`): `edgeaa.model.step.run_edge_deltas` in hardware, the
polygon core's stepper.

It steps the shared loop (`edgeaa.hdl.column_loop.ColumnLoop`: ``x, y, jq, jr``) and adds three
loop registers: ``hs`` (where the column's piece starts, the model's hs), ``adj`` (P1's
folded row minus the loop's row, one less per row step) and ``first_col`` (column 0).
The column's piece end ``he`` (`piece_end`) is formed in the stepping clock; then, one
column per clock:

* p1: the piece's heights, the depth of its crossing part (with one segment, less the
  intercept << 2: the estimate's numerator, so p1 holds no intercept), the column's total,
  band and rectangles (selects of per-edge constants by first / last column; the y-major
  band and the x-major upper rectangle share a register, an edge being one or the other),
  and the per-edge values the later stages need (the stepper reads the per-edge constants
  from the bank payload, which the setup holds until the clock the edge's last column is
  stepped, and the next edge may start while that column is still in the pipeline, so
  nothing after the stepping clock reads the bank);
* p2: the clamped triangle estimate of the depth (`triangle_estimate`, shift-adds by the
  small odd constants) and the piece's cover in each row;
* p3: the areas of the column's upper and lower
  rows (`column_deltas`' r_up and r_low, or a_up and a_low), the total less the lower and
  the middle row's bound (one register each for the x-major and the y-major value): the
  cut that splits the cells' chain of carry chains (about six from p2) over two clocks, for
  Fmax;
* the output register: the cells of `column_deltas` and their screen cells (`delta_cells`):
  from p3, the middle row's area and each delta one subtraction with the winding's sign
  folded in (`_fast_cells`: the fewest carry chains after p3); and ``nonzero``, a cell's
  delta not zero, as its operands differ in the payload's bits (beside the subtraction, not
  after it).

Every pipeline register takes the shape of its value (Amaranth widens adds by a bit), so no
intermediate wraps; a value is cut narrower only where its operands' shapes bound it (a
clamp has its bound's shape, a sum of two registers one bit more than the wider, the clamped
estimate its largest slope term's width, the covers of rows r and r + 1 their clamped
heights' difference); only the payload's fields are cut to the width table's ``x``, ``y``
and ``delta``, which the model checks. No multiplier: adds, compares, selects and fixed
shifts.

Observation points for the formal harness (attributes of the stepper, set when it is
elaborated): ``delta_he`` the piece end of the column being stepped, ``delta_stages`` the
registers of p1, p2 and p3 (namespaces, each with ``valid`` and ``last``),
``delta_cells`` the four ``(x, y, delta)`` values the output register loads (before the
payload's cut).
"""

from __future__ import annotations

import types

from amaranth.hdl import C, Cat, Module, Mux, Signal, Value, signed, unsigned

from ..model.beat import DELTAS, DELTAS_FAST, BeatFormat
from ..model.config import EdgeConfig
from .column_loop import ColumnLoop, derived_values
from .layouts import const_mul, delta_layout, log2, register_shape, signed_widened

__all__ = ["DeltaStepper", "delta_pipeline", "delta_registers"]

# The bank fields the loop steps: registers loaded from the bank when an edge starts. The
# delta stepper reads every other field from the bank payload while it steps the edge.
_LOOP_FIELDS = ("x", "y", "remaining", "jq", "jr")
DELTA_FORMATS = (DELTAS, DELTAS_FAST)  # compact's stepper and the fast one (bank copied)


class DeltaStepper(ColumnLoop):
    """The delta stepper: the accumulation deltas of `run_edge_deltas`, one beat per column.

    ``setup`` (in stream, `setup_layout` with the end pieces): with `DELTAS` (``live_bank``)
    the stepper starts the edge (``start``: loads its loop registers ``x, y, remaining, jq,
    jr`` and ``delta_regs``) when the bank is valid and it is idle, reads every other field
    (wires of the same names) and the derived constants from the payload, which the setup
    holds stable while it is valid and not taken, and takes the bank in the clock it steps
    the edge's last column: the transfer means "edge done". With `DELTAS_FAST` it copies the
    bank (every field and derived constant a register, `ColumnLoop._load`) as it starts the
    edge, when it is idle or steps the last column of the one before: the transfer is the
    start, and the setup unit is free ``C`` clocks sooner. ``deltas`` (out stream,
    `delta_layout`, also ``out``): one registered beat per column, ``latency`` =
    `fmt.pipeline_depth` = 4 clocks after the column's step when nothing stalls (p1, p2, p3,
    the output register).

    Observation points (formal harness): `ColumnLoop`'s, ``delta_regs`` (name -> register),
    and, once elaborated, ``delta_he``, ``delta_stages`` and ``delta_cells`` (this module's
    docstring).
    """

    def __init__(self, config: EdgeConfig, fmt: BeatFormat = DELTAS):
        if fmt not in DELTA_FORMATS:
            raise TypeError(f"fmt must be DELTAS or DELTAS_FAST, not {fmt!r}")
        super().__init__(config, fmt, delta_layout(config))
        self.start = Signal(name="start")
        self.delta_regs = delta_registers(config)

    @property
    def stages(self) -> list:
        """The registers of p1, p2 (and p3) (``delta_stages``; set when elaborated)."""
        return self.delta_stages

    def _handshake(self, last) -> list:
        """Reading the bank live: start an edge when idle, take its bank when its last column
        steps. Copying it: take it (and start) when idle or stepping the last column."""
        if self.format.live_bank:
            return [
                self.start.eq(self.setup.valid & ~self.active),
                self.setup.ready.eq(self.step & last),
            ]
        return [
            self.setup.ready.eq(~self.active | (self.step & last)),
            self.start.eq(self.setup.valid & self.setup.ready),
        ]

    def elaborate(self, platform):
        m = Module()
        en, last = self._control(m)
        advance = self._advance(m)
        valids = delta_pipeline(m, self, en, last, advance)
        self._idle(m, valids)
        self._loop(m, advance, last)
        if self.format.live_bank:
            self._live(m)
        else:
            self._load(m)  # `ColumnLoop`: the fields and derived constants are registers
        return m

    def _live(self, m):
        """Load the loop registers when an edge starts; every other field, and the derived
        constants, are wires of the bank payload, which the setup holds until the stepper
        takes it in the clock it steps the edge's last column (what the output pipeline
        needs after that clock travels in its stages)."""
        bank = self.setup.payload
        with m.If(self.start):
            m.d.sync += self.active.eq(1)
        for field in self.format.bank_fields(self.config):
            reg = getattr(self, field.name)
            if field.array is None:
                pairs = [(reg, bank[field.name])]
            else:
                pairs = [(r, bank[field.name][j]) for j, r in enumerate(reg)]
            for r, value in pairs:
                if field.name in _LOOP_FIELDS:
                    with m.If(self.start):
                        m.d.sync += r.eq(value)
                else:
                    m.d.comb += r.eq(value)
        for name, value in derived_values(self.config, self).items():
            m.d.comb += self.derived[name].eq(value)


def delta_registers(config: EdgeConfig) -> dict[str, Signal]:
    """The deltas stepper's loop registers besides the bank's: name -> register."""
    widths = config.register_widths()
    return {
        "hs": Signal(register_shape(widths["height"]), name="hs"),
        # P1's row minus the loop's: end_row - row0 at load, -1 per row step
        "adj": Signal(signed(widths["x"].bits + 2), name="adj"),
        "first_col": Signal(name="first_col"),
        # khr - du modulo 2**w, loaded when an edge starts: the piece end's carry is the carry
        # out of jr + khr_du, one carry chain from registers (Fmax: compact's stepper)
        "khr_du": Signal(unsigned(widths["du"].bits), name="khr_du"),
    }


def _clamp(value, hi):
    """value clamped to [0, hi] (the model's `_clamp`, same order of tests), in the shape of
    `hi`: the result is 0, `hi` or a value in [0, hi], so it fits `hi`'s shape whatever the
    width of `value` (exact, no wrap)."""
    hi = Value.cast(hi)
    clamped = Mux(value < 0, 0, Mux(value > hi, hi, value))[: len(hi)]
    return clamped.as_signed() if hi.shape().signed else clamped


def _stage(m, en, prefix: str, values: dict) -> types.SimpleNamespace:
    """Registers of one pipeline stage, each shaped like its value, loaded when `en`."""
    regs = {}
    for name, value in values.items():
        value = Value.cast(value)
        reg = Signal(value.shape(), name=f"{prefix}_{name}")
        with m.If(en):
            m.d.sync += reg.eq(value)
        regs[name] = reg
    return types.SimpleNamespace(**regs)


def delta_pipeline(m, st, en, last, advance) -> list[Signal]:
    """Add the delta stepper's loop registers' updates and its pipeline to `m` (`st` the
    `DeltaStepper`, `en` its enable, `last` its last-column flag, `advance` the loop step);
    returns the valid flags of the stages before the output register."""
    he = _piece_end(m, st, last)
    _loop(m, st, he, advance.row_step)
    p1 = _stage(m, en, "d1", _stage0(st, last, he))
    p2 = _stage(m, en, "d2", _covers(st.config, p1))
    p3 = _stage(m, en, "d3", _ends(p2))  # the rows' areas; one subtraction a cell after it
    stages = [p1, p2, p3]
    cells, nonzero = _fast_cells(p3, st.config.register_widths()["delta"].bits)
    _output(m, st, en, p3, cells, nonzero)
    # Observation points (formal harness): no logic of their own.
    st.delta_he, st.delta_stages, st.delta_cells = he, stages, cells
    return [stage.valid for stage in stages]


def _piece_end(m, st, last):
    """`piece_end`: floor(J + K/2), or P1's height in a partial last column."""
    regs = st.delta_regs
    # jq + khq + [jr + khr >= du] in one carry chain: with jr, khr < du, the low half
    # jr + (khr - du mod 2**w) carries into the high half exactly then
    khr_du = regs["khr_du"]
    w = len(khr_du)
    full = (Cat(st.jr, st.jq) + Cat(khr_du, st.khq))[w:]
    adj = regs["adj"]
    # end_height + sign(adj) ifix in one add (-ifix = ~ifix + 1 on ifix made signed)
    ifix = signed_widened(st.ifix)
    at_end = st.end_height + Mux(adj < 0, ~ifix, Mux(adj > 0, ifix, 0)) + (adj < 0)
    he = Signal(register_shape(st.config.register_widths()["height"]), name="he")
    m.d.comb += he.eq(Mux(last & st.last_partial, at_end, full))
    return he


def _loop(m, st, he, row_step):
    """The piece starts where the previous ended (one row less on a row step); an edge's
    start (``st.start``: bank valid, stepper idle) loads the bank's."""
    regs = st.delta_regs
    with m.If(st.step):
        m.d.sync += [
            regs["hs"].eq(Mux(row_step, he - st.ifix, he)),
            regs["adj"].eq(regs["adj"] - row_step),
            regs["first_col"].eq(0),
        ]
    bank = st.setup.payload
    with m.If(st.start):
        m.d.sync += [
            regs["hs"].eq(bank.hs0),
            regs["adj"].eq(bank.end_row - bank.row0),
            regs["first_col"].eq(1),
            regs["khr_du"].eq(bank.khr - bank.du),
        ]


def _stage0(st, last, he) -> dict:
    """What p1 loads in the stepping clock: the piece and the column's per-edge selects."""
    n = st.config.segments
    regs = st.delta_regs
    hs, adj, ifix = regs["hs"], regs["adj"], st.ifix
    first = regs["first_col"] & st.first_partial
    end = last & st.last_partial
    x_major = st.col_dx != 0
    # total1 + sign(adj) band1 in one add (-band1 = ~band1 + 1, band1 signed), in the width
    # of the sum of two of its registers' values (exact)
    total1 = st.total1 + Mux(adj < 0, ~st.band1, Mux(adj > 0, st.band1, 0)) + (adj < 0)
    total1 = total1[: max(len(st.total1), len(st.band1)) + 1].as_signed()
    interior = Mux(x_major, st.khq, st.jq)
    low = he > ifix
    values = dict(
        valid=st.active,
        last=last,
        x=st.x,
        y=st.y,
        x_major=x_major,
        neg=x_major & (st.col_dx < 0),  # the column pair's values swap on screen
        minor_neg=Mux(x_major, st.row_dy < 0, st.row_dx < 0),
        sigma_neg=st.sigma < 0,
        hs=hs,
        he=he,
        ifix=ifix,
        low=low,
        total=Mux(first, st.total0, Mux(end, total1, interior)),
        # an edge is x-major or y-major: the y-major band and the x-major upper rectangle
        # share a register
        band_rect=Mux(
            x_major, Mux(first, st.rect0, 0), Mux(first, st.band0, Mux(end, st.band1, ifix))
        ),
        rect_low=Mux(end, st.rect1, 0),
    )
    assert len(st.seg_intercepts) == n
    assert not any(icpt.shape().signed for icpt in st.seg_intercepts)  # see `_estimate`
    if n == 1:
        # t = (depth >> 2) - intercept = (depth - (intercept << 2)) >> 2: the intercept
        # folded into the depth's operand here, p1 holds no intercept
        values["depth_icpt"] = _depth(low, he, hs, ifix, st.seg_intercepts[0] << 2)
    elif n:
        values["depth"] = _depth(low, he, hs, ifix)
        values.update({f"thr{j}": thr for j, thr in enumerate(st.seg_thresholds, start=1)})
        values.update({f"icpt{j}": icpt for j, icpt in enumerate(st.seg_intercepts)})
    return values


def _depth(low, he, hs, ifix, icpt=None):
    """The depth of the piece's crossing part, he - ifix when it crosses into the row below,
    else -hs, less `icpt` if given, in one add after ``low``: he + ~(ifix + icpt) + 1 or
    ~hs + ~(icpt - 1) + 1. The subtrahends are sums of per-edge constants (formed off the path
    through ``low``; without `icpt`, ifix and all ones). Modulo 2**width, where the difference
    fits: exact. Without `icpt` the width is `_depth_width` (p1's register for seg2, seg4)."""
    width = _depth_width(he, hs, signed_widened(ifix))
    if icpt is None:
        sub_low, sub_high = signed_widened(ifix), C(-1, signed(1))
    else:
        width = max(width, len(icpt)) + 1
        sub_low = (ifix + icpt)[:width]
        sub_high = (signed_widened(icpt) - 1)[:width]  # all ones when icpt is 0
    return (Mux(low, he, ~hs) + ~Mux(low, sub_low, sub_high) + 1)[:width].as_signed()


def _depth_width(he, hs, ifix) -> int:
    """The width of `_depth`: of the wider of he - ifix and -hs (ifix signed)."""
    return max(len(he), len(hs), len(ifix)) + 1


def _estimate(config: EdgeConfig, p1):
    """`triangle_estimate` of p1's depth, clamped at 0 (0 without segments)."""
    n = config.segments
    if n == 0:
        return 0
    shift = 2 + log2(n)
    if n == 1:  # the intercept folded into p1's depth
        t = p1.depth_icpt >> shift
    else:
        segment = sum(p1.depth >= getattr(p1, f"thr{j}") for j in range(1, n))
        t = (const_mul(p1.depth, 1) >> shift) - p1.icpt0
        for j in range(1, n):
            line = (const_mul(p1.depth, 2 * j + 1) >> shift) - getattr(p1, f"icpt{j}")
            t = Mux(segment == j, line, t)
        assert not any(getattr(p1, f"icpt{j}").shape().signed for j in range(n))
    # Clamped at 0 it is at most the largest line's slope term (the intercepts are unsigned):
    # no sign bit and only that term's width (exact).
    depth_width = _depth_width(p1.he, p1.hs, signed_widened(p1.ifix))
    top = (1 << (depth_width - 1)) - 1
    width = max((top * (2 * j + 1)) >> shift for j in range(n)).bit_length()
    return Mux(t > 0, t, 0)[:width]


def _covers(config: EdgeConfig, p1) -> dict:
    """What p2 loads: the estimate and the piece's cover of rows r - 1, r and r + 1."""
    hs, he, ifix = p1.hs, p1.he, p1.ifix
    carried = ("valid", "last", "x", "y", "x_major", "neg", "minor_neg", "sigma_neg")
    carried += ("low", "total", "band_rect", "rect_low")
    # One compare of each end with ifix: p1's low is he > ifix; hs >= ifix selects as
    # hs > ifix does (they differ only where hs = ifix).
    up, low, hs_ge = hs < 0, p1.low, hs >= ifix
    cov_mid = Mux(he < 0, 0, Mux(low, ifix, he)) - Mux(up, 0, Mux(hs_ge, ifix, hs))
    cov_low = Mux(low, he, ifix) - Mux(hs_ge, hs, ifix)
    return dict(
        {name: getattr(p1, name) for name in carried},
        t=_estimate(config, p1),
        up=up,
        hs_ge=hs_ge,
        he_le0=he <= 0,
        cov_up=Mux(he < 0, he, 0) - Mux(up, hs, 0),
        cov_mid=cov_mid[: len(ifix) + 1].as_signed(),  # two heights in [0, ifix]
        cov_low=cov_low[: max(len(he), len(hs), len(ifix) + 1)].as_signed(),  # two heights >= 0
    )


def _x_major_ends(p2):
    """`_deltas_x_major`'s r_low and r_up: the areas on the +u side in rows r + 1 and r - 1."""
    total, t = p2.total, p2.t
    r_low = Mux(p2.hs_ge, total, Mux(p2.low, _clamp(t + p2.rect_low, p2.cov_low), 0))
    # cov_up - t - rect > cov_up iff t + rect < 0: the clamp's compare is the sign of t + rect,
    # whose complement the subtraction takes (exact: full-width values)
    t_rect = t + p2.band_rect
    over = p2.cov_up - t_rect
    clamped_up = Mux(over < 0, 0, Mux(t_rect < 0, p2.cov_up, over))[: len(p2.cov_up)].as_signed()
    r_up = Mux(p2.he_le0, total, Mux(p2.up, clamped_up, 0))
    return r_low, r_up


def _y_major_ends(p2):
    """`_deltas_y_major`'s a_low and a_up: the areas in cells r + 1 and r - 1."""
    total, band, t = p2.total, p2.band_rect, p2.t
    a_low = _clamp(Mux(p2.hs_ge, total - band, Mux(p2.low, t, 0)), band)
    # up_value > band only when he <= 0 and total > 0 (band - t > band never: t >= 0): the
    # clamp's compare without a carry chain (exact)
    up_value = Mux(p2.he_le0, total + band, Mux(p2.up, band - t, band))
    over = p2.he_le0 & (total > 0)
    a_up = Mux(up_value < 0, 0, Mux(over, band, up_value))[: len(band)].as_signed()
    return a_low, a_up


def _ends(p2) -> dict:
    """What p3 loads: the column's areas in its lower and upper rows
    (``lo``, ``hi``), the total less the lower (``rest``: the middle row's area is rest - hi
    clamped to ``bound``) and the middle row's bound (x-major: the cover of row r; y-major:
    the band). An edge is x-major or y-major: one register for each pair (the cut that
    balances p2's carry chains against the output register's, about three each)."""
    carried = ("valid", "last", "x", "y", "x_major", "neg", "minor_neg", "sigma_neg", "up")
    r_low, r_up = _x_major_ends(p2)
    a_low, a_up = _y_major_ends(p2)
    x_major, total, band = p2.x_major, p2.total, p2.band_rect
    return dict(
        {name: getattr(p2, name) for name in carried},
        cov_up=p2.cov_up,
        cov_low=p2.cov_low,
        lo=Mux(x_major, r_low, a_low),
        hi=Mux(x_major, r_up, a_up),
        rest=Mux(x_major, total - r_low, total + band - a_low),
        bound=Mux(x_major, p2.cov_mid, band),
    )


def _fast_cells(p3, delta_bits: int) -> tuple[list, Value]:
    """The four cells on screen from p3 (`_deltas_x_major`: r_a, cov_a - r_a, r_b, cov_b -
    r_b, the column pair swapped when ``neg``; `_deltas_y_major`: band - q0, q0 - q1, q1,
    0), each one subtraction ``a - b`` with the winding's sign folded in (-(a - b) = b - a
    swaps the operands): the fewest carry chains after p3. And the beat's ``nonzero``: bit k
    is ``a != b`` in the low `delta_bits` (the payload's), which is ``(a - b) mod 2**bits !=
    0``: cell k's delta as sent is not zero, formed beside its subtraction."""
    up = p3.up
    mid = _clamp(p3.rest - p3.hi, p3.bound)  # r_mid or a_mid
    r_a, r_b = Mux(up, p3.hi, mid), Mux(up, mid, p3.lo)
    cov_a, cov_b = Mux(up, p3.cov_up, p3.bound), Mux(up, p3.bound, p3.cov_low)
    y_major = _y_major_operands(p3, r_a, r_b)
    cells, nonzero = [], []
    for k in range(4):
        pair, right = divmod(k, 2)
        r, cov = (r_a, cov_a) if pair == 0 else (r_b, cov_b)
        covered = p3.neg ^ right  # the x-major cell holds cov - r, else r
        a = Mux(p3.x_major, Mux(covered, cov, r), y_major[k][0])
        b = Mux(p3.x_major, Mux(covered, r, 0), y_major[k][1])
        sigma_neg = p3.sigma_neg
        cells.append(_cell_at(p3, k, Mux(sigma_neg, b, a) - Mux(sigma_neg, a, b)))
        # a ^ b in their common shape (each extended exactly): its bits above the narrower
        # operand's repeat that operand's top bit, so its low bits up to the payload's decide
        differ = a ^ b
        nonzero.append(differ[: min(delta_bits, len(differ))].any())
    return cells, Cat(*nonzero)


def _y_major_operands(p3, q0, q1) -> list:
    """`_deltas_y_major`'s cells as differences: band - q0, q0 - q1, q1, 0 (the band is
    p3's ``bound``)."""
    return [(p3.bound, q0), (q0, q1), (q1, 0), (0, 0)]


def _cell_at(stage, k: int, delta) -> tuple:
    """Cell `k` of the column on screen, ``(x, y, delta)``: x-major, row a or b (k // 2) and
    column x or x + 1; y-major, v offset k - up, one cell lower along -v. Each coordinate is
    one add of a small offset (selects of constants and ``up``)."""
    pair, right = divmod(k, 2)
    up = stage.up
    row = pair - up  # x-major: -1, 0 or +1 rows along +v, one row_dy each on screen
    dx = Mux(stage.x_major, right, Mux(stage.minor_neg, 1 + up - k, k - up))
    dy = Mux(stage.x_major, Mux(stage.minor_neg, -row, row), 0)
    return stage.x + dx, stage.y + dy, delta


def _output(m, st, en, stage, cells, nonzero) -> None:
    """`delta_cells`: `cells` (of the stage before the output register, signed by the
    winding) and their `nonzero` flags into the payload."""
    widths = st.config.register_widths()
    beat = st.out.payload
    with m.If(en):
        m.d.sync += [
            st.out.valid.eq(stage.valid),
            beat.last.eq(stage.last),
            beat.nonzero.eq(nonzero),
        ]
        for k, (x, y, delta) in enumerate(cells):
            cell = beat[f"cell{k}"]
            m.d.sync += [cell.x.eq(x), cell.y.eq(y), cell.delta.eq(delta)]
    assert len(cell.delta) == widths["delta"].bits
