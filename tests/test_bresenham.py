# amaranth: UnusedElaboratable=no
"""The aliased Bresenham baseline core against a plain Python Bresenham, pixel for pixel.

Every test compares the whole pixel stream (with the `last` framing) of a batch of lines
with the reference, so a lost, duplicated or misplaced pixel fails. The batches cover all
eight octants, the axes and diagonals, one-pixel lines, endpoints on half pixels, and the
edges of the coordinate range; they run with and without random source idles and sink
back-pressure, and the sink checks that a held pixel stays valid and unchanged.
"""

from __future__ import annotations

import random
from fractions import Fraction

import pytest
from amaranth import Module, Signal
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out
from amaranth.sim import Simulator
from hypothesis import given, settings
from hypothesis import strategies as st

from edgeaa.hdl.bresenham import BresenhamLine
from edgeaa.model import EdgeConfig
from edgeaa.sim.simulators.streams import (
    StreamProtocolError,
    stream_get,
    stream_get_packet,
    stream_get_random,
    stream_put,
    stream_put_all,
)

SMALL = EdgeConfig(coord_bits=3, subpixel_bits=2)
DEFAULT = EdgeConfig()

# -- the reference -------------------------------------------------------------------------------


def to_pixel(value: int, config: EdgeConfig, rounding: str) -> int:
    s = config.subpixel_bits
    if rounding == "nearest":
        return (value + ((1 << s) >> 1)) >> s
    return value >> s


def reference_line(x0: int, y0: int, x1: int, y1: int) -> list[tuple[int, int]]:
    """Bresenham's line from (x0, y0) to (x1, y1) inclusive, in integer pixels."""
    dx, sx = abs(x1 - x0), (1 if x0 < x1 else -1)
    dy, sy = -abs(y1 - y0), (1 if y0 < y1 else -1)
    err = dx + dy
    x, y = x0, y0
    pixels = [(x, y)]
    while (x, y) != (x1, y1):
        e2 = 2 * err
        if e2 >= dy:
            err += dy
            x += sx
        if e2 <= dx:
            err += dx
            y += sy
        pixels.append((x, y))
    return pixels


def reference_pixels(config, rounding, command) -> list[tuple[int, int]]:
    return reference_line(*(to_pixel(v, config, rounding) for v in command))


@settings(max_examples=300, deadline=None)
@given(st.lists(st.integers(-40, 40), min_size=4, max_size=4))
def test_reference_is_a_bresenham_line(ends):
    """The reference itself: 8-connected, one pixel per major step, within 1/2 of the line."""
    x0, y0, x1, y1 = ends
    pixels = reference_line(x0, y0, x1, y1)
    dx, dy = x1 - x0, y1 - y0
    assert pixels[0] == (x0, y0) and pixels[-1] == (x1, y1)
    assert len(pixels) == max(abs(dx), abs(dy)) + 1
    x_major = abs(dx) >= abs(dy)
    for (xa, ya), (xb, yb) in zip(pixels, pixels[1:], strict=False):
        assert max(abs(xb - xa), abs(yb - ya)) == 1
        assert (xb != xa) if x_major else (yb != ya)
    for x, y in pixels:
        if x_major and dx:
            assert abs(y - (y0 + Fraction(dy * (x - x0), dx))) <= Fraction(1, 2)
        elif dy:
            assert abs(x - (x0 + Fraction(dx * (y - y0), dy))) <= Fraction(1, 2)


# -- the simulation ------------------------------------------------------------------------------


PERIOD = 1e-8


def run_lines(dut, commands, *, seed=0, idle=0.0, stall=0.0, drain=6):
    """Push `commands` through `dut`; return per line the (x, y) pixels and transfer cycles.

    The sink takes one packet (up to `last`) per command, then checks that nothing follows.
    The simulation stops after a generous cycle budget, so a core that stalls fails instead
    of hanging the test.
    """
    rng_source, rng_sink = random.Random(seed), random.Random(seed + 1)
    names = ("x0", "y0", "x1", "y1")
    payloads = [dict(zip(names, command, strict=True)) for command in commands]
    longest = 2 * (1 << (dut.pixel_bits + 1))
    s = dut.config.subpixel_bits
    pixels = sum((max(abs(c[2] - c[0]), abs(c[3] - c[1])) >> s) + 2 for c in commands)
    budget = 10 * (pixels + 4 * len(commands)) / ((1 - idle) * (1 - stall)) + 100
    packets, cycles = [], []
    cycle = 0
    finished = False

    async def clock(ctx):
        nonlocal cycle
        while True:
            await ctx.tick()
            cycle += 1

    async def source(ctx):
        await stream_put_all(ctx, dut.i, payloads, rng_source, idle=idle)

    async def sink(ctx):
        for _ in commands:
            packet = await stream_get_packet(ctx, dut.o, rng_sink, stall=stall, limit=longest)
            packets.append([(p.x, p.y) for p in packet])
            cycles.append(cycle)
        ctx.set(dut.o.ready, 1)
        for _ in range(drain):
            _, _, valid = await ctx.tick().sample(dut.o.valid)
            assert not valid, "the core sent a pixel after the last line"
        nonlocal finished
        finished = True

    sim = Simulator(dut)
    sim.add_clock(PERIOD)
    sim.add_testbench(clock, background=True)
    sim.add_testbench(source)
    sim.add_testbench(sink)
    sim.run_until(budget * PERIOD)
    assert finished, (
        f"after {cycle} cycles the sink has {len(packets)} of {len(commands)} lines: "
        f"the core stopped (or never set last)"
    )
    return packets, cycles


def octant(dx: int, dy: int) -> int:
    return (dx < 0) * 4 + (dy < 0) * 2 + (abs(dy) > abs(dx))


def line_cases(config: EdgeConfig, rounding: str, rng: random.Random, per_octant=3, reach=20):
    """Commands (sub-pixel units): random lines in every octant plus the special cases."""
    hi = config.max_vertex
    scale = config.subpixel_scale
    half = scale // 2
    cases = []
    wanted = dict.fromkeys(range(8), per_octant)
    while any(wanted.values()):
        cx, cy = rng.randint(0, hi), rng.randint(0, hi)
        span = reach * scale
        command = [min(max(c + rng.randint(-span, span), 0), hi) for c in (cx, cy, cx, cy)]
        x0, y0, x1, y1 = (to_pixel(v, config, rounding) for v in command)
        if (x0, y0) == (x1, y1) or abs(x1 - x0) == abs(y1 - y0) or 0 in (x1 - x0, y1 - y0):
            continue
        k = octant(x1 - x0, y1 - y0)
        if wanted[k]:
            wanted[k] -= 1
            cases.append(tuple(command))
    mid = (hi // 2) & ~(scale - 1)
    n = min(7 * scale, mid, hi - mid) & ~(scale - 1)
    for ex, ey in [(n, 0), (-n, 0), (0, n), (0, -n), (n, n), (-n, n), (n, -n), (-n, -n)]:
        cases.append((mid, mid, mid + ex, mid + ey))  # axes and exact diagonals
    cases.append((mid, mid, mid, mid))  # one pixel
    cases.append((mid + half, mid + half - 1, mid + half, mid + half - 1))  # halves round up
    cases.append((mid + half, mid, mid + 3 * scale + half - 1, mid + scale + half))
    cases.append((0, 0, n, 0))  # the edges of the range
    cases.append((hi, hi, hi - n, hi - n // 2))
    cases.append((0, hi, 0, hi - n))
    cases.append((hi, 0, hi - n // 2, n))
    rng.shuffle(cases)
    return cases


def expected_packets(config, rounding, commands):
    return [reference_pixels(config, rounding, command) for command in commands]


# -- tests ---------------------------------------------------------------------------------------


def quiet(dut):
    """A core built only to be inspected: no "created but never used" warning."""
    dut._MustUse__silence = True
    return dut


def test_signature():
    dut = quiet(BresenhamLine(config=DEFAULT))
    command = data.StructLayout({name: 15 for name in ("x0", "y0", "x1", "y1")})
    pixel = data.StructLayout({"x": 12, "y": 12, "last": 1})
    assert dut.signature.members["i"] == In(stream.Signature(command))
    assert dut.signature.members["o"] == Out(stream.Signature(pixel))
    assert dut.pixel_bits == 12 and quiet(BresenhamLine(rounding="floor")).pixel_bits == 11
    assert quiet(BresenhamLine(config=EdgeConfig(subpixel_bits=0))).pixel_bits == 11
    assert quiet(BresenhamLine()).config == DEFAULT


@pytest.mark.parametrize(
    "kwargs, error, message",
    [
        ({"config": 11}, TypeError, "config must be an edgeaa.model.EdgeConfig, not 11"),
        ({"rounding": "up"}, ValueError, "rounding must be one of nearest, floor, not 'up'"),
    ],
)
def test_bad_parameters(kwargs, error, message):
    with pytest.raises(error, match=message):
        BresenhamLine(**kwargs)


PRESSURE = [
    pytest.param(0.0, 0.0, id="full-rate"),
    pytest.param(0.5, 0.6, id="idle-and-backpressure"),
]


@pytest.mark.parametrize("idle, stall", PRESSURE)
@pytest.mark.parametrize(
    "config, rounding",
    [
        pytest.param(DEFAULT, "nearest", id="W11s4-nearest"),
        pytest.param(DEFAULT, "floor", id="W11s4-floor"),
        pytest.param(SMALL, "nearest", id="W3s2-nearest"),
        pytest.param(EdgeConfig(coord_bits=5, subpixel_bits=0), "nearest", id="W5s0"),
    ],
)
def test_matches_reference(config, rounding, idle, stall):
    seed = 1000 * config.coord_bits + config.subpixel_bits + (rounding == "floor")
    commands = line_cases(config, rounding, random.Random(seed))
    dut = BresenhamLine(config=config, rounding=rounding)
    packets, _ = run_lines(dut, commands, seed=seed, idle=idle, stall=stall)
    assert packets == expected_packets(config, rounding, commands)


def test_small_config_all_extremes():
    """Every line between corners and edge midpoints of the smallest range: the widest errors."""
    config = SMALL
    hi = config.max_vertex
    points = [(x, y) for x in (0, hi // 2, hi) for y in (0, hi // 2, hi)]
    commands = [(*a, *b) for a in points for b in points]
    dut = BresenhamLine(config=config)
    packets, _ = run_lines(dut, commands, seed=7, idle=0.3, stall=0.3)
    assert packets == expected_packets(config, "nearest", commands)


def test_long_lines():
    """Full-length lines of the default configuration (2049 pixels) under back-pressure."""
    hi = DEFAULT.max_vertex
    commands = [(0, 0, hi, hi // 3), (hi, 5, 17, hi)]
    dut = BresenhamLine(config=DEFAULT)
    packets, _ = run_lines(dut, commands, seed=3, stall=0.25)
    assert [len(p) for p in packets] == [2049, 2049]
    assert packets == expected_packets(DEFAULT, "nearest", commands)


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.tuples(*[st.integers(0, SMALL.max_vertex)] * 4), min_size=1, max_size=6),
    st.integers(0, 2**16),
)
def test_matches_reference_hypothesis(commands, seed):
    dut = BresenhamLine(config=SMALL)
    packets, _ = run_lines(dut, commands, seed=seed, idle=0.3, stall=0.4)
    assert packets == expected_packets(SMALL, "nearest", commands)


def test_one_pixel_per_clock():
    """Back to back at full rate a line of n pixels takes n + OVERHEAD_CYCLES cycles."""
    scale = DEFAULT.subpixel_scale
    lengths = [1, 2, 9, 30, 5]
    commands = [(0, 0, (n - 1) * scale, (n // 2) * scale) for n in lengths]
    dut = BresenhamLine(config=DEFAULT)
    packets, cycles = run_lines(dut, commands)
    assert [len(p) for p in packets] == lengths
    steps = [b - a for a, b in zip(cycles, cycles[1:], strict=False)]
    assert steps == [n + BresenhamLine.OVERHEAD_CYCLES for n in lengths[1:]]


# -- the stream helpers --------------------------------------------------------------------------


class _Dropper(wiring.Component):
    """A broken source: valid is high every other cycle whether or not the payload was taken."""

    def __init__(self):
        super().__init__({"o": Out(stream.Signature(8))})

    def elaborate(self, platform):
        m = Module()
        count = Signal(8)
        m.d.sync += count.eq(count + 1)
        m.d.comb += [self.o.valid.eq(count[0]), self.o.payload.eq(count)]
        return m


def test_stream_hold_check_catches_a_dropped_valid():
    dut = _Dropper()

    async def bench(ctx):
        rng = random.Random(0)
        with pytest.raises(StreamProtocolError, match="valid must stay high"):
            for _ in range(50):
                await stream_get_random(ctx, dut.o, rng, stall=0.7)

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(bench)
    sim.run()


def test_stream_put_get_roundtrip():
    """stream_put and stream_get against a one-stage buffer: order and values kept."""

    class Buffer(wiring.Component):
        def __init__(self):
            super().__init__({"i": In(stream.Signature(8)), "o": Out(stream.Signature(8))})

        def elaborate(self, platform):
            m = Module()
            with m.If(self.o.ready | ~self.o.valid):
                m.d.comb += self.i.ready.eq(1)
                m.d.sync += [self.o.valid.eq(self.i.valid), self.o.payload.eq(self.i.payload)]
            return m

    dut = Buffer()
    values = list(range(1, 40, 3))
    got = []

    async def source(ctx):
        for value in values:
            await stream_put(ctx, dut.i, value)

    async def sink(ctx):
        for _ in values:
            got.append(await stream_get(ctx, dut.o))

    sim = Simulator(dut)
    sim.add_clock(1e-8)
    sim.add_testbench(source)
    sim.add_testbench(sink)
    sim.run()
    assert got == values
