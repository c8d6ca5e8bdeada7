"""``pipe``, ``beat`` and ``minor``: what the stepper's output pipeline holds and emits.

``pipe``, ``beat`` (N == 1 segments, as the default ``paper`` mode): every beat equals the
full-width model column (`spec.column`: the model's ``column_areas`` and ``output_value``) of
the registers its column was stepped with. The harness carries a snapshot of the stepper's
registers along the output pipeline (one enable moves it: the output register empty or
taken), so the core's truncating, re-associated arithmetic is exact. ``pipe`` states what
stage p1 holds (valid, last, the snapshot's invariants and the stage registers, white-box
helpers that make the beat check 1-inductive; proven with ``bounds`` assumed), ``beat`` the
output register (proven with ``bounds`` and ``pipe`` assumed).

``minor`` (bounded only): the primary write's row within [0, 2**W], the neighbour's and the
row after the last column within [-1, 2**W + 1].
"""

from __future__ import annotations

import types

from amaranth.hdl import Mux, Signal, Value
from amaranth.lib import data

from ....hdl.layouts import write_layout
from .spec import all_, axes, column, constants_ok, implies

_ARRAYS = ("seg_thresholds", "seg_intercepts")


def check(ctx):
    """The ``pipe``, ``beat`` and ``minor`` groups, from what `bounds.check` left in `ctx`."""
    config = ctx.config
    if config.segments == 1:
        snaps = _snapshots(ctx)
        _stage_p1(ctx, *snaps[0])
        _output(ctx, *snaps[-1])
    if "minor" in ctx.checks or "minor" in ctx.assumes:
        _minor(ctx)


def _snapshots(ctx) -> list:
    """(snapshot, valid) of the stepper's registers for each pipeline position, p1 first
    and the output register last."""
    m, st = ctx.m, ctx.st
    writes = ctx.core.writes
    en = ~writes.valid | writes.ready
    snaps = []
    source, source_valid = st, ctx.stepper.active
    for index in range(ctx.stepper.latency):
        regs = {
            name: delayed(m, en, getattr(source, name), f"s{index + 1}_{name}")
            for name in vars(st)
            if name not in _ARRAYS
        }
        for name in _ARRAYS:
            values = getattr(source, name)
            regs[name] = [
                delayed(m, en, value, f"s{index + 1}_{name}{j}") for j, value in enumerate(values)
            ]
        valid = delayed(m, en, source_valid, f"s{index + 1}_valid")
        snap = types.SimpleNamespace(**regs)
        snaps.append((snap, valid))
        source, source_valid = snap, valid
    return snaps


def delayed(m, en, value, name: str) -> Signal:
    """`value` one pipeline move later."""
    reg = Signal(Value.cast(value).shape(), name=name)
    with m.If(en):
        m.d.sync += reg.eq(value)
    return reg


def _stage_p1(ctx, s1, v1):
    """Stage p1 (``pipe``): valid/last as the snapshot's; the snapshot satisfies the stepper
    invariants; the stage registers restate the snapshot (white-box helpers)."""
    config, stepper = ctx.config, ctx.stepper
    F, I = config.F, config.intensity_bits  # noqa: E741
    assert stepper.latency == 2, "the pipe lemmas describe the two-stage pipeline (N == 1)"

    def add(condition, name):
        ctx.emit("pipe", condition, f"pipe: {name}")

    p1 = stepper.stages[0]
    c1 = column(config, s1, axes(s1))
    add(p1.valid == v1, "p1 valid")
    add(implies(v1, p1.last == (s1.remaining == 0)), "p1 last")
    for name, condition in constants_ok(config, s1).items():
        add(implies(v1, condition), f"p1 snapshot {name}")
    add(implies(v1, axes(s1).steps_ok), "p1 snapshot steps")
    neg = s1.value_sign < 0
    i_d = s1.ifix >> F
    icpt = s1.seg_intercepts[0] << 2
    vw = F + I
    lemmas = {
        "x_": p1.x_ == s1.x,
        "y_": p1.y_ == s1.y,
        "neg": p1.neg == neg,
        "base": p1.base == s1.value_base,
        "ubase": p1.ubase == Mux(neg, s1.value_base - i_d, s1.value_base + i_d),
        "row_dx_": p1.row_dx_ == s1.row_dx,
        "row_dy_": p1.row_dy_ == s1.row_dy,
        "obs_jq": p1.obs_jq == s1.jq,
        "obs_ifix": p1.obs_ifix == s1.ifix,
        "above": p1.above == c1.above,
        "below": p1.below == c1.below_raw,
        "t_above": p1.t_above == (c1.dq_above - icpt) >> 2,
        "t_below_inv": p1.t_below_inv == (s1.jq + c1.borrow - s1.khq + icpt - 1) >> 2,
        "v0": p1.v0 == ((s1.jq ^ neg.replicate(vw)) + (s1.value_base << F) + (1 << (F - 1)))[:vw],
    }
    for name, condition in lemmas.items():
        add(implies(v1, condition), f"p1 register {name}")
    # The areas observed as the column leaves p1.
    areas = (stepper.area0 == c1.area0) & implies(c1.two, stepper.area1 == c1.area1)
    add(implies(stepper.area_step, areas), "p1 areas")


def _output(ctx, s2, v2):
    """The output register (``beat``): the beat of the snapshot's column (a group of its
    own, so that it can be proven with the stage helpers above assumed)."""
    config, writes = ctx.config, ctx.core.writes
    beat = data.View(write_layout(config), ctx.payload)
    bits = config.coord_bits + 2
    c2 = column(config, s2, axes(s2))
    ctx.emit("beat", writes.valid == v2, "beat: beat valid")
    match = all_(
        [
            beat.lane0.x == s2.x,
            beat.lane0.y == s2.y,
            beat.lane0.value == c2.value0,
            beat.lane1_valid == c2.two,
            beat.last == (s2.remaining == 0),
            # Coordinates modulo the register width: the rows are bounded only by the
            # bounded `minor` check (here the ghost row may reach 2**(W + 1)).
            implies(
                c2.two,
                (beat.lane1.x[:bits] == c2.x1[:bits])
                & (beat.lane1.y[:bits] == c2.y1[:bits])
                & (beat.lane1.value == c2.value1),
            ),
        ]
    )
    ctx.emit("beat", implies(v2, match), "beat: beat equals the full-width column")


def _minor(ctx):
    """The minor axis (``minor``): by induction (``bounds``) the harness proves the start row
    is within [0, 2**W] and the row then moves monotonically, at most one row per column; the
    exact bound for later columns depends on (columns left) * (slope), a product of two
    per-edge values that SAT-based induction cannot handle, so this is a bounded check from
    reset (it reaches only the first columns of an edge)."""
    top = 1 << ctx.config.coord_bits
    st_axes, col = ctx.st_axes, ctx.column
    minor_ok = all_(
        [
            st_axes.minor >= 0,
            st_axes.minor <= top,
            implies(col.two, (col.minor1 >= -1) & (col.minor1 <= top + 1)),
            col.minor_next >= -1,
            col.minor_next <= top + 1,
        ]
    )
    ctx.emit("minor", implies(ctx.stepper.active, minor_ok), "minor: rows within the image")
