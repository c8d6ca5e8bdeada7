# amaranth: UnusedElaboratable=no
"""The core's beats against the model (`check_run`): the corpus, hypothesis edges,
back-pressure, the boundary states of the loop and the bank handover.
"""

from __future__ import annotations

import random

import pytest
from core_bench import (
    corpus,
    is_good,
    longest_edges,
    run_and_check,
    run_of,
    sim_settings,
)
from fixtures import CORE_CONFIGS, core_config_params, edge_commands, random_edge_commands
from hypothesis import given
from hypothesis import strategies as st

from edgeaa.model import Edge, EdgeConfig, run_edge, setup
from edgeaa.model import timing as timing_model


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
    for edge in random_edge_commands(config, rng, tries, 6):
        if not is_good(config, edge):
            continue
        new = [hit for hit in boundary_states(config, edge) if found.get(hit, 0) < per_class]
        if new:
            chosen.append(edge)
            for hit in boundary_states(config, edge):
                found[hit] = found.get(hit, 0) + 1
    return chosen


# -- (3)-(5) equivalence with run_edge, trace and timing --------------------------------------


@pytest.mark.parametrize("name", core_config_params())
def test_corpus(name):
    """Every corner case in one run: writes, bank, trace and beat clocks against the model."""
    config = CORE_CONFIGS[name]
    cases = corpus(config, longest=name != "wide")
    run_and_check(config, [edge for _, edge in cases], label=f"corpus {name}")


@pytest.mark.parametrize("name", core_config_params())
def test_hypothesis_edges(name):
    config = CORE_CONFIGS[name]

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
    config = CORE_CONFIGS[name]
    rng = random.Random(seed)
    edges = [edge for _, edge in corpus(config, longest=False)]
    edges = (
        random_edge_commands(config, rng, 10, 24)
        + edges[::3]
        + random_edge_commands(config, rng, 10, 3)
    )
    edges.insert(5, Edge(4, 4, 4, 4))  # a bad command in the middle of the stream
    run_and_check(config, edges, seed=seed, idle=idle, stall=stall, label=f"backpressure {name}")


@pytest.mark.parametrize("name", core_config_params())
def test_boundary_states(name):
    """Edges the model shows to hit the ties of every compare (and the t < 0 clamp)."""
    config = CORE_CONFIGS[name]
    edges = boundary_edges(config, seed=1, tries=1500)
    hits = set().union(*(boundary_states(config, edge) for edge in edges))
    assert {"carry tie", "row step tie", "rounding tie"} <= hits or name == "truncated", hits
    if config.segments:
        assert {"above d = 0", "below d = 0", "borrow tie", "t > 0"} <= hits, hits
    if name == "lowfrac":
        rare = {"above 0 < d < 1", "below 0 < d < 1", "segment threshold tie"}
        assert rare | {"slope doubling tie"} <= hits, hits
    run_and_check(config, edges, label=f"boundary states {name}")


@pytest.mark.parametrize("seed", [None, 12])
def test_handover(seed):
    """Mixed lengths around the setup interval P: the bank handover and the FINAL wait, clock
    for clock."""
    config = CORE_CONFIGS["default"]
    interval = timing_model.setup_interval(config)
    # After an edge longer than two setups the next bank waits for the stepper and the
    # setup after it waits in FINAL: a one-column edge then shows a late bank write.
    lengths = [100, 1, 2, 1, interval, interval - 1, 1, interval + 1, 1, 1, 120, 1, 1, 3]
    edges = [run_of(config, 10 + n, 20 + 3 * n, c, inside="right" if n % 3 else "left")
             for n, c in enumerate(lengths)]  # fmt: skip
    edges.insert(4, Edge(5, 5, 5, 5))  # a dropped command while the bank waits
    assert [setup(config, edge).columns for edge in edges if is_good(config, edge)] == lengths
    run_and_check(config, edges, seed=seed, idle=0.2, stall=0.3, label="handover")


# -- slow sweeps (pytest -m slow) ------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("name", core_config_params())
def test_longest_edges_slow(name):
    config = CORE_CONFIGS[name]
    run_and_check(config, longest_edges(config), label=f"longest {name}")


@pytest.mark.slow
@pytest.mark.parametrize("name", [name for name in CORE_CONFIGS if name != "wide"])
def test_random_long_edges_slow(name):
    config = CORE_CONFIGS[name]
    rng = random.Random(20)
    edges = random_edge_commands(config, rng, 12, 1 << config.coord_bits)
    run_and_check(config, edges, label=f"random long {name}")
    run_and_check(config, edges, seed=21, idle=0.3, stall=0.4, label=f"random long {name}")


@pytest.mark.slow
@pytest.mark.parametrize("name", core_config_params())
def test_hypothesis_edges_slow(name):
    config = CORE_CONFIGS[name]

    @sim_settings(25)
    @given(st.lists(edge_commands(config, 40), min_size=10, max_size=30), st.integers(0, 2**32))
    def check(edges, seed):
        run_and_check(config, edges, label=f"hypothesis {name}")
        run_and_check(config, edges, seed=seed, idle=0.4, stall=0.4, label=f"hypothesis {name}")

    check()
