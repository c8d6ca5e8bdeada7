"""The end pieces of the deltas core's setup (`edgeaa.model.edge.end_pieces` in hardware).

Only the setup of a core with output ``"deltas"`` has them. No new clock: the values that
need no lane result are registered in RUN's last clock (``kq``, ``row0`` and the column
count are known by then) and FINAL forms the two that need the accumulator's start ``jq``
(``hs0`` of a whole first column, ``total0`` of a y-major edge) when it writes the bank.

Everything is in half sub-pixel steps as in the model (``2 S`` per pixel, so a pixel's edges
are whole numbers): ``mg`` (from the first column's start to P0) and ``me`` (from P1 to the
last column's end) are the low ``s + 1`` bits of ``2 u0 + S`` and ``S - 2 u1`` (both in
``[0, 2 S)`` by the choice of c0 and c1), zero for a column the clip window cut;
``e1 = (2 v1 + S) mod 2 S`` gives P1's height in its row. The products are small: ``|I_d|``
by a few sub-pixel bits, or ``kq`` by a square of them (setup only, multiplies allowed).
"""

from __future__ import annotations

import types

from amaranth.hdl import Const, Mux, Signal, signed, unsigned

from ..model.config import EdgeConfig
from .layouts import register_shape

__all__ = ["final_pieces", "pieces_registers", "run_end_loads"]

# The pieces registered at the end of RUN (bank fields of the same name), then FINAL's own.
_EARLY = ("end_row", "end_height", "total1", "rect0", "rect1", "band0", "band1")


def pieces_registers(config: EdgeConfig) -> types.SimpleNamespace:
    """The setup's registers of the end pieces: ``cut_end`` (WINDOW: the window cut the last
    column), the `_EARLY` bank fields and the operands FINAL needs (``single``, ``w0``,
    ``hs0_fp`` and ``square0``, the x-major first piece's squared width)."""
    widths = config.register_widths()
    s = config.subpixel_bits
    height = register_shape(widths["height"])
    regs = {name: Signal(height, name=f"pc_{name}") for name in _EARLY}
    regs["end_row"] = Signal(register_shape(widths["y"]), name="pc_end_row")
    regs.update(
        cut_end=Signal(name="pc_cut_end"),
        single=Signal(name="pc_single"),  # one partial column holds both vertices
        w0=Signal(unsigned(s + 2), name="pc_w0"),  # the first piece's width (2 S per pixel)
        hs0_fp=Signal(height, name="pc_hs0_fp"),  # hs0 of a partial first column
        square0=Signal(unsigned(2 * s + 3), name="pc_square0"),  # <= (2 S)**2
    )
    return types.SimpleNamespace(**regs)


def run_end_loads(unit) -> list:
    """The loads of RUN's last clock: the pieces that need no lane result (`unit` is the
    `EdgeSetupUnit`; its regs, command and ``pieces`` registers). x-major edges use rect
    and y-major ones band, so one product serves both where the shift allows; the products
    by ``|I_d|`` multiply the sub-pixel factors first (``half`` is ``|I_d|`` shifted)."""
    config = unit.config
    s, F = config.subpixel_bits, config.F
    S, k = 1 << s, F - s - 1  # half = |I_d| << k: ifix per half sub-pixel step
    r, cmd, pc = unit.regs, unit.cmd, unit.pieces
    fp, lp = ~r.start_clip, ~pc.cut_end  # the first and last columns hold the vertices
    p0, p1 = Mux(r.x_major, cmd.x0, cmd.y0), Mux(r.x_major, cmd.x1, cmd.y1)
    mg = Mux(fp, Mux(r.major_neg, S - (p0 << 1), (p0 << 1) + S)[: s + 1], 0)
    me = Mux(lp, Mux(r.major_neg, S + (p1 << 1), S - (p1 << 1))[: s + 1], 0)
    single = (r.columns == 1) & fp & lp
    v1_2 = ((r.v0_r + r.dv) << 1) + S  # 2 v1 + S
    e1 = v1_2[: s + 1]  # P1's height in its row, half sub-pixel steps
    h0 = (r.v0_r << 1) + S - (r.row0 << (s + 1))  # 2 v0 - (2 row0 - 1) S
    w0 = 2 * S - mg - Mux(single, me, 0)
    w1 = 2 * S - me
    xm = r.x_major
    # x: rect0 = (max(-hs0, 0) mg) >> (s + 1) (mg = 0 unless hs0 = half h0); y: band0.
    first_rect = (r.i_d * Mux(xm, Mux(h0 < 0, -h0, 0) * mg, w0)) << k
    # x: rect1 = (end_height me) >> (s + 1); y: the first term of total1.
    end_rect = ((r.i_d * (e1 * Mux(xm, me, w1))) << k) >> (s + 1)
    sq = 2 * s + 3  # K w^2 / 2 with w over 2 S: (kq w^2) >> (2 s + 3)
    slope_area = (r.kq * Mux(xm, 4 * S * S - me * me, w1 * w1)) >> sq
    return [
        pc.single.eq(single),
        pc.w0.eq(w0),
        pc.hs0_fp.eq((r.i_d * h0) << k),
        pc.square0.eq((2 * S - mg) * (2 * S - mg) - Mux(single, me * me, 0)),
        pc.end_row.eq(v1_2 >> (s + 1)),
        pc.end_height.eq((r.i_d * e1) << k),
        pc.total1.eq(Mux(xm, slope_area, end_rect - slope_area)),
        pc.rect0.eq(Mux(xm, first_rect >> (s + 1), 0)),
        pc.rect1.eq(Mux(xm, end_rect, 0)),
        pc.band0.eq(Mux(xm, 0, first_rect)),
        pc.band1.eq(Mux(xm, 0, (r.i_d * w1) << k)),
    ]


def final_pieces(m, unit) -> None:
    """The end pieces of ``next_bank`` (combinational, FINAL): the registered ones, the
    flags, the winding sign, and ``hs0``, ``total0``, which need ``jq`` (lane A's result;
    one product: ``kq`` by the squared width for x-major, the height sum by the width for
    y-major)."""
    s = unit.config.subpixel_bits
    r, cmd, pc, nb = unit.regs, unit.cmd, unit.pieces, unit.next_bank
    fp = ~r.start_clip
    borrow = nb.jr < nb.khr
    carry = (nb.jr + nb.khr) >= nb.du
    hs0 = Mux(fp, pc.hs0_fp, nb.jq - nb.khq - borrow)
    adj = pc.end_row - r.row0  # P1's row from the first column's: -1, 0 or +1 when single
    at_end = pc.end_height + Mux(adj > 0, nb.ifix, Mux(adj < 0, -nb.ifix, 0))
    he_first = Mux(pc.single, at_end, nb.jq + nb.khq + carry)
    xm = r.x_major
    area0 = Mux(xm, nb.kq, hs0 + he_first) * Mux(xm, pc.square0, pc.w0)
    # Travelling down the screen with the inside on the left puts the inside on the +x side.
    dy_pos, inside_left = ~unit.accepted["dy_le0"], cmd.inside == 0
    plus, minus = Const(1, signed(2)), Const(-1, signed(2))
    m.d.comb += [
        nb.sigma.eq(Mux(dy_pos == inside_left, plus, minus)),
        nb.row0.eq(r.row0),
        nb.first_partial.eq(fp),
        nb.last_partial.eq(~pc.cut_end),
        nb.hs0.eq(hs0),
        nb.total0.eq(Mux(xm, area0 >> (2 * s + 3), area0 >> (s + 2))),
        *(nb[name].eq(getattr(pc, name)) for name in _EARLY),
    ]
