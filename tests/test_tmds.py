"""The TMDS encoder (`edgeaa.hdl.tmds`) against the DVI 1.0 algorithm (`edgeaa.model.video`),
and the algorithm's own properties: every data word decodes to its byte, the running
disparity is the stream's ones minus zeros and stays within [-8, 8] (DC balance)."""

from __future__ import annotations

import random

from amaranth.sim import Simulator
from hypothesis import given, settings
from hypothesis import strategies as st

from edgeaa.hdl.tmds import TMDSEncoder
from edgeaa.model.video import (
    CONTROL_TOKENS,
    VGA,
    TMDSState,
    tmds_decode,
    tmds_encode,
    tmds_stream,
)


def _reachable() -> list[int]:
    seen, todo = {0}, [0]
    while todo:
        cnt = todo.pop()
        for data in range(256):
            state = TMDSState(cnt)
            tmds_encode(state, 1, data, 0)
            if state.cnt not in seen:
                seen.add(state.cnt)
                todo.append(state.cnt)
    return sorted(seen)


def test_the_reference_decodes_and_its_disparity_is_the_streams_and_bounded():
    assert _reachable() == list(range(-8, 9, 2))
    for cnt in _reachable():
        for data in range(256):
            state = TMDSState(cnt)
            word = tmds_encode(state, 1, data, 0)
            assert tmds_decode(word) == (data, None)
            ones = bin(word).count("1")
            assert state.cnt - cnt == ones - (10 - ones), (cnt, data, word)
    for c, token in enumerate(CONTROL_TOKENS):
        state = TMDSState(6)
        assert tmds_encode(state, 0, 0x55, c) == token and state.cnt == 0
        assert tmds_decode(token) == (0, c)


def test_known_words():
    # 0x00 from disparity 0: XOR chain (q_m8 = 1) of zeros, sent as it is: 0b0100000000
    assert tmds_stream([(1, 0x00, 0)])[0] == [0b0100000000]
    # 0xFF: XNOR chain (8 ones), q_m = 0xFF -> inverted (q_m8 = 0): 0b1000000000
    assert tmds_stream([(1, 0xFF, 0)])[0] == [0b1000000000]


def _simulate(symbols) -> tuple[list[int], list[int]]:
    dut = TMDSEncoder()
    words, cnts = [], []

    async def bench(ctx):
        for de, data, control in symbols:
            ctx.set(dut.de, de)
            ctx.set(dut.data, data)
            ctx.set(dut.control, control)
            await ctx.tick()
            words.append(ctx.get(dut.word))
            cnts.append(ctx.get(dut.cnt))

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    return words, cnts


def test_the_encoder_is_the_reference_from_every_reachable_disparity():
    """Every byte from every reachable running disparity: a stream that steers the
    disparity to each state (found by search in the model), then the byte, then a control
    word to restart."""
    steer = {0: []}
    todo = [0]
    while todo:  # the shortest byte sequence to each disparity
        cnt = todo.pop(0)
        for data in range(256):
            state = TMDSState(cnt)
            tmds_encode(state, 1, data, 0)
            if state.cnt not in steer:
                steer[state.cnt] = [*steer[cnt], data]
                todo.append(state.cnt)
    symbols = []
    for cnt in sorted(steer):
        for data in range(256):
            symbols += [(1, d, 0) for d in steer[cnt]] + [(1, data, 0), (0, 0, data & 3)]
    want = tmds_stream(symbols)
    assert _simulate(symbols) == want


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_encoder_is_the_reference_on_random_video(seed):
    rng = random.Random(seed)
    symbols = []
    for _ in range(rng.randint(1, 6)):  # lines of data between blanking periods
        symbols += [(1, rng.choice([rng.randrange(256), 0, 255, 0x10]), 0)]
        symbols += [(1, rng.randrange(256), 0) for _ in range(rng.randint(0, 40))]
        symbols += [(0, 0, rng.randrange(4)) for _ in range(rng.randint(1, 3))]
    assert _simulate(symbols) == tmds_stream(symbols), f"seed {seed}"


def test_the_video_timing_is_640x480_at_60():
    assert (VGA.h_total, VGA.v_total) == (800, 525)
    assert 59 < VGA.refresh_hz < 61
    assert VGA.sync(0, 0) == (1, 1)  # idle high: both pulses negative
    assert VGA.sync(656, 490) == (0, 0) and VGA.sync(752, 492) == (1, 1)
