# amaranth: UnusedElaboratable=no
"""The setup's bank handed to the stepper against the model's `setup()` (each edge's
setup simulated alone, the core reset between edges).
"""

from __future__ import annotations

import pytest
from amaranth.hdl import Module, ResetInserter, Signal, Value
from amaranth.sim import Simulator
from core_bench import (
    corpus,
    decoder,
    expected_bank,
    is_visible,
    longest_edges,
    sim_settings,
)
from fixtures import CORE_CONFIGS, core_config_params, edge_commands
from hypothesis import given
from hypothesis import strategies as st

from edgeaa.hdl import (
    LineCore,
    PolygonCore,
)
from edgeaa.model import Edge, EdgeConfig
from edgeaa.model.beat import DELTAS_FAST
from edgeaa.sim.simulators.commands import edge_clip, edge_payload

# -- (2) setup registers against setup() -----------------------------------------------------


def fast_core(config: EdgeConfig) -> PolygonCore:
    """The fast pipeline's core: its setup's lanes take two steps a clock (radix 4)."""
    return PolygonCore(config, fmt=DELTAS_FAST)


def simulate_setup(config: EdgeConfig, edges: list[Edge], core=LineCore) -> list[dict | None]:
    """The bank each edge's setup produces (None: dropped, or no column in the window),
    resetting the core between edges so that long edges cost only their setup time.
    `core`: the core's class, or a function of the configuration that builds it."""
    dut = core(config)
    flush = Signal()
    top = Module()
    top.submodules.dut = ResetInserter(flush)(dut)
    decode_bank = decoder(dut.stepper.setup.payload.shape())
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


def check_setup(config: EdgeConfig, edges: list[Edge], core=LineCore):
    pieces = core is not LineCore  # the polygon core's bank carries the end pieces
    for edge, bank in zip(edges, simulate_setup(config, edges, core), strict=True):
        if not is_visible(config, edge):
            assert bank is None, f"{edge} (bad, or nothing in its window) produced a bank"
            continue
        want = expected_bank(config, edge, pieces)
        assert bank == want, (
            f"{config} {edge}: bank differs from setup(): "
            f"{ {k: (bank[k], want[k]) for k in want if bank[k] != want[k]} }"
        )


@pytest.mark.parametrize("name", core_config_params())
def test_setup_matches_model(name):
    config = CORE_CONFIGS[name]
    max_pixels = 1 << config.coord_bits  # full-range edges: only the setup is simulated

    @sim_settings(5)
    @given(st.lists(edge_commands(config, max_pixels), min_size=8, max_size=12))
    def check(edges):
        check_setup(config, edges)

    check()


def test_setup_corner_cases():
    for config in CORE_CONFIGS.values():
        check_setup(config, [edge for _, edge in corpus(config)] + longest_edges(config))


@pytest.mark.parametrize("name", core_config_params())
def test_radix4_setup_matches_model(name):
    """The fast core's setup, two lane steps a clock (`edgeaa.model.timing.run_schedule`:
    leading zero steps, a short first pass or a last |I_d| clock of one step in some
    configurations), gives `setup()`'s bank with the end pieces, start-clipped edges too."""
    config = CORE_CONFIGS[name]

    @sim_settings(5)
    @given(st.lists(edge_commands(config, 1 << config.coord_bits), min_size=8, max_size=12))
    def check(edges):
        check_setup(config, edges, fast_core)

    check()
    check_setup(config, [edge for _, edge in corpus(config)] + longest_edges(config), fast_core)


@pytest.mark.slow
@pytest.mark.parametrize("name", core_config_params())
def test_setup_matches_model_slow(name):
    config = CORE_CONFIGS[name]

    @sim_settings(40)
    @given(st.lists(edge_commands(config, 1 << config.coord_bits), min_size=10, max_size=20))
    def check(edges):
        check_setup(config, edges)

    check()
