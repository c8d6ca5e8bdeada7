# amaranth: UnusedElaboratable=no
"""Several setup units (`edgeaa.hdl.dispatch.SetupArray`): banks and beats equal the model's
in command order, every clock equals the timing model's (`schedule` with ``setup_units``),
no beat lost or duplicated under random back-pressure, and the checks can fail.
"""

from __future__ import annotations

import random

import pytest
from core_bench import check_run, run_and_check, run_of, sim_settings, simulate
from fixtures import CORE_CONFIGS, edge_commands, random_edge_commands
from hypothesis import given
from hypothesis import strategies as st

from edgeaa.hdl import LineCore
from edgeaa.hdl.dispatch import SetupArray
from edgeaa.model import Clip, Edge, setup
from edgeaa.model import timing as timing_model
from edgeaa.model.timing import MAX_SETUP_UNITS

UNITS = (2, 3, timing_model.DEFAULT_SETUP_UNITS)


def mixed_stream(config, seed: int, count: int) -> list[Edge]:
    """Short (1 to 4 columns) and long edges, bad commands and clipped ones, shuffled."""
    rng = random.Random(seed)
    edges = random_edge_commands(config, rng, count, 4, clip=True)
    edges += random_edge_commands(config, rng, count // 4, 60)
    edges += [Edge(5, 5, 5, 5), Edge(10, 10, 90, 40, i_in=7, i_out=7)]  # bad commands
    rng.shuffle(edges)
    return edges


@pytest.mark.parametrize("units", UNITS)
@pytest.mark.parametrize("name", ["default", "seg4", "small", "wide"])
def test_random_streams_clock_exact(name, units):
    """Banks, beats, error pulses and every clock, on short and long edges (seed printed in
    the label of any failure)."""
    config = CORE_CONFIGS[name]
    seed = 100 + units
    edges = mixed_stream(config, seed, 24)
    run_and_check(config, edges, label=f"mixed seed {seed}", setup_units=units)


@pytest.mark.parametrize("units", UNITS)
def test_back_pressure_no_beat_lost_or_duplicated(units):
    """Random source idles and sink stalls: the same beats, in order, each once."""
    config = CORE_CONFIGS["default"]
    for seed in (1, 2):
        edges = mixed_stream(config, seed, 20)
        run_and_check(
            config, edges, seed=seed, idle=0.3, stall=0.5, label="stalls", setup_units=units
        )


def test_in_order_when_units_finish_out_of_order():
    """A start-clipped edge (W + 1 more setup clocks) ahead of short edges on other units:
    the later units finish first, the banks still reach the stepper in command order."""
    config = CORE_CONFIGS["default"]
    S = config.subpixel_scale
    clipped = Edge(10 * S, 10 * S, 90 * S, 30 * S, clip=Clip(50, 0, 2048, 2048))
    assert setup(config, clipped).clipped_start
    edges = [clipped] + [run_of(config, 200 + n, 50 + n, 1 + n % 3) for n in range(6)]
    edges.insert(3, Edge(20 * S, 20 * S, 40 * S, 25 * S, clip=Clip(100, 0, 200, 2048)))  # empty
    timings = timing_model.write_cycles(config, edges, setup_units=4)
    banks = [t.bank for t in timings if not t.dropped]
    assert banks[1] < banks[0]  # the second unit's bank is ready before the first's
    run = run_and_check(config, edges, label="out of order", setup_units=4)
    assert [clock for clock, _ in run.banks] == sorted(clock for clock, _ in run.banks)


@sim_settings(6)
@given(st.data())
def test_hypothesis_edges(data):
    """Hypothesis commands over the full coordinate range (good, bad, clipped) through an
    array of a drawn size in a drawn configuration."""
    name = data.draw(st.sampled_from(["default", "pw", "truncated", "lowfrac", "wide"]))
    config = CORE_CONFIGS[name]
    units = data.draw(st.sampled_from(UNITS))
    pixels = data.draw(st.sampled_from([3, 12, 1 << config.coord_bits]))
    edges = data.draw(st.lists(edge_commands(config, pixels, clip=True), min_size=4, max_size=10))
    run_and_check(config, edges, label=f"hypothesis {name}", setup_units=units)


def test_a_wrong_unit_count_in_the_model_is_caught():
    """The clock comparison can fail: the run of a 3-unit core against 2-unit timing."""
    config = CORE_CONFIGS["default"]
    edges = [run_of(config, 3 + n, 7 + n, 1) for n in range(8)]
    run = simulate(config, edges, setup_units=3)
    run.setup_units = 2
    with pytest.raises(AssertionError, match="accept clocks|beat clocks"):
        check_run(run, exact_timing=True)


def test_an_ungated_dispatch_is_caught(monkeypatch):
    """The order check can fail: a dispatcher that offers the command to a busy unit whose
    unit accepts in HOLD as a lone unit does (it accepts it in the clock the stepper takes
    its bank, which the array does not count) loses edges. (An array's units do not accept
    in HOLD: ``accept_in_hold=False``.)"""

    def ungated(self, m):
        d = self.dispatch
        m.d.comb += self.edges.ready.eq(~self.busy.bit_select(d, 1))
        for index, unit in enumerate(self.units):
            m.d.comb += [
                unit.edges.payload.eq(self.edges.payload),
                unit.edges.valid.eq(self.edges.valid & (d == index)),
            ]
        with m.If(self.edges.valid & self.edges.ready):
            m.d.sync += d.eq(self._next(d))

    monkeypatch.setattr(SetupArray, "_dispatch", ungated)
    init = SetupArray.__init__

    def lone_units(self, *args, **kwargs):
        init(self, *args, **kwargs)
        for unit in self.units:
            unit._accept_in_hold = True

    monkeypatch.setattr(SetupArray, "__init__", lone_units)
    config = CORE_CONFIGS["default"]
    edges = [run_of(config, 3 + n, 7 + n, 40 if n == 0 else 1) for n in range(8)]
    with pytest.raises(AssertionError):
        run_and_check(config, edges, label="ungated", setup_units=2)


def test_setup_units_is_checked():
    config = CORE_CONFIGS["default"]
    assert isinstance(LineCore(config, setup_units=2).setup, SetupArray)
    assert LineCore(config, setup_units=1).setup_units == 1
    for bad in (0, MAX_SETUP_UNITS + 1, 2.0, True, "9"):
        with pytest.raises(TypeError, match="setup_units"):
            LineCore(config, setup_units=bad)


def test_timing_model_is_the_single_unit_schedule_for_one():
    """`schedule` with one unit is the single unit's (the next accept in the clock of the
    load), and an array of one would be slower: a unit in an array is free the clock after."""
    config = CORE_CONFIGS["default"]
    edges = [run_of(config, 3 + n, 7 + n, 2) for n in range(5)]
    one = timing_model.beat_cycles(config, edges, setup_units=1)
    assert one[-1] - one[0] > 4 * timing_model.setup_interval(config, 1) - 2
    nine = timing_model.beat_cycles(config, edges, setup_units=9)
    assert nine == list(range(nine[0], nine[0] + 10))  # back to back: 2 columns each
