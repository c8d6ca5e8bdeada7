"""``dbounds``, ``dloop``, ``dpipe``, ``dbeat``: the deltas core (``output="deltas"``).

The model side is `spec.deltas_column`: the model's `piece_end`, `column_deltas`,
`delta_cells` and `advance` on a loop state. The stepper's loop state is its bank registers,
``x, y, jq, jr, remaining`` and the deltas registers ``hs``, ``adj`` (P1's row minus the
loop's: the model's row is ``end_row - adj``) and ``first_col``.

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
    end less a row on a row step, one row further, not the first), after a bank load the
    bank's (modulo the registers' widths; ``dbounds`` and ``bounds`` show they fit).
``dpipe``, ``dbeat``
    Every beat's cells are the model's `delta_cells` of the loop state its column was
    stepped with (modulo the payload's widths, which ``dbounds`` shows the model's values
    fit), and ``last`` is set exactly on an edge's last column. As for the writes core
    (`pipeline`), the harness carries a snapshot of the loop state along the pipeline;
    ``dpipe`` states what p1 holds (the model's heights and the column's per-edge selects)
    and that the cells the output register would load from p2 are the model's, ``dbeat``
    the output register.
"""

from __future__ import annotations

import types

from amaranth.hdl import Mux, Signal, Value
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
    pass2 = (setup.in_run & (r.counter > s + 1)) | setup.in_final
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
    for name, condition in ctx.live.fits.items():
        if name in ("height", "t", "delta"):
            ctx.emit("dbounds", implies(active, condition), f"dbounds: column {name} fits")


# -- dloop ---------------------------------------------------------------------------------


def _loop(ctx, st):
    """Ghost registers with the model's next loop state, loaded when the stepper steps or
    loads the bank; the stepper's registers must equal them while it is active."""
    m, stepper, bank = ctx.m, ctx.stepper, ctx.setup.bank
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
    }
    loaded = {name: getattr(b, name) for name in ("x", "y", "jq", "jr", "remaining")}
    loaded.update(hs=b.hs0, adj=b.end_row - b.row0, first_col=1)
    for name, reg in regs.items():
        want = Signal(reg.shape(), name=f"want_{name}")
        with m.If(stepper.step):
            m.d.sync += want.eq(stepped[name])
        with m.If(bank.valid & bank.ready):  # the load wins, as in the stepper
            m.d.sync += want.eq(loaded[name])
        ctx.emit("dloop", implies(stepper.active, reg == want), f"dloop: {name}")


# -- dpipe, dbeat --------------------------------------------------------------------------


def _snapshots(ctx, st) -> list:
    """(snapshot, valid) of the loop state for each pipeline position, p1 first and the
    output register last (one enable moves them, as the stepper's pipeline)."""
    m, out = ctx.m, ctx.out
    en = ~out.valid | out.ready
    snaps = []
    source, source_valid = st, ctx.stepper.active
    for index in range(ctx.stepper.latency):
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
    _stage_p2(ctx, *snaps[1])
    _output(ctx, *snaps[2])


def _stage_p1(ctx, s1, v1):
    """``dpipe``: p1 holds the column of its snapshot: the model's piece (``hs``, ``he``, the
    depth of its crossing part) and the column's per-edge selects (restated from
    `column_deltas`: total, band, the rectangles)."""
    p1 = ctx.stages[0]
    c1 = _column(ctx, s1, "d1spec")
    x_major = s1.col_dx != 0
    ifix, hs, he = s1.ifix, s1.hs, c1.he
    low = he > ifix
    band1 = Mux(c1.adj > 0, s1.band1, Mux(c1.adj < 0, -s1.band1, 0))
    interior = Mux(x_major, s1.khq, s1.jq)
    last_total = s1.total1 + band1
    values = {
        "last": s1.remaining == 0,
        "x": s1.x,
        "y": s1.y,
        "x_major": x_major,
        "neg": x_major & (s1.col_dx < 0),
        "minor_neg": Mux(x_major, s1.row_dy < 0, s1.row_dx < 0),
        "sigma_neg": s1.sigma < 0,
        "hs": hs,
        "he": he,
        "ifix": ifix,
        "low": low,
        "depth": Mux(low, he - ifix, -hs),
        "total": Mux(c1.first, s1.total0, Mux(c1.last, last_total, interior)),
        "band": Mux(c1.first, s1.band0, Mux(c1.last, s1.band1, ifix)),
        "rect_up": Mux(c1.first, s1.rect0, 0),
        "rect_low": Mux(c1.last, s1.rect1, 0),
    }
    values.update({f"thr{j}": t for j, t in enumerate(s1.seg_thresholds, start=1)})
    values.update({f"icpt{j}": icpt for j, icpt in enumerate(s1.seg_intercepts)})
    ctx.emit("dpipe", p1.valid == v1, "dpipe: p1 valid")
    for name, value in values.items():
        ctx.emit("dpipe", implies(v1, getattr(p1, name) == value), f"dpipe: p1 {name}")
    _snapshot_ok(ctx, "dpipe", s1, v1, "p1")


def _snapshot_ok(ctx, group, snap, valid, where):
    """The invariants of the stepper that the model's cells need, on a snapshot: the unit
    steps of a folded edge and the winding sign (+-1)."""
    ok = all_([axes(snap).steps_ok, (snap.sigma == 1) | (snap.sigma == -1)])
    ctx.emit(group, implies(valid, ok), f"{group}: {where} snapshot steps and sign")


def _stage_p2(ctx, s2, v2):
    """``dpipe``: p2 holds the column of its snapshot: the cells the output register loads
    from it are the model's, in full width."""
    p2 = ctx.stages[1]
    c2 = _column(ctx, s2, "d2spec")
    ctx.emit("dpipe", p2.valid == v2, "dpipe: p2 valid")
    ctx.emit("dpipe", implies(v2, p2.last == (s2.remaining == 0)), "dpipe: p2 last")
    for k, (cell, model) in enumerate(zip(ctx.stepper.delta_cells, c2.cells, strict=True)):
        match = all_([Value.cast(a) == b for a, b in zip(cell, model, strict=True)])
        ctx.emit("dcells", implies(v2, match), f"dcells: p2 cell{k}")


def _output(ctx, s3, v3):
    """``dbeat``: the output register is the beat of its snapshot's column: the model's
    cells (modulo the payload's widths) and ``last`` on the edge's last column."""
    beat = data.View(ctx.layout, ctx.payload)
    c3 = _column(ctx, s3, "d3spec")
    ctx.emit("dbeat", ctx.out.valid == v3, "dbeat: beat valid")
    ctx.emit("dbeat", implies(v3, beat.last == (s3.remaining == 0)), "dbeat: last")
    for k, model in enumerate(c3.cells):
        cell = beat[f"cell{k}"]
        got = (cell.x, cell.y, cell.delta)
        match = all_(
            [
                Value.cast(a).as_unsigned() == Value.cast(b)[: len(Value.cast(a))]
                for a, b in zip(got, model, strict=True)
            ]
        )
        ctx.emit("dbeat", implies(v3, match), f"dbeat: cell{k} is the model's")
