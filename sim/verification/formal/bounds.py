"""``bounds``: no register overflows for any command.

The invariants of the setup registers (fold of the latched command, its columns cut to the
latched window, the column count), of both multiply-divide lanes (remainder below du,
quotient bounded by the multiplier bits consumed so far, each step's sums within their
registers; lane A's first pass over ``2 (first S - u0)``, ``W + s + 2`` bits when the window
moved the first column), of the deltas setup's Horner products over the lanes' clocks
(`_products`; FINAL's, the y-major ``total0``, needs none: below), of the bank the setup is
about to write (``next_bank``), of the bank and of the stepper (jq < ifix, jr < du, kq <=
ifix, the half increment, segment constants, derived constants, value range, the major axis
within [0, 2**W] from the first to the last column). The start row (the minor axis of the
first column) is within [0, 2**W] for edges whose start the window did not move; for the
others its bound needs the product (first - c0) * slope, which SAT-based induction cannot
handle: the harness follows those edges with a ghost flag and leaves their start row to
simulation (the core tests compare every bank with the model's `setup`). Every intermediate
sum of the column being stepped (the exit depths dq/dr, t, the areas, the output values,
jsum and the next jq, jr) is computed in full width by `spec.column` and must fit the
`EdgeConfig.register_widths` entry that `run_edge` checks; the stepper's ``jsum`` and ``dq``
wires must equal them.

`check` leaves in `ctx` what the pipeline checks and the covers read: ``st`` (the stepper's
registers as a bank-like record), ``st_axes``, ``column`` (`spec.column` of ``st``).
"""

from __future__ import annotations

import types

from amaranth.hdl import Mux, Signal, Value, signed, unsigned

from ....hdl.pieces import (
    EndPieces,
    end_multiplicand,
    id_products,
    kq_multiplicands,
    kq_products,
)
from ....hdl.setup import accept_values
from ....hdl.stepper import LineStepper
from .spec import all_, axes, column, constants_ok, fields, fold, implies, major_ok, window


def check(ctx):
    asserts = []

    def add(condition, name):
        asserts.append((condition, f"bounds: {name}"))

    s = _setup(ctx, add)
    ctx.setup_spec = s  # the latched command's fold and window, the next bank (deltas checks)
    lanes = _lanes(ctx, s, add)
    if isinstance(ctx.setup.pieces, EndPieces):  # the part's products
        _products(ctx, s, lanes, add)
    _bank(ctx, s, add)
    _stepper(ctx, add)
    for condition, message in asserts:
        ctx.emit("bounds", condition, message)


# -- the setup: fold and window registers ----------------------------------------------------


def _setup(ctx, add) -> types.SimpleNamespace:
    """The setup's registers against the fold and window of the latched command; returns
    what the lane and bank checks share."""
    config, setup = ctx.config, ctx.setup
    r = setup.regs
    f = fold(config, setup.cmd)
    # The window is the one the core sampled with the command (the harness drives the
    # port freely in every clock).
    win = window(config, f, setup.clip_r)
    in_window, run, final = setup.in_window, setup.in_run, setup.in_final
    busy = in_window | run | final
    cut = run | final  # the columns are cut to the window, lane A is loaded
    counter = r.counter
    nb = fields(setup.next_bank, setup.next_bank.shape())
    nb_axes = axes(nb)
    # The registers the setup loads when it accepts a command, besides the command: each
    # equals its value with the latched command in place of the incoming payload.
    for name, value in accept_values(config, setup.cmd).items():
        add(implies(~setup.in_idle, setup.accepted[name] == value), f"accepted {name}")
    # FOLD registers c0, c1 (as first, last) and the folded window; WINDOW cuts the
    # columns to it and registers v0; the first RUN clock forms the column count, the
    # second ends an edge with no column (so from counter 2 on there is one at least).
    counted = final | (run & (counter >= 1))
    visible = final | (run & (counter >= 2))
    late = [
        implies(busy, (r.lo == win.lo) & (r.hi == win.hi)),
        implies(in_window, (r.first == f.c0) & (r.last == f.c1) & (counter == 0)),
        implies(cut, (r.first == win.first) & (r.last == win.last)),
        implies(cut, r.start_clip == win.start_clip),
        implies(cut, r.v0_r == f.v0),
        implies(counted, r.columns == win.columns),
        implies(visible, (win.columns >= 1) & (nb.remaining == win.columns - 1)),
        implies(cut, nb_axes.major == Mux(f.major_neg, -win.first, win.first)),
        implies(visible, major_ok(config, nb_axes)),
    ]
    add(all_(late), "fold and window registers")
    registers = _fold_registers(config, r, f, nb, nb_axes)
    for name, condition in registers.items():
        add(implies(busy, condition), name)
    # |e| and its sign from FOLD; e is positive when the window moved the first column
    # (WINDOW clears the sign: no sign fix-up then).
    e_ok = [
        implies(busy, r.e_mag_r == f.e_mag),
        implies(in_window, r.e_neg == (f.e < 0)),
        implies(cut, r.e_neg == ((f.e < 0) & ~win.start_clip)),
    ]
    add(all_(e_ok), "e registers")
    plan = setup.schedule  # RUN's clocks (`edgeaa.model.timing.run_schedule`)
    run_cycles, long_run = plan.run, plan.run + plan.start_clip
    add(implies(run, counter < Mux(r.start_clip, long_run, run_cycles)), "counter")
    return types.SimpleNamespace(fold=f, win=win, busy=busy, nb=nb, nb_axes=nb_axes)


def _fold_registers(config, r, f, nb, nb_axes) -> dict:
    """Invariants that hold while the setup is busy (WINDOW, RUN, FINAL): the FOLD registers
    are the fold of the latched command, its geometry, and the steps of the next bank."""
    top = 1 << config.coord_bits
    return {
        "fold_registers": all_(
            [
                ~f.bad,
                r.du == f.du,
                r.dv == f.dv,
                r.neg_du == -r.du,
                r.i_d == f.i_d,
                r.minor_neg == f.minor_neg,
                r.value_base == f.value_base,
                r.value_neg == f.value_neg,
            ]
        ),
        "fold_geometry": all_(
            [
                r.du != 0,
                r.dv <= r.du,
                f.c0 >= -top,
                f.c0 <= top,
                f.columns >= 1,
                f.columns <= top + 1,
            ]
        ),
        "bank_steps": all_(
            [
                nb_axes.steps_ok,
                nb_axes.x_major == f.x_major,
                nb_axes.col_step == Mux(f.major_neg, -1, 1),
                nb_axes.row_step == Mux(f.minor_neg, -1, 1),
                nb.du == f.du,
                nb.ifix == f.i_d << config.F,
            ]
        ),
    }


# -- the setup: the multiply-divide lanes ------------------------------------------------------


def _lane(ctx, lane, multiplier, bits, done, *, x_at_most, digit=None, pad=0, single=None):
    """Invariants of a lane after `done` steps of its `bits`-bit multiplier led by `pad`
    zero bits (each leaves q = r = 0), and whether its next clock's steps (its
    `edgeaa.model.timing.RunSchedule.steps`; the first only where `single`) fit their
    registers."""
    s = ctx.config.subpixel_bits
    du = ctx.setup.regs.du
    q, r, a, x = lane.q, lane.r, lane.a, lane.x
    a_bits = len(a)
    wide = (Value.cast(multiplier).as_unsigned() << (a_bits - bits - pad)) << done
    consumed = wide >> a_bits
    conds = [a == wide[:a_bits], r < du, x_at_most(x)]
    # The lane keeps X - du, X - 2 du and digit + 2 precomputed.
    conds += [
        lane.x_du == x - du,
        lane.x_2du == x - (du << 1),
        lane.digit2 == lane.digit + 2,
    ]
    if digit is None:
        conds += [
            lane.digit == 0,
            (q < consumed) | ((q == consumed) & (r == 0)),
            implies(x == 0, (q == 0) & (r == 0)),
        ]
    else:
        conds.append((q < (consumed << (s + 1))) | ((consumed == 0) & (q == 0) & (r == 0)))
    # The next clock's steps in full width (`MulDivLane.step`).
    fits = []
    for k in range(ctx.setup.schedule.steps):
        bit = a[-1 - k]
        total = (r << 1) + Mux(bit, x, 0)
        quotient_digit = Mux(total >= (du << 1), 2, Mux(total >= du, 1, 0))
        q = (q << 1) + quotient_digit
        if digit is not None:
            q = q + Mux(bit, digit, 0)
        r = total - Mux(quotient_digit == 2, du << 1, Mux(quotient_digit == 1, du, 0))
        step_fits = (total < (1 << (len(lane.r) + 2))) & (q < (1 << len(lane.q)))
        fits.append(step_fits if k == 0 or single is None else implies(~single, step_fits))
    return all_(conds), all_(fits)


def _done(counter, start, clocks, steps):
    """Steps a lane has taken `counter - start` clocks into a pass of `clocks` clocks of
    `steps` each (all of them from its end on)."""
    into = (counter - start)[: len(counter)]
    return Mux(counter >= start + clocks, clocks * steps, into * steps)


def _lanes(ctx, s, add):
    config, setup = ctx.config, ctx.setup
    F, I = config.F, config.intensity_bits  # noqa: E741
    sub = config.subpixel_bits
    r, win, plan = setup.regs, s.win, setup.schedule
    run, final, counter = setup.in_run, setup.in_final, r.counter
    steps = plan.steps
    pass1_bits, pass2_bits = sub + 1, I + F - sub - 1
    fixup = Mux(r.start_clip, plan.pass1_long, plan.pass1)

    def dv_is(x):
        return x == r.dv

    # Lane B is loaded in FOLD and steps from the first RUN clock (counter 0).
    b_bits = I + F - 1
    steps_b = Mux(final, plan.lane_b * steps, _done(counter, 0, plan.lane_b, steps))
    lane_b, lane_b_step = _lane(
        ctx,
        setup.lane_b,
        r.i_d << (F - 1),
        b_bits,
        steps_b,
        x_at_most=dv_is,
        pad=plan.lane_b_pad,
    )
    add(implies(s.busy, lane_b), "lane_b")
    add(implies(run & (counter < plan.lane_b), lane_b_step), "lane_b step fits")
    # Lane A is loaded in WINDOW: pass 1 over the W + s + 2 bit multiplier (stopped after
    # s + 1 bits when the start did not move: one step in its last clock if
    # `RunSchedule.pass1_single`), the fix-up at `fixup`, then pass 2 (and the tail).
    lane_a = setup.lane_a
    short_done = plan.pass1_pad + pass1_bits  # steps at the fix-up, start not moved
    done1 = Mux(
        r.start_clip | (counter < plan.pass1), (counter * steps)[: len(counter) + 1], short_done
    )
    single = (~r.start_clip & (counter == plan.pass1 - 1)) if plan.pass1_single else None
    pass1, pass1_step = _lane(
        ctx,
        lane_a,
        win.multiplier,
        win.bits,
        done1,
        x_at_most=dv_is,
        pad=plan.pass1_pad,
        single=single,
    )
    add(implies(run & (counter <= fixup), pass1), "lane_a pass 1")
    add(implies(run & (counter < fixup), pass1_step), "lane_a pass 1 step fits")
    in_pass2 = (run & (counter > fixup)) | final
    done2 = Mux(final, plan.pass2 * steps, _done(counter, fixup + 1, plan.pass2, steps))
    pass2, pass2_step = _lane(
        ctx,
        lane_a,
        r.i_d << (F - sub - 1),
        pass2_bits,
        done2,
        x_at_most=lambda x: x < r.du,
        digit=lane_a.digit,
        pad=plan.pass2_pad,
    )
    add(implies(in_pass2, pass2), "lane_a pass 2")
    stepping2 = run & (counter > fixup) & (counter <= fixup + plan.pass2)  # not the tail
    add(implies(stepping2, pass2_step), "lane_a pass 2 step fits")
    # The multiplier bits of pass 2 consumed (past its leading zero steps).
    steps_a = Mux(done2 > plan.pass2_pad, done2 - plan.pass2_pad, 0)[: len(done2)]
    # The start row is in the image. Not checked for an edge whose start the window moved:
    # there it follows from q' = floor(2 e dv / du) <= 2 dv + S - 1 with e up to du + S/2,
    # a product of two per-edge values that SAT-based induction cannot handle (with
    # |e| <= S/2 the linear q' <= 2 |e| <= S suffices). Such an edge's start row is
    # followed as a ghost (`start_moved` below) and its bound left to simulation.
    top = 1 << config.coord_bits
    bank_row = (s.nb_axes.minor >= 0) & (s.nb_axes.minor <= top)
    add(implies(in_pass2 & ~win.start_clip, bank_row), "bank start row")
    # What FINAL writes: once both lanes are done, all bank invariants.
    for name, condition in constants_ok(config, s.nb).items():
        add(implies(final, condition), f"next bank {name}")
    # kq, kr are registered in the clock after lane B's last step.
    b_q, b_r = setup.lane_b.q, setup.lane_b.r
    k_bit = (b_r << 1) >= r.du
    k_ready = final | (run & (counter > plan.lane_b))
    k_ok = (r.kq == (b_q << 1) + k_bit) & (r.kr == (b_r << 1) - Mux(k_bit, r.du, 0))
    add(implies(k_ready, k_ok), "kq, kr registered from lane B")
    return types.SimpleNamespace(in_pass2=in_pass2, steps_a=steps_a, k_ready=k_ready)


def _products(ctx, spec, lanes, add):
    """The deltas setup's Horner products (`edgeaa.hdl.pieces`), formed over the lanes'
    clocks. Their multiplicands are constant from the clock each product starts (they read
    registers loaded by WINDOW, and ``row0`` at the fix-up), so each step keeps a linear
    relation between the product and the digits formed so far; only the two products the
    model's `end_pieces` states exactly (``end_height``, ``hs0``) need an exact one.

    By ``|I_d|``, one bit a clock MSB first over the first ``I`` clocks of lane A's second
    pass (cleared at the fix-up), with ``digits`` the bits of ``|I_d|`` consumed so far:
    ``id_e1``, ``id_h0`` are the multiplicand times ``digits`` (modulo the register; P = 2 P
    + bit M keeps that), ``id_w1`` and y-major ``id_first`` (times ``w1``, ``w0``, both at
    most ``2 S``) at most ``digits << (s + 1)``, which bounds the bands by ifix.

    By kq, one quotient digit a clock beside lane B, then ``k_bit`` (cleared by WINDOW), with
    ``formed`` lane B's quotient and then kq: each at most ``formed << (2 s + 2)`` (its
    multiplicand is at most ``(2 S)^2``), which keeps them in their registers and the
    x-major slope area ``(kq << (2 s + 2)) - k_me`` positive; ``k_me <= k_mg`` while their
    multiplicands are so ordered, so the x-major first area ``k_mg - k_me`` of one column
    is positive too. (An exact invariant would need the wide products again.)

    Both order facts (``w0 >= 0``; ``me^2 <= (2 S - mg)^2`` in one column) need the last
    column's cut, which WINDOW registers (c1 > hi).

    FINAL's product (``y_area0``, `edgeaa.hdl.pieces.total0_steps`: the y-major ``total0``
    by ``w0``'s bits) has no invariant: no check reads a y-major ``total0`` (`spec.pieces_ok`
    bounds the x-major totals only; the y-major deltas clamp their areas to the bands), so the
    proofs hold whatever it is, and the core tests compare it in every bank with the model
    (why not an exact one: docs/hardware.md, "Formal proofs of the deltas core")."""
    config, setup, win, f = ctx.config, ctx.setup, spec.win, spec.fold
    r, run, final = setup.regs, setup.in_run, setup.in_final
    cut_end = setup.pieces.cut_end == (win.last != f.c1)
    add(implies(run | final, cut_end), "cut end")
    s, I = config.subpixel_bits, config.intensity_bits  # noqa: E741
    # The top steps_a bits of |I_d| (all I of them from then on), I bits wide.
    unread = Mux(lanes.steps_a >= I, 0, I - lanes.steps_a)[: I.bit_length()]
    digits = r.i_d >> unread
    products = {reg.name: (reg, value) for reg, value in id_products(setup)}
    id_ok = {}
    for name in ("pc_id_e1", "pc_id_h0"):
        reg, value = products[name]
        want = Signal(reg.shape(), name=f"want_{name}")  # modulo the register (`eq`)
        ctx.m.d.comb += want.eq(digits * value)
        id_ok[name] = reg == want
    wide = digits << (s + 1)
    id_ok["pc_id_w1"] = products["pc_id_w1"][0] <= wide
    id_ok["pc_id_first"] = r.x_major | (products["pc_id_first"][0] <= wide)
    for name, condition in id_ok.items():
        add(implies(lanes.in_pass2, condition), f"product {name}")
    if setup.schedule.steps > 1:  # WINDOW registered the multiplicands: they stay its values
        same = all_([reg == value for reg, value in kq_multiplicands(setup)])
        add(implies(run | final, same), "kq multiplicands registered")
        end = setup.pieces.m_end == end_multiplicand(setup)
        add(implies(run | final, end), "id_end multiplicand registered")
    formed = Mux(lanes.k_ready, r.kq, setup.lane_b.q) << (2 * s + 2)
    (k_me, m_me), (k_mg, m_mg) = kq_products(setup)
    square = 1 << (2 * s + 2)  # (2 S)**2
    k_ok = [
        m_me <= square,
        m_mg <= square,
        k_me <= formed,
        k_mg <= formed,
        implies(m_me <= m_mg, k_me <= k_mg),
    ]
    add(implies(run | final, all_(k_ok)), "products by kq")


# -- the bank ----------------------------------------------------------------------------------


def _bank(ctx, s, add):
    """The bank's invariants, and the ghost flags of an edge whose start the window moved
    (its start row is not bounded here; see "bank start row" above)."""
    m, config, setup = ctx.m, ctx.config, ctx.setup
    bank = setup.bank
    top = 1 << config.coord_bits
    bk = fields(bank.payload, bank.payload.shape())
    bk_axes = axes(bk)
    for name, condition in constants_ok(config, bk).items():
        add(implies(bank.valid, condition), f"bank {name}")
    add(implies(bank.valid, major_ok(config, bk_axes)), "bank major axis")
    # The bank is the setup's: its start moved when the setup's window did (``start_clip``).
    moved_bank, moved_stepper = setup.regs.start_clip, Signal(name="start_moved")
    with m.If(ctx.stepper.start):  # the stepper loads its loop registers from the bank
        m.d.sync += moved_stepper.eq(moved_bank)
    bank_row = (bk_axes.minor >= 0) & (bk_axes.minor <= top)
    add(implies(bank.valid & ~moved_bank, bank_row), "bank start row")
    ctx.bk, ctx.bk_axes, ctx.moved_stepper = bk, bk_axes, moved_stepper


# -- the stepper -------------------------------------------------------------------------------

_LOOP_FITS = ("jsum", "next_acc", "next_major")  # `spec.column`'s fits of the loop's step


def _stepper_registers(config, stepper) -> types.SimpleNamespace:
    """The stepper's `bank_fields` registers as a bank-like record (arrays as lists; the
    deltas stepper's per-edge constants are wires of the bank payload)."""
    fields = stepper.format.bank_fields(config)
    regs = {field.name: getattr(stepper, field.name) for field in fields}
    regs.update(seg_thresholds=stepper.seg_thresholds, seg_intercepts=stepper.seg_intercepts)
    return types.SimpleNamespace(**regs)


def _stepper(ctx, add):
    m, config, stepper = ctx.m, ctx.config, ctx.stepper
    W = config.coord_bits
    top = 1 << W
    bank = ctx.setup.bank
    st = _stepper_registers(config, stepper)
    st_axes = axes(st)
    active = stepper.active
    if ctx.format.live_bank:  # it reads the per-edge constants from the held bank
        add(implies(active, bank.valid), "stepper: its edge's bank is held")
    for name, condition in constants_ok(config, st).items():
        add(implies(active, condition), f"stepper {name}")
    add(implies(active, major_ok(config, st_axes)), "stepper major axis")
    col = column(config, st, st_axes)
    # The minor axis: monotonic, at most one row per column, from a start row in range.
    # The harness follows the row in a wider ghost register, so that the proof does not
    # depend on the row staying within the register (only the bounded check shows that).
    start_row = Signal(signed(W + 3))
    start_remaining = Signal(unsigned(W + 1))
    row = Signal(signed(W + 4))
    with m.If(stepper.step):
        m.d.sync += row.eq(row + Mux(col.row_step, st_axes.row_step, 0))
    with m.If(stepper.start):
        m.d.sync += [
            start_row.eq(ctx.bk_axes.minor),
            start_remaining.eq(ctx.bk.remaining),
            row.eq(ctx.bk_axes.minor),
        ]
    rows = Mux(st_axes.row_step < 0, start_row - row, row - start_row)
    stepped = [
        row[: W + 2] == st_axes.minor[: W + 2],
        implies(~ctx.moved_stepper, (start_row >= 0) & (start_row <= top)),
        start_remaining <= top,
        st.remaining <= start_remaining,
        rows >= 0,
        rows <= start_remaining - st.remaining,
    ]
    add(implies(active, all_(stepped)), "stepper rows stepped")
    for name, condition in col.fits.items():
        # The deltas core computes no writes: only the loop's registers matter there.
        if isinstance(stepper, LineStepper) or name in _LOOP_FITS:
            add(implies(active, condition), f"column {name} fits")
    if ctx.fault == "tight_jq":
        add(implies(active, st.jq < (st.ifix >> 1)), "false invariant jq < ifix / 2")
    # The per-edge constants the stepper derives at load (`ColumnLoop.derive`).
    for name, value in stepper.derive(st).items():
        add(implies(active, stepper.derived[name] == value), f"stepper derived {name}")
    # Observation wires of the column being stepped.
    add(implies(active, stepper.jsum == col.jsum), "stepper jsum wire")
    if isinstance(stepper, LineStepper) and config.segments:
        add(implies(active, stepper.dq == col.dq), "stepper dq wire")
    ctx.st, ctx.st_axes, ctx.column = st, st_axes, col
