"""``count``: no accepted command is lost.

The harness counts good commands accepted minus edges finished (beats with ``last & valid &
ready``) minus edges with no column in their window (which end in their second RUN clock
when the setup's column count is not positive; the ``bounds`` group proves that count is the
model's), and bad commands accepted minus ``error`` pulses. Each count equals the occupancy
derived from the core's state (the setup's state, the bank, the stepper, an edge's last
column in a stage of the stepper's output pipeline or in the output register, a pending
``error``), is within [0, `capacity`] and is 0 when the core is idle; the columns of an edge
are contiguous in the pipeline. A tag bit rides along each command (setup and its bank ->
stepper -> pipeline stages -> output register): a bad command never reaches the bank, the
stepper or a beat. ``errors`` equals the saturating count of ``error`` pulses. The registers
the setup loads with a command equal `accept_values` of the latched command while it is not
idle.
"""

from __future__ import annotations

import types

from amaranth.hdl import Mux, Signal, signed
from amaranth.lib import data

from ....hdl.setup import accept_values
from .spec import all_, fold, implies


def capacity(core) -> int:
    """Commands the core can hold: one in the setup (in work, its bank waiting, or its
    pending error), one in the stepper and one per stage of the stepper's output pipeline
    (its last column there while the stepper already steps the next edge): ``2 +
    stepper.latency``. The deltas stepper steps the edge whose bank the setup holds: ``1 +
    stepper.latency``."""
    return 1 + (not core.format.live_bank) + core.stepper.latency


def check(ctx):
    """Emit the ``count`` properties; leave ``finished`` and ``pending_good`` in `ctx` for
    the covers."""
    m, config, core = ctx.m, ctx.config, ctx.core
    setup, stepper = ctx.setup, ctx.stepper
    edges, out, bank = core.edges, ctx.out, setup.bank
    beat = data.View(ctx.layout, ctx.payload)
    incoming_bad = fold(config, edges.payload).bad
    cmd_bad = fold(config, setup.cmd).bad
    accepted = edges.valid & edges.ready
    finished = out.valid & out.ready & beat.last
    error = ctx.error
    in_window, in_run, in_final = setup.in_window, setup.in_run, setup.in_final
    # An edge with no column inside its window ends in its second RUN clock, when the
    # column count the setup formed is not positive (that the count is right, i.e. that
    # exactly the edges the model gives no column end here, is a `bounds` check).
    abandoned = in_run & (setup.regs.counter == 1) & (setup.regs.columns <= 0)

    pending_good = Signal(signed(6))
    pending_bad = Signal(signed(4))
    m.d.sync += [
        pending_good.eq(pending_good + (accepted & ~incoming_bad) - finished - abandoned),
        pending_bad.eq(pending_bad + (accepted & incoming_bad) - error),
    ]
    # The stepper's output pipeline, youngest first: the stages p1 .. p{latency - 1} and the
    # output register. An edge whose last column has left the stepper is counted where that
    # column is.
    positions = [*((stage.valid, stage.last) for stage in ctx.stages), (out.valid, beat.last)]
    occupancy = _occupancy(ctx, positions, cmd_bad, error)
    tags = _tags(ctx, positions, cmd_bad)

    errors_max = (1 << core.errors_bits) - 1
    pulses = Signal(core.errors_bits)
    saturated = Mux(error & (pulses != errors_max), pulses + 1, pulses)
    m.d.sync += pulses.eq(saturated)

    properties = [
        (pending_good == occupancy.good, "count: good commands in flight"),
        (pending_bad == occupancy.bad, "count: bad commands in flight"),
        ((pending_good >= 0) & (pending_bad >= 0), "count: more out than accepted"),
        (pending_good + pending_bad <= capacity(core), "count: capacity"),
        (implies(occupancy.idle, (pending_good == 0) & (pending_bad == 0)), "count: idle"),
        (implies(error, setup.in_idle), "count: error only in IDLE"),
        (all_(occupancy.contiguous), "count: columns of an edge are contiguous"),
        (implies(in_window | in_run | in_final, ~cmd_bad), "count: bad command in the setup"),
        (implies(bank.valid, ~cmd_bad), "count: bad command in the bank"),
        (implies(stepper.active, ~tags.stepper), "count: bad command stepped"),
        (all_(tags.positions), "count: column or beat of a bad command"),
        (core.errors == saturated, "count: errors counts error pulses"),
    ]
    if ctx.format.live_bank:  # the stepper takes the bank when the last column steps
        properties.append((implies(stepper.active, bank.valid), "count: bank held"))
    # The registers loaded with the command (white-box helpers for the induction).
    for name, value in accept_values(config, setup.cmd).items():
        condition = implies(~setup.in_idle, setup.accepted[name] == value)
        properties.append((condition, "count: accepted"))
    for condition, message in properties:
        ctx.emit("count", condition, message)
    ctx.finished, ctx.pending_good = finished, pending_good


def _occupancy(ctx, positions, cmd_bad, error) -> types.SimpleNamespace:
    """The commands the core's state holds: ``good`` and ``bad`` counts, ``idle``, and
    ``contiguous`` (each column that is not its edge's last has the next one behind it)."""
    setup, stepper, bank = ctx.setup, ctx.stepper, ctx.setup.bank
    in_fold, in_window = setup.in_fold, setup.in_window
    in_run, in_final = setup.in_run, setup.in_final
    last_waiting = sum(valid & is_last for valid, is_last in positions)
    # The deltas stepper steps the edge whose bank the setup still holds: counted once.
    stepped = 0 if ctx.format.live_bank else stepper.active
    held_good = (
        (in_fold & ~cmd_bad) + in_window + in_run + in_final + bank.valid + stepped + last_waiting
    )
    held_bad = (in_fold & cmd_bad) + error
    idle = all_(
        [
            setup.in_idle,
            ~error,
            ~bank.valid,
            ~stepper.active,
            *(~valid for valid, _ in positions),
        ]
    )
    # A column that is not its edge's last has the edge's next column right behind it.
    contiguous = []
    younger = stepper.active
    for valid, is_last in positions:
        contiguous.append(implies(valid & ~is_last, younger))
        younger = valid
    return types.SimpleNamespace(good=held_good, bad=held_bad, idle=idle, contiguous=contiguous)


def _tags(ctx, positions, cmd_bad):
    """The command's badness, carried by the harness from the bank (the setup's latched
    command while the bank is valid) to the stepper and along the pipeline; ``positions``:
    each pipeline position holds no bad command's column."""
    m, out = ctx.m, ctx.out
    en = ~out.valid | out.ready
    tag_stepper = Signal()
    tags = [Signal(name=f"tag_p{index + 1}") for index in range(len(positions))]
    with m.If(ctx.stepper.start):  # the stepper loads the bank's edge
        m.d.sync += tag_stepper.eq(cmd_bad)
    with m.If(en):
        m.d.sync += [
            tag.eq(older) for tag, older in zip(tags, [tag_stepper, *tags[:-1]], strict=True)
        ]
    tagged = [implies(valid, ~tag) for (valid, _), tag in zip(positions, tags, strict=True)]
    return types.SimpleNamespace(stepper=tag_stepper, positions=tagged)
