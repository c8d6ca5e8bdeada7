"""Issue 12's higher-radix option, measured on one lane: the setup's lane B (`MulDivLane`,
radix 2: one quotient bit a clock) against a radix-4 lane (two bits a clock), both computing
``khq, khr = divmod(|I_d| dv 2**(F - 1), du)`` for the default configuration.

Each lane is checked against Python's divmod in Amaranth simulation (seeded random operands,
the seed printed), then synthesised alone for the iCE40 HX8K and the ECP5 25F (Yosys LUT4
and flip-flops, the I/O harness subtracted; nextpnr Fmax). ``python
benchmarks/lane_radix.py [--count N] [--seed S] [--no-synth]``. The radix-4 lane is an
experiment kept here, not part of the core.
"""

from __future__ import annotations

import argparse
import random
import sys

from amaranth.hdl import Module, Mux, Signal, signed, unsigned
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out
from amaranth.sim import Simulator

from edgeaa.hdl.layouts import register_shape
from edgeaa.hdl.setup import MulDivLane
from edgeaa.model.config import EdgeConfig


def _ports(config: EdgeConfig, a_bits: int) -> dict:
    widths = config.register_widths()
    du = register_shape(widths["du"])
    return {
        "start": In(1),  # load a, x, du this clock
        "a": In(a_bits),
        "x": In(du),  # x <= du
        "du": In(du),
        "q": Out(unsigned(widths["jq"].bits)),
        "r": Out(du),
    }


class Radix2Lane(wiring.Component):
    """The core's lane B as it is: `MulDivLane` with no digit, one multiplier bit a clock."""

    def __init__(self, config: EdgeConfig):
        self._config = config
        self.a_bits = config.intensity_bits + config.F - 1
        self.clocks = self.a_bits
        super().__init__(_ports(config, self.a_bits))

    def elaborate(self, platform):
        m = Module()
        du_bits = self._config.register_widths()["du"].bits
        lane = MulDivLane("lane", self._config, self.a_bits, 0)
        neg_du = Signal(signed(du_bits + 1))
        m.d.sync += neg_du.eq(-self.du)
        step = lane.step(m, neg_du, "lane")
        with m.If(self.start):
            m.d.sync += lane.load(
                self.a, self.a_bits, self.x, self.x - self.du, self.x - 2 * self.du
            )
        with m.Else():
            m.d.sync += step
        m.d.comb += [self.q.eq(lane.q), self.r.eq(lane.r)]
        return m


class Radix4Lane(wiring.Component):
    """Two multiplier bits a clock: ``V = 4 V + b X`` (b in 0..3) keeping ``V = Q du + R``.

    With ``R < du`` and ``X <= du`` the candidate ``T = 4 R + b X`` is below ``7 du``, so the
    quotient digit d is 0 .. 6: ``T - d du`` for d = 1 .. 6 are formed in parallel from the
    per-pass multiples ``d du`` and ``3 X`` (registered at load), and d is the largest whose
    difference is not negative. Each clock chains two carry chains (T, then T - d du)."""

    def __init__(self, config: EdgeConfig):
        self._config = config
        bits = config.intensity_bits + config.F - 1
        self.a_bits = bits + bits % 2  # whole digits: a leading zero bit when odd
        self.clocks = self.a_bits // 2
        super().__init__(_ports(config, self.a_bits))

    def elaborate(self, platform):
        m = Module()
        du_bits = self._config.register_widths()["du"].bits
        q = Signal.like(self.q)
        r = Signal(du_bits)
        a = Signal(self.a_bits)
        x = [Signal(du_bits + 2, name=f"x{b}") for b in range(1, 4)]  # X, 2 X, 3 X
        mul = [Signal(du_bits + 3, name=f"du{d}") for d in range(1, 7)]  # d du
        bx = Mux(a[-2:] == 0, 0, Mux(a[-2:] == 1, x[0], Mux(a[-2:] == 2, x[1], x[2])))
        total = Signal(du_bits + 3)
        m.d.comb += total.eq((r << 2) + bx)
        diffs = [Signal(signed(du_bits + 4), name=f"t_less_{d}du") for d in range(1, 7)]
        m.d.comb += [diff.eq(total - mul[d]) for d, diff in enumerate(diffs)]
        digit, rest = Signal(3), Signal(du_bits)
        m.d.comb += [digit.eq(0), rest.eq(total)]
        for d, diff in enumerate(diffs, start=1):  # the largest d whose difference is >= 0
            with m.If(~diff[-1]):
                m.d.comb += [digit.eq(d), rest.eq(diff)]
        with m.If(self.start):
            m.d.sync += [q.eq(0), r.eq(0), a.eq(self.a << (self.a_bits - len(self.a)))]
            m.d.sync += [x[0].eq(self.x), x[1].eq(self.x << 1), x[2].eq(self.x * 3)]
            m.d.sync += [reg.eq(self.du * d) for d, reg in enumerate(mul, start=1)]
        with m.Else():
            m.d.sync += q.eq((q << 2) + digit)
            m.d.sync += [r.eq(rest), a.eq(a << 2)]
        m.d.comb += [self.q.eq(q), self.r.eq(r)]
        return m


def check(lane_cls, config: EdgeConfig, count: int, seed: int) -> None:
    """The lane against divmod on `count` random operands (seeded)."""
    rng = random.Random(seed)
    dut = lane_cls(config)
    du_max = (1 << config.register_widths()["du"].bits) - 1
    cases = []
    for _ in range(count):
        du = rng.choice([rng.randint(1, 64), rng.randint(1, du_max)])
        x = rng.randint(0, du)
        a = rng.randint(0, (1 << config.intensity_bits) - 1) << (config.F - 1)
        cases.append((a, x, du))
    failures = []

    async def bench(ctx):
        for a, x, du in cases:
            ctx.set(dut.start, 1)
            ctx.set(dut.a, a)
            ctx.set(dut.x, x)
            ctx.set(dut.du, du)
            await ctx.tick()
            ctx.set(dut.start, 0)
            await ctx.tick().repeat(dut.clocks)
            got = (ctx.get(dut.q), ctx.get(dut.r))
            if got != divmod(a * x, du):
                failures.append((a, x, du, got))

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    if failures:
        sys.exit(
            f"{lane_cls.__name__}: {len(failures)} wrong of {count} (seed {seed}): {failures[0]}"
        )
    print(
        f"{lane_cls.__name__}: {count} divisions equal divmod, {dut.clocks} clocks each "
        f"(seed {seed})"
    )


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=300, help="random divisions per lane")
    parser.add_argument("--seed", type=int, default=1, help="random seed (printed)")
    parser.add_argument("--no-synth", action="store_true", help="simulate only")
    args = parser.parse_args(argv)
    if args.count < 1:
        parser.error(f"--count must be at least 1, not {args.count}")
    config = EdgeConfig()
    for lane_cls in (Radix2Lane, Radix4Lane):
        check(lane_cls, config, args.count, args.seed)
    if args.no_synth:
        return 0
    from edgeaa.sim.synthesis import synthesize

    print("| lane | target | clocks per division | LUT4 | FF | Fmax (MHz) |")
    print("| --- | --- | ---: | ---: | ---: | ---: |")
    for target in ("ice40", "ecp5"):
        for lane_cls in (Radix2Lane, Radix4Lane):
            lane = lane_cls(config)
            result = synthesize(lane, target, wrap=True)
            print(
                f"| {lane_cls.__name__} | {result.device} | {lane.clocks} | {result.core_luts} "
                f"| {result.core_ffs} | {result.fmax_mhz:.1f} |"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
