# amaranth: UnusedElaboratable=no
"""The hardware core against the model: interface, setup, per-column trace, timing, streams.

Amaranth simulator, async testbenches only. Every simulation run is checked the same way
(`check_run`): the ordered beats equal `run_edge` (lanes, values, last flags), the setup bank
handed to the stepper equals `setup()`, bad commands are dropped and counted, edges with no
column in their clip window leave nothing (no bank, no error), and the sink is empty at the
end. Each command is offered with its window on the ``clip`` port
(`edgeaa.sim.verification.commands`).
Runs with an always-ready sink and a back-to-back source additionally match the stepper's
registers to the model's per-column trace and every beat's clock to `edgeaa.model.timing`.
The stepper's scaled areas are compared with the model's `Write.area` too, so a tie decided
differently inside the loop shows even when the rounded value hides it.

The runner (`simulate`) is one per-clock testbench that drives the source, the sink and
samples the internal observation points together (cheaper than three testbenches here);
`edgeaa.sim.verification.streams` serves the small directed
tests. The core simulates at 2-4k clocks/s, so
edges are short and many of them share one run; long sweeps are marked slow
(``pytest -m slow``).
"""

from __future__ import annotations

import random
import re
from dataclasses import dataclass, field, replace

import pytest
from amaranth.back import rtlil
from amaranth.hdl import Module, ResetInserter, Shape, Signal, Value, signed, unsigned
from amaranth.lib import data
from amaranth.lib.wiring import In, Out
from amaranth.sim import Simulator
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from edgeaa.hdl import (
    EdgeAntialiaser,
    EdgeStepper,
    clip_layout,
    setup_layout,
    verilog,
    write_layout,
)
from edgeaa.hdl.core import ERRORS_BITS
from edgeaa.model import Clip, Edge, EdgeConfig, EdgeError, run_edge, setup
from edgeaa.model import timing as timing_model
from edgeaa.sim.simulators.verilator import lint
from edgeaa.sim.synthesis import muldiv_cells
from edgeaa.sim.verification.commands import edge_clip, edge_payload
from edgeaa.sim.verification.scoreboard import Beat, edge_beats
from edgeaa.sim.verification.streams import stream_put

CONFIGS = {
    "default": EdgeConfig(),
    "pw": EdgeConfig(mode="pw"),
    "seg2": EdgeConfig(mode="seg2"),
    "seg4": EdgeConfig(mode="seg4"),
    "truncated": EdgeConfig(accumulator="truncated"),
    "small": EdgeConfig(coord_bits=4, subpixel_bits=0, intensity_bits=4),
    "wide": EdgeConfig(coord_bits=15, subpixel_bits=8),
    # The fewest fraction bits allowed: ties of the exact-remainder tests become reachable.
    "lowfrac": EdgeConfig(
        coord_bits=5, subpixel_bits=6, intensity_bits=2, frac_bits=8, mode="seg2"
    ),
}


# -- payload decoding (raw integers are much faster to sample than data.Const) ---------------


def _fields(layout, prefix=""):
    """(dotted name, offset, width, signed) of each leaf field of a layout."""
    for name, fld in layout:
        shape = fld.shape
        key = f"{prefix}{name}"
        if isinstance(shape, data.Layout):
            for sub, offset, width, is_signed in _fields(shape, f"{key}."):
                yield sub, fld.offset + offset, width, is_signed
        else:
            shape = Shape.cast(shape)
            yield key, fld.offset, shape.width, shape.signed


def decoder(layout):
    fields = list(_fields(layout))

    def decode(raw: int) -> dict[str, int]:
        out = {}
        for key, offset, width, is_signed in fields:
            value = (raw >> offset) & ((1 << width) - 1)
            if is_signed and value >> (width - 1):
                value -= 1 << width
            out[key] = value
        return out

    return decode


def is_good(config: EdgeConfig, edge: Edge) -> bool:
    """The model accepts the command (the core does not drop it as bad)."""
    try:
        setup(config, edge)
    except EdgeError:
        return False
    return True


def is_visible(config: EdgeConfig, edge: Edge) -> bool:
    """A good command with at least one column inside its clip window (it gets a bank)."""
    return is_good(config, edge) and setup(config, edge).columns > 0


# -- the simulation runner -------------------------------------------------------------------


@dataclass
class Run:
    """What one simulation observed, clock by clock."""

    config: EdgeConfig
    edges: list
    label: str
    setup_latency: int
    accepts: list = field(default_factory=list)  # clock of each accepted command
    beats: list = field(default_factory=list)  # (clock, decoded payload)
    steps: list = field(default_factory=list)  # (clock, x, y, jq, jr) per column stepped
    areas: list = field(default_factory=list)  # (clock, area0, area1) per column, in order
    banks: list = field(default_factory=list)  # (clock, decoded bank) handed to the stepper
    error_pulses: list = field(default_factory=list)  # clocks with `error` high
    errors: int = 0  # final `errors` count
    final_idle: tuple = ()  # writes.valid, bank valid, stepper active, edges.ready
    clocks: int = 0


def simulate(
    config: EdgeConfig,
    edges: list,
    *,
    seed: int | None = None,
    idle: float = 0.0,
    stall: float = 0.0,
    label: str = "",
) -> Run:
    """Offer `edges` in order (each with its window on ``clip``) and drain the writes; with
    `seed`, random idle source clocks (probability `idle` per clock before each offer), random
    sink stalls (`stall`) and a random window on ``clip`` whenever no edge is offered."""
    dut = EdgeAntialiaser(config)
    stepper = dut.stepper
    rng = random.Random(seed) if seed is not None else None
    tag = f"[{label} seed={seed} idle={idle} stall={stall} config={config}]"
    run = Run(config, list(edges), tag, dut.setup_latency)
    payloads = [edge_payload(config, edge) for edge in edges]
    clips = [edge_clip(config, edge) for edge in edges]
    expected_beats = sum(setup(config, edge).columns for edge in edges if is_good(config, edge))
    per_edge = dut.setup_latency + dut.start_clip_cycles + 4
    max_clocks = 50 + (len(edges) + 2) * per_edge * 4 + expected_beats
    if stall:
        max_clocks += int(expected_beats * 4 / (1 - stall))
    if idle:
        max_clocks += int(len(edges) * 4 * per_edge / (1 - idle))
    decode_beat = decoder(write_layout(config))
    decode_bank = decoder(setup_layout(config))
    beat_bits = Value.cast(dut.writes.payload)
    bank_bits = Value.cast(stepper.setup.payload)
    drain_clocks = dut.setup_latency + 8

    async def bench(ctx):
        index = 0
        offering = False
        held = None  # raw beat valid but not taken in the previous clock
        quiet = 0
        clock = 0
        while True:
            eager = rng is None or not rng.random() < idle
            if index < len(payloads) and not offering and eager:
                ctx.set(dut.edges.payload, payloads[index])
                ctx.set(dut.clip, clips[index])
                ctx.set(dut.edges.valid, 1)
                offering = True
            elif rng is not None and not offering:
                # The window is sampled with the edge only: anything in the other clocks.
                ctx.set(dut.clip, random_clip(config, rng))
            ready = rng is None or not rng.random() < stall
            ctx.set(dut.writes.ready, ready)
            (
                _,
                _,
                e_ready,
                w_valid,
                w_raw,
                error,
                step,
                x,
                y,
                jq,
                jr,
                area_step,
                area0,
                area1,
                b_valid,
                b_ready,
                b_raw,
            ) = await ctx.tick().sample(
                dut.edges.ready,
                dut.writes.valid,
                beat_bits,
                dut.error,
                stepper.step,
                stepper.x,
                stepper.y,
                stepper.jq,
                stepper.jr,
                stepper.area_step,
                stepper.area0,
                stepper.area1,
                stepper.setup.valid,
                stepper.setup.ready,
                bank_bits,
            )
            if offering and e_ready:
                run.accepts.append(clock)
                index += 1
                offering = False
                ctx.set(dut.edges.valid, 0)
            if held is not None:
                assert w_valid and w_raw == held, (
                    f"{tag} clock {clock}: a stalled beat changed or vanished "
                    f"(valid={w_valid}, payload {w_raw:#x}, was {held:#x})"
                )
            held = w_raw if w_valid and not ready else None
            if w_valid and ready:
                run.beats.append((clock, decode_beat(w_raw)))
            if step:
                run.steps.append((clock, x, y, jq, jr))
            if area_step:
                run.areas.append((clock, area0, area1))
            if b_valid and b_ready:
                run.banks.append((clock, decode_bank(b_raw)))
            if error:
                run.error_pulses.append(clock)
            clock += 1
            done = index == len(payloads) and len(run.beats) >= expected_beats
            quiet = quiet + 1 if done else 0
            if quiet > drain_clocks or clock > max_clocks:
                break
        run.clocks = clock
        run.errors = ctx.get(dut.errors)
        # The core is idle: nothing in the output register, the bank, the stepper or setup.
        run.final_idle = (
            ctx.get(dut.writes.valid),
            ctx.get(stepper.setup.valid),
            ctx.get(stepper.active),
            ctx.get(dut.edges.ready),
        )

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    return run


# -- checks ----------------------------------------------------------------------------------


def expected_beats(config: EdgeConfig, edge: Edge) -> list[Beat]:
    """The model's writes of one edge as two-lane beats (the shared scoreboard's form)."""
    return edge_beats(run_edge(config, edge))


def observed_beat(beat: dict) -> Beat:
    lane1 = (beat["lane1.x"], beat["lane1.y"], beat["lane1.value"]) if beat["lane1_valid"] else None
    return Beat((beat["lane0.x"], beat["lane0.y"], beat["lane0.value"]), lane1, bool(beat["last"]))


def expected_bank(config: EdgeConfig, edge: Edge) -> dict[str, int]:
    st_ = setup(config, edge)
    bank = {
        "x": st_.x,
        "y": st_.y,
        "remaining": st_.columns - 1,
        "col_dx": st_.col_dx,
        "col_dy": st_.col_dy,
        "row_dx": st_.row_dx,
        "row_dy": st_.row_dy,
        "value_base": st_.value_base,
        "value_sign": st_.value_sign,
    }
    for name in ("du", "ifix", "jq", "jr", "kq", "kr", "khq", "khr"):
        bank[name] = getattr(st_, name)
    for j, value in enumerate(st_.seg_thresholds):
        bank[f"seg_thresholds.{j}"] = value
    for j, value in enumerate(st_.seg_intercepts):
        bank[f"seg_intercepts.{j}"] = value
    return bank


def first_difference(got: list, want: list) -> int | None:
    for index, (a, b) in enumerate(zip(got, want, strict=False)):
        if a != b:
            return index
    return None if len(got) == len(want) else min(len(got), len(want))


def check_run(run: Run, *, exact_timing: bool) -> None:
    """All checks of one run; `exact_timing` for an always-ready sink and eager source."""
    config, tag = run.config, run.label
    good = [edge for edge in run.edges if is_good(config, edge)]
    visible = [edge for edge in good if setup(config, edge).columns]  # the others: no bank
    bad = len(run.edges) - len(good)

    # Beats: the model's writes, in order, lane by lane, with the last flags.
    got = [observed_beat(beat) for _, beat in run.beats]
    want = [beat for edge in good for beat in expected_beats(config, edge)]
    position = 0
    for n, edge in enumerate(good):
        edge_want = expected_beats(config, edge)
        edge_got = got[position : position + len(edge_want)]
        assert edge_got == edge_want, (
            f"{tag} good edge {n} {edge}: beats differ from run_edge "
            f"(first difference at column {first_difference(edge_got, edge_want)})"
        )
        position += len(edge_want)
    assert len(got) == len(want), f"{tag} {len(got)} beats, model has {len(want)}"

    # The bank handed to the stepper: the model's setup() of each edge with a visible column.
    assert len(run.banks) == len(visible), f"{tag} {len(run.banks)} banks, {len(visible)} edges"
    for n, (edge, (_, bank)) in enumerate(zip(visible, run.banks, strict=True)):
        want_bank = expected_bank(config, edge)
        assert bank == want_bank, (
            f"{tag} visible edge {n} {edge}: bank differs from setup(): "
            f"{ {k: (bank[k], want_bank[k]) for k in bank if bank[k] != want_bank[k]} }"
        )

    # Bad commands: dropped and counted, one error pulse each (an edge with no column in its
    # window is not an error).
    assert run.errors == min(bad, (1 << ERRORS_BITS) - 1), f"{tag} errors={run.errors}"
    assert len(run.error_pulses) == bad, f"{tag} error pulses {run.error_pulses}"
    assert len(run.accepts) == len(run.edges), f"{tag} accepted {len(run.accepts)} commands"
    # The sink is empty at the end and the core idle.
    assert run.final_idle == (0, 0, 0, 1), f"{tag} not idle at the end: {run.final_idle}"

    # Per-column trace of the stepper registers, and the scaled areas of the column's writes
    # (observed in the pipeline's last stage, in the same order).
    assert len(run.areas) == len(run.steps), f"{tag} {len(run.areas)} areas, {len(run.steps)}"
    got_steps = [step[1:] + area[1:] for step, area in zip(run.steps, run.areas, strict=True)]
    want_steps = []
    for edge in good:
        result = run_edge(config, edge)
        for state, column in zip(result.trace, result.columns, strict=True):
            area1 = column[1].area if len(column) > 1 else None
            want_steps.append((state.x, state.y, state.jq, state.jr, column[0].area, area1))
    got_steps = [
        (*step[:5], step[5] if want[5] is not None else None)
        for step, want in zip(got_steps, want_steps, strict=False)
    ]
    assert len(run.steps) == len(want_steps), f"{tag} {len(run.steps)} columns stepped"
    assert got_steps == want_steps, (
        f"{tag} stepper registers or areas differ from the model's trace at column "
        f"{first_difference(got_steps, want_steps)} (x, y, jq, jr, area0, area1)"
    )

    if not exact_timing:
        return
    # The clock of each accept, bank load, stepped column, beat and error pulse.
    timings = timing_model.write_cycles(config, run.edges, run.setup_latency)
    assert run.accepts == [t.accepted for t in timings], f"{tag} accept clocks"
    want_clocks = [clock for t in timings for clock in t.beats]
    got_clocks = [clock for clock, _ in run.beats]
    assert got_clocks == want_clocks, (
        f"{tag} beat clocks differ from the timing model; first at beat "
        f"{first_difference(got_clocks, want_clocks)}"
    )
    depth = timing_model.pipeline_depth(config)  # clocks from a column's step to its beat
    assert [clock for clock, *_ in run.steps] == [c - depth for c in want_clocks], f"{tag} steps"
    assert [clock for clock, *_ in run.areas] == [c - 1 for c in want_clocks], f"{tag} areas"
    assert [clock for clock, _ in run.banks] == [t.load for t in timings if not t.dropped]
    want_errors = [t.accepted + 2 for t in timings if not is_good(config, t.edge)]
    assert run.error_pulses == want_errors, f"{tag} error pulse clocks"


def run_and_check(config, edges, *, seed=None, idle=0.0, stall=0.0, label=""):
    run = simulate(config, edges, seed=seed, idle=idle, stall=stall, label=label)
    check_run(run, exact_timing=seed is None)
    return run


# -- edge corpora ----------------------------------------------------------------------------


def corpus(config: EdgeConfig, *, longest: bool = True) -> list[tuple[str, Edge]]:
    """Named corner cases, scaled to the configuration; all inside the coordinate range."""
    S, hi, full = config.subpixel_scale, config.max_vertex, config.full_scale
    span = 1 << config.coord_bits
    step = max(1, min(5, span // 4))  # pixels
    c = (span // 2) * S  # a pixel centre near the middle
    long_ = step * S + S // 3
    short = long_ // 2 + 1
    half = S // 2
    cases = []

    def add(name, x0, y0, x1, y1, **kwargs):
        assert all(0 <= v <= hi for v in (x0, y0, x1, y1)), (name, x0, y0, x1, y1)
        cases.append((name, Edge(x0, y0, x1, y1, **kwargs)))

    octants = [(1, 0), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1), (1, 0)]
    directions = [
        (long_, short),
        (short, long_),
        (-short, long_),
        (-long_, short),
        (-long_, -short),
        (-short, -long_),
        (short, -long_),
        (long_, -short),
    ]
    for n, ((dx, dy), _) in enumerate(zip(directions, octants, strict=True)):
        inside = ("left", "right")[n % 2]
        i_in, i_out = ((full, 0), (0, full), (full // 3, full), (1, 0))[n % 4]
        add(f"octant{n}", c + 1, c + half, c + 1 + dx, c + half + dy, inside=inside, i_in=i_in,
            i_out=i_out)  # fmt: skip
    for name, dx, dy in (
        ("0deg", long_, 0),
        ("180deg", -long_, 0),
        ("45deg", long_, long_),
        ("135deg", -long_, long_),
        ("225deg", -long_, -long_),
        ("315deg", long_, -long_),
        ("vertical_down", 0, long_),
        ("vertical_up", 0, -long_),
    ):
        add(name, c, c, c + dx, c + dy, inside="right", i_in=0, i_out=full)
        add(f"{name}_left", c + half, c + S - 1, c + half + dx, c + S - 1 + dy, i_out=full - 1)
    add("shortest_x", c, c, c + 1, c)
    add("shortest_y", c, c, c, c + 1, inside="right")
    if S >= 2:
        add("single_column_x", c, c, c + 1, c + 1 if S > 2 else c, i_in=1, i_out=full)
        add("single_column_y", c + 1, c - half + 1, c, c + half - 1, inside="right")
    for offset in sorted({0, 1, half - 1, half, half + 1, S - 1} & set(range(S))):
        add(f"subpixel{offset}_start", c + offset, c + offset, c + long_, c + short)
        add(f"subpixel{offset}_end", c, c, c + long_ - S + 1 + offset, c - short + offset)
    add("corner_origin", 0, 0, long_, short, inside="right")
    add("corner_max", hi, hi, hi - short, hi - long_)
    add("edge_top", hi, 0, hi - long_, 0, i_in=full, i_out=full - 1)
    add("edge_left", 0, hi, 0, hi - long_, i_in=0, i_out=1)
    if longest:
        add("longest_diagonal", 0, 0, hi, hi, i_in=full, i_out=0)
        add("longest_antidiagonal", hi, 0, 0, hi, inside="right", i_in=0, i_out=full)
        add("longest_bottom_row", hi, hi, 0, hi - 1, i_in=1, i_out=0)
    return cases


def longest_edges(config: EdgeConfig) -> list[Edge]:
    hi = config.max_vertex
    return [edge for name, edge in corpus(config) if name.startswith("longest")] + [
        Edge(hi, hi, hi, 0, inside="right"),  # the longest vertical, at the right border
    ]


def snap(config: EdgeConfig, value: int, grid: str) -> int:
    """`value` moved onto a pixel centre or corner (exact geometric coincidences)."""
    S = config.subpixel_scale
    if grid == "centre":
        return value - value % S
    if grid == "corner":
        return min(value - value % S + S // 2, config.max_vertex)
    return value


@st.composite
def edge_commands(draw, config: EdgeConfig, max_pixels: int, clip: bool = False):
    """Edge commands (good or bad) at most `max_pixels` long on each axis, often with their
    vertices on pixel centres or corners; with `clip`, each with a window (`window_near`)."""
    hi, full = config.max_vertex, config.full_scale
    reach = max_pixels * config.subpixel_scale
    x0, y0 = draw(st.integers(0, hi)), draw(st.integers(0, hi))
    x1 = draw(st.integers(max(0, x0 - reach), min(hi, x0 + reach)))
    y1 = draw(st.integers(max(0, y0 - reach), min(hi, y0 + reach)))
    grid = draw(st.sampled_from(("any", "any", "centre", "corner")))
    edge = Edge(
        *(snap(config, value, grid) for value in (x0, y0, x1, y1)),
        inside=draw(st.sampled_from(("left", "right"))),
        i_in=draw(st.integers(0, full)),
        i_out=draw(st.integers(0, full)),
    )
    if clip:
        window = window_near(config, edge, lambda lo, hi: draw(st.integers(lo, hi)))
        edge = replace(edge, clip=window)
    return edge


def random_clip(config: EdgeConfig, rng: random.Random) -> dict[str, int]:
    """Any value of the ``clip`` port (four bounds in [0, 2**W], possibly empty)."""
    top = 1 << config.coord_bits
    return {name: rng.randint(0, top) for name in Clip._fields}


def window_near(config: EdgeConfig, edge: Edge, pick) -> Clip | None:
    """A clip window for `edge`, drawn with ``pick(lo, hi)`` (an integer in [lo, hi]): none,
    a random one, or bounds within two pixels of the edge's span on both axes, ordered (the
    window cuts the edge's start, its end, both or nothing) or not (often empty)."""
    top, S = 1 << config.coord_bits, config.subpixel_scale
    kind = pick(0, 4)
    if kind == 0:
        return None
    if kind == 1:
        return Clip(*(pick(0, top) for _ in Clip._fields))
    bounds = []
    for a, b in ((edge.x0, edge.x1), (edge.y0, edge.y1)):
        near = (max(0, min(a, b) // S - 2), min(top, -(-max(a, b) // S) + 2))
        low, high = pick(*near), pick(*near)
        bounds.append((min(low, high), max(low, high)) if kind < 4 else (low, high))
    (x_min, x_max), (y_min, y_max) = bounds
    return Clip(x_min, y_min, x_max, y_max)


def with_window(config: EdgeConfig, edge: Edge, start: int, end: int, *, minor=None) -> Edge:
    """`edge` with a window that keeps its (unclipped) columns ``start .. end`` along the major
    axis (clamped to the image; outside ``0 .. columns - 1`` the window reaches beyond the
    edge); the minor axis gets the whole image, or `minor` = (min, max)."""
    st_ = setup(config, replace(edge, clip=None))
    top = 1 << config.coord_bits
    major, step = (st_.x, st_.col_dx) if st_.x_major else (st_.y, st_.col_dy)
    a, b = (min(max(major + step * c, 0), top) for c in (start, end))
    lo, hi = (a, b) if start > end else (min(a, b), max(a, b))  # start > end: min > max
    other = (0, top) if minor is None else minor
    if st_.x_major:
        return replace(edge, clip=Clip(lo, other[0], hi, other[1]))
    return replace(edge, clip=Clip(other[0], lo, other[1], hi))


def random_edges(
    config: EdgeConfig, rng: random.Random, count: int, max_pixels: int, *, clip: bool = False
):
    """Random edge commands (good or bad); with `clip`, each with a window (`window_near`)."""
    hi, full = config.max_vertex, config.full_scale
    reach = max_pixels * config.subpixel_scale
    edges = []
    for _ in range(count):
        x0, y0 = rng.randint(0, hi), rng.randint(0, hi)
        x1 = rng.randint(max(0, x0 - reach), min(hi, x0 + reach))
        y1 = rng.randint(max(0, y0 - reach), min(hi, y0 + reach))
        grid = rng.choice(("any", "any", "centre", "corner"))
        x0, y0, x1, y1 = (snap(config, value, grid) for value in (x0, y0, x1, y1))
        inside = rng.choice(("left", "right"))
        edge = Edge(x0, y0, x1, y1, inside, rng.randint(0, full), rng.randint(0, full))
        if clip:
            edge = replace(edge, clip=window_near(config, edge, rng.randint))
        edges.append(edge)
    return edges


def boundary_states(config: EdgeConfig, edge: Edge) -> set[str]:
    """The rare decisions of the loop an edge exercises (ties of the compares, clamps)."""
    result = run_edge(config, edge)
    st_, hits = result.setup, set()
    n = config.segments
    khr_exact = ((st_.ifix >> config.F) * st_.dv << (config.F - 1)) % st_.du
    if 2 * khr_exact == st_.du:
        hits.add("slope doubling tie")  # kq = 2 khq + (2 khr >= du)
    for state in result.trace:
        jq, jr = state.jq, state.jr
        rsum = jr + st_.kr
        if rsum == st_.du:
            hits.add("carry tie")
        if jq + st_.kq + (rsum >= st_.du) in (st_.ifix - 1, st_.ifix):
            hits.add("row step tie")
        if n == 0:
            continue
        rsum = jr + st_.khr
        carry = rsum >= st_.du
        if rsum == st_.du:
            hits.add("exit carry tie")
        depths = {
            "above": (jq + st_.khq + carry - st_.ifix, rsum - carry * st_.du),
            "below": (st_.khq - jq - (st_.khr < jr), st_.khr - jr + (st_.khr < jr) * st_.du),
        }
        if st_.khr == jr:
            hits.add("borrow tie")
        for side, (dq, dr) in depths.items():
            if dq == 0:
                hits.add(f"{side} d = 0" if dr == 0 else f"{side} 0 < d < 1")
                if dr == 1:
                    hits.add(f"{side} d = 1/du")  # the smallest positive exit depth
            if dq in st_.seg_thresholds:
                hits.add("segment threshold tie")
            if dq > 0 or (dq == 0 and dr > 0):
                j = sum(dq >= threshold for threshold in st_.seg_thresholds)
                shift = 2 + n.bit_length() - 1
                t = (((2 * j + 1) * dq) >> shift) - st_.seg_intercepts[j]
                hits.add("t < 0" if t < 0 else "t = 0" if t == 0 else "t > 0")
                break  # the model tests below only when not above
    half = 1 << (config.F - 1)
    for write in result.writes:
        if write.area & ((half << 1) - 1) == half:
            hits.add("rounding tie")
    return hits


def boundary_edges(config: EdgeConfig, seed: int, tries: int, per_class: int = 2) -> list[Edge]:
    """Short random edges chosen with the model so that every rare decision reachable in
    `tries` edges is exercised at least `per_class` times (when found)."""
    rng = random.Random(seed)
    found: dict[str, int] = {}
    chosen = []
    for edge in random_edges(config, rng, tries, 6):
        if not is_good(config, edge):
            continue
        new = [hit for hit in boundary_states(config, edge) if found.get(hit, 0) < per_class]
        if new:
            chosen.append(edge)
            for hit in boundary_states(config, edge):
                found[hit] = found.get(hit, 0) + 1
    return chosen


def sim_settings(max_examples: int) -> settings:
    """Few examples (each one is a simulation), no deadline, no example database."""
    return settings(
        max_examples=max_examples,
        deadline=None,
        database=None,
        phases=(Phase.explicit, Phase.generate),  # no shrinking: it re-runs simulations
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )


# -- (1) interface ---------------------------------------------------------------------------


def _members(signature):
    return {name: (member.flow, member) for name, member in signature.members.items()}


@pytest.mark.parametrize("name", ["default", "small"])
def test_interface(name):
    config = CONFIGS[name]
    W, s = config.coord_bits, config.subpixel_bits
    I = config.intensity_bits  # noqa: E741
    dut = EdgeAntialiaser(config)
    members = dut.signature.members
    assert set(members) == {"edges", "clip", "writes", "errors", "error"}
    assert members["edges"].flow == In and members["writes"].flow == Out
    assert members["errors"].flow == Out and members["errors"].shape == unsigned(16)
    assert members["error"].flow == Out and members["error"].shape == unsigned(1)
    # The clip window: four pixel bounds in [0, 2**W]; undriven, it clips nothing.
    assert members["clip"].flow == In and members["clip"].shape == clip_layout(config)
    bounds = {key: Shape.cast(fld.shape) for key, fld in clip_layout(config)}
    assert bounds == {key: unsigned(W + 1) for key in ("x_min", "y_min", "x_max", "y_max")}
    clip = clip_layout(config).from_bits(Value.cast(dut.clip).init)
    assert [clip[key] for key, _ in clip_layout(config)] == list(Clip.full(config))
    edges = members["edges"].signature.members
    assert set(edges) == {"payload", "valid", "ready"}
    layout = edges["payload"].shape
    assert {key: Shape.cast(fld.shape) for key, fld in layout} == {
        "x0": unsigned(W + s),
        "y0": unsigned(W + s),
        "x1": unsigned(W + s),
        "y1": unsigned(W + s),
        "i_in": unsigned(I),
        "i_out": unsigned(I),
        "inside": unsigned(1),
    }
    out = members["writes"].signature.members["payload"].shape
    assert [key for key, _ in out] == ["lane0", "lane1", "lane1_valid", "last"]
    pixel = {"x": signed(W + 2), "y": signed(W + 2), "value": unsigned(I)}
    for lane in ("lane0", "lane1"):
        assert {key: Shape.cast(fld.shape) for key, fld in out[lane].shape} == pixel
    assert Shape.cast(out["lane1_valid"].shape) == unsigned(1)
    assert Shape.cast(out["last"].shape) == unsigned(1)
    with pytest.raises(TypeError, match="config must be an EdgeConfig"):
        EdgeAntialiaser({"coord_bits": 11})
    with pytest.raises(TypeError, match="errors_bits must be a positive integer, not 0"):
        EdgeAntialiaser(config, errors_bits=0)


@pytest.mark.parametrize("name", list(CONFIGS))
def test_stepper_registers_use_the_width_table(name):
    config = CONFIGS[name]
    stepper = EdgeAntialiaser(config).stepper
    for reg_name, width in config.register_widths().items():
        sig = getattr(stepper, reg_name, None)
        if sig is None:  # a combinational value of the loop: checked in the RTLIL below
            continue
        assert sig.shape() == (signed if width.signed else unsigned)(width.bits), reg_name
    for sig in stepper.seg_thresholds + stepper.seg_intercepts:
        assert sig.shape() == unsigned(config.register_widths()["seg_const"].bits)
    text = rtlil.convert(stepper, emit_src=False)
    for wire_name, key in (("jsum", "jsum"), ("dq", "dq"), ("t", "t"), ("area0", "area")):
        if config.segments == 0 and key in ("dq", "t"):
            continue
        width = config.register_widths()[key]
        assert re.search(rf"wire width {width.bits} (signed )?\\{wire_name}\n", text), wire_name


@pytest.mark.parametrize("name", list(CONFIGS))
def test_setup_latency_is_the_timing_model(name):
    config = CONFIGS[name]
    dut = EdgeAntialiaser(config)
    depth = timing_model.pipeline_depth(config)
    assert dut.stepper.latency == depth == (2 if config.segments <= 1 else 3)
    assert dut.setup_latency == timing_model.setup_latency(config)
    assert dut.setup_latency == config.intensity_bits + config.F + 6 + depth
    assert dut.run_cycles == timing_model.run_cycles(config) == config.intensity_bits + config.F + 1
    assert timing_model.setup_interval(config) == dut.setup_interval == dut.run_cycles + 4
    assert dut.start_clip_cycles == timing_model.start_clip_cycles(config) == config.coord_bits + 1
    assert timing_model.run_cycles(config, True) == dut.run_cycles + dut.start_clip_cycles


# -- (2) setup registers against setup() -----------------------------------------------------


def simulate_setup(config: EdgeConfig, edges: list[Edge]) -> list[dict | None]:
    """The bank each edge's setup produces (None: dropped, or no column in the window),
    resetting the core between edges so that long edges cost only their setup time."""
    dut = EdgeAntialiaser(config)
    flush = Signal()
    top = Module()
    top.submodules.dut = ResetInserter(flush)(dut)
    decode_bank = decoder(setup_layout(config))
    bank = dut.stepper.setup
    results = []

    async def bench(ctx):
        for edge in edges:
            ctx.set(dut.edges.payload, edge_payload(config, edge))
            ctx.set(dut.clip, edge_clip(config, edge))
            ctx.set(dut.edges.valid, 1)
            await ctx.tick().until(dut.edges.ready)
            ctx.set(dut.edges.valid, 0)
            for _ in range(dut.setup_latency + dut.start_clip_cycles + 2):
                _, _, valid, error, raw = await ctx.tick().sample(
                    bank.valid, dut.error, Value.cast(bank.payload)
                )
                if valid or error:
                    break
            results.append(decode_bank(raw) if valid else None)
            ctx.set(flush, 1)
            await ctx.tick()
            ctx.set(flush, 0)

    sim = Simulator(top)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    return results


def check_setup(config: EdgeConfig, edges: list[Edge]):
    for edge, bank in zip(edges, simulate_setup(config, edges), strict=True):
        if not is_visible(config, edge):
            assert bank is None, f"{edge} (bad, or nothing in its window) produced a bank"
            continue
        want = expected_bank(config, edge)
        assert bank == want, (
            f"{config} {edge}: bank differs from setup(): "
            f"{ {k: (bank[k], want[k]) for k in want if bank[k] != want[k]} }"
        )


@pytest.mark.parametrize("name", list(CONFIGS))
def test_setup_matches_model(name):
    config = CONFIGS[name]
    max_pixels = 1 << config.coord_bits  # full-range edges: only the setup is simulated

    @sim_settings(5)
    @given(st.lists(edge_commands(config, max_pixels), min_size=8, max_size=12))
    def check(edges):
        check_setup(config, edges)

    check()


def test_setup_corner_cases():
    for config in CONFIGS.values():
        check_setup(config, [edge for _, edge in corpus(config)] + longest_edges(config))


# -- (3)-(5) equivalence with run_edge, trace and timing --------------------------------------


@pytest.mark.parametrize("name", list(CONFIGS))
def test_corpus(name):
    """Every corner case in one run: writes, bank, trace and beat clocks against the model."""
    config = CONFIGS[name]
    cases = corpus(config, longest=name != "wide")
    run_and_check(config, [edge for _, edge in cases], label=f"corpus {name}")


@pytest.mark.parametrize("name", list(CONFIGS))
def test_hypothesis_edges(name):
    config = CONFIGS[name]

    @sim_settings(6)
    @given(st.lists(edge_commands(config, 8), min_size=5, max_size=15))
    def check(edges):
        run_and_check(config, edges, label=f"hypothesis {name}")

    check()


BACKPRESSURE = [
    ("default", 1, 0.5, 0.5),
    ("default", 2, 0.0, 0.8),
    ("default", 3, 0.9, 0.0),
    ("seg4", 4, 0.3, 0.6),
    ("pw", 5, 0.3, 0.6),
    ("truncated", 6, 0.5, 0.5),
    ("small", 7, 0.5, 0.5),
    ("wide", 8, 0.3, 0.3),
]


@pytest.mark.parametrize(("name", "seed", "idle", "stall"), BACKPRESSURE)
def test_backpressure(name, seed, idle, stall):
    """Random source idle clocks and sink stalls: the same writes, none lost or duplicated."""
    config = CONFIGS[name]
    rng = random.Random(seed)
    edges = [edge for _, edge in corpus(config, longest=False)]
    edges = random_edges(config, rng, 10, 24) + edges[::3] + random_edges(config, rng, 10, 3)
    edges.insert(5, Edge(4, 4, 4, 4))  # a bad command in the middle of the stream
    run_and_check(config, edges, seed=seed, idle=idle, stall=stall, label=f"backpressure {name}")


@pytest.mark.parametrize("name", list(CONFIGS))
def test_boundary_states(name):
    """Edges the model shows to hit the ties of every compare (and the t < 0 clamp)."""
    config = CONFIGS[name]
    edges = boundary_edges(config, seed=1, tries=1500)
    hits = set().union(*(boundary_states(config, edge) for edge in edges))
    assert {"carry tie", "row step tie", "rounding tie"} <= hits or name == "truncated", hits
    if config.segments:
        assert {"above d = 0", "below d = 0", "borrow tie", "t > 0"} <= hits, hits
    if name == "lowfrac":
        rare = {"above 0 < d < 1", "below 0 < d < 1", "segment threshold tie"}
        assert rare | {"slope doubling tie"} <= hits, hits
    run_and_check(config, edges, label=f"boundary states {name}")


def run_of(config: EdgeConfig, x: int, y: int, columns: int, **kwargs) -> Edge:
    """An x-major edge of exactly `columns` columns starting at pixel centre (x, y)."""
    S = config.subpixel_scale
    x0, y0 = x * S, y * S
    x1 = x0 + max(1, (columns - 1) * S)  # one sub-pixel for a single column
    return Edge(x0, y0, x1, y0 + columns * S // 3, **kwargs)


@pytest.mark.parametrize("seed", [None, 12])
def test_handover(seed):
    """Mixed lengths around the setup interval P: the bank handover and the FINAL wait, clock
    for clock."""
    config = CONFIGS["default"]
    interval = timing_model.setup_interval(config)
    # After an edge longer than two setups the next bank waits for the stepper and the
    # setup after it waits in FINAL: a one-column edge then shows a late bank write.
    lengths = [100, 1, 2, 1, interval, interval - 1, 1, interval + 1, 1, 1, 120, 1, 1, 3]
    edges = [run_of(config, 10 + n, 20 + 3 * n, c, inside="right" if n % 3 else "left")
             for n, c in enumerate(lengths)]  # fmt: skip
    edges.insert(4, Edge(5, 5, 5, 5))  # a dropped command while the bank waits
    assert [setup(config, edge).columns for edge in edges if is_good(config, edge)] == lengths
    run_and_check(config, edges, seed=seed, idle=0.2, stall=0.3, label="handover")


# -- (5b) the clip window ---------------------------------------------------------------------


def clipped_corpus(config: EdgeConfig) -> list[Edge]:
    """Corner-case edges of at least three columns under directed windows: the start cut, the
    end cut, both, one column, wider than the edge, beyond either end, min > max, the minor
    axis only (which clips nothing); and one-column windows at both image borders."""
    top, S, hi = 1 << config.coord_bits, config.subpixel_scale, config.max_vertex
    names = ("octant", "vertical", "45deg", "225deg", "subpixel")
    edges = []
    for name, edge in corpus(config, longest=False):
        if not name.startswith(names) or not is_good(config, edge):
            continue
        columns = setup(config, edge).columns
        if columns < 3:
            continue
        mid = columns // 2
        for start, end in (
            (1, columns - 1),
            (0, columns - 2),
            (1, columns - 2),
            (columns - 1, columns - 1),
            (mid, mid),
            (-3, columns + 2),
            (columns, columns + 2),
            (-3, -1),
            (mid + 1, mid),
        ):
            edges.append(with_window(config, edge, start, end))
        edges.append(with_window(config, edge, -1, columns, minor=(1, 0)))
    reach = min(5 * S, hi)
    edges += [
        Edge(0, 0, reach, S // 2, clip=Clip(0, 0, 0, top)),  # column 0 only
        Edge(hi, hi, hi - reach, hi - S // 2, clip=Clip(top, 0, top, top)),  # column 2**W only
        Edge(hi, 0, hi - reach, 0, clip=Clip(top, 0, 0, top)),  # min > max at the extremes
        Edge(0, hi, S // 2, hi - reach, inside="right", clip=Clip(0, top, top, top)),
    ]
    return edges


def clip_classes(config: EdgeConfig, edges: list[Edge]) -> dict[str, int]:
    """How many good edges are start-clipped, end-clipped only, empty or not clipped."""
    out = {"start": 0, "end": 0, "empty": 0, "none": 0}
    for edge in edges:
        if not is_good(config, edge):
            continue
        clipped = setup(config, edge)
        full = setup(config, replace(edge, clip=None))
        if not clipped.columns:
            out["empty"] += 1
        elif clipped.clipped_start:
            out["start"] += 1
        elif clipped.columns < full.columns:
            out["end"] += 1
        else:
            out["none"] += 1
    return out


@pytest.mark.parametrize("name", ["default", "small", "lowfrac", "seg4", "wide"])
def test_clip_corpus(name):
    """Directed windows, back to back (each edge's window differs from the last): writes, bank,
    trace and beat clocks against the model and the timing model."""
    config = CONFIGS[name]
    edges = clipped_corpus(config)
    assert min(clip_classes(config, edges).values()) >= 4, clip_classes(config, edges)
    run_and_check(config, edges, label=f"clip corpus {name}")


# Lane A's first pass of a start-clipped edge needs a quotient of W + s + 2 bits: wider
# than the accumulator (I + F = 10 bits) in this configuration.
NARROW = EdgeConfig(coord_bits=4, subpixel_bits=8, intensity_bits=1)


@pytest.mark.parametrize("name", [*CONFIGS, "narrow"])
def test_clip_hypothesis(name):
    config = NARROW if name == "narrow" else CONFIGS[name]

    @sim_settings(5)
    @given(st.lists(edge_commands(config, 8, clip=True), min_size=5, max_size=12))
    def check(edges):
        run_and_check(config, edges, label=f"clip hypothesis {name}")

    check()


@pytest.mark.parametrize(("name", "seed"), [("default", 31), ("small", 32), ("seg2", 33)])
def test_clip_backpressure(name, seed):
    """Random windows, random source idle clocks and sink stalls, and a random value on the
    ``clip`` port whenever no edge is offered (the window is sampled with the edge only)."""
    config = CONFIGS[name]
    rng = random.Random(seed)
    edges = random_edges(config, rng, 16, 12, clip=True) + clipped_corpus(config)[::7]
    edges.insert(3, Edge(4, 4, 4, 4, clip=Clip(0, 0, 0, 0)))  # bad: an error, not "empty"
    classes = clip_classes(config, edges)
    assert min(classes.values()) >= 2, classes
    run_and_check(config, edges, seed=seed, idle=0.4, stall=0.5, label=f"clip stalls {name}")


def start_quotient(config: EdgeConfig, edge: Edge) -> int:
    """Lane A's first-pass quotient ``floor(2 |e| dv / du)`` for a visible edge, with
    ``e = first S - u0`` the offset of its first column's centre from P0 (folded)."""
    st_ = setup(config, edge)
    major, p0 = (st_.x, edge.x0) if st_.x_major else (st_.y, edge.y0)
    step = st_.col_dx or st_.col_dy
    e = step * major * config.subpixel_scale - step * p0
    return 2 * abs(e) * st_.dv // st_.du


@pytest.mark.parametrize("name", ["default", "narrow", "small", "wide"])
def test_clip_longest_start_offset(name):
    """Windows that keep only the last columns of the longest edges (diagonals, a row, a
    column; both directions): the start offset is almost the edge's length, so lane A's
    first-pass quotient is near its largest, about 2 dv < 2**(W + s + 2) (beyond the
    accumulator's width in the narrow configuration)."""
    config = NARROW if name == "narrow" else CONFIGS[name]
    W, s = config.coord_bits, config.subpixel_bits
    edges = []
    for edge in longest_edges(config):
        edges += [edge, replace(edge, x0=edge.x1, y0=edge.y1, x1=edge.x0, y1=edge.y0)]
    clipped = []
    for edge in edges:
        columns = setup(config, edge).columns
        for first, last in ((columns - 1, columns - 1), (columns - 3, columns - 1), (2, 4)):
            clipped.append(with_window(config, edge, first, last))
    quotients = [start_quotient(config, edge) for edge in clipped]
    assert max(quotients) >= 1 << (W + s), quotients
    if name == "narrow":
        assert max(quotients) >= 1 << (config.intensity_bits + config.F)
    run_and_check(config, clipped, label=f"longest start offset {name}")


def test_clip_latency():
    """Exact clocks: a start-clipped edge on an idle core has its first beat W + 1 clocks later
    than L; an end-clipped one at L; an edge with no column in its window occupies the setup
    for 5 clocks (the next command is accepted 5 clocks after it) and pulses no error."""
    config = CONFIGS["default"]
    W = config.coord_bits
    latency = timing_model.setup_latency(config)
    edge = run_of(config, 10, 20, 6)
    start_cut, end_cut = with_window(config, edge, 2, 5), with_window(config, edge, 0, 3)
    empty = with_window(config, edge, 7, 9)
    assert [setup(config, e).columns for e in (start_cut, end_cut, empty)] == [4, 4, 0]
    assert setup(config, start_cut).clipped_start and not setup(config, end_cut).clipped_start

    run = run_and_check(config, [start_cut], label="start-clipped latency")
    assert [clock for clock, _ in run.beats] == list(range(latency + W + 1, latency + W + 5))
    assert run.banks[0][1]["x"] == 12 and run.banks[0][1]["remaining"] == 3
    run = run_and_check(config, [end_cut], label="end-clipped latency")
    assert [clock for clock, _ in run.beats] == list(range(latency, latency + 4))

    bad = Edge(7, 7, 7, 7)
    run = run_and_check(config, [empty, bad, empty, edge], label="empty edge occupancy")
    assert run.accepts == [0, 5, 7, 12] and run.error_pulses == [7], run.accepts
    assert [clock for clock, _ in run.beats] == list(range(12 + latency, 12 + latency + 6))
    assert len(run.banks) == 1


# -- (6) bad commands ------------------------------------------------------------------------


def test_bad_commands_are_dropped_and_counted():
    config = CONFIGS["default"]
    good = Edge(100, 200, 260, 250, i_in=200, i_out=30)
    edges = [
        Edge(50, 50, 50, 50),  # zero length first, on an idle core
        good,
        Edge(7, 9, 7, 9, i_in=0, i_out=255),  # zero length
        Edge(10, 10, 90, 40, i_in=77, i_out=77),  # I_in == I_out
        Edge(10, 10, 90, 40, i_in=0, i_out=0),
        Edge(30, 40, 100, 10, inside="right"),
        Edge(config.max_vertex, 0, config.max_vertex, 0),
        good,
    ]
    run = run_and_check(config, edges, label="bad commands")
    assert run.errors == 5
    # Under back-pressure and source idling too.
    run_and_check(config, edges, seed=11, idle=0.5, stall=0.5, label="bad commands")


def test_errors_counter_saturates():
    config = CONFIGS["small"]
    dut = EdgeAntialiaser(config, errors_bits=2)
    bad = edge_payload(config, Edge(3, 3, 3, 3))
    seen = []

    async def bench(ctx):
        for _ in range(5):
            await stream_put(ctx, dut.edges, bad)
            seen.append(ctx.get(dut.errors))
        await ctx.tick().repeat(3)
        seen.append(ctx.get(dut.errors))
        assert ctx.get(dut.writes.valid) == 0

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    assert seen[-1] == 3, seen
    assert seen == sorted(seen)


# -- (7) throughput --------------------------------------------------------------------------


@pytest.mark.parametrize(("name", "length"), [("default", "P"), ("wide", "P"), ("default", "20L")])
def test_throughput(name, length):
    """Edges of at least P (the setup interval) columns leave back to back: one column per
    clock.

    Two streams: many edges of exactly P columns (the shortest that hide the next setup) and
    three edges of 20 L columns each. (The small configuration cannot get there: its longest
    edge has 17 columns, P = 18.)
    """
    config = CONFIGS[name]
    latency = timing_model.setup_latency(config)
    S = config.subpixel_scale
    hi = config.max_vertex
    columns = timing_model.setup_interval(config) if length == "P" else 20 * latency
    count = max(3, 20 * latency // columns + 1)  # the whole stream >= 20 setup latencies
    rng = random.Random(3)
    edges = []
    for n in range(count):
        dy = rng.randint(-(columns - 1) * S, (columns - 1) * S)
        x0 = rng.randint(0, max(0, S // 2 - 1))  # keeps the column count exactly `columns`
        y0 = rng.randint(max(0, -dy), min(hi, hi - dy))
        edge = Edge(x0, y0, x0 + (columns - 1) * S, y0 + dy, i_in=n % 2 * config.full_scale)
        edges.append(edge if n % 2 else Edge(edge.x1, edge.y1, edge.x0, edge.y0, "right"))
    assert {setup(config, edge).columns for edge in edges} == {columns}
    run = run_and_check(config, edges, label=f"throughput {name}")
    clocks = [clock for clock, _ in run.beats]
    assert clocks == timing_model.beat_cycles(config, edges)  # (also checked in run_and_check)
    total = len(clocks)
    assert total >= 19 * latency
    # Steady state: no gap between edges, exactly as predicted.
    assert clocks == list(range(latency, latency + total))
    assert timing_model.sustained_rate(config, columns) == 1
    # The whole stream from clock 0, latency included.
    rate = total / (clocks[-1] + 1)
    timings = timing_model.write_cycles(config, edges)
    assert rate == timing_model.stream_rate(timings) == total / (latency + total) >= 0.95, rate


def test_timing_model_basics():
    config = CONFIGS["default"]
    latency = timing_model.setup_latency(config)
    edge = run_of(config, 3, 4, 5)
    bad = Edge(1, 1, 1, 1)
    assert timing_model.beat_cycles(config, [edge]) == list(range(latency, latency + 5))
    shifted = timing_model.write_cycles(config, [bad, bad, edge])
    assert [t.accepted for t in shifted] == [0, 2, 4]
    assert shifted[-1].beats == tuple(range(latency + 4, latency + 9))
    interval = timing_model.setup_interval(config)
    assert timing_model.sustained_rate(config, 10) == 10 / interval
    assert timing_model.sustained_rate(config, interval) == 1
    assert timing_model.sustained_rate(config, 10, latency) == 10 / interval


def test_short_edges_are_setup_bound():
    config = CONFIGS["default"]
    interval = timing_model.setup_interval(config)
    edges = [Edge(16 * n, 100, 16 * n + 16 * 9, 130 + n) for n in range(8)]  # 10 columns
    run = run_and_check(config, edges, label="short edges")
    starts = [clock for clock, beat in run.beats if beat["last"]]
    assert all(b - a == interval for a, b in zip(starts, starts[1:], strict=False)), starts
    assert timing_model.sustained_rate(config, 10) == 10 / interval


# -- (8) no multiplier or divider in the stepping loop ---------------------------------------


@pytest.mark.parametrize("name", list(CONFIGS))
def test_stepper_has_no_multiplier_or_divider(name):
    assert muldiv_cells(EdgeStepper(CONFIGS[name])) == {}


def test_setup_uses_bit_serial_units():
    # Not a requirement (the setup may multiply), but the design has no $mul/$div at all.
    assert muldiv_cells(EdgeAntialiaser(CONFIGS["seg4"])) == {}


# -- Verilog ---------------------------------------------------------------------------------


def test_verilog_ports():
    text = verilog(CONFIGS["default"])
    header = re.search(r"module edgeaa_core\((.*?)\);", text, re.S).group(1)
    ports = {port.strip() for port in header.split(",")}
    assert ports == {
        "clk",
        "rst",
        "edges__valid",
        "edges__ready",
        *(f"edges__payload__{name}" for name in ("x0", "y0", "x1", "y1", "i_in", "i_out")),
        "edges__payload__inside",
        "writes__valid",
        "writes__ready",
        *(f"writes__payload__{lane}__{name}" for lane in ("lane0", "lane1") for name in "xy"),
        "writes__payload__lane0__value",
        "writes__payload__lane1__value",
        "writes__payload__lane1_valid",
        "writes__payload__last",
        *(f"clip__{name}" for name in ("x_min", "y_min", "x_max", "y_max")),
        "errors",
        "error",
    }
    assert "input [14:0] edges__payload__x0;" in text
    assert "input [11:0] clip__x_max;" in text
    assert "output [12:0] writes__payload__lane1__y;" in text


@pytest.mark.parametrize("name", ["default", "seg4", "small"])
def test_verilog_lints(name):
    """verilator --lint-only -Wall, with only the documented waivers of sim/verilator.py."""
    proc = lint(verilog(CONFIGS[name]))
    assert proc.returncode == 0, proc.stdout + proc.stderr


# -- slow sweeps (pytest -m slow) ------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("name", list(CONFIGS))
def test_longest_edges_slow(name):
    config = CONFIGS[name]
    run_and_check(config, longest_edges(config), label=f"longest {name}")


@pytest.mark.slow
@pytest.mark.parametrize("name", [name for name in CONFIGS if name != "wide"])
def test_random_long_edges_slow(name):
    config = CONFIGS[name]
    rng = random.Random(20)
    edges = random_edges(config, rng, 12, 1 << config.coord_bits)
    run_and_check(config, edges, label=f"random long {name}")
    run_and_check(config, edges, seed=21, idle=0.3, stall=0.4, label=f"random long {name}")


@pytest.mark.slow
@pytest.mark.parametrize("name", list(CONFIGS))
def test_hypothesis_edges_slow(name):
    config = CONFIGS[name]

    @sim_settings(25)
    @given(st.lists(edge_commands(config, 40), min_size=10, max_size=30), st.integers(0, 2**32))
    def check(edges, seed):
        run_and_check(config, edges, label=f"hypothesis {name}")
        run_and_check(config, edges, seed=seed, idle=0.4, stall=0.4, label=f"hypothesis {name}")

    check()


@pytest.mark.slow
@pytest.mark.parametrize("name", list(CONFIGS))
def test_setup_matches_model_slow(name):
    config = CONFIGS[name]

    @sim_settings(40)
    @given(st.lists(edge_commands(config, 1 << config.coord_bits), min_size=10, max_size=20))
    def check(edges):
        check_setup(config, edges)

    check()
