# amaranth: UnusedElaboratable=no
"""The polygon core (``PolygonCore(config)``) against the model's
`run_edge_deltas`, beat for beat: the four cells of every column and the last flags, the bank
(the end pieces included) against `setup()`, bad commands dropped and counted, and with an
eager source and an always-ready sink every beat's clock against `edgeaa.model.timing`
(of `DELTAS`). In Amaranth's simulator (`simulate`, here) and in the compiled
Verilator harness, with random source idles and sink stalls (a stalled beat must hold).
"""

from __future__ import annotations

import random

import pytest
from core_bench import (
    Run,
    check_clocks,
    check_outputs,
    corpus,
    drive,
    first_difference,
    is_good,
    run_of,
    sim_settings,
)
from fixtures import CORE_CONFIGS, core_config_params, edge_commands, random_edge_commands
from hypothesis import given
from hypothesis import strategies as st

from edgeaa.hdl import (
    DeltaStepper,
    LineCore,
    PolygonCore,
    core_verilog,
    delta_layout,
)
from edgeaa.model import Edge, EdgeConfig, setup
from edgeaa.model import timing as timing_model
from edgeaa.model.beat import (
    CELLS,
    DELTAS,
    DELTAS_FAST,
    WRITES,
    DeltaBeat,
    delta_column_beats,
)
from edgeaa.model.step import run_edge_deltas
from edgeaa.sim.simulators import amaranth_sim, verilator_harness
from edgeaa.sim.simulators.amaranth_runner import decoder
from edgeaa.sim.simulators.verilator_harness import drain_clocks
from edgeaa.sim.synthesis import muldiv_cells
from edgeaa.sim.verification.workloads import random_sim_edges


def expected_deltas(config: EdgeConfig, edges) -> list[list[DeltaBeat]]:
    """The model's delta beats of each good edge (bad commands have none)."""
    return [
        delta_column_beats(run_edge_deltas(config, edge)) for edge in edges if is_good(config, edge)
    ]


# -- the Amaranth runner ---------------------------------------------------------------------


def _as_beat(beat: dict) -> DeltaBeat:
    cells = tuple(tuple(beat[f"{cell}.{name}"] for name in ("x", "y", "delta")) for cell in CELLS)
    return DeltaBeat(cells, bool(beat["last"]), beat["nonzero"])


def simulate(
    config, edges, *, seed=None, idle=0.0, stall=0.0, label="", setup_units=None, fmt=DELTAS
) -> Run:
    """Offer `edges` in order (each with its window on ``clip``) and drain the deltas as
    `DeltaBeat`s (`core_bench.drive`); with `seed`, random idle source clocks, sink stalls
    and clip windows between the edges; `setup_units` and `fmt` (its depth and FINAL) the
    core's."""
    units = timing_model.DEFAULT_SETUP_UNITS if setup_units is None else setup_units
    dut = PolygonCore(config, setup_units=units, fmt=fmt)
    depth = fmt.pipeline_depth(config)
    tag = f"[{label} seed={seed} idle={idle} stall={stall} units={units} depth={depth} {config}]"
    run = Run(config, list(edges), tag, dut.setup_latency, setup_units=units, fmt=fmt)
    fields = decoder(delta_layout(config))
    drain = drain_clocks(config, fmt)
    return drive(dut, run, decode=lambda raw: _as_beat(fields(raw)), drain=drain,
                 seed=seed, idle=idle, stall=stall)  # fmt: skip


def check_run(run: Run, *, exact_timing: bool) -> None:
    config, tag = run.config, run.label
    got = [beat for _, beat in run.beats]
    check_outputs(run, got, expected_deltas(config, run.edges), pieces=True)
    if not exact_timing:
        return
    fmt = run.fmt
    timings = timing_model.write_cycles(config, run.edges, fmt=fmt, setup_units=run.setup_units)
    check_clocks(run, timings)
    # The stepper takes the bank in the clock it steps the edge's last column (`live_bank`:
    # edge done), or copies it as it loads it.
    depth = timing_model.pipeline_depth(config, fmt)
    good = [t for t in timings if not t.dropped]
    taken = [t.beats[-1] - depth if fmt.live_bank else t.load for t in good]
    assert [clock for clock, _ in run.banks] == taken, f"{tag} bank transfer clocks"


def run_and_check(config, edges, *, seed=None, idle=0.0, stall=0.0, label="", **core):
    """`simulate` and check the deltas (and, without `seed`, every clock); `core`: the
    core's ``setup_units`` and ``fmt``."""
    run = simulate(config, edges, seed=seed, idle=idle, stall=stall, label=label, **core)
    check_run(run, exact_timing=seed is None)
    return run


# -- edge sets ---------------------------------------------------------------------------------


def kinds(config: EdgeConfig, edges) -> set[str]:
    """What the edges exercise: octants, partial and cut end columns, single columns."""
    out = set()
    for edge in edges:
        if not is_good(config, edge):
            out.add("bad")
            continue
        st_ = setup(config, edge)
        p = st_.pieces
        if not st_.columns:
            out.add("empty window")
            continue
        out.add(f"octant {st_.x_major:d}{st_.col_dx + st_.col_dy:+d}{st_.row_dx + st_.row_dy:+d}")
        out.add("start cut" if not p.first_partial else "first partial")
        out.add("end cut" if not p.last_partial else "last partial")
        if st_.columns == 1 and p.first_partial and p.last_partial:
            out.add("single column")
        out.add(f"sigma {p.sigma:+d}")
    return out


def mixed_edges(config: EdgeConfig, seed: int, count: int = 24) -> list[Edge]:
    """The corner corpus (every octant, sub-pixel starts and ends, image corners) and random
    edges with clip windows near them, short and longer, with a bad command among them."""
    rng = random.Random(seed)
    edges = [edge for _, edge in corpus(config, longest=False)]
    edges += random_edge_commands(config, rng, count, 3, clip=True)
    edges += random_edge_commands(config, rng, count // 2, 20, clip=True)
    edges.insert(7, Edge(4, 4, 4, 4))  # a bad command: dropped and counted
    return edges


# -- Amaranth simulator ------------------------------------------------------------------------


@pytest.mark.parametrize("name", core_config_params())
def test_corpus_and_clipped_edges(name):
    """Every octant, sub-pixel ends, clip windows: the model's deltas, bank and clocks."""
    config = CORE_CONFIGS[name]
    edges = mixed_edges(config, seed=1)
    octants = {kind for kind in kinds(config, edges) if kind.startswith("octant")}
    assert len(octants) == 8, octants
    want = {"start cut", "end cut", "first partial", "last partial", "sigma +1", "sigma -1"}
    assert want | {"bad", "empty window"} <= kinds(config, edges)
    run_and_check(config, edges, label=f"corpus {name}")


# F = s + 1: lane A's second pass is |I_d|'s bits alone, so the products by |I_d| would end
# in RUN's last clock, which reads them (RUN takes a tail clock: `run_schedule`).
NO_SPARE_FRACTION = EdgeConfig(coord_bits=2, subpixel_bits=5, intensity_bits=1)


@pytest.mark.parametrize("fmt", [DELTAS, DELTAS_FAST])
def test_no_spare_fraction_bit(fmt):
    """The end pieces where the products by |I_d| fill pass 2 (F = s + 1; before RUN's tail
    clock the deltas core's banks differed from the model's here): deltas, banks, clocks."""
    config = NO_SPARE_FRACTION
    assert config.subpixel_bits + 1 == config.F
    assert timing_model.run_schedule(config, fmt.lane_steps, pieces=True).tail >= 1
    edges = random_edge_commands(config, random.Random(0), 30, 1 << config.coord_bits)
    run_and_check(config, edges, label="F = s + 1", fmt=fmt)


BACKPRESSURE = [
    ("default", 1, 0.5, 0.5),
    ("default", 2, 0.0, 0.8),
    ("pw", 3, 0.3, 0.6),
    ("seg4", 4, 0.3, 0.6),
    ("truncated", 5, 0.5, 0.5),
    ("small", 6, 0.5, 0.5),
    ("wide", 7, 0.3, 0.3),
    ("lowfrac", 8, 0.2, 0.7),
]


@pytest.mark.parametrize(("name", "seed", "idle", "stall"), BACKPRESSURE)
def test_backpressure(name, seed, idle, stall):
    """Random source idles and sink stalls: the same deltas, none lost or duplicated."""
    config = CORE_CONFIGS[name]
    edges = mixed_edges(config, seed=seed, count=16)
    run_and_check(config, edges, seed=seed, idle=idle, stall=stall, label=f"stalls {name}")


@pytest.mark.parametrize("name", ["default", "seg2", "small", "lowfrac"])
def test_hypothesis_edges(name):
    config = CORE_CONFIGS[name]

    @sim_settings(5)
    @given(st.lists(edge_commands(config, 6, clip=True), min_size=4, max_size=12))
    def check(edges):
        run_and_check(config, edges, label=f"hypothesis {name}")

    check()


def test_single_columns():
    """Edges inside one column (both vertices in it): P1's row one above, on or below the
    first column's, and the one-column total of both end pieces."""
    config = CORE_CONFIGS["default"]
    rng = random.Random(5)
    S, hi = config.subpixel_scale, config.max_vertex
    edges = []
    while len(edges) < 40:
        x0, y0 = rng.randint(S, hi - S), rng.randint(S, hi - S)
        dx, dy = rng.randint(-S + 1, S - 1), rng.randint(-S + 1, S - 1)
        edge = Edge(x0, y0, x0 + dx, y0 + dy, rng.choice(("left", "right")), None, 0)
        if is_good(config, edge) and setup(config, edge).columns == 1:
            edges.append(edge)
    assert "single column" in kinds(config, edges)
    run_and_check(config, edges, label="single columns")
    run_and_check(config, edges, seed=9, idle=0.3, stall=0.5, label="single columns")


def test_handover():
    """Edge lengths around the setup interval: the stepper takes the bank in the clock it
    steps the edge's last column (whose pieces are still in the pipeline when the next edge
    starts), and the setup accepts the next command then."""
    config = CORE_CONFIGS["seg4"]
    interval = timing_model.setup_interval(config, fmt=DELTAS)
    lengths = [60, 1, 2, 1, interval, interval - 1, 1, interval + 1, 1, 1, 3]
    edges = [
        run_of(config, 10 + n, 20 + 3 * n, c, inside="right" if n % 3 else "left")
        for n, c in enumerate(lengths)
    ]
    run_and_check(config, edges, label="handover")
    run_and_check(config, edges, seed=3, idle=0.2, stall=0.3, label="handover")


@pytest.mark.parametrize("units", [1, 3])
def test_setup_and_stepping_take_turns(units):
    """Equal edges of C columns: the setup works on the next edge only once the stepper has
    taken the bank (edge done), so one unit gives one edge per C + P clocks; the hardware's
    spacing is `sustained_rate`'s."""
    config = CORE_CONFIGS["default"]
    columns = 5
    edges = [run_of(config, 10 + n, 20 + n, columns) for n in range(4 * units + 2)]
    run = run_and_check(config, edges, label="take turns", setup_units=units)
    firsts = [clock for clock, _ in run.beats][::columns]
    spacing = firsts[-1] - firsts[-1 - units]  # one round of the units, in steady state
    rate = timing_model.sustained_rate(config, columns, fmt=DELTAS, setup_units=units)
    assert rate == columns * units / spacing
    if units == 1:
        assert spacing == columns + timing_model.setup_interval(config, fmt=DELTAS)


@pytest.mark.parametrize("units", [2, 3])
def test_setup_array(units):
    """A deltas core with a `SetupArray`: the collector shows one unit's bank until the
    stepper takes it (edge done), so the payload it reads holds; the model's deltas and
    every clock (`schedule` with ``setup_units``), short edges included, and under stalls."""
    config = CORE_CONFIGS["default"]
    edges = mixed_edges(config, seed=20 + units, count=12)
    edges += [run_of(config, 10 + n, 20 + 3 * n, 1 + n % 3) for n in range(8)]
    run_and_check(config, edges, label="array", setup_units=units)
    run_and_check(config, edges, seed=units, idle=0.2, stall=0.5, label="array", setup_units=units)


@pytest.mark.parametrize(("name", "units"), [("default", 1), ("small", 4)])
def test_fast_core(name, units):
    """The fast core (`DELTAS_FAST`, the fast pipeline's: p3 between p2 and the output
    register, FINAL's product by a multiplier in two clocks): the same deltas and banks,
    every clock the timing model's; and under stalls."""
    config = CORE_CONFIGS[name]
    edges = mixed_edges(config, seed=40 + units, count=16)
    core = {"setup_units": units, "fmt": DELTAS_FAST}
    run_and_check(config, edges, label="fast core", **core)
    run_and_check(config, edges, seed=units, idle=0.2, stall=0.5, label="fast core", **core)


def test_a_wrong_model_is_caught(monkeypatch):
    """The comparison can fail: with one cell of the model's deltas changed, it does."""
    import edgeaa.model.step as step

    config = CORE_CONFIGS["default"]
    edges = mixed_edges(config, seed=2, count=4)
    run = simulate(config, edges)
    original = step.delta_cells

    def shifted(a, st_, x, y, d):
        cells = original(a, st_, x, y, d)
        return [(cx, cy + 1, v) if k == 3 else (cx, cy, v) for k, (cx, cy, v) in enumerate(cells)]

    monkeypatch.setattr(step, "delta_cells", shifted)
    with pytest.raises(AssertionError, match="beats differ from the model"):
        check_run(run, exact_timing=True)


# -- structure ---------------------------------------------------------------------------------


@pytest.mark.parametrize("name", core_config_params())
def test_deltas_stepper_has_no_multiplier(name):
    assert muldiv_cells(DeltaStepper(CORE_CONFIGS[name])) == {}


def _mul_widths(design) -> list[tuple[int, int]]:
    """(A_WIDTH, B_WIDTH) of every $mul cell of `design`'s RTLIL."""
    import re

    from amaranth.back import rtlil

    text = rtlil.convert(design)
    cells = re.findall(r"cell \$mul .*?\n(.*?)\n\s*end", text, flags=re.S)
    widths = []
    for body in cells:
        a = int(re.search(r"parameter \\A_WIDTH (\d+)", body)[1])
        widths.append((a, int(re.search(r"parameter \\B_WIDTH (\d+)", body)[1])))
    return widths


@pytest.mark.parametrize("name", ["default", "small", "wide"])
def test_deltas_setup_has_no_wide_product(name):
    """The products by kq and by |I_d| are shift-adds over the lanes' clocks, the y-major
    first area (the height sum times the first piece's width) one over FINAL's clocks
    (`edgeaa.hdl.pieces`): every $mul left has both factors of sub-pixel bits."""
    from edgeaa.hdl.pieces import EndPieces
    from edgeaa.hdl.setup import EdgeSetupUnit

    config = CORE_CONFIGS[name]
    widths = _mul_widths(EdgeSetupUnit(config, pieces=EndPieces(config)))
    small = config.subpixel_bits + 3
    assert widths and all(max(a, b) <= small for a, b in widths), widths
    assert len(widths) <= 5, widths
    # The fast core's (a DSP block each): one more, FINAL's height sum by the first piece's
    # width (s + 2 bits); and the x-major first rectangle's max(-h0, 0) mg formed at RUN's
    # end from |I_d| max(-h0, 0) = max(-id_h0, 0) (I + s + 3 bits) by mg's half, instead of
    # max(-h0, 0) by it before RUN's Horner steps
    fast = _mul_widths(EdgeSetupUnit(config, pieces=EndPieces(config, multiplier=True)))
    wide = sorted(set(fast) - set(widths), key=min)
    s, i = config.subpixel_bits, config.intensity_bits
    assert len(fast) == len(widths) + 1 and len(wide) == 2, fast
    assert wide[0] == (i + s + 3, max(s, 1)), wide
    assert min(wide[1]) == s + 2 and max(wide[1]) > small, wide


def test_the_line_core_keeps_its_bank():
    """The end pieces are in the polygon core's bank only: each core's bank stream carries
    its format's fields."""
    config = CORE_CONFIGS["default"]
    writes = {f.name for f in WRITES.bank_fields(config)}
    deltas = {f.name for f in DELTAS.bank_fields(config)}
    assert writes < deltas and not writes & {"hs0", "sigma", "total0"}
    for top, names in ((LineCore, writes), (PolygonCore, deltas)):
        layout = top(config).setup.bank.payload.shape()
        assert {str(name) for name, _ in layout} == names, top


@pytest.mark.parametrize("name", ["default", "seg4", pytest.param("small", marks=pytest.mark.slow)])
def test_verilog_lints(name):
    """verilator --lint-only -Wall with the documented waivers, like the writes core."""
    from edgeaa.sim.simulators.verilator import lint

    text = core_verilog(PolygonCore(CORE_CONFIGS[name]))
    assert "deltas__payload__cell3__delta" in text and "writes__valid" not in text
    proc = lint(text)
    assert proc.returncode == 0, proc.stdout + proc.stderr


# -- the compiled Verilator harness and the Python simulator ------------------------------------


def _flat(config, edges):
    return [beat for beats in expected_deltas(config, edges) for beat in beats]


@pytest.mark.parametrize("name", ["default", "pw", "seg4", "wide", "lowfrac"])
def test_compiled_harness(name):
    """The compiled core: the model's deltas with stalls and idles, and without them every
    beat in the clock the timing model predicts."""
    config = CORE_CONFIGS[name]
    seed = 30
    edges = random_sim_edges(config, 300, seed, max_pixels=40, bad_fraction=0.02, clip_fraction=0.4)
    want = _flat(config, edges)
    run = verilator_harness.run(config, edges, top=PolygonCore)
    assert run.as_beats() == want, f"seed {seed}: beat {first_difference(run.as_beats(), want)}"
    predicted = timing_model.beat_cycles(config, edges, fmt=DELTAS)
    assert run.beats[:, 0].tolist() == predicted
    stalled = verilator_harness.run(config, edges, seed=seed, idle=0.2, stall=0.4, top=PolygonCore)
    assert stalled.as_beats() == want, f"seed {seed}: lost, duplicated or wrong beats"
    assert stalled.errors == run.errors == len(edges) - sum(is_good(config, e) for e in edges)


def test_python_and_compiled_simulators_agree_clock_for_clock():
    config = CORE_CONFIGS["seg4"]  # built for test_compiled_harness too
    edges = random_sim_edges(config, 20, 31, max_pixels=24, bad_fraction=0.1, clip_fraction=0.5)
    slow = amaranth_sim.run(config, edges, top=PolygonCore)
    fast = verilator_harness.run(config, edges, top=PolygonCore)
    assert slow.beats.tolist() == fast.beats.tolist()
    assert slow.as_beats() == _flat(config, edges)


@pytest.mark.slow
@pytest.mark.parametrize("name", core_config_params())
def test_long_edges_compiled_slow(name):
    """Edges over the whole coordinate range (the longest of the corpus among them), with and
    without back-pressure, in the compiled core."""
    config = CORE_CONFIGS[name]
    edges = [edge for _, edge in corpus(config)]
    edges += random_sim_edges(config, 200, 40, max_pixels=1 << config.coord_bits, clip_fraction=0.3)
    want = _flat(config, edges)
    run = verilator_harness.run(config, edges, top=PolygonCore)
    assert run.as_beats() == want
    assert run.beats[:, 0].tolist() == timing_model.beat_cycles(config, edges, fmt=DELTAS)
    stalled = verilator_harness.run(config, edges, seed=41, idle=0.3, stall=0.5, top=PolygonCore)
    assert stalled.as_beats() == want
