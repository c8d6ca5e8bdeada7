"""``dbounds``, ``dloop``, ``dpipe``, ``dbeat``: the polygon core (its `DeltaStepper`).

The model side is `spec.deltas_column`: the model's `piece_end`, `column_deltas`,
`delta_cells` and `advance` on a loop state. The stepper's loop state is its loop registers
``x, y, jq, jr, remaining`` and ``hs``, ``adj`` (P1's row minus the loop's: the model's row is
``end_row - adj``) and ``first_col``, with the per-edge constants of the bank payload (the
setup holds the bank while the stepper steps its edge).

``dbounds``
    The end pieces: what FINAL writes equals the model's `end_pieces` where those are
    selects and small products of the fold (`spec.end_pieces`: the winding sign, the start
    row, the partial flags, P1's row and height, the first piece's start), and the bank's
    and the stepper's satisfy `spec.pieces_ok`; the loop's piece start is the bank's
    ``hs0`` in the first column and floor(J - K/2) after it (with the truncated
    accumulator, ``jq + khq - kq``); every register of the column being stepped (the
    heights, the estimate ``t``, the four deltas) fits its width.
``dloop``
    The loop follows the model's: after each step ``x, y, jq, jr, hs, adj, first_col`` and
    ``remaining`` are the model's next state of the column stepped (`advance`, the piece
    end less a row on a row step, one row further, not the first), after an edge's start
    the bank's (modulo the registers' widths; ``dbounds`` and ``bounds`` show they fit).
``dpipe``, ``dcells``, ``dbeat``
    Every beat's cells are the model's `delta_cells` of the loop state its column was
    stepped with (modulo the payload's widths, which ``dbounds`` shows the model's values
    fit), and ``last`` is set exactly on an edge's last column. As for the writes core
    (`pipeline`), the harness carries a snapshot of the loop state along p1, p2 and (the
    deep stepper, `DELTAS_FAST`) p3; ``dpipe`` states what p1 holds (the model's heights
    and the column's per-edge selects), what p2 holds (those it carries, the model's
    clamped estimate, the piece's cover of each row) and what p3 holds (those it carries,
    the areas of the upper and lower rows, the total less the lower, the middle row's
    bound: of p2's values, which the harness registers as the pipeline moves), ``dcells``
    that the cells the output register loads from p2 or p3 are the model's in full width,
    ``dbeat`` the output register against them; the harness registers the model's cells of
    p2's snapshot as the pipeline moves (one copy of the model per stage up to p2, none
    after it: k-induction would have to prove the copies equal).
"""

from __future__ import annotations

import types

from amaranth.hdl import Cat, Mux, Signal, Value
from amaranth.lib import data

from .pipeline import delayed
from .spec import all_, axes, deltas_column, end_pieces, implies, pieces_ok, whole_column_start

DELTA_CHECKS = ("dbounds", "dloop", "dpipe", "dcells", "dbeat")


def check(ctx):
    """The deltas groups asked for (checked or assumed), from what `bounds.check` left in
    `ctx`; leaves ``live`` (`spec.deltas_column` of the column being stepped) for the
    covers."""
    wanted = set(ctx.checks) | set(ctx.assumes)
    st = loop_state(ctx.st, ctx.stepper)
    ctx.live = _column(ctx, st, "live")
    if "dbounds" in wanted:
        _setup_pieces(ctx)
        _loop_bounds(ctx, st)
    if "dloop" in wanted:
        _loop(ctx, st)
    if wanted & {"dpipe", "dcells", "dbeat"}:
        _pipeline(ctx, st)


def loop_state(record, stepper) -> types.SimpleNamespace:
    """The stepper's bank-like record with the deltas loop registers."""
    return types.SimpleNamespace(**vars(record), **stepper.delta_regs)


def _column(ctx, st, prefix):
    return deltas_column(ctx.config, st, st.end_row - st.adj, st.first_col, ctx.m, prefix)


# -- dbounds -------------------------------------------------------------------------------


def _setup_pieces(ctx):
    """The setup's end pieces: the first piece's height in pass 2 (from ``row0``, bounded
    like the start row, for an edge whose start the window did not move), FINAL's bank
    against the model, the bank's invariants."""
    config, setup = ctx.config, ctx.setup
    s, S = config.subpixel_bits, config.subpixel_scale
    r, spec = setup.regs, ctx.setup_spec
    # 2 v0 + S - 2 S row0 = (M mod 2 S) - q with |q| <= S (lane A's first pass over |e|
    # <= S / 2): the first piece's start in half sub-pixel steps, in [-S, 3 S).
    h0 = (r.v0_r << 1) + S - (r.row0 << (s + 1))
    pass2 = (setup.in_run & (r.counter > setup.schedule.pass1)) | setup.in_final
    ctx.emit(
        "dbounds",
        implies(pass2 & ~r.start_clip, (h0 >= -S) & (h0 < 3 * S)),
        "dbounds: first piece's start in pass 2",
    )
    # WINDOW registers whether the window cuts the last column (c1 > hi).
    cut_end = setup.pieces.cut_end == (spec.win.last != spec.fold.c1)
    ctx.emit("dbounds", implies(setup.in_run | setup.in_final, cut_end), "dbounds: cut end")
    nb, final = spec.nb, setup.in_final
    model = end_pieces(config, spec.fold, spec.win, setup.cmd, nb)
    for name, condition in model.items():
        ctx.emit("dbounds", implies(final, condition), f"dbounds: next bank {name}")
    for name, condition in pieces_ok(config, nb).items():
        ctx.emit("dbounds", implies(final, condition), f"dbounds: next bank pieces {name}")
    for name, condition in pieces_ok(config, ctx.bk).items():
        ctx.emit("dbounds", implies(setup.bank.valid, condition), f"dbounds: bank {name}")


def _loop_bounds(ctx, st):
    """The stepper's end pieces, its piece start and the widths of the column's registers."""
    active = ctx.stepper.active
    for name, condition in pieces_ok(ctx.config, st, start=False).items():
        ctx.emit("dbounds", implies(active, condition), f"dbounds: stepper {name}")
    # After the first column: floor(J - K/2); with the remainders dropped K = kq, K/2 = khq.
    exact = ctx.config.accumulator == "exact"
    later = whole_column_start(st) if exact else st.jq + st.khq - st.kq
    start = Mux(st.first_col, st.hs0, later)
    ctx.emit("dbounds", implies(active, st.hs == start), "dbounds: piece start")
    # the edge's khr - du (mod 2**w), which the piece end's carry reads
    khr_du = st.khr_du == (st.khr - st.du)[: len(st.khr_du)]
    ctx.emit("dbounds", implies(active, khr_du), "dbounds: khr_du")
    for name, condition in ctx.live.fits.items():
        if name in ("height", "t", "delta"):
            ctx.emit("dbounds", implies(active, condition), f"dbounds: column {name} fits")


# -- dloop ---------------------------------------------------------------------------------


def _loop(ctx, st):
    """Ghost registers with the model's next loop state, loaded when the stepper steps or
    starts an edge (``start``); the stepper's registers must equal them while it is
    active."""
    m, stepper = ctx.m, ctx.stepper
    live, b = ctx.live, ctx.bk
    regs = {name: getattr(st, name) for name in ("x", "y", "jq", "jr", "remaining")}
    regs.update(stepper.delta_regs)
    step = live.step
    row = st.end_row - st.adj
    stepped = {
        "x": step.x,
        "y": step.y,
        "jq": step.jq,
        "jr": step.jr,
        "remaining": st.remaining - 1,
        "hs": live.hs_next,
        "adj": st.end_row - (row + step.row_step),
        "first_col": 0,
        "khr_du": st.khr_du,
    }
    loaded = {name: getattr(b, name) for name in ("x", "y", "jq", "jr", "remaining")}
    loaded.update(hs=b.hs0, adj=b.end_row - b.row0, first_col=1, khr_du=b.khr - b.du)
    for name, reg in regs.items():
        want = Signal(reg.shape(), name=f"want_{name}")
        with m.If(stepper.step):
            m.d.sync += want.eq(stepped[name])
        with m.If(stepper.start):  # the start wins, as in the stepper
            m.d.sync += want.eq(loaded[name])
        ctx.emit("dloop", implies(stepper.active, reg == want), f"dloop: {name}")
    # The piece end of the column being stepped is the model's (`piece_end`): with ``hs``
    # above, each column starts where the previous one ended (a row less on a row step).
    he = implies(stepper.active, stepper.delta_he == live.he)
    ctx.emit("dloop", he, "dloop: piece end")
    if ctx.fault == "tight_hs":  # false: a piece can start in the row above (a cover)
        ctx.emit("dloop", implies(stepper.active, st.hs >= 0), "dloop: false invariant hs >= 0")


# -- dpipe, dbeat --------------------------------------------------------------------------


def _snapshots(ctx, st) -> list:
    """(snapshot, valid) of the loop state for p1, p2, p3 (one enable moves them, as the
    stepper's pipeline)."""
    m, out = ctx.m, ctx.out
    en = ~out.valid | out.ready
    snaps = []
    source, source_valid = st, ctx.stepper.active
    for index in range(ctx.stepper.latency - 1):
        regs = {}
        for name, value in vars(source).items():
            tag = f"d{index + 1}s_{name}"
            if isinstance(value, list):
                regs[name] = [delayed(m, en, v, f"{tag}{j}") for j, v in enumerate(value)]
            else:
                regs[name] = delayed(m, en, value, tag)
        valid = delayed(m, en, source_valid, f"d{index + 1}s_valid")
        snap = types.SimpleNamespace(**regs)
        snaps.append((snap, valid))
        source, source_valid = snap, valid
    return snaps


def _pipeline(ctx, st):
    snaps = _snapshots(ctx, st)
    _stage_p1(ctx, *snaps[0])
    values, cells = _stage_p2(ctx, *snaps[1])
    valid = snaps[1][1]
    if len(ctx.stages) == 3:  # DELTAS_FAST: p3 between p2 and the output register
        valid, values, cells = _stage_p3(ctx, snaps[2][1], values, cells)
    _cells_ok(ctx, valid, cells)
    _output(ctx, valid, values["last"], cells)


def _stage_p1(ctx, s1, v1):
    """``dpipe``: p1 holds the column of its snapshot: the model's piece (``hs``, ``he``, the
    depth of its crossing part) and the column's per-edge selects (restated from
    `column_deltas`: total, band, the rectangles)."""
    p1 = ctx.stages[0]
    values = _p1_values(s1, _column(ctx, s1, "d1spec"))
    ctx.emit("dpipe", p1.valid == v1, "dpipe: p1 valid")
    for name, value in values.items():
        ctx.emit("dpipe", implies(v1, getattr(p1, name) == value), f"dpipe: p1 {name}")
    _snapshot_ok(ctx, "dpipe", s1, v1, "p1")


def _p1_values(s, c) -> dict:
    """What p1 holds for the column of loop state `s` (`c` its `spec.deltas_column`)."""
    x_major = s.col_dx != 0
    ifix, hs, he = s.ifix, s.hs, c.he
    low = he > ifix
    band1 = Mux(c.adj > 0, s.band1, Mux(c.adj < 0, -s.band1, 0))
    interior = Mux(x_major, s.khq, s.jq)
    last_total = s.total1 + band1
    band = Mux(c.first, s.band0, Mux(c.last, s.band1, ifix))
    rect_up = Mux(c.first, s.rect0, 0)
    values = {
        "last": s.remaining == 0,
        "x": s.x,
        "y": s.y,
        "x_major": x_major,
        "neg": x_major & (s.col_dx < 0),
        "minor_neg": Mux(x_major, s.row_dy < 0, s.row_dx < 0),
        "sigma_neg": s.sigma < 0,
        "hs": hs,
        "he": he,
        "ifix": ifix,
        "low": low,
        "total": Mux(c.first, s.total0, Mux(c.last, last_total, interior)),
        # one register: the y-major band, the x-major upper rectangle
        "band_rect": Mux(x_major, rect_up, band),
        "rect_low": Mux(c.last, s.rect1, 0),
    }
    depth = Mux(low, he - ifix, -hs)
    if len(s.seg_intercepts) == 1:  # the intercept folded into the depth (t's numerator)
        values["depth_icpt"] = depth - (s.seg_intercepts[0] << 2)
    elif s.seg_intercepts:
        values["depth"] = depth
        values.update({f"thr{j}": t for j, t in enumerate(s.seg_thresholds, start=1)})
        values.update({f"icpt{j}": icpt for j, icpt in enumerate(s.seg_intercepts)})
    return values


def _p2_values(s, c) -> dict:
    """What p2 holds for the column of loop state `s`: p1's values it carries, the model's
    clamped estimate ``t`` and ``up``, and the piece's cover of the rows r - 1, r, r + 1
    (restated from `column_deltas`)."""
    p1 = _p1_values(s, c)
    carried = ("last", "x", "y", "x_major", "neg", "minor_neg", "sigma_neg")
    carried += ("low", "total", "band_rect", "rect_low")
    hs, he, ifix = s.hs, c.he, s.ifix
    return dict(
        {name: p1[name] for name in carried},
        t=c.t,
        up=c.up,
        hs_ge=hs >= ifix,
        he_le0=he <= 0,
        cov_up=Mux(he < 0, he, 0) - Mux(hs < 0, hs, 0),
        cov_mid=_clamp(he, ifix) - _clamp(hs, ifix),
        cov_low=Mux(he > ifix, he, ifix) - Mux(hs > ifix, hs, ifix),
    )


def _clamp(value, hi):
    return Mux(value < 0, 0, Mux(value > hi, hi, value))


def _snapshot_ok(ctx, group, snap, valid, where):
    """The invariants of the stepper that the model's cells need, on a snapshot: the unit
    steps of a folded edge and the winding sign (+-1)."""
    ok = all_([axes(snap).steps_ok, (snap.sigma == 1) | (snap.sigma == -1)])
    ctx.emit(group, implies(valid, ok), f"{group}: {where} snapshot steps and sign")


def _stage_p2(ctx, s2, v2):
    """``dpipe``: p2 holds the column of its snapshot (`_p2_values`), which satisfies
    `_snapshot_ok`; returns those values and the model's cells of that column
    (`spec.deltas_column`)."""
    p2 = ctx.stages[1]
    c2 = _column(ctx, s2, "d2spec")
    values = _p2_values(s2, c2)
    ctx.emit("dpipe", p2.valid == v2, "dpipe: p2 valid")
    for name, value in values.items():
        ctx.emit("dpipe", implies(v2, getattr(p2, name) == value), f"dpipe: p2 {name}")
    # what the fast core's `dcells` needs of the column whose cells p3 holds one move later
    _snapshot_ok(ctx, "dpipe", s2, v2, "p2")
    return values, c2.cells


def _p3_values(p2) -> dict:
    """What p3 holds, from the values p2 held (`_p2_values`) one move earlier: those it
    carries and the areas of the column's lower and upper rows (restated from
    `column_deltas`: ``lo``, ``hi``), the total less the lower (``rest``) and the middle
    row's bound, each the x-major or the y-major one."""
    carried = ("last", "x", "y", "x_major", "neg", "minor_neg", "sigma_neg", "up")
    carried += ("cov_up", "cov_low")
    total, t, band = p2["total"], p2["t"], p2["band_rect"]
    hs_ge, low, up, he_le0 = p2["hs_ge"], p2["low"], p2["up"], p2["he_le0"]
    cov_up, cov_low = p2["cov_up"], p2["cov_low"]
    r_low = Mux(hs_ge, total, Mux(low, _clamp(t + p2["rect_low"], cov_low), 0))
    r_up = Mux(he_le0, total, Mux(up, _clamp(cov_up - t - band, cov_up), 0))
    a_low = _clamp(Mux(hs_ge, total - band, Mux(low, t, 0)), band)
    a_up = _clamp(Mux(he_le0, total + band, Mux(up, band - t, band)), band)
    x_major = p2["x_major"]
    return dict(
        {name: p2[name] for name in carried},
        lo=Mux(x_major, r_low, a_low),
        hi=Mux(x_major, r_up, a_up),
        rest=Mux(x_major, total - r_low, total + band - a_low),
        bound=Mux(x_major, p2["cov_mid"], band),
    )


def _stage_p3(ctx, v3, p2_values, p2_cells):
    """``dpipe`` (the deep stepper's p3): p3 holds `_p3_values` of what p2 held
    (`p2_values`, registered by the harness as the pipeline moves: no second copy of the
    model's column, which k-induction would have to prove equal to p2's). Returns p3's
    valid, p2's values and the model's cells of p2's column (`p2_cells`), both registered
    likewise, one move later."""
    m, p3 = ctx.m, ctx.stages[2]
    en = ~ctx.out.valid | ctx.out.ready
    held = {name: delayed(m, en, value, f"d3m_{name}") for name, value in p2_values.items()}
    cells = [
        [
            delayed(m, en, value, f"d3m_cell{k}_{name}")
            for value, name in zip(cell, "xyd", strict=True)
        ]
        for k, cell in enumerate(p2_cells)
    ]
    ctx.emit("dpipe", p3.valid == v3, "dpipe: p3 valid")
    for name, value in _p3_values(held).items():
        ctx.emit("dpipe", implies(v3, getattr(p3, name) == value), f"dpipe: p3 {name}")
    return v3, held, cells


def _cells_ok(ctx, valid, cells):
    """``dcells``: the cells the output register loads (from p2, or the deep stepper's p3)
    are the model's `cells` of that stage's column, in full width."""
    for k, (cell, model) in enumerate(zip(ctx.stepper.delta_cells, cells, strict=True)):
        match = all_([Value.cast(a) == b for a, b in zip(cell, model, strict=True)])
        ctx.emit("dcells", implies(valid, match), f"dcells: cell{k}")


def _output(ctx, valid, last, cells):
    """``dbeat``: the output register is the beat of its column: the model's cells of the
    loop state the column was stepped with (`cells` of the stage before it, of p2's
    snapshot, registered again by the harness when the pipeline moves; modulo the payload's
    widths) and ``last`` on the edge's last column (the stage's `last`, likewise)."""
    m, out = ctx.m, ctx.out
    en = ~out.valid | out.ready
    beat = data.View(ctx.layout, ctx.payload)
    v_out = delayed(m, en, valid, "dout_valid")
    last = delayed(m, en, last, "dout_last")
    ctx.emit("dbeat", out.valid == v_out, "dbeat: beat valid")
    ctx.emit("dbeat", implies(v_out, beat.last == last), "dbeat: last")
    flags = Cat(*(beat[f"cell{k}"].delta != 0 for k in range(len(cells))))
    ctx.emit("dbeat", implies(out.valid, beat.nonzero == flags), "dbeat: nonzero, the deltas'")
    for k, model in enumerate(cells):
        cell = beat[f"cell{k}"]
        got = (cell.x, cell.y, cell.delta)
        want = [
            delayed(m, en, Value.cast(b)[: len(Value.cast(a))], f"dout_cell{k}_{name}")
            for a, b, name in zip(got, model, "xyd", strict=True)
        ]
        match = all_([Value.cast(a).as_unsigned() == b for a, b in zip(got, want, strict=True)])
        ctx.emit("dbeat", implies(v_out, match), f"dbeat: cell{k} is the model's")
