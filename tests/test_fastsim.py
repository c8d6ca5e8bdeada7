"""The compiled Verilator harness: bit-exact beats, and beat clocks equal to the timing model."""

import pytest

from edgeaa.model import EdgeConfig
from edgeaa.model.timing import write_cycles
from edgeaa.sim import fastsim
from edgeaa.sim.scoreboard import expected_beats
from edgeaa.sim.workloads import random_edges

DEFAULT = EdgeConfig()


def test_beats_equal_the_model_under_stalls_and_idles():
    seed = 11
    edges = random_edges(DEFAULT, 2000, seed, max_pixels=200, bad_fraction=0.01)
    expected, dropped = expected_beats(DEFAULT, edges)
    run = fastsim.run(DEFAULT, edges, seed=seed, idle=0.1, stall=0.3)
    assert run.errors == dropped > 0, f"seed {seed}"
    beats = run.as_beats()
    assert len(beats) == len(expected), f"seed {seed}: lost or duplicated beats"
    for i, (got, want) in enumerate(zip(beats, expected, strict=True)):
        assert got == want, f"seed {seed}: beat {i} is {got}, the model says {want}"


@pytest.mark.parametrize(
    "config",
    [DEFAULT, EdgeConfig(mode="seg4", accumulator="truncated", coord_bits=15, subpixel_bits=8)],
    ids=["default", "seg4-truncated-wide"],
)
def test_every_beat_leaves_in_the_clock_the_timing_model_predicts(config):
    seed = 12
    edges = random_edges(config, 300, seed, max_pixels=120, bad_fraction=0.02)
    run = fastsim.run(config, edges)
    predicted = [clock for timing in write_cycles(config, edges) for clock in timing.beats]
    assert run.beats[:, 0].tolist() == predicted, f"seed {seed}"
    assert run.as_beats() == expected_beats(config, edges)[0], f"seed {seed}"


def test_a_wrong_model_is_caught(monkeypatch):
    """The comparison can fail: change the model's neighbour test and the beats differ."""
    import edgeaa.model.step as step

    edges = random_edges(DEFAULT, 50, seed=13)
    run = fastsim.run(DEFAULT, edges)
    monkeypatch.setattr(step, "exit_depth_below", lambda st, jq, jr, reg: (0, False))
    assert run.as_beats() != expected_beats(DEFAULT, edges)[0]


def test_bad_probabilities_are_rejected():
    with pytest.raises(ValueError, match=r"stall must be a probability in \[0, 1\)"):
        fastsim.run(DEFAULT, [], stall=1.0)


def test_python_and_compiled_simulators_agree_clock_for_clock():
    from edgeaa.sim import amaranth_run

    seed = 14
    edges = random_edges(DEFAULT, 20, seed, max_pixels=24, bad_fraction=0.1)
    slow, fast = amaranth_run.run(DEFAULT, edges), fastsim.run(DEFAULT, edges)
    assert slow.beats.tolist() == fast.beats.tolist(), f"seed {seed}"
    assert slow.errors == fast.errors == expected_beats(DEFAULT, edges)[1], f"seed {seed}"
    assert slow.as_beats() == expected_beats(DEFAULT, edges)[0], f"seed {seed}"
