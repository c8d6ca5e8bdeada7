"""The compiled Verilator harness: bit-exact beats, and beat clocks equal to the timing model."""

import dataclasses

import numpy as np
import pytest

from edgeaa.model import Clip, Edge, EdgeConfig, EdgeError, setup
from edgeaa.model.beat import edge_columns
from edgeaa.model.timing import (
    DEFAULT_SETUP_UNITS,
    EMPTY_EDGE_CYCLES,
    beat_cycles,
    setup_latency,
    start_clip_cycles,
    write_cycles,
)
from edgeaa.model.vector import run_edges
from edgeaa.render.engines import beat_clocks, beats_to_writes, run_engine
from edgeaa.sim.simulators import amaranth_sim, verilator_harness
from edgeaa.sim.simulators.commands import COMMAND_FIELDS
from edgeaa.sim.verification.scoreboard import beats_to_array, expected_beats
from edgeaa.sim.verification.workloads import random_sim_edges

DEFAULT = EdgeConfig()
WIDE = EdgeConfig(mode="seg4", accumulator="truncated", coord_bits=15, subpixel_bits=8)
TINY = EdgeConfig(mode="seg2", accumulator="truncated", coord_bits=4, subpixel_bits=0)


def assert_beats_match_under_stalls(edges, seed: int, config=DEFAULT) -> None:
    """The compiled core under random idles and stalls gives the model's beats, in order, and
    counts exactly the bad commands (an empty clip window is not one). The harness itself
    checks that a stalled beat holds (`edgeaa.sim.simulators.harness.UnstableBeat`)."""
    expected, dropped = expected_beats(config, edges)
    run = verilator_harness.run(config, edges, seed=seed, idle=0.1, stall=0.3)
    assert run.errors == dropped > 0, f"seed {seed}"
    beats = run.as_beats()
    assert len(beats) == len(expected), f"seed {seed}: lost or duplicated beats"
    for i, (got, want) in enumerate(zip(beats, expected, strict=True)):
        assert got == want, f"seed {seed}: beat {i} is {got}, the model says {want}"


def test_beats_equal_the_model_under_stalls_and_idles():
    seed = 11
    edges = random_sim_edges(DEFAULT, 2000, seed, max_pixels=200, bad_fraction=0.01)
    assert_beats_match_under_stalls(edges, seed)


@pytest.mark.parametrize("config", [DEFAULT, WIDE], ids=["default", "seg4-truncated-wide"])
def test_every_beat_leaves_in_the_clock_the_timing_model_predicts(config):
    seed = 12
    edges = random_sim_edges(config, 300, seed, max_pixels=120, bad_fraction=0.02)
    run = verilator_harness.run(config, edges)
    predicted = [clock for timing in write_cycles(config, edges) for clock in timing.beats]
    assert run.beats[:, 0].tolist() == predicted, f"seed {seed}"
    assert run.as_beats() == expected_beats(config, edges)[0], f"seed {seed}"


def test_a_wrong_model_is_caught(monkeypatch):
    """The comparison can fail: change the model's neighbour test and the beats differ."""
    import edgeaa.model.column as column

    edges = random_sim_edges(DEFAULT, 50, seed=13)
    run = verilator_harness.run(DEFAULT, edges)
    original = column.exit_depths

    def never_below(a, st, jq, jr):
        depths = original(a, st, jq, jr)
        return {**depths, "below": depths["below"] & False}

    monkeypatch.setattr(column, "exit_depths", never_below)
    assert run.as_beats() != expected_beats(DEFAULT, edges)[0]


def test_bad_probabilities_are_rejected():
    with pytest.raises(ValueError, match=r"stall must be a probability in \[0, 1\)"):
        verilator_harness.run(DEFAULT, [], stall=1.0)


def test_python_and_compiled_simulators_agree_clock_for_clock():
    seed = 14
    edges = random_sim_edges(DEFAULT, 20, seed, max_pixels=24, bad_fraction=0.1)
    slow, fast = amaranth_sim.run(DEFAULT, edges), verilator_harness.run(DEFAULT, edges)
    assert slow.beats.tolist() == fast.beats.tolist(), f"seed {seed}"
    assert slow.errors == fast.errors == expected_beats(DEFAULT, edges)[1], f"seed {seed}"
    assert slow.as_beats() == expected_beats(DEFAULT, edges)[0], f"seed {seed}"


# -- the clip window --------------------------------------------------------------------------


def clip_mix(config, edges):
    """How many edges are bad, hold no column in their window, or have their start clipped."""
    counts = {"bad": 0, "empty": 0, "start": 0}
    for edge in edges:
        try:
            st = setup(config, edge)
        except EdgeError:
            counts["bad"] += 1
            continue
        counts["empty"] += st.columns == 0
        counts["start"] += st.clipped_start
    return counts


def test_clipped_beats_equal_the_model_under_stalls_and_idles():
    seed = 21
    edges = random_sim_edges(
        DEFAULT, 2000, seed, max_pixels=200, bad_fraction=0.01, clip_fraction=0.7
    )
    assert min(clip_mix(DEFAULT, edges).values()) > 10, f"seed {seed}: a weak mix"
    assert_beats_match_under_stalls(edges, seed)


def test_clipped_beats_of_a_tiny_configuration_under_stalls():
    """4 coordinate bits, no sub-pixel bits, seg2 and truncated: windows cut most edges."""
    seed = 2027
    edges = random_sim_edges(TINY, 400, seed, bad_fraction=0.02, clip_fraction=0.7)
    assert min(clip_mix(TINY, edges).values()) > 3, f"seed {seed}: a weak mix"
    assert_beats_match_under_stalls(edges, seed, TINY)


@pytest.mark.slow
@pytest.mark.parametrize(
    "config, count",
    [(DEFAULT, 100_000), (EdgeConfig(mode="pw", coord_bits=15, subpixel_bits=8), 2_000)],
    ids=["default", "pw-wide"],
)
def test_many_edges_under_stalls(config, count):
    seed = 100_000
    edges = random_sim_edges(config, count, seed, bad_fraction=0.02, clip_fraction=0.2)
    assert_beats_match_under_stalls(edges, seed, config)


@pytest.mark.parametrize("max_pixels", [120, 16], ids=["stepper-bound", "setup-bound"])
@pytest.mark.parametrize("config", [DEFAULT, WIDE], ids=["default", "seg4-truncated-wide"])
def test_clipped_beats_leave_in_the_clock_the_timing_model_predicts(config, max_pixels):
    """Start-clipped edges take the long setup pass; empty ones leave the setup early: with
    short edges (setup-bound) both show in the beat clocks."""
    seed = 22
    edges = random_sim_edges(
        config, 300, seed, max_pixels=max_pixels, bad_fraction=0.02, clip_fraction=0.6
    )
    assert min(clip_mix(config, edges).values()) > 3, f"seed {seed}: a weak mix"
    run = verilator_harness.run(config, edges)
    predicted = [clock for timing in write_cycles(config, edges) for clock in timing.beats]
    assert run.beats[:, 0].tolist() == predicted, f"seed {seed}"
    assert run.as_beats() == expected_beats(config, edges)[0], f"seed {seed}"


@pytest.mark.parametrize("config", [DEFAULT, WIDE], ids=["default", "seg4-truncated-wide"])
def test_a_start_clipped_last_edge_is_waited_for(config):
    """The run ends after a quiet spell: it must outlast the long setup of a start-clipped
    edge (W + 1 clocks over the latency), also after empty edges and with nothing before."""
    s = config.subpixel_scale
    top = 1 << config.coord_bits
    edge = Edge(2 * s, 3 * s, 30 * s, 9 * s, clip=Clip(20, 0, top, top))  # columns 20 .. 30
    empty = Edge(2 * s, 3 * s, 30 * s, 9 * s, clip=Clip(31, 0, top, top))
    for edges in ([edge], [edge, empty, empty], [empty, edge], [empty]):
        run = verilator_harness.run(config, edges)
        expected = expected_beats(config, edges)[0]
        assert run.as_beats() == expected
        assert run.beats[:, 0].tolist() == beat_cycles(config, edges)
    # After an empty edge (accepted in clock 0, gone from its unit in 5 clocks; with several
    # units the edge goes to the next one in clock 1):
    after = EMPTY_EDGE_CYCLES if DEFAULT_SETUP_UNITS == 1 else 1
    first = after + setup_latency(config) + start_clip_cycles(config)
    assert verilator_harness.run(config, [empty, edge]).beats[0, 0] == first


def test_python_and_compiled_simulators_agree_on_clipped_edges():
    seed = 23
    edges = random_sim_edges(DEFAULT, 30, seed, max_pixels=24, bad_fraction=0.1, clip_fraction=0.8)
    assert all(clip_mix(DEFAULT, edges).values()), f"seed {seed}: a weak mix"
    slow, fast = amaranth_sim.run(DEFAULT, edges), verilator_harness.run(DEFAULT, edges)
    assert slow.beats.tolist() == fast.beats.tolist(), f"seed {seed}"
    assert slow.errors == fast.errors == expected_beats(DEFAULT, edges)[1], f"seed {seed}"
    assert slow.beats[:, 0].tolist() == beat_cycles(DEFAULT, edges), f"seed {seed}"
    assert slow.as_beats() == expected_beats(DEFAULT, edges)[0], f"seed {seed}"


def test_clip_windows_reach_the_command_file():
    """Each row carries the edge's window after its payload; None is the full window."""
    top = 1 << DEFAULT.coord_bits
    edges = [Edge(0, 0, 64, 16), Edge(0, 0, 64, 16, inside="right", clip=Clip(1, 2, 3, 4))]
    rows = verilator_harness.edge_commands(DEFAULT, edges)
    assert rows.shape == (2, len(COMMAND_FIELDS)) == (2, 11)
    assert rows[0].tolist() == [0, 0, 64, 16, DEFAULT.full_scale, 0, 0, 0, 0, top, top]
    assert rows[1, -5:].tolist() == [1, 1, 2, 3, 4]


def test_a_window_the_port_cannot_carry_is_refused():
    top = 1 << DEFAULT.coord_bits
    with pytest.raises(EdgeError, match="clip x_max"):
        verilator_harness.edge_commands(
            DEFAULT, [Edge(0, 0, 64, 16, clip=Clip(0, 0, top + 1, top))]
        )


# -- the renderer's engine glue ---------------------------------------------------------------


def test_beats_to_writes_skips_edges_without_columns():
    """Edges with no column in their window end no beat; writes keep the sent edge's index."""
    seed = 24
    top = 1 << DEFAULT.coord_bits
    edges = random_sim_edges(DEFAULT, 200, seed, clip_fraction=0.8)
    edges[-1] = dataclasses.replace(edges[-1], clip=Clip(top, top, 0, 0))  # the last is empty
    columns = edge_columns(DEFAULT, edges)
    assert (columns == 0).sum() > 10 and columns[0] == 0 and columns[-1] == 0, "a weak mix"
    expected = beats_to_array(expected_beats(DEFAULT, edges)[0])
    beats = np.hstack([np.zeros((len(expected), 1), dtype=np.int64), expected])  # clock 0
    edge_index, x, y, value = beats_to_writes(beats, columns)
    model = run_edges(DEFAULT, edges)
    for got, want in zip((edge_index, x, y, value), (model.edge_index, model.x, model.y,
                                                     model.value), strict=True):  # fmt: skip
        assert np.array_equal(got, want), f"seed {seed}"
    with pytest.raises(RuntimeError, match="ended"):
        beats_to_writes(beats, np.append(columns, 3))
    moved = beats.copy()
    first_end = int(np.flatnonzero(moved[:, 8])[0])
    moved[[first_end, first_end + 1], 8] = moved[[first_end + 1, first_end], 8]
    with pytest.raises(RuntimeError, match="do not end the edges"):
        beats_to_writes(moved, columns)


@pytest.mark.parametrize("engine", ["verilator", "amaranth"])
def test_engines_give_the_model_writes_for_clipped_edges(engine):
    """run_engine's edge_index counts every edge sent, also those that end no beat."""
    seed = 25
    top = 1 << DEFAULT.coord_bits
    edges = random_sim_edges(DEFAULT, 200 if engine == "verilator" else 12, seed, clip_fraction=0.7)
    edges[-1] = dataclasses.replace(edges[-1], clip=Clip(top, top, 0, 0))  # the last is empty
    model, sim = run_engine(DEFAULT, edges, "model"), run_engine(DEFAULT, edges, engine)
    for field in ("edge_index", "x", "y", "value"):
        assert np.array_equal(getattr(sim, field), getattr(model, field)), f"seed {seed} {field}"
    assert np.array_equal(sim.beat_clocks, beat_clocks(DEFAULT, edges)), f"seed {seed}"
