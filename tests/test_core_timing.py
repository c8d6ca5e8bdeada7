# amaranth: UnusedElaboratable=no
"""The core's clocks: the setup latency against the timing model, throughput, short
edges; bad commands dropped and counted, and the error counter.
"""

from __future__ import annotations

import random

import pytest
from amaranth.sim import Simulator
from core_bench import (
    run_and_check,
    run_of,
)
from fixtures import CORE_CONFIGS, core_config_params, edge_configs
from hypothesis import given

from edgeaa.hdl import (
    LineCore,
    PolygonCore,
)
from edgeaa.model import Edge, setup
from edgeaa.model import timing as timing_model
from edgeaa.model.beat import DELTAS, DELTAS_FAST, WRITES
from edgeaa.sim.simulators.commands import edge_payload
from edgeaa.sim.simulators.streams import stream_put


@pytest.mark.parametrize("name", core_config_params())
def test_setup_latency_is_the_timing_model(name):
    config = CORE_CONFIGS[name]
    dut = LineCore(config)
    depth = timing_model.pipeline_depth(config)
    assert dut.stepper.latency == depth == (2 if config.segments <= 1 else 3)
    assert dut.setup_latency == timing_model.setup_latency(config)
    assert dut.setup_latency == config.intensity_bits + config.F + 6 + depth
    assert dut.run_cycles == timing_model.run_cycles(config) == config.intensity_bits + config.F + 1
    assert dut.setup_units == timing_model.DEFAULT_SETUP_UNITS
    assert timing_model.setup_interval(config) == dut.setup_interval
    nine = LineCore(config, setup_units=9)
    assert nine.setup_interval == timing_model.setup_interval(config, 9)
    assert nine.setup_interval == -(-(dut.run_cycles + 5) // 9)
    assert timing_model.setup_interval(config, 1) == dut.run_cycles + 4
    assert LineCore(config, setup_units=1).setup_interval == dut.run_cycles + 4
    assert dut.start_clip_cycles == timing_model.start_clip_cycles(config) == config.coord_bits + 1
    assert timing_model.run_cycles(config, True) == dut.run_cycles + dut.start_clip_cycles


@pytest.mark.parametrize("name", core_config_params())
def test_deltas_setup_latency_is_the_timing_model(name):
    """The deltas core's setup spends ``ceil((s + 2) / 2)`` clocks in FINAL (the y-major
    total0 product, two bits of w0 a clock): latency and interval grow by that less one over
    the line core's FINAL clock; its beats' clocks are checked against the model in
    tests/test_core_deltas.py."""
    config = CORE_CONFIGS[name]
    s, R = config.subpixel_bits, timing_model.run_cycles(config)
    dut = PolygonCore(config)
    final = timing_model.final_cycles(config, DELTAS)
    assert dut.setup.final_cycles == final == -(-(s + 2) // 2)
    assert timing_model.final_cycles(config) == LineCore(config).setup.final_cycles == 1
    depth = timing_model.pipeline_depth(config, DELTAS)
    assert dut.stepper.latency == depth == 4  # p1, p2, p3, the output register
    # The fast core: the same depth and a FINAL of two clocks (by a multiplier).
    fast = PolygonCore(config, fmt=DELTAS_FAST)
    assert fast.stepper.latency == timing_model.pipeline_depth(config, DELTAS_FAST) == 4
    assert fast.setup.final_cycles == timing_model.final_cycles(config, DELTAS_FAST) == 2
    # the format says which (with s <= 2 the serial product takes two clocks too)
    assert fast.setup.pieces.multiplier and not dut.setup.pieces.multiplier
    with pytest.raises(TypeError, match="fmt must be DELTAS or DELTAS_FAST"):
        PolygonCore(config, fmt=WRITES)
    # ... and two lane steps a clock: RUN about half as long (`run_schedule`)
    fast_run = timing_model.run_cycles(config, fmt=DELTAS_FAST)
    assert fast.run_cycles == fast_run == timing_model.run_schedule(config, 2, pieces=True).run
    assert fast_run <= -(-R // 2) + 3  # two pads, a single step and a tail at most
    fewer = final - 2 + R - fast_run  # FINAL by a multiplier, and RUN's clocks
    assert fast.setup_latency == dut.setup_latency - fewer
    assert fast.setup_interval == dut.setup_interval - fewer == fast_run + 5
    assert fast.start_clip_cycles == timing_model.start_clip_cycles(config, DELTAS_FAST)
    extra = config.coord_bits + 1  # W + 1 bits more, two a clock
    assert extra // 2 <= fast.start_clip_cycles <= -(-extra // 2)
    if name == "default":  # docs/hardware.md, "Two lane steps a clock"
        assert (fast_run, fast.start_clip_cycles, fast.setup_latency) == (11, 6, 21)
    assert dut.setup_latency == timing_model.setup_latency(config, DELTAS)
    assert dut.setup_latency == config.intensity_bits + config.F + 5 + final + depth
    assert dut.setup_interval == timing_model.setup_interval(config, 1, DELTAS) == R + 3 + final
    nine = PolygonCore(config, setup_units=9)
    assert nine.setup_interval == timing_model.setup_interval(config, 9, DELTAS)
    assert nine.setup_interval == -(-(R + 4 + final) // 9)
    assert timing_model.unit_cycles(config, 1, DELTAS) == dut.setup_interval
    rate = timing_model.sustained_rate(config, 10, fmt=DELTAS)
    assert rate == timing_model.sustained_rate(config, 10, dut.setup_latency, DELTAS)
    assert rate == 10 / (10 + dut.setup_interval)  # the setup and the stepping take turns


@given(edge_configs())
def test_run_schedule_covers_every_bit(config):
    """`run_schedule`: one step a clock is the bit-serial RUN (I + F + 1 clocks, W + 1 more
    when start-clipped; with the end pieces one more when F = s + 1); at two, every pass's
    clocks take exactly its leading zeros and its bits (the short first pass and the
    products by |I_d| one step less in their last clock where flagged), and kq and the
    products are complete before RUN's last clock."""
    W, s, F, I = config.coord_bits, config.subpixel_bits, config.F, config.intensity_bits  # noqa: E741
    lines = timing_model.run_schedule(config, 1)  # the line core's: no end pieces
    assert (lines.run, lines.start_clip, lines.tail) == (I + F + 1, W + 1, 0)
    one = timing_model.run_schedule(config, 1, pieces=True)
    tail = int(s + 1 == F)  # pass 2 is |I_d|'s bits alone: the products end in its last clock
    assert (one.run, one.start_clip, one.tail) == (I + F + 1 + tail, W + 1, tail)
    assert (one.pass1_pad, one.pass2_pad, one.lane_b_pad) == (0, 0, 0)
    two = timing_model.run_schedule(config, 2, pieces=True)
    assert two.pass1_long * 2 == two.pass1_pad + W + s + 2
    assert two.pass1 * 2 - two.pass1_single == two.pass1_pad + s + 1
    assert two.pass2 * 2 == two.pass2_pad + I + F - s - 1
    assert two.id_clocks * 2 - two.id_single == two.pass2_pad + I
    assert two.lane_b * 2 == two.lane_b_pad + I + F - 1
    assert max(two.pass1_pad, two.pass2_pad, two.lane_b_pad) <= 1
    assert two.lane_b + 1 <= two.run - 1  # kq registered, then RUN's last clock reads it
    assert two.id_clocks < two.pass2 + two.tail  # the products by |I_d| too
    assert two.run <= -(-one.run // 2) + 3  # two pads, a single step and a tail at most
    with pytest.raises(ValueError, match="1 or 2"):
        timing_model.run_schedule(config, 4)


# -- (6) bad commands ------------------------------------------------------------------------


def test_bad_commands_are_dropped_and_counted():
    config = CORE_CONFIGS["default"]
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
    config = CORE_CONFIGS["small"]
    dut = LineCore(config, errors_bits=2)
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
    config = CORE_CONFIGS[name]
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
    config = CORE_CONFIGS["default"]
    latency = timing_model.setup_latency(config)
    edge = run_of(config, 3, 4, 5)
    bad = Edge(1, 1, 1, 1)
    for units in (1, timing_model.DEFAULT_SETUP_UNITS):
        beats = timing_model.beat_cycles(config, [edge], setup_units=units)
        assert beats == list(range(latency, latency + 5))
    shifted = timing_model.write_cycles(config, [bad, bad, edge], setup_units=1)
    assert [t.accepted for t in shifted] == [0, 2, 4]
    assert shifted[-1].beats == tuple(range(latency + 4, latency + 9))
    # Several units: one command per clock while units are free; a bad one retires when its
    # unit is back in IDLE (two clocks after its accept), then the collector moves on.
    shifted = timing_model.write_cycles(config, [bad, bad, edge], setup_units=9)
    assert [t.accepted for t in shifted] == [0, 1, 2]
    assert shifted[-1].beats == tuple(range(latency + 2, latency + 7))
    interval = timing_model.setup_interval(config, 1)
    assert timing_model.sustained_rate(config, 10, setup_units=1) == 10 / interval
    assert timing_model.sustained_rate(config, interval, setup_units=1) == 1
    assert timing_model.sustained_rate(config, 10, latency, setup_units=1) == 10 / interval
    per_unit = timing_model.run_cycles(config) + 5
    assert timing_model.sustained_rate(config, 1, latency, setup_units=9) == 9 / per_unit
    assert timing_model.sustained_rate(config, 1, setup_units=9) == 9 / per_unit
    assert timing_model.sustained_rate(config, 4, setup_units=9) == 1


@pytest.mark.parametrize("units", [1, 9])
def test_short_edges_are_setup_bound(units):
    """Edges shorter than the setup interval: one unit takes R + 4 clocks per edge; nine
    units take R + 5 clocks per nine edges (one edge every 3 clocks by default)."""
    config = CORE_CONFIGS["default"]
    interval = timing_model.setup_interval(config, units)
    columns = 10 if units == 1 else 1
    edges = [run_of(config, 3 + n, 100 + n, columns) for n in range(30)]
    run = run_and_check(config, edges, label="short edges", setup_units=units)
    starts = [clock for clock, beat in run.beats if beat["last"]]
    gaps = [b - a for a, b in zip(starts, starts[1:], strict=False)]
    if units == 1:
        assert set(gaps) == {interval}, gaps
    else:  # nine edges (a burst, one a clock) every R + 5 clocks: 25 / 9 <= 3 clocks each
        per_unit = timing_model.run_cycles(config) + 5
        assert [starts[n + 9] - starts[n] for n in range(len(starts) - 9)] == [per_unit] * 21
        assert per_unit / units <= interval == 3, gaps
    assert timing_model.sustained_rate(config, columns, setup_units=units) == min(
        1, columns * units / timing_model.unit_cycles(config, units)
    )
