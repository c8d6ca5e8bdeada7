"""Cycle timing model of the hardware cores (`edgeaa.hdl.core.LineCore`, `PolygonCore`).

Clocks are numbered from 0, the first clock after reset. A stream transfer "happens in clock
c" when valid and ready are both high in clock c (it completes at the clock edge ending c).

Structure. The core has a setup state machine (IDLE -> FOLD -> WINDOW -> RUN -> FINAL ->
HOLD) and a stepper, joined by the bank stream (the setup's registers, held until the stepper
takes them):

* IDLE: ``edges.ready`` is high; an edge offered in clock ``a`` is accepted in clock ``a``,
  and the ``clip`` port is sampled with it.
* FOLD (clock ``a + 1``): octant folding and the bad-command check. A bad command (zero
  length, or I_in == I_out) is dropped here: ``error`` pulses in clock ``a + 2``, ``errors``
  counts it from clock ``a + 2``, and the core is back in IDLE in clock ``a + 2``.
* WINDOW (clock ``a + 2``): the first and last columns, cut to the clip window along the
  major axis, and the multiplier of the start-row pass (the offset of the first column's
  centre from P0).
* RUN (``R`` clocks, ``a + 3 .. a + R + 2``): two lanes of a bit-serial multiply-divide unit.
  Lane A: the start row (``s + 1`` clocks, or ``W + s + 2`` when the window moved the first
  column, the offset then being up to the edge's length), one fix-up clock, then
  ``I + F - s - 1`` clocks for the initial accumulator. Lane B in parallel: ``I + F - 1``
  clocks for the slope. So ``R = I + F + 1``, plus ``W + 1`` for a start-clipped edge: fixed
  per configuration otherwise (one more in the polygon core when ``F = s + 1``:
  `run_schedule`).
  The fast pipeline's core (`edgeaa.model.beat.DELTAS_FAST`) takes two lane steps a clock:
  about half of each (R = 11, and 6 more when start-clipped, in the default configuration).
  An edge with no column inside the window leaves RUN after its second clock (``a + 4``)
  without writing the bank: back in IDLE in clock ``a + 5``.
* FINAL (``Phi = final_cycles`` clocks, ``a + R + 3 .. a + R + 2 + Phi``): the bank's
  contents are complete in its last clock (combinational, from the registers). ``Phi = 1``
  for the line-writes core; ``ceil((s + 2) / 2)`` for the deltas core, whose setup forms the
  y-major ``total0`` product there, two bits of the first piece's width a clock; 2 for the fast
  pipeline's deltas core (`edgeaa.model.beat.DELTAS_FAST`), whose setup multiplies.
* HOLD (from clock ``a + R + 3 + Phi``): the bank is valid, the registers hold, until the
  stepper takes it; in that clock the setup accepts the next command if one is offered (IDLE
  after it otherwise).
* The line-writes stepper loads (copies and takes) the bank in the first clock ``t`` where
  the bank is valid and the stepper is idle or stepping the previous edge's last column
  (the handover has no bubble). The deltas stepper (the polygon core's) starts the edge
  (loads its loop registers) in the first clock ``t`` where the bank is valid and it is
  idle, reads the per-edge constants from the held bank and takes it in the clock it steps
  the edge's last column, ``t + C``: the setup works on the next edge only after that. The
  fast pipeline's deltas stepper (`edgeaa.model.beat.DELTAS_FAST`, no ``live_bank``) copies
  the bank as the line-writes stepper does. Column ``c`` of the edge is stepped in clock
  ``t + 1 + c``. Its writes are computed by a pipeline behind the loop, ``D =
  pipeline_depth`` registers deep counting the output register (D = 2 for N <= 1 segments,
  i.e. pw and paper; D = 3 for seg2 and seg4; D = 4 in every mode for the polygon core's
  accumulation deltas, `DELTAS` and `DELTAS_FAST`): the beat is valid in
  clock ``t + 1 + D + c``. The deltas core's setup computes the end pieces in the same
  clocks, FINAL's included: only D and Phi differ between the two outputs
  (`edgeaa.model.beat.WRITES` and `DELTAS` declare both, and whether the stepper holds the
  bank live; every function here takes the output's format, `WRITES` by default).

With ``L = setup_latency = R + 4 + Phi + D`` (R of an edge not clipped at its start): an edge
accepted in clock ``a`` by an idle core has its first beat in clock ``a + L`` (``a + L + W +
1`` if clipped at its start). For edge ``n`` (good edges only, always-ready sink, source
offering edges back to back from clock 0)::

    a[0] = 0, a[n + 1] = t[n]         (after a bad command accepted in a: next at a + 2;
                                       after an edge with no visible column: next at a + 5)
    f[n] = a[n] + R[n] + 2 + Phi                 FINAL's last clock (the bank valid from f + 1)
    t[n] = max(f[n] + 1, t[n - 1] + C[n - 1])    clock the stepper loads edge n
    beat of column c of edge n: t[n] + 1 + D + c     (C[n] = visible columns of edge n)

and for the deltas core, whose setup holds edge n until its last column is stepped::

    a[n + 1] = t[n] + C[n]                       the clock edge n's bank is taken
    t[n] = max(f[n] + 1, t[n - 1] + C[n - 1] + 1) = f[n] + 1 (one setup unit)

The setup has no bank register of its own: it holds edge n until the stepper takes it, so the
next edge is accepted in that clock at the earliest (``a[n + 1] = t[n]``; a setup with its
own bank register could accept it in ``f[n] + 1`` and wait in FINAL for ``t[n - 1]`` only).
While the stepper keeps up (``t[n] = f[n] + 1``) both give the same clocks; a setup that
finishes while the stepper is still on a long edge waits for it.

``R + 2 + Phi = L - D - 2``. ``L = R + 4 + Phi + D`` (``I + F + 5 + Phi + D`` at one lane
step a clock): for the line-writes core 27 clocks
for the default configuration and its pw variant (F = 11), 28 for seg2 and seg4, 37 for the
truncated accumulator (F = 21); 19 for coord_bits=4 subpixel_bits=0 intensity_bits=4 (F = 7);
for the deltas core (D = 4, Phi = ceil((s + 2) / 2)) 31 in the default configuration; 21 for
the fast pipeline's (`edgeaa.model.beat.DELTAS_FAST`: R = 11, D = 4, Phi = 2).

Sustained rate. The setup accepts one edge every ``P = setup_interval = R + 3 + Phi`` clocks
at most (``P = L - D - 1``: 24 for the default configuration's line-writes core, 26 for its
deltas core; accept to load, the next accept in the load's clock); the stepper takes ``C``
clocks per edge. A stream of edges of ``C`` columns therefore sustains ``C / max(C, P)``
columns per clock: exactly one column per clock (no gap between edges) when every edge has
at least ``P`` columns. From an idle core, a stream of such edges (total ``T`` columns) has
its last beat in clock ``L + T - 1``: the mean over the whole run is ``T / (L + T)``
(`stream_rate`), at least 0.95 once ``T >= 19 L``. Shorter edges are setup-bound: one edge
per ``P`` clocks. The deltas core steps an edge only while its setup holds the bank, so
setup and stepping take turns: one edge of ``C`` columns per ``C + P`` clocks with one setup
unit. A stalled sink delays the stepper and its pipeline (and, once its bank waits, the
setup) clock for clock; nothing else depends on the data. `schedule`'s ``sink_ready`` and
``holds`` model the polygon pipeline's accumulator: first ready in clock T (after a scan),
then taking each beat over ``holds`` clocks, a nonzero cell a clock (`beat_wait`), with
``skid`` behind a skid buffer (`edgeaa.hdl.skid.SkidBuffer`, `SinkClock`); its ``idle`` a
source that idles before some commands.

Clipping. A window that cuts the end of an edge costs nothing: the column count is smaller.
One that cuts its start costs ``W + 1`` setup clocks (the long start-row pass) and saves one
stepping clock per column cut; the setup overlaps the previous edge's stepping, so the extra
clocks show only when the setup is the bottleneck.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass

import numpy as np

from .beat import WRITES, BeatFormat
from .config import EdgeConfig
from .edge import Edge, EdgeError, setup

__all__ = [
    "DEFAULT_SETUP_UNITS",
    "MAX_SETUP_UNITS",
    "ClockBreakdown",
    "clock_breakdown",
    "EdgeTiming",
    "beat_cycles",
    "final_cycles",
    "pipeline_depth",
    "RunSchedule",
    "run_cycles",
    "run_schedule",
    "setup_interval",
    "setup_latency",
    "start_clip_cycles",
    "beat_wait",
    "SinkClock",
    "load_clocks",
    "stream_cycles",
    "stream_rate",
    "sustained_rate",
    "unit_cycles",
    "write_cycles",
]

BAD_COMMAND_CYCLES = 2  # accept + FOLD: a dropped command occupies the setup two clocks
EMPTY_EDGE_CYCLES = 5  # accept, FOLD, WINDOW, two RUN clocks: an edge with no visible column
# Setup units of the core by default (`edgeaa.hdl.dispatch.SetupArray`). One: the smallest
# core (the polygon pipeline must fit an iCE40 HX8K). With R = 20 RUN clocks (the default
# configuration, F = 11) nine units accept an edge every ceil(25 / 9) = 3 clocks, at about
# six times the line core's area (docs/hardware.md, "Setup throughput"); ceil(27 / 9) = 3
# for the deltas core, whose FINAL takes ceil((s + 2) / 2) = 3 clocks.
DEFAULT_SETUP_UNITS = 1
MAX_SETUP_UNITS = 16


@dataclass(frozen=True)
class RunSchedule:
    """RUN clock by clock, for lanes taking `steps` multiply-divide steps a clock
    (`edgeaa.hdl.lanes`; one for `WRITES` and `DELTAS`, two for `DELTAS_FAST`). A pass of
    ``n`` multiplier bits starts with ``pad`` zero steps (a leading zero bit leaves the
    lane's quotient and remainder at zero, so the result is the same), making ``pad + n`` a
    whole number of clocks. Lane A's first pass (``s + 1`` bits, or ``W + s + 2`` when the
    window moved the first column: one loaded register, one pad) ends with a clock of one
    step when ``pad + s + 1`` is not whole clocks (`pass1_single`); the fix-up clock
    follows; then lane A's second pass (``I + F - s - 1`` bits, ``|I_d|``'s ``I`` first:
    the products by ``|I_d|`` step over its first `id_clocks`, their last of one step when
    `id_single`). Lane B (``I + F - 1`` bits) steps from RUN's first clock; ``kq`` is
    registered in the clock after it. The polygon core's RUN ends reading ``kq`` and the
    products by ``|I_d|`` in its last clock, so both are complete before it: if not, lane A
    holds its result for `tail` clocks after pass 2 (at one step a clock only when ``F = s +
    1``, where pass 2 is ``|I_d|``'s bits alone: RUN is ``I + F + 2`` there, ``I + F + 1``
    otherwise)."""

    steps: int
    pass1_pad: int
    pass1: int  # clocks of lane A's first pass (start not moved)
    pass1_long: int  # ... when the window moved the first column
    pass1_single: bool  # the short first pass's last clock takes one step
    pass2_pad: int
    pass2: int  # clocks of lane A's second pass
    tail: int  # clocks lane A then holds before RUN ends
    id_clocks: int  # clocks of the second pass that carry |I_d|'s bits
    id_single: bool  # the last of them steps the products by |I_d| once
    lane_b_pad: int
    lane_b: int  # clocks of lane B

    @property
    def run(self) -> int:
        """RUN's clocks (start not moved): pass 1, the fix-up, pass 2, the tail."""
        return self.pass1 + 1 + self.pass2 + self.tail

    @property
    def start_clip(self) -> int:
        """RUN's extra clocks when the window moved the first column."""
        return self.pass1_long - self.pass1


def run_schedule(config: EdgeConfig, steps: int = 1, pieces: bool = False) -> RunSchedule:
    """RUN's schedule for lanes of `steps` (1 or 2) steps a clock (`RunSchedule`), of a
    setup with the end pieces (`pieces`: the polygon core's, whose RUN ends reading the
    products by ``|I_d|``) or without."""
    if steps not in (1, 2):
        raise ValueError(f"lane steps a clock must be 1 or 2, not {steps!r}")
    W, s, F, I = config.coord_bits, config.subpixel_bits, config.F, config.intensity_bits  # noqa: E741

    def clocks(bits: int) -> int:
        return -(-bits // steps)

    short, long, pass2, lane_b = s + 1, W + s + 2, I + F - s - 1, I + F - 1
    pad1, pad_b = -long % steps, -lane_b % steps
    pass1 = clocks(pad1 + short)
    pad2 = -pass2 % steps
    # RUN's last clock reads kq (registered the clock after lane B's last) and the products
    # by |I_d| (formed in the clocks before): lane A holds for `tail` clocks if need be.
    # (kq readable from lane B's clocks + 1; RUN's last at pass1 + pass2 + tail, the last
    # product step at pass1 + ids)
    ids, pass2_clocks = clocks(pad2 + I), clocks(pad2 + pass2)
    tail = max(
        0,
        clocks(pad_b + lane_b) + 1 - pass1 - pass2_clocks,
        ids + 1 - pass2_clocks if pieces else 0,
    )
    return RunSchedule(
        steps=steps,
        pass1_pad=pad1,
        pass1=pass1,
        pass1_long=clocks(pad1 + long),
        pass1_single=(pad1 + short) % steps != 0,
        pass2_pad=pad2,
        pass2=pass2_clocks,
        tail=tail,
        id_clocks=ids,
        id_single=(pad2 + I) % steps != 0,
        lane_b_pad=pad_b,
        lane_b=clocks(pad_b + lane_b),
    )


def run_cycles(config: EdgeConfig, clipped_start: bool = False, fmt: BeatFormat = WRITES) -> int:
    """Clocks of the RUN state (`run_schedule` of the format's lane steps): lane A's two
    multiply-divide passes and its fix-up clock, ``I + F + 1`` at one step a clock (the
    first pass ``W + 1`` clocks longer when the clip window moved the first column)."""
    plan = run_schedule(config, fmt.lane_steps, fmt.pieces)
    return plan.run + (plan.start_clip if clipped_start else 0)


def final_cycles(config: EdgeConfig, fmt: BeatFormat = WRITES) -> int:
    """Clocks of the FINAL state (`BeatFormat.final_cycles`): one for the line core;
    ``ceil((s + 2) / 2)`` for the polygon core, whose setup forms the y-major ``total0``
    product there two bits of the first piece's width ``w0`` (``s + 2`` bits) a clock
    (`edgeaa.hdl.pieces.total0_steps`); two for the fast core's, which multiplies."""
    return fmt.final_cycles(config)


def start_clip_cycles(config: EdgeConfig, fmt: BeatFormat = WRITES) -> int:
    """Extra setup clocks of an edge whose first column the clip window moved (``W + 1`` at
    one lane step a clock)."""
    return run_schedule(config, fmt.lane_steps, fmt.pieces).start_clip


def pipeline_depth(config: EdgeConfig, fmt: BeatFormat = WRITES) -> int:
    """Clocks from a column's step to its beat (`BeatFormat.pipeline_depth`): the stepper's
    output pipeline, counting the output register (2 with at most one segment, 3 with two or
    more; the polygon core's is 3 in every mode: the piece's depth, the estimate and covers,
    then the cells; 4 with the deep stepper, `DELTAS_FAST`, whose p3 holds the outer rows'
    areas)."""
    return fmt.pipeline_depth(config)


def setup_latency(config: EdgeConfig, fmt: BeatFormat = WRITES) -> int:
    """Clocks from accepting an edge (idle core, not clipped at its start) to its first beat:
    accept, FOLD, WINDOW, RUN, FINAL (`final_cycles`), bank, stepper load, the step of
    column 0, then the output pipeline: ``R + 4 + Phi + D``."""
    return run_cycles(config, fmt=fmt) + 4 + final_cycles(config, fmt) + pipeline_depth(config, fmt)


def setup_interval(
    config: EdgeConfig, setup_units: int = DEFAULT_SETUP_UNITS, fmt: BeatFormat = WRITES
) -> int:
    """Clocks per edge the setup sustains, rounded up: edges of at least this many columns
    keep the stepper busy (one column per clock). One unit: accept, FOLD, WINDOW, RUN,
    FINAL (``Phi`` clocks, `final_cycles`), then the load, in whose clock it accepts the next
    edge: ``R + 3 + Phi``. ``N >= 2`` units (`SetupArray`): each holds an edge from its
    accept to the stepper's load of its bank and retires it then, ``R + 4 + Phi`` clocks,
    so ``ceil((R + 4 + Phi) / N)``. (A deltas core whose stepper reads the bank live,
    `DELTAS`, also holds each edge while it steps: `sustained_rate`.)"""
    if setup_units == 1:
        return unit_cycles(config, 1, fmt)
    return -(-unit_cycles(config, setup_units, fmt) // setup_units)


def unit_cycles(
    config: EdgeConfig, setup_units: int = DEFAULT_SETUP_UNITS, fmt: BeatFormat = WRITES
) -> int:
    """Clocks one setup unit spends per edge in steady state: ``R + 3 + Phi`` alone (accept
    to the load, the next accept in the load's clock), ``R + 4 + Phi`` in an array (accept
    to retirement, then free the clock after); a deltas core reading the bank live (`DELTAS`,
    not `DELTAS_FAST`) holds the edge ``C`` clocks more while it steps."""
    return run_cycles(config, fmt=fmt) + 3 + final_cycles(config, fmt) + (setup_units != 1)


@dataclass(frozen=True)
class EdgeTiming:
    """When one edge command went through the core (None fields and no beats: a bad command
    the core dropped, or an edge with no column in its clip window)."""

    edge: Edge
    accepted: int  # clock the command was accepted
    bank: int | None  # clock of FINAL (the bank is valid from the next clock)
    load: int | None  # clock the stepper loaded the bank (deltas: started the edge)
    beats: tuple[int, ...]  # clock of each column's beat (valid and ready; the sink's take)
    # the first clock its setup unit is free again (may accept; an array's unit: the clock
    # after it retired the command, when the array may be idle)
    released: int = 0
    waits: int = 0  # clocks its beats waited in the stepper's output register

    @property
    def dropped(self) -> bool:
        """No bank write: a bad command, or nothing visible in the clip window."""
        return self.load is None


def write_cycles(
    config: EdgeConfig,
    edges,
    setup_latency_: int | None = None,
    fmt: BeatFormat = WRITES,
    setup_units: int = DEFAULT_SETUP_UNITS,
) -> list[EdgeTiming]:
    """Predict the clock of every beat for an always-ready sink and a back-to-back source.

    `edges` are `Edge` commands offered in order from clock 0, each as soon as the previous
    one is accepted. Commands the model rejects (`EdgeError`) are dropped by the core and
    get no beats; so are edges with no column in their clip window. `setup_latency_`
    defaults to `setup_latency(config, fmt)`; pass the core's ``setup_latency`` to check
    the two agree. `fmt` is the core's output (`WRITES` or `DELTAS`): one beat per column
    either way, the pipeline depth, FINAL and the bank's handover differ. `setup_units` is
    the core's.
    """
    shapes = []
    for edge in edges:
        try:
            st = setup(config, edge)
        except EdgeError:
            shapes.append(None)
            continue
        shapes.append((st.columns, st.clipped_start))
    return schedule(config, shapes, edges, setup_latency_, fmt, setup_units)


def schedule(
    config: EdgeConfig,
    shapes,
    edges=None,
    setup_latency_: int | None = None,
    fmt: BeatFormat = WRITES,
    setup_units: int = DEFAULT_SETUP_UNITS,
    *,
    idle=None,
    sink_ready: int = 0,
    holds=None,
    skid: bool = False,
) -> list[EdgeTiming]:
    """`write_cycles` from each edge's (columns, clipped_start) as setup gives them (None for
    a command the core drops as bad), for callers that hold the setups already
    (`edgeaa.model.edge.setup_batch`). `edges` only labels the timings.

    `idle`: clocks the source idles before offering each command: command k is offered
    ``idle[k]`` clocks after the clock following command k - 1's accept, the first in clock
    ``idle[0]`` (default: back to back from clock 0). `sink_ready`: the sink is not ready
    before this clock and ready from it (`beat_wait`). `holds`: per command, the clocks the
    sink takes each of its beats (`beat_wait`; default one). `skid`: a skid buffer sits
    before the sink (`SinkClock`); each timing's beats are then the sink's takes.
    """
    latency = setup_latency(config, fmt) if setup_latency_ is None else setup_latency_
    depth = pipeline_depth(config, fmt)
    live = fmt.live_bank  # the stepper takes the bank at the edge's end
    extra = start_clip_cycles(config, fmt)  # RUN's clocks more for a start-clipped edge
    if setup_units == 1:
        sink = SinkClock(sink_ready, skid)
        return _schedule_one(extra, shapes, edges, latency, depth, live, idle, sink, holds)
    timing = _Units(extra, latency, depth, live, setup_units, SinkClock(sink_ready, skid))
    return [
        timing.command(shape, None if edges is None else edges[k], _idle(idle, k), _hold(holds, k))
        for k, shape in enumerate(shapes)
    ]


def _idle(idle, k: int) -> int:
    return 0 if idle is None else int(idle[k])


def _hold(holds, k: int):
    return None if holds is None else holds[k]


def load_clocks(config: EdgeConfig, columns, clipped_start, bad=None, fmt: BeatFormat = WRITES):
    """`schedule`'s load clocks of the stepped edges (good, with a visible column), as an
    int64 array, from arrays of every command's columns and clipped_start (`bad`: the
    commands the core drops), one setup unit, back-to-back source, ready sink: numpy, no
    loop over the edges (the renderer's cycles, `stream_cycles`).

    The recurrence of `_schedule_one` without waits: edge n's load is
    ``max(accept + L - D - 1 (+ W + 1 if clipped at its start), last + live)``, its accept
    the previous stepped edge's load (line writes) or its last column's clock ``last =
    load + C`` (deltas, `live`), plus the clocks of the commands dropped since (2 bad, 5
    with no column). So each load is the previous one plus a term of the two edges alone:
    a cumulative sum."""
    columns = np.asarray(columns, dtype=np.int64).reshape(-1)
    clipped = np.asarray(clipped_start, dtype=bool).reshape(-1)
    bad = np.zeros(len(columns), bool) if bad is None else np.asarray(bad, dtype=bool)
    live = int(fmt.live_bank)
    dropped = np.where(bad, BAD_COMMAND_CYCLES, np.where(columns > 0, 0, EMPTY_EDGE_CYCLES))
    before = np.cumsum(dropped) - dropped  # clocks of the drops before each command
    idx = np.flatnonzero(~bad & (columns > 0))
    drops = np.diff(before[idx], prepend=0)  # since the previous stepped edge
    c = columns[idx]
    setup = setup_latency(config, fmt) - pipeline_depth(config, fmt) - 1
    setup = setup + np.where(clipped[idx], start_clip_cycles(config, fmt), 0) + drops
    prev = np.concatenate([[0], c[:-1]])
    step = np.maximum(live * prev + setup, prev + live)
    if len(step):
        step[0] = setup[0]  # the first edge waits for its setup only
    return np.cumsum(step)


def stream_cycles(
    config: EdgeConfig, columns, clipped_start, bad=None, fmt: BeatFormat = WRITES
) -> int:
    """Clocks from the first command to the last beat, inclusive (`load_clocks`'s last edge:
    its load, one clock, its columns, then the pipeline's depth); 0 for no beat."""
    columns = np.asarray(columns, dtype=np.int64).reshape(-1)
    loads = load_clocks(config, columns, clipped_start, bad, fmt)
    if not len(loads):
        return 0
    stepped = columns[columns > 0] if bad is None else columns[(columns > 0) & ~np.asarray(bad)]
    return int(loads[-1] + stepped[-1] + pipeline_depth(config, fmt) + 1)


def beat_wait(valid: int, sink_ready: int, hold: int) -> int:
    """Clocks a beat valid in clock `valid` waits in the stepper's output register: until the
    sink is ready (`sink_ready`, the polygon pipeline's accumulator after a scan), then
    ``hold - 1`` more while the sink takes it (the accumulator takes a beat's nonzero cells
    one a clock, or two or four with two or four scan lanes, `edgeaa.model.tile.beat_clocks`,
    and the beat in
    the last of them)."""
    return max(0, sink_ready - valid) + hold - 1


class SinkClock:
    """The sink as the stepper's output register meets it, beat by beat (`take`): first
    ready in clock `ready`, taking each beat over its ``hold`` clocks (`beat_wait`). With
    `skid`, a skid buffer (`edgeaa.hdl.skid.SkidBuffer`) sits before it: the buffer takes a
    beat in the first clock it is valid and the buffer empty (the sink took the beat before
    it), and the sink starts on it that clock (the buffer adds no latency) or once ready,
    so the stepper no longer waits out the sink's hold of each beat, only the previous
    beat's when its next comes sooner."""

    def __init__(self, ready: int = 0, skid: bool = False):
        self.ready, self.skid = ready, skid
        self.empty = 0  # first clock the buffer is empty again

    def take(self, valid: int, hold: int) -> tuple[int, int]:
        """A beat valid in the stepper's output register from clock `valid`: (the clocks it
        waits there, the clock the sink takes it)."""
        if not self.skid:
            wait = beat_wait(valid, self.ready, hold)
            self.ready = 0
            return wait, valid + wait
        handed = max(valid, self.empty)
        taken = max(handed, self.ready) + hold - 1
        self.ready, self.empty = 0, taken + 1
        return handed - valid, taken


class _Enabled:
    """The stepper's clocks: its one enable (``~out.valid | out.ready``) is low while a beat
    waits in the output register, which freezes the loop and the pipeline (the setup runs on
    until its bank waits, and a bank is loaded in a freeze only while the loop is idle). A
    wait is added at the enabled clock of index ``j`` where its beat is valid (``wait``, in
    ascending ``j``); every enabled clock from that index on moves ``length`` clocks later."""

    def __init__(self):
        self.starts: list[int] = []  # index of each wait
        self.shifts: list[int] = [0]  # total length of the waits before and at each

    def clock(self, index: int) -> int:
        """The enabled clock of `index` (clock `index` when nothing waited)."""
        return index + self.shifts[bisect.bisect_right(self.starts, index)]

    def index(self, clock: int) -> int:
        """Index of the first enabled clock at or after `clock`."""
        lo, hi = clock - self.shifts[-1], clock  # clock(i) >= i and grows by at least 1
        while lo < hi:
            mid = (lo + hi) // 2
            lo, hi = (mid + 1, hi) if self.clock(mid) < clock else (lo, mid)
        return lo

    def wait(self, index: int, length: int) -> None:
        if length:
            assert not self.starts or index > self.starts[-1], "waits in ascending order"
            self.starts.append(index)
            self.shifts.append(self.shifts[-1] + length)


def _schedule_one(
    extra: int,
    shapes,
    edges,
    latency: int,
    depth: int,
    live: bool,
    idle=None,
    sink: SinkClock | None = None,
    holds=None,
):
    """`schedule` of the core with one setup unit: it holds an edge from its accept to the
    stepper's transfer of its bank and accepts the next command from that clock on. The
    transfer is the load (line writes), or with `live` (deltas) the step of the edge's last
    column, the next edge starting in a later clock. `extra`: `start_clip_cycles`."""
    out: list[EdgeTiming] = []
    accept = 0  # the setup's first free clock, then the accept
    prev_last = None  # the clock the stepper steps the previous good edge's last column
    enabled, sink = _Enabled(), sink or SinkClock()
    for k, shape in enumerate(shapes):
        edge = None if edges is None else edges[k]
        if idle is not None:
            accept = max(accept, (out[-1].accepted + 1 if out else 0) + idle[k])
        columns = 0 if shape is None else int(shape[0])
        if not columns:
            done = accept + (BAD_COMMAND_CYCLES if shape is None else EMPTY_EDGE_CYCLES)
            out.append(EdgeTiming(edge, accept, None, None, (), done))
            accept = done
            continue
        clipped_start = bool(shape[1])
        bank = accept + latency - depth - 2 + (extra if clipped_start else 0)
        load = bank + 1 if prev_last is None else max(bank + 1, prev_last + live)
        first = enabled.index(load + 1)  # column c stepped at enabled index first + c
        hold = None if holds is None else holds[k]
        beats, waits = _beats(enabled, sink, first + depth, columns, hold)
        prev_last = enabled.clock(first + columns - 1)
        released = prev_last if live else load
        out.append(EdgeTiming(edge, accept, bank, load, beats, released, waits))
        accept = released
    return out


class _Units:
    """`schedule` of the core with `units` setup units (`edgeaa.hdl.dispatch.SetupArray`),
    command by command (`command`).

    Command k goes to unit k mod N when that unit has retired its previous command; a good
    edge's unit ends FINAL ``R + 2 + Phi`` clocks after accepting it (never waiting: a unit
    holds one command); the stepper loads it once the collector points at it and the stepper
    is free; a dropped command retires once its unit is back in IDLE and the collector points
    at it. The collector points at the next unit the clock after a retirement. A good edge
    retires when the stepper takes its bank: at the load (line writes), or with `live`
    (deltas) in the clock its last column is stepped, the next edge starting after it. A
    stalled sink freezes the stepper as with one unit (`_Enabled`); the units run on."""

    def __init__(self, extra, latency, depth, live, units, sink: SinkClock):
        self.extra = extra  # `start_clip_cycles`
        self.latency, self.depth, self.live = latency, depth, live
        self.free = [0] * units  # first clock each unit may accept in
        self.k, self.accept = 0, -1
        self.collector = 0  # first clock the collector points at the next command's unit
        self.stepper_free = 0  # first clock the stepper may load in (idle, or its last column)
        self.enabled, self.sink = _Enabled(), sink

    def command(self, shape, edge, idle: int, hold) -> EdgeTiming:
        unit = self.k % len(self.free)
        self.k += 1
        accept = self.accept = max(self.accept + 1 + idle, self.free[unit])
        columns = 0 if shape is None else int(shape[0])
        if not columns:
            done = accept + (BAD_COMMAND_CYCLES if shape is None else EMPTY_EDGE_CYCLES)
            retire = max(done, self.collector)
            timing = EdgeTiming(edge, accept, None, None, (), retire + 1)
        else:
            bank = accept + self.latency - self.depth - 2 + (self.extra if shape[1] else 0)
            load = max(bank + 1, self.collector, self.stepper_free)
            enabled = self.enabled
            first = enabled.index(load + 1)  # column c stepped at enabled index first + c
            beats, waits = _beats(enabled, self.sink, first + self.depth, columns, hold)
            last = enabled.clock(first + columns - 1)
            retire = last if self.live else load
            self.stepper_free = last + self.live
            timing = EdgeTiming(edge, accept, bank, load, beats, retire + 1, waits)
        self.collector = self.free[unit] = retire + 1
        return timing


def _beats(enabled: _Enabled, sink: SinkClock, start: int, columns: int, hold):
    """An edge's beats: column c's valid in the stepper's output register at enabled index
    ``start + c`` (its step's index and the pipeline's depth), waiting there for the sink
    (`SinkClock.take`, `hold` the sink's clocks for each, None: one). Returns the clocks the
    sink takes them and the clocks they waited."""
    beats, waits = [], 0
    for c in range(columns):
        valid = enabled.clock(start + c)
        wait, taken = sink.take(valid, 1 if hold is None else int(hold[c]))
        enabled.wait(start + c, wait)
        beats.append(taken)
        waits += wait
    return tuple(beats), waits


def beat_cycles(
    config: EdgeConfig,
    edges,
    setup_latency_: int | None = None,
    fmt: BeatFormat = WRITES,
    setup_units: int = DEFAULT_SETUP_UNITS,
) -> list[int]:
    """The clock of every beat of the stream, in order (`write_cycles` flattened)."""
    timings = write_cycles(config, edges, setup_latency_, fmt, setup_units)
    return [beat for timing in timings for beat in timing.beats]


def sustained_rate(
    config: EdgeConfig,
    columns: int,
    setup_latency_: int | None = None,
    fmt: BeatFormat = WRITES,
    setup_units: int = DEFAULT_SETUP_UNITS,
) -> float:
    """Steady-state columns per clock of an endless stream of edges of `columns` columns
    (`setup_latency_`, if given, is the core's: a unit spends ``L - D - 1`` clocks per edge
    alone, ``L - D`` in an array): ``C / max(C, unit clocks / N)``. With ``live_bank``
    (`DELTAS`) the unit also holds the edge while it steps (``C`` more clocks) and its
    stepper starts an edge the clock after the previous one's last column: ``C / max(C + 1,
    unit clocks / N)``."""
    if setup_latency_ is None:
        per_unit = unit_cycles(config, setup_units, fmt)
    else:
        per_unit = setup_latency_ - pipeline_depth(config, fmt) - (setup_units == 1)
    live = fmt.live_bank
    per_unit += columns if live else 0
    return columns * setup_units / max((columns + live) * setup_units, per_unit)


@dataclass(frozen=True)
class ClockBreakdown:
    """Where the clocks of a stream went (`clock_breakdown`): ``clocks`` (clock 0 to the last
    beat) = ``stepping`` (one per column) + ``setup_bound`` (the stepper idle between two
    edges, waiting for the next bank) + ``latency`` (before the first column and the output
    pipeline after the last) + ``stalls`` (sink back-pressure: 0 for the timing model's
    always-ready sink)."""

    clocks: int
    edges: int  # edges stepped (good, with a visible column)
    stepping: int
    setup_bound: int
    latency: int
    stalls: int = 0

    @property
    def columns_per_clock(self) -> float:
        return self.stepping / self.clocks if self.clocks else 0.0

    @property
    def edges_per_clock(self) -> float:
        return self.edges / self.clocks if self.clocks else 0.0


def clock_breakdown(timings: list[EdgeTiming], depth: int) -> ClockBreakdown:
    """Split a schedule's clocks (`write_cycles`, `schedule`; `depth` its `pipeline_depth`)
    into stepping, setup-bound and latency clocks (`ClockBreakdown`)."""
    stepped = [t for t in timings if not t.dropped]
    if not stepped:
        return ClockBreakdown(0, 0, 0, 0, 0)
    columns = sum(len(t.beats) for t in stepped)
    gaps = sum(b.load - (a.load + len(a.beats)) for a, b in zip(stepped, stepped[1:], strict=False))
    latency = stepped[0].load + 1 + depth
    clocks = stepped[-1].beats[-1] + 1
    assert clocks == columns + gaps + latency, "the breakdown does not add up"
    return ClockBreakdown(clocks, len(stepped), columns, gaps, latency)


def stream_rate(timings: list[EdgeTiming]) -> float:
    """Columns per clock of a whole stream: beats over clocks from clock 0 to the last beat."""
    beats = [beat for timing in timings for beat in timing.beats]
    if not beats:
        return 0.0
    return len(beats) / (max(beats) + 1)
