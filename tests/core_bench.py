# amaranth: UnusedElaboratable=no
"""The test bench of the hardware core (tests/test_core_*.py): the simulation runner, the
checks of a run against the model, and the edge corpora.

The tests check the core against the model: interface, setup, per-column trace, timing,
streams.

Amaranth simulator, async testbenches only. Every simulation run is checked the same way
(`check_run`): the ordered beats equal `run_edge` (lanes, values, last flags), the setup bank
handed to the stepper equals `setup()`, bad commands are dropped and counted, edges with no
column in their clip window leave nothing (no bank, no error), and the sink is empty at the
end. Each command is offered with its window on the ``clip`` port
(`edgeaa.sim.simulators.commands`).
Runs with an always-ready sink and a back-to-back source additionally match the stepper's
registers to the model's per-column trace and every beat's clock to `edgeaa.model.timing`.
The stepper's scaled areas are compared with the model's `Write.area` too, so a tie decided
differently inside the loop shows even when the rounded value hides it.

The runner (`simulate`, and `drive` which the deltas core's tests share) is a configuration
of the one Amaranth driver (`edgeaa.sim.simulators.amaranth_sim.run_core`) with probes on the
setup bank, the error pulse and the stepper's registers;
`edgeaa.sim.simulators.streams` serves the small directed tests. The core simulates at
2-4k clocks/s, so edges are short and many of them share one run; long sweeps are marked
slow (``pytest -m slow``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from amaranth.hdl import Value
from hypothesis import HealthCheck, Phase, settings

from edgeaa.hdl import (
    LineCore,
    write_layout,
)
from edgeaa.hdl.core import ERRORS_BITS
from edgeaa.model import Clip, Edge, EdgeConfig, EdgeError, run_edge, setup
from edgeaa.model import timing as timing_model
from edgeaa.model.bank import bank_values
from edgeaa.model.beat import WRITES, BeatFormat
from edgeaa.sim.simulators.amaranth_runner import Probe, decoder
from edgeaa.sim.simulators.amaranth_sim import run_core
from edgeaa.sim.simulators.verilator_harness import drain_clocks
from edgeaa.sim.verification.scoreboard import Beat, edge_beats


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
    setup_units: int = timing_model.DEFAULT_SETUP_UNITS
    fmt: BeatFormat = WRITES  # the core's output (its depth and FINAL's clocks)
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
    setup_units: int = timing_model.DEFAULT_SETUP_UNITS,
) -> Run:
    """Offer `edges` in order (each with its window on ``clip``) and drain the writes; with
    `seed`, random idle source clocks (probability `idle` before each offer), random sink
    stalls (`stall`) and a random window on ``clip`` whenever no edge is offered. Observes
    the stepper's registers and areas besides the bank and the error pulses."""
    dut = LineCore(config, setup_units=setup_units)
    stepper = dut.stepper
    tag = f"[{label} seed={seed} idle={idle} stall={stall} config={config}"
    label = f"{tag} setup_units={setup_units}]"
    run = Run(config, list(edges), label, dut.setup_latency, setup_units=setup_units)

    def registers(clock, step, x, y, jq, jr, area_step, area0, area1):
        if step:
            run.steps.append((clock, x, y, jq, jr))
        if area_step:
            run.areas.append((clock, area0, area1))

    signals = (stepper.step, stepper.x, stepper.y, stepper.jq, stepper.jr)
    signals += (stepper.area_step, stepper.area0, stepper.area1)
    decode = decoder(write_layout(config))
    probe = Probe(signals, registers)
    drain = drain_clocks(config)
    return drive(dut, run, decode=decode, drain=drain, seed=seed, idle=idle,
                 stall=stall, probes=(probe,))  # fmt: skip


def drive(dut, run: Run, *, decode, drain, seed, idle, stall, probes=()) -> Run:
    """`run.edges` through the core `dut` (`amaranth_sim.run_core`) into `run`: the beats of
    its output stream, the clock of each accept, each bank the stepper takes, each error
    pulse, the error count and the idle state at the end; `probes` observe more."""
    stepper = dut.stepper
    decode_bank = decoder(stepper.setup.payload.shape())

    def bank_and_error(clock, valid, ready, raw, error):
        if valid and ready:
            run.banks.append((clock, decode_bank(raw)))
        if error:
            run.error_pulses.append(clock)

    bank = (stepper.setup.valid, stepper.setup.ready, Value.cast(stepper.setup.payload))
    out, sink = dut.out, dut.format.stream
    # The core is idle at the end: nothing in the output register, the bank, the stepper.
    idle_signals = (out.valid, stepper.setup.valid, stepper.active, dut.edges.ready)
    trace = run_core(
        dut, run.config, run.edges, sink, decode=decode, drain=drain, seed=seed, idle=idle,
        stall=stall, probes=(Probe((*bank, dut.error), bank_and_error), *probes),
        final=(dut.errors, *idle_signals), tag=run.label,
    )  # fmt: skip
    (run.accepts,), (run.beats,), run.clocks = trace.accepts, trace.beats, trace.clocks
    run.errors, *final_idle = trace.final
    run.final_idle = tuple(final_idle)
    return run


# -- checks ----------------------------------------------------------------------------------


def expected_beats(config: EdgeConfig, edge: Edge) -> list[Beat]:
    """The model's writes of one edge as two-lane beats (the shared scoreboard's form)."""
    return edge_beats(run_edge(config, edge))


def observed_beat(beat: dict) -> Beat:
    lane1 = (beat["lane1.x"], beat["lane1.y"], beat["lane1.value"]) if beat["lane1_valid"] else None
    return Beat((beat["lane0.x"], beat["lane0.y"], beat["lane0.value"]), lane1, bool(beat["last"]))


def expected_bank(config: EdgeConfig, edge: Edge, pieces: bool = False) -> dict[str, int]:
    """The bank `setup()` gives the edge (with the end pieces: the polygon core's), keyed like
    `decoder` keys the core's bank (array elements as ``name.j``)."""
    bank = {}
    for name, value in bank_values(config, setup(config, edge), pieces).items():
        if isinstance(value, tuple):
            bank.update({f"{name}.{j}": item for j, item in enumerate(value)})
        else:
            bank[name] = value
    return bank


def first_difference(got: list, want: list) -> int | None:
    for index, (a, b) in enumerate(zip(got, want, strict=False)):
        if a != b:
            return index
    return None if len(got) == len(want) else min(len(got), len(want))


def check_outputs(run: Run, got: list, want: list[list], *, pieces: bool = False) -> None:
    """What both cores owe the model, timing aside: `got` (the run's beats, decoded) is the
    concatenation of `want` (the model's beats of each good edge, in order); the bank handed
    to the stepper is `setup()`'s for each edge with a visible column (`pieces`: the polygon
    core's bank); bad commands are dropped and counted, one error pulse each (an edge with
    no column in its window is not an error); every command is accepted and the core ends
    idle."""
    config, tag = run.config, run.label
    good = [edge for edge in run.edges if is_good(config, edge)]
    position = 0
    for n, (edge, edge_want) in enumerate(zip(good, want, strict=True)):
        edge_got = got[position : position + len(edge_want)]
        assert edge_got == edge_want, (
            f"{tag} good edge {n} {edge}: beats differ from the model "
            f"(first difference at column {first_difference(edge_got, edge_want)})"
        )
        position += len(edge_want)
    assert len(got) == position, f"{tag} {len(got)} beats, the model has {position}"
    visible = [edge for edge in good if setup(config, edge).columns]  # the others: no bank
    assert len(run.banks) == len(visible), f"{tag} {len(run.banks)} banks, {len(visible)} edges"
    for n, (edge, (_, bank)) in enumerate(zip(visible, run.banks, strict=True)):
        want_bank = expected_bank(config, edge, pieces)
        assert bank == want_bank, (
            f"{tag} visible edge {n} {edge}: bank differs from setup() (core, model): "
            f"{ {k: (bank[k], want_bank[k]) for k in bank if bank[k] != want_bank[k]} }"
        )
    bad = len(run.edges) - len(good)
    assert run.errors == min(bad, (1 << ERRORS_BITS) - 1), f"{tag} errors={run.errors}"
    assert len(run.error_pulses) == bad, f"{tag} error pulses {run.error_pulses}"
    assert len(run.accepts) == len(run.edges), f"{tag} accepted {len(run.accepts)} commands"
    assert run.final_idle == (0, 0, 0, 1), f"{tag} not idle at the end: {run.final_idle}"


def check_clocks(run: Run, timings: list) -> list[int]:
    """The accept and beat clocks equal the timing model's `timings` (`write_cycles` of the
    run's edges, always-ready sink and eager source); returns the beat clocks."""
    tag = run.label
    assert run.accepts == [t.accepted for t in timings], f"{tag} accept clocks"
    want_clocks = [clock for t in timings for clock in t.beats]
    got_clocks = [clock for clock, _ in run.beats]
    assert got_clocks == want_clocks, (
        f"{tag} beat clocks differ from the timing model; first at beat "
        f"{first_difference(got_clocks, want_clocks)}"
    )
    return want_clocks


def check_run(run: Run, *, exact_timing: bool) -> None:
    """All checks of one line core run; `exact_timing` for an always-ready sink and eager
    source."""
    config, tag = run.config, run.label
    good = [edge for edge in run.edges if is_good(config, edge)]
    got = [observed_beat(beat) for _, beat in run.beats]
    check_outputs(run, got, [expected_beats(config, edge) for edge in good])

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
    timings = timing_model.write_cycles(
        config, run.edges, run.setup_latency, setup_units=run.setup_units
    )
    want_clocks = check_clocks(run, timings)
    depth = timing_model.pipeline_depth(config)  # clocks from a column's step to its beat
    assert [clock for clock, *_ in run.steps] == [c - depth for c in want_clocks], f"{tag} steps"
    assert [clock for clock, *_ in run.areas] == [c - 1 for c in want_clocks], f"{tag} areas"
    assert [clock for clock, _ in run.banks] == [t.load for t in timings if not t.dropped]
    want_errors = [t.accepted + 2 for t in timings if not is_good(config, t.edge)]
    assert run.error_pulses == want_errors, f"{tag} error pulse clocks"


def run_and_check(config, edges, *, seed=None, idle=0.0, stall=0.0, label="", setup_units=None):
    units = timing_model.DEFAULT_SETUP_UNITS if setup_units is None else setup_units
    run = simulate(config, edges, seed=seed, idle=idle, stall=stall, label=label, setup_units=units)
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


def sim_settings(max_examples: int) -> settings:
    """Few examples (each one is a simulation), no deadline, no example database."""
    return settings(
        max_examples=max_examples,
        deadline=None,
        database=None,
        phases=(Phase.explicit, Phase.generate),  # no shrinking: it re-runs simulations
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )


def run_of(config: EdgeConfig, x: int, y: int, columns: int, **kwargs) -> Edge:
    """An x-major edge of exactly `columns` columns starting at pixel centre (x, y)."""
    S = config.subpixel_scale
    x0, y0 = x * S, y * S
    x1 = x0 + max(1, (columns - 1) * S)  # one sub-pixel for a single column
    return Edge(x0, y0, x1, y0 + columns * S // 3, **kwargs)
