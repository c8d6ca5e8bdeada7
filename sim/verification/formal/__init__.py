# amaranth: UnusedElaboratable=no
"""Formal checks of `edgeaa.hdl.EdgeAntialiaser` with SymbiYosys (YoWASP builds).

`FormalHarness` wraps the core for one configuration. Every input is free in every clock
(``AnySeq``): the ``edges`` payload and valid, the ``clip`` window, ``writes.ready`` and, by
default, the reset. There are no input assumptions at all: ports of exactly the model's
widths can only carry commands the model accepts or bad commands the core must drop (zero
length, I_in == I_out), and any window (each bound in [0, 2**W] by its width, min > max
allowed), so "any input" is "any legal or bad command with any window, any back-pressure,
any reset". The window is not held stable: it may change in every clock, and the harness
takes the setup's registered copy (``clip_r``, sampled with the command) as the command's
window, like the registered command ``cmd``. The harness reads only what the core exposes
for verification on purpose: the observation attributes of `edgeaa.hdl.EdgeSetupUnit`
(``cmd``, ``clip_r``, ``accepted`` with `edgeaa.hdl.setup.accept_values`, ``regs``, the
lanes, ``in_idle`` .. ``in_final``, ``next_bank``) and of `edgeaa.hdl.EdgeStepper` (its
`bank_fields` registers, the deltas stepper's per-edge ones wires of the bank payload,
``active``, ``start``, ``step``, ``jsum``, ``dq``, ``stages``, ``area_step``, ``area0``,
``area1``, ``derived`` with ``derive``). A rename there is an AttributeError
when the harness is built, never a vacuous proof.

Files: `spec` (the model-side specification: fold, window, bank invariants, one column in
full width), `harness` (`FormalHarness`), one module per property family (`stream`, `count`,
`bounds`, `pipeline` for ``pipe``, ``beat`` and ``minor``, `deltas` for the deltas core,
`covers`) and `run` (`Proof`, `PROOFS`, `DELTA_PROOFS`, `run_proof`, `main`).

Check groups (``checks``):

``stream``
    The hold rule of ``writes`` and of the setup's ``bank`` stream (writes core only: the
    deltas proof checks its output alone): a beat that is valid and not taken stays valid
    with the same payload in the next clock (unless the reset is asserted in between).
``count``
    No accepted command is lost. The harness counts good commands accepted minus edges
    finished (beats with ``last & valid & ready``) minus edges with no column in their window
    (which end in their second RUN clock when the core's column count is not positive; the
    ``bounds`` group proves that count is the model's), and bad commands accepted minus
    ``error`` pulses. Each count equals the occupancy derived from the core's state (the setup state
    machine, the bank, the stepper, an edge's last column in a stage of the stepper's output
    pipeline or in the output register, a pending ``error``), is within [0, `capacity`] and
    is 0 when the core is idle; the columns of an edge are contiguous in the pipeline. A tag
    bit rides along each command (setup and its bank -> stepper -> pipeline stages -> output
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
    flag and leaves their start row to simulation (`tests/test_core_setup.py` compares every
    bank with the model's `setup`). Every
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

``dbounds``, ``dloop``, ``dpipe``, ``dcells``, ``dbeat`` (the deltas core, ``output="deltas"``)
    The end pieces of the setup and the deltas loop's registers against the model's, every
    height, estimate and delta register of a column within its width, the loop following
    the model's loop (the piece start telescoping from the previous piece end), the
    pipeline stages, the cells and the beat: `deltas` has the details. ``stream`` and
    ``count`` apply to the deltas stream unchanged (``pipe``, ``beat``, ``minor`` do not).

Covers (``covers``, run with ``mode cover``): ``drop`` a dropped command; ``stepper`` a
two-lane beat, a neighbour in the row below, a beat that is not the last, a last beat, a
held beat taken, two edges in flight; ``deltas`` the deltas core's (`covers`). ``assumes``
turns check groups into assumptions: sound once they are proven by induction (they hold in
every reachable state), and it gives a bounded check the invariants for free.

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
minor       bmc      latency+0   latency-3   16 min at F = 21 (depth 37)
==========  =======  ==========  ==========  ==========================================

White-box helpers. k-induction needs invariants of every register, so the harness states
some in terms of the core's observation attributes: the registers loaded with the command
(``accepted``), the fold and window registers (``first``, ``last``, ``lo``, ``hi``,
``start_clip``, ``columns``), the lanes (with their precomputed ``x - du`` forms), ``kq`` and
``kr``, the stepper's derived constants and, for the two-stage output pipeline, what stage
``p1`` holds (``stages[0]``). A change of the core's internals can make an induction fail
(status UNKNOWN, `FormalResult.failed` names the helper); then the helper needs the same
change, not the property.

`python -m edgeaa.sim.verification.formal [proof ...]` runs proofs from the command line.

Faults (``fault``, to show the checks can fail): ``stall_payload`` flips a payload bit the
harness observes while a beat is held (a core that changes a stalled beat), ``stall_bank``
the same on the setup's bank, ``silent_drop``
hides the ``error`` pulse (a core that drops a bad command without reporting it),
``tight_jq`` asserts the false invariant jq < ifix / 2, ``tight_hs`` (deltas core, group
``dloop``) the false invariant hs >= 0. The deltas proofs (`DELTA_PROOFS`) and their times:
docs/hardware.md, "Formal proofs of the deltas core".
"""

from __future__ import annotations

from .count import capacity
from .harness import CHECKS, COVERS, FAULTS, FormalHarness
from .run import (
    DELTA_PROOFS,
    PROOFS,
    FormalError,
    FormalResult,
    FormalToolNotFoundError,
    Proof,
    find_tools,
    harness_rtlil,
    main,
    run_proof,
    sby_script,
)

__all__ = [
    "CHECKS",
    "COVERS",
    "DELTA_PROOFS",
    "FAULTS",
    "PROOFS",
    "FormalError",
    "FormalHarness",
    "FormalResult",
    "FormalToolNotFoundError",
    "Proof",
    "capacity",
    "find_tools",
    "harness_rtlil",
    "main",
    "run_proof",
    "sby_script",
]
