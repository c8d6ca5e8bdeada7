"""The end pieces of the polygon core's setup (`edgeaa.model.edge.end_pieces` in hardware):
`EndPieces`, the part `edgeaa.hdl.setup.EdgeSetupUnit` takes (``pieces=EndPieces(config)``).

Only the polygon core's setup has them (the line core's has `NO_END_PIECES`, whose hooks add
nothing). The values that need no lane
result are registered in RUN's last clock (``kq``, ``row0`` and the column count are known
by then) and ``next_bank`` forms the two that need the accumulator's start ``jq`` (``hs0``
of a whole first column, ``total0`` of a y-major edge) from FINAL on. The y-major
``total0`` is ``(hs0 + he_first) w0 >> (s + 2)``: its product is formed in FINAL, which
takes ``ceil((s + 2) / 2)`` clocks in this setup (`edgeaa.model.timing.final_cycles`), two
bits of the first piece's width ``w0`` (``s + 2`` bits, at most ``2 S``) a clock, MSB first
(`total0_steps`: ``P = 4 P + d (hs0 + he_first)``, the multiplicand constant once the
lanes are done), so ``next_bank`` reads a register in HOLD, not a multiplier (its cost:
docs/hardware.md, "FINAL of `s + 2` clocks" and "A radix-4 FINAL").

Everything is in half sub-pixel steps as in the model (``2 S`` per pixel, so a pixel's edges
are whole numbers): ``mg`` (from the first column's start to P0) and ``me`` (from P1 to the
last column's end) are the low ``s + 1`` bits of ``2 u0 + S`` and ``S - 2 u1`` (both in
``[0, 2 S)`` by the choice of c0 and c1), zero for a column the clip window cut; ``e1 = (2
v1 + S) mod 2 S`` gives P1's height in its row. The products of ``kq`` by a square of them
are formed one quotient digit per clock beside lane B (`kq_product_steps`, Horner: ``P = 2 P
+ d M`` for lane B's digit ``d`` of ``khq``, then ``P = 2 P + k_bit M`` when ``kq = 2 khq +
k_bit`` is registered), so no wide multiplier is needed: ``k_me = kq me^2`` (x-major; ``kq
w1^2`` y-major) and ``k_mg = kq (2 S - mg)^2``. Their multiplicands depend only on registers
loaded by WINDOW (the fold, ``cut_end``, ``start_clip``), constant through RUN. The products
by ``|I_d|`` (times ``h0``, ``e1``, ``w1`` and two products of them) are formed one bit a
clock (`id_product_steps`) over the first ``I`` clocks of lane A's second pass, whose
multiplier bits are ``|I_d|``'s, MSB first; their multiplicands are constant from the clock
after the fix-up (``h0`` reads ``row0``), and with two lane steps a clock WINDOW registers
the one that is a product (``end``: `end_multiplicand`), as it does kq's squares. For
``s > 0`` ``mg``, ``me``, ``w1`` and ``e1`` are even, and the two products among them
multiply their halves. The proofs' invariants of
the half-formed products are `edgeaa.sim.verification.formal.bounds`' ``_products`` (FINAL's
product needs none: see there).
"""

from __future__ import annotations

import types

from amaranth.hdl import Cat, Const, Mux, Signal, signed, unsigned

from ..model.config import EdgeConfig
from .layouts import register_shape, signed_widened
from .setup_fold import r_cut_end, r_start_clip, w_v0

__all__ = [
    "NO_END_PIECES",
    "EndPieces",
    "end_multiplicand",
    "final_pieces",
    "id_product_clear",
    "id_product_steps",
    "id_products",
    "kq_multiplicands",
    "kq_product_steps",
    "kq_products",
    "pieces_registers",
    "run_end_loads",
    "total0_product",
    "total0_steps",
]

# The pieces registered at the end of RUN (bank fields of the same name), then FINAL's own.
_EARLY = ("end_row", "end_height", "total1", "rect0", "rect1", "band0", "band1")


def pieces_registers(config: EdgeConfig) -> types.SimpleNamespace:
    """The setup's registers of the end pieces: ``cut_end`` (WINDOW: the window cut the last
    column), the `_EARLY` bank fields, the operands FINAL needs (``single``, ``w0``,
    ``hs0_fp``), the products by kq (``k_me``, ``k_mg``: `kq_product_steps`), by
    ``|I_d|`` (``id_*``: `id_product_steps`) and by ``w0`` (``y_area0``: `total0_steps`)."""
    widths = config.register_widths()
    s, I = config.subpixel_bits, config.intensity_bits  # noqa: E741
    product = unsigned(widths["kq"].bits + 2 * s + 3)  # kq times at most (2 S)**2
    height = register_shape(widths["height"])
    regs = {name: Signal(height, name=f"pc_{name}") for name in _EARLY}
    regs["end_row"] = Signal(register_shape(widths["y"]), name="pc_end_row")
    regs.update(
        cut_end=Signal(name="pc_cut_end"),
        single=Signal(name="pc_single"),  # one partial column holds both vertices
        w0=Signal(unsigned(s + 2), name="pc_w0"),  # the first piece's width (2 S per pixel)
        hs0_fp=Signal(height, name="pc_hs0_fp"),  # hs0 of a partial first column
        k_me=Signal(product, name="pc_k_me"),
        k_mg=Signal(product, name="pc_k_mg"),
        # their multiplicands (comb; registers loaded by WINDOW with two lane steps a clock)
        m_me=Signal(unsigned(2 * s + 3), name="pc_m_me"),
        m_mg=Signal(unsigned(2 * s + 3), name="pc_m_mg"),
        # the multiplicand of id_end (`end_multiplicand`; loaded by WINDOW with two lane
        # steps a clock)
        m_end=Signal(unsigned(2 * s + 3), name="pc_m_end"),
        # (hs0 + he_first) w0 modulo 2**(bits of total0 + s + 2), and its multiplicand
        # (comb): total0 of a y-major edge is y_area0 >> (s + 2) (`total0_steps`)
        y_area0=Signal(unsigned(height.width + s + 2), name="pc_y_area0"),
        m_area0=Signal(unsigned(height.width + s + 2), name="pc_m_area0"),
        m_held=Signal(unsigned(height.width + s + 2), name="pc_m_held"),  # m_area0, registered
        # |I_d| times h0, e1, w1, first, end (`id_product_steps`)
        id_h0=Signal(signed(I + s + 4), name="pc_id_h0"),  # h0 in [-S, 3 S)
        id_e1=Signal(unsigned(I + s + 1), name="pc_id_e1"),  # e1 < 2 S
        id_w1=Signal(unsigned(I + s + 2), name="pc_id_w1"),  # w1 <= 2 S
        id_first=Signal(unsigned(I + 2 * s + 3), name="pc_id_first"),  # < 6 S^2
        id_end=Signal(unsigned(I + 2 * s + 2), name="pc_id_end"),  # < 4 S^2
    )
    return types.SimpleNamespace(**regs)


def _end_widths(unit, start_clip=None, cut_end=None) -> types.SimpleNamespace:
    """``mg``, ``me`` (the first and last columns' cut parts) and ``w1 = 2 S - me``: from
    registers loaded by WINDOW, so constant through RUN (or in WINDOW, from the
    `start_clip` and `cut_end` it loads)."""
    s = unit.config.subpixel_bits
    S = 1 << s
    r, cmd, pc = unit.regs, unit.cmd, unit.pieces
    start_clip = r.start_clip if start_clip is None else start_clip
    cut_end = pc.cut_end if cut_end is None else cut_end
    fp, lp = ~start_clip, ~cut_end  # the first and last columns hold the vertices
    p0, p1 = Mux(r.x_major, cmd.x0, cmd.y0), Mux(r.x_major, cmd.x1, cmd.y1)
    # 2 u + S = 2 (u + S // 2) + S % 2 (u = +-p): bit 0 is a constant (zero for s > 0),
    # the rest s bits (mg_h, me_h: even widths are twice them, a multiplier can take those).
    half = S // 2
    mg_in_h = Mux(r.major_neg, half - p0, p0 + half)[:s]  # the halves with the vertex in
    me_in_h = Mux(r.major_neg, half + p1, half - p1)[:s]
    mg_h, me_h = Mux(fp, mg_in_h, 0), Mux(lp, me_in_h, 0)
    mg, me = Cat(fp & (S % 2), mg_h)[: s + 1], Cat(lp & (S % 2), me_h)[: s + 1]
    w1 = (2 * S - me)[: s + 2]
    me_in = Cat(Const(S % 2, 1), me_in_h)[: s + 1]
    return types.SimpleNamespace(
        fp=fp,
        lp=lp,
        mg=mg,
        me=me,
        w1=w1,
        mg_h=mg_h,
        # mg, me and w1 when the column holds the vertex (what fp and lp pick, or 0 and 2 S)
        mg_in=Cat(Const(S % 2, 1), mg_in_h)[: s + 1],
        me_in=me_in,
        w1_in=(2 * S - me_in)[: s + 2],
    )


def kq_product_steps(unit, digits, single=None) -> list:
    """Horner steps of the products by kq, one a digit of `digits` (``(twice, once)``
    each, ``d = 2 twice + once``): ``P = 2 P + d M`` (lane B's quotient digits, or ``k_bit``
    with ``twice = 0`` for the last step; `single` keeps the first step only). After lane
    B's ``I + F - 1`` digits and the ``k_bit`` step, ``k_me = kq Mux(x_major, me^2, w1^2)``
    and ``k_mg = kq (2 S - mg)^2`` exactly (``kq = 2 khq + k_bit``)."""
    loads = []
    for product, value in kq_products(unit):
        addends = [Mux(twice, value << 1, Mux(once, value, 0)) for twice, once in digits]
        loads.append(product.eq(_horner(product, addends, single)))
    return loads


def _horner(product, addends, single=None):
    """``P = 2 P + a`` for each of `addends` in turn (modulo `product`'s register: only the
    low bits matter), `single` (None: never) keeping the first only."""
    value = (product << 1) + addends[0]
    for addend in addends[1:]:
        more = (value << 1) + addend
        value = more if single is None else Mux(single, value, more)
    return value


def kq_products(unit) -> list:
    """(register, multiplicand) of each product by kq (`kq_product_steps`)."""
    pc = unit.pieces
    return [(pc.k_me, pc.m_me), (pc.k_mg, pc.m_mg)]


def _end_factors(unit) -> types.SimpleNamespace:
    """The sub-pixel factors of the pieces (combinational, valid from the clock after lane
    A's fix-up: ``h0`` needs ``row0``), and the flag ``single``."""
    s = unit.config.subpixel_bits
    S = 1 << s
    r, w = unit.regs, _end_widths(unit)
    single = (r.columns == 1) & w.fp & w.lp
    v1_2 = _v1_2(unit, r.v0_r)
    e1 = v1_2[: s + 1]  # P1's height in its row, half sub-pixel steps
    # h0 = 2 v0 - (2 row0 - 1) S = m - q in [-S, 3 S) when the first column holds P0 (row0's
    # digit m in [0, 2 S), |q| <= S): s + 3 bits; it is used only then (mg = 0 otherwise).
    h0 = ((r.v0_r << 1) + S - (r.row0 << (s + 1)))[: s + 3].as_signed()
    w0 = 2 * S - w.mg - Mux(single, w.me, 0)
    xm = r.x_major
    neg_h0 = Mux(h0 < 0, -h0, 0)[: s + 1]  # max(-h0, 0) <= S
    # WINDOW's register with two lane steps a clock (`end_multiplicand`)
    end = unit.pieces.m_end if unit.schedule.steps > 1 else _end_product(unit, e1, w)
    return types.SimpleNamespace(
        single=single,
        v1_2=v1_2,
        w0=w0,
        # the multiplicands of the products by |I_d| (`id_product_steps`)
        h0=h0,
        e1=e1,
        w1=w.w1,
        # x: max(-h0, 0) mg (rect0; with a multiplier formed at RUN's end, `run_end_loads`);
        # y: w0 (band0)
        first=w0 if unit.pieces.multiplier else Mux(xm, _first_x(unit, neg_h0, w), w0),
        # x: e1 me (rect1); y: e1 w1 (the first term of total1)
        end=end,
    )


def _first_x(unit, neg_h0, w):
    """``neg_h0 mg`` (`neg_h0` times ``max(-h0, 0)``, or at RUN's end ``|I_d| max(-h0, 0)``
    = ``max(-id_h0, 0)``); for ``s > 0`` mg is even: a product of its half."""
    return (neg_h0 * w.mg_h) << 1 if unit.config.subpixel_bits else neg_h0 * w.mg


def _v1_2(unit, v0):
    """``2 v1 + S`` from `v0` (``v0_r``, or in WINDOW the value it loads)."""
    return ((v0 + unit.regs.dv) << 1) + (1 << unit.config.subpixel_bits)


def _end_product(unit, e1, w):
    """x-major ``e1 me`` (rect1), y-major ``e1 w1`` (total1's first term); `w` from
    `_end_widths`. For ``s > 0`` both factors are even: a product of halves. Formed with the
    vertex in the last column and then picked by the window's cut (``me = 0``, ``w1 = 2 S``),
    so that the cut's compare runs beside the multiplier, not in front of it."""
    s = unit.config.subpixel_bits
    xm = unit.regs.x_major
    if s:
        product = (e1[1:] * Mux(xm, w.me_in[1:], (1 << s) - w.me_in[1:])[: s + 1]) << 2
        return Mux(w.lp, product, Mux(xm, 0, e1[1:] << (s + 2)))
    product = e1 * Mux(xm, w.me_in, w.w1_in)
    return Mux(w.lp, product, Mux(xm, 0, e1 << 1))


def end_multiplicand(unit, v0=None, start_clip=None, cut_end=None):
    """`_end_product` of the registers WINDOW loads (``v0_r``, ``start_clip``, ``cut_end``),
    or in WINDOW of the values it loads: constant through RUN, so WINDOW registers it
    (``m_end``) with two lane steps a clock, off RUN's chained Horner adds."""
    s = unit.config.subpixel_bits
    e1 = _v1_2(unit, unit.regs.v0_r if v0 is None else v0)[: s + 1]
    return _end_product(unit, e1, _end_widths(unit, start_clip, cut_end))


ID_PRODUCTS = ("h0", "e1", "w1", "first", "end")  # `id_product_steps`: |I_d| times these


def id_product_steps(unit, bits, single=None) -> list:
    """Horner steps of the products by ``|I_d|``: ``P = 2 P + bit M`` for each multiplicand
    of `ID_PRODUCTS` and each of `bits` in turn (`single`: the first only), the next bits of
    ``|I_d|`` (MSB first: lane A's multiplier bits in the first clocks of its second pass;
    `unit` clears them at the fix-up)."""
    return [
        product.eq(_horner(product, [Mux(bit, value, 0) for bit in bits], single))
        for product, value in id_products(unit)
    ]


def id_products(unit) -> list:
    """(register, multiplicand) of each product by ``|I_d|`` (`ID_PRODUCTS`; the
    multiplicands are combinational, constant from the clock after the fix-up; ``end``'s
    the register ``m_end`` with two lane steps a clock)."""
    f, pc = _end_factors(unit), unit.pieces
    return [(getattr(pc, f"id_{name}"), getattr(f, name)) for name in ID_PRODUCTS]


def id_product_clear(unit) -> list:
    return [getattr(unit.pieces, f"id_{name}").eq(0) for name in ID_PRODUCTS]


def run_end_loads(unit) -> list:
    """The loads of RUN's last clock: the pieces that need no lane result (`unit` is the
    `EdgeSetupUnit`; its regs, command and ``pieces`` registers). x-major edges use rect
    and y-major ones band, so one product serves both where the shift allows; the products
    by ``|I_d|`` are done (``id_*``), shifted by ``k`` they are in ``ifix`` units."""
    config = unit.config
    s, F = config.subpixel_bits, config.F
    k = F - s - 1  # |I_d| << k: ifix per half sub-pixel step
    r, pc, f = unit.regs, unit.pieces, _end_factors(unit)
    xm = r.x_major
    first_rect = pc.id_first << k  # x: rect0 << (s + 1); y: band0
    rect0 = first_rect
    if pc.multiplier:  # x: |I_d| max(-h0, 0) = max(-id_h0, 0), times mg by a DSP block here
        neg = Mux(pc.id_h0 < 0, -pc.id_h0, 0)[: len(pc.id_h0) - 1]
        rect0 = _first_x(unit, neg, _end_widths(unit)) << k
    end_rect = (pc.id_end << k) >> (s + 1)  # x: rect1; y: the first term of total1
    sq = 2 * s + 3  # K w^2 / 2 with w over 2 S: (kq w^2) >> (2 s + 3)
    # kq (4 S^2 - me^2) for x-major, kq w1^2 for y-major (`kq_product_steps`)
    slope_area = Mux(xm, (r.kq << (2 * s + 2)) - pc.k_me, pc.k_me) >> sq
    return [
        pc.single.eq(f.single),
        pc.w0.eq(f.w0),
        pc.hs0_fp.eq(pc.id_h0 << k),
        pc.end_row.eq(f.v1_2 >> (s + 1)),
        pc.end_height.eq(pc.id_e1 << k),
        pc.total1.eq(Mux(xm, slope_area, end_rect - slope_area)),
        pc.rect0.eq(Mux(xm, rect0 >> (s + 1), 0)),
        pc.rect1.eq(Mux(xm, end_rect, 0)),
        pc.band0.eq(Mux(xm, 0, first_rect)),
        pc.band1.eq(Mux(xm, 0, pc.id_w1 << k)),
        pc.y_area0.eq(0),  # FINAL's product (`total0_steps`), counted by the counter
        r.counter.eq(0),
    ]


def _not(value):
    """``-value - 1`` (exact: `value` sign-extended by one bit first when unsigned)."""
    return ~value if value.shape().signed else ~signed_widened(value)


def total0_steps(unit) -> list:
    """One clock of FINAL in the deltas setup, radix 4 with Booth digits: ``y_area0 = 4
    y_area0 + d M`` for the digits ``d`` in ``{-2, ..., 2}`` of ``w0`` (MSB first, the
    counter's: cleared at the end of RUN), ``M = hs0 + he_first``, and the counter's step.
    ``w0 <= 2 S`` (its bits above ``s + 1`` clear, the top one only for ``2 S``), so the top
    digit and its carry out, ``2 b[2D-1] + b[2D-2] + b[2D-3]``, are ``0``, ``1`` or ``2``:
    the first clock selects ``0``, ``M`` or ``2 M`` (``y_area0`` is zero then) and registers
    ``M`` (``m_held``); each later clock adds ``4 y_area0`` and ``M`` or ``2 M`` of the
    register, inverted with a carry in for a negative digit. So no ``3 M`` is formed and
    ``M``'s carry chains are followed by a select (Fmax: compact's critical path in two
    seeds of five). After FINAL's ``ceil((s + 2) / 2)`` clocks ``y_area0 = M w0`` (modulo
    the register: enough bits for ``total0 = y_area0 >> (s + 2)``); ``M`` reads registers
    the setup holds from RUN's end until the load. Derivation: docs/hardware.md, "The
    nonzero flags in the beat, and a Booth FINAL"."""
    pc, counter = unit.pieces, unit.regs.counter
    digits = _final_digits(len(pc.w0))
    # b[-1] = 0, then w0 to 2 D bits: digit j reads bits 2 j - 1, 2 j and 2 j + 1 of w0
    bits = Cat(Const(0, 1), pc.w0, Const(0, 2 * digits - len(pc.w0)))
    # each digit's three bits, MSB first (bit selects: a word select multiplies)
    low, mid, top = (Cat(*(bits[2 * j + i] for j in reversed(range(digits)))) for i in range(3))
    l, h, t = (part.bit_select(counter, 1) for part in (low, mid, top))  # noqa: E741
    # later clocks: d = -2 t + h + l; |d| = 2 for 011 and 100, 1 for h != l; t the sign
    # (-a = ~a + 1 in the register's width: the sum is taken modulo 2**width throughout)
    twice = Mux(t, ~h & ~l, h & l)
    magnitude = Mux(twice, pc.m_held << 1, Mux(h ^ l, pc.m_held, 0))[: len(pc.y_area0)]
    later = (pc.y_area0 << 2) + Mux(t, ~magnitude, magnitude) + t
    # first clock: 2 t + h + l (t set only with h and l clear: w0 = 2 S)
    first = Mux(t | (h & l), pc.m_area0 << 1, Mux(h ^ l, pc.m_area0, 0))
    return [
        pc.y_area0.eq(Mux(counter == 0, first, later)),
        pc.m_held.eq(pc.m_area0),
        counter.eq(counter + 1),
    ]


def _final_digits(bits: int) -> int:
    """Clocks of the radix-4 FINAL (`total0_steps`): a digit of two bits of ``w0`` each."""
    return (bits + 1) // 2


def total0_product(unit) -> list:
    """One of FINAL's two clocks in the fast core's setup (`EndPieces` with ``multiplier``):
    the first registers the multiplicand, ``y_area0 = hs0 + he_first`` (its carry chains
    off the multiplier's path), the second multiplies, ``y_area0 = y_area0 w0``: the product
    of `total0_steps`, modulo the same register."""
    pc, counter = unit.pieces, unit.regs.counter
    product = Mux(counter == 0, pc.m_area0, pc.y_area0 * pc.w0)
    return [pc.y_area0.eq(product), counter.eq(counter + 1)]


def final_pieces(m, unit) -> None:
    """The end pieces of ``next_bank`` (combinational, complete in FINAL's last clock): the
    registered ones, the flags, the winding sign, and ``hs0``, ``total0``, which need ``jq``
    (lane A's result; one product: ``kq`` by the squared width for x-major, the height sum
    by the width for y-major, formed in FINAL by `total0_steps`; the x-major one, kq times
    the first piece's squared width, is ``k_mg`` less ``k_me`` when one column holds both
    vertices), and the multiplicands of `kq_product_steps` and `total0_steps`."""
    s = unit.config.subpixel_bits
    r, cmd, pc, nb = unit.regs, unit.cmd, unit.pieces, unit.next_bank
    fp = ~r.start_clip
    borrow = nb.jr < nb.khr
    carry = (nb.jr + nb.khr) >= nb.du
    # a - b = a + ~b + 1 (~b = -b - 1, b sign-extended first): the 1 - borrow and the
    # negation's + 1 ride as one-bit operands (a carry in), one carry chain each.
    hs0 = Mux(fp, pc.hs0_fp, nb.jq + _not(nb.khq) + ~borrow)
    adj = pc.end_row - r.row0  # P1's row from the first column's: -1, 0 or +1 when single
    down = adj < 0
    at_end = pc.end_height + Mux(adj > 0, nb.ifix, Mux(down, _not(nb.ifix), 0)) + down
    he_first = Mux(pc.single, at_end, nb.jq + nb.khq + carry)
    xm = r.x_major
    k_area0 = pc.k_mg - Mux(pc.single, pc.k_me, 0)  # kq ((2 S - mg)^2 - single me^2)
    # Travelling down the screen with the inside on the left puts the inside on the +x side.
    dy_pos, inside_left = ~unit.accepted["dy_le0"], cmd.inside == 0
    plus, minus = Const(1, signed(2)), Const(-1, signed(2))
    m.d.comb += [
        nb.sigma.eq(Mux(dy_pos == inside_left, plus, minus)),
        nb.row0.eq(r.row0),
        nb.first_partial.eq(fp),
        nb.last_partial.eq(~pc.cut_end),
        nb.hs0.eq(hs0),
        nb.total0.eq(Mux(xm, k_area0 >> (2 * s + 3), pc.y_area0 >> (s + 2))),
        pc.m_area0.eq(hs0 + he_first),  # `total0_steps`
        *(nb[name].eq(getattr(pc, name)) for name in _EARLY),
    ]
    if unit.schedule.steps == 1:  # two lane steps a clock: registers (`EndPieces`)
        m.d.comb += [reg.eq(value) for reg, value in kq_multiplicands(unit)]


def kq_multiplicands(unit, start_clip=None, cut_end=None) -> list:
    """(register, value) of the multiplicands of `kq_product_steps` (`_end_widths` of
    `start_clip` and `cut_end`, the registers' if None): ``me^2`` (x-major) or ``w1^2 = (2 S
    - me)^2`` (y-major), and ``(2 S - mg)^2``."""
    s = unit.config.subpixel_bits
    S, pc, xm = 1 << s, unit.pieces, unit.regs.x_major
    w = _end_widths(unit, start_clip, cut_end)
    # squared before the window's cut picks them (a cut vertex: me = mg = 0, w1 = 2 S), so
    # the cut's compare runs beside the multipliers, not in front of them
    me, w1 = w.me_in, w.w1_in
    g1 = (2 * S - w.mg_in)[: s + 2]
    return [
        (pc.m_me, Mux(w.lp, Mux(xm, me * me, w1 * w1), Mux(xm, 0, 4 * S * S))),
        (pc.m_mg, Mux(w.fp, g1 * g1, 4 * S * S)),
    ]


class EndPieces:
    """The end-pieces part of a setup unit: its registers (`pieces_registers`, as attributes)
    and the hooks the unit calls. The bank gains the `edgeaa.model.bank` fields marked
    ``pieces`` (``in_bank``); WINDOW loads ``cut_end`` and clears the kq products; RUN forms
    the products by ``|I_d|`` beside lane A's pass 2 and by kq beside lane B, and loads
    `run_end_loads` in its last clock; FINAL takes ``ceil((s + 2) / 2)`` clocks
    (`total0_steps`), or two with `multiplier` (`total0_product`: a DSP block of the fast
    pipeline's ECP5); ``next_bank`` gets `final_pieces`. One instance per setup unit (its
    registers)."""

    in_bank = True

    def __init__(self, config: EdgeConfig, *, multiplier: bool = False):
        vars(self).update(vars(pieces_registers(config)))
        self.multiplier = multiplier

    @property
    def final_cycles(self) -> int:
        # two bits of w0 a clock (`total0_steps`), or the multiplicand then the product
        return 2 if self.multiplier else _final_digits(len(self.w0))

    def window_loads(self, unit) -> list:
        """``cut_end``, the kq products cleared; with two lane steps a clock also their
        multiplicands (squares: a DSP block each on the ECP5, off RUN's chained adds) and
        id_end's (`end_multiplicand`, a DSP product too)."""
        r = unit.regs
        loads = [self.cut_end.eq(r_cut_end(r)), self.k_me.eq(0), self.k_mg.eq(0)]
        if unit.schedule.steps > 1:
            clip, cut = r_start_clip(r), r_cut_end(r)
            loads += [reg.eq(value) for reg, value in kq_multiplicands(unit, clip, cut)]
            loads.append(self.m_end.eq(end_multiplicand(unit, w_v0(unit), clip, cut)))
        return loads

    def lane_a_steps(self, m, unit, lanes) -> None:
        """The products by |I_d|: its bits lead lane A's pass 2, a bit a lane step (the
        last of them, when `edgeaa.model.timing.RunSchedule.id_single`, one step)."""
        plan = unit.schedule
        bits = [unit.lane_a.a[-1 - k] for k in range(plan.steps)]
        single = lanes.id_last if plan.id_single else None
        with m.If(lanes.fixup):
            m.d.sync += id_product_clear(unit)
        with m.Elif(lanes.id_bits):
            m.d.sync += id_product_steps(unit, bits, single)

    def lane_b_steps(self, m, unit, lanes, b_done) -> None:
        """The products by kq, one quotient digit a lane step, then k_bit (one adder each:
        the digit is picked before it)."""
        with m.If(unit.regs.counter <= lanes.b_clocks):
            (twice, once), *more = unit.lane_b.digits
            first = (Mux(b_done, 0, twice), Mux(b_done, lanes.k_bit, once))
            single = b_done if more else None  # k_bit's step alone
            m.d.sync += kq_product_steps(unit, [first, *more], single)

    def run_end(self, m, unit) -> None:
        """RUN's last clock: kq, row0 and the column count are known."""
        m.d.sync += run_end_loads(unit)

    def final(self, m, unit) -> None:
        """FINAL: the y-major total0 product, two bits of w0 a clock or by a multiplier."""
        m.d.sync += total0_product(unit) if self.multiplier else total0_steps(unit)
        with m.If(unit.regs.counter == self.final_cycles - 1):
            m.next = "HOLD"

    def next_bank(self, m, unit) -> None:
        final_pieces(m, unit)


class _NoEndPieces:
    """The line core's setup: no end pieces, one FINAL clock, hooks that add nothing."""

    in_bank = False
    final_cycles = 1

    def window_loads(self, unit) -> list:
        return []

    def lane_a_steps(self, m, unit, lanes) -> None:
        pass

    def lane_b_steps(self, m, unit, lanes, b_done) -> None:
        pass

    def run_end(self, m, unit) -> None:
        pass

    def final(self, m, unit) -> None:
        m.next = "HOLD"

    def next_bank(self, m, unit) -> None:
        pass


NO_END_PIECES = _NoEndPieces()
