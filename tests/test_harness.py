# amaranth: UnusedElaboratable=no
"""The generated Verilator harness on a small top of its own: it is made from the top's
declared formats (any stream names, side ports, signed leaves, counters), and its checks can
fail: a stalled beat that changes or is withdrawn, a top that stops moving, a command value
its port cannot carry, an input no command column drives."""

from __future__ import annotations

import numpy as np
import pytest
from amaranth.back import verilog
from amaranth.hdl import Module, Signal, signed, unsigned
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from edgeaa.sim.simulators import harness

DEFECTS = ("none", "change", "withdraw", "stop")  # what the top does wrong, set per command


class Echo(wiring.Component):
    """Each command (a, b) comes back one beat later as (a + b, a - b); `count` counts the
    beats taken. The side port ``defect`` (`DEFECTS`, sampled with the command) makes the
    beat change or go away while it is stalled, or the top stop taking commands."""

    def __init__(self):
        command = data.StructLayout({"a": unsigned(8), "b": unsigned(8)})
        beat = data.StructLayout({"sum": unsigned(9), "diff": signed(9)})
        super().__init__(
            {
                "ops": In(stream.Signature(command)),
                "defect": In(2),
                "results": Out(stream.Signature(beat)),
                "count": Out(16),
            }
        )

    def elaborate(self, platform):
        m = Module()
        defect, stopped = Signal(2), Signal()
        free = ~self.results.valid | self.results.ready
        m.d.comb += self.ops.ready.eq(free & ~stopped)
        with m.If(self.results.valid & self.results.ready):
            m.d.sync += [self.results.valid.eq(0), self.count.eq(self.count + 1)]
        with m.Elif(self.results.valid & (defect == DEFECTS.index("change"))):
            m.d.sync += self.results.payload.sum.eq(self.results.payload.sum + 1)
        with m.Elif(self.results.valid & (defect == DEFECTS.index("withdraw"))):
            m.d.sync += self.results.valid.eq(0)
        with m.If(self.ops.valid & self.ops.ready):
            a, b = self.ops.payload.a, self.ops.payload.b
            m.d.sync += [
                self.results.valid.eq(1),
                self.results.payload.sum.eq(a + b),
                self.results.payload.diff.eq(a - b),
                defect.eq(self.defect),
                stopped.eq(self.defect == DEFECTS.index("stop")),
            ]
        return m


def echo_verilog() -> str:
    """`Echo` as Verilog with a port per leaf, named as `edgeaa.hdl.core.flat_verilog` names
    them (which adds the core's header, so cannot take this top)."""
    echo, m, ports = Echo(), Module(), []
    m.submodules.echo = echo
    for path, member, value in echo.signature.flatten(echo):
        leaves = [(path, value)]
        if isinstance(value, data.View):
            leaves = [((*path, name), value[name]) for name, _ in value.shape()]
        for leaf_path, leaf in leaves:
            port = Signal(leaf.shape(), name="__".join(map(str, leaf_path)))
            m.d.comb += leaf.eq(port) if member.flow == In else port.eq(leaf)
            ports.append(port)
    return verilog.convert(m, name="echo", ports=ports, emit_src=False)


COMMANDS = harness.StreamFormat("ops", (("a",), ("b",)), side=(("defect",),))
BEATS = harness.StreamFormat("results", (("sum",), ("diff",)))


@pytest.fixture(scope="module")
def echo():
    top = harness.harness_top(Echo(), "echo", COMMANDS, BEATS)
    return top, harness.build(("echo",), top, echo_verilog, "-O1")


def commands(count: int, seed: int, defect: str = "none", at: int = 0) -> np.ndarray:
    """`count` random commands, those from `at` on with `defect`."""
    rng = np.random.default_rng(seed)
    rows = np.zeros((count, 3), dtype=np.int64)
    rows[:, :2] = rng.integers(0, 256, (count, 2))
    rows[at:, 2] = DEFECTS.index(defect)
    return rows


def run(echo, rows, seed, **kwargs):
    top, exe = echo
    options = {"idle": 0.3, "stall": 0.5, "drain": 8, "max_quiet": 200} | kwargs
    return harness.run_harness(exe, top, rows, seed=seed, **options)


def test_the_top_is_read_from_its_signature():
    top = harness.harness_top(Echo(), "echo", COMMANDS, BEATS)
    assert [p.name for p in top.commands] == ["ops__payload__a", "ops__payload__b", "defect"]
    assert [(p.name, p.bits, p.signed) for p in top.beats] == [
        ("results__payload__sum", 9, False),
        ("results__payload__diff", 9, True),
    ]
    assert [p.name for p in top.counters] == ["count"]


def test_every_beat_comes_out_in_order_under_back_pressure(echo):
    seed = 3
    rows = commands(500, seed)
    done = run(echo, rows, seed, expected=len(rows))
    a, b = rows[:, 0], rows[:, 1]
    assert done.rows[:, 1].tolist() == (a + b).tolist(), f"seed {seed}"
    assert done.rows[:, 2].tolist() == (a - b).tolist(), f"seed {seed}: diff sign-extended"
    assert done.counters == {"count": len(rows)}
    assert len(done.taken) == len(rows) and np.all(np.diff(done.taken) > 0)
    assert np.all(np.diff(done.rows[:, 0]) > 0) and done.clocks > done.rows[-1, 0] + 8


@pytest.mark.parametrize("defect", ["change", "withdraw"])
def test_a_stalled_beat_that_does_not_hold_is_reported(echo, defect):
    seed = 4
    with pytest.raises(harness.UnstableBeat, match=f"stalled results beat {defect}"):
        run(echo, commands(200, seed, defect, at=100), seed)
    run(echo, commands(200, seed, defect, at=100), seed, stall=0.0)  # never stalled: fine


def test_a_top_that_stops_moving_is_a_hang_not_a_wait(echo):
    with pytest.raises(harness.HarnessHang, match="nothing moved for 200 clocks: 11 of 50"):
        run(echo, commands(50, 5, "stop", at=10), 5)
    with pytest.raises(harness.HarnessHang, match="50 of 50 commands taken, 50 of 51 results"):
        run(echo, commands(50, 5), 5, expected=51)


def test_a_command_its_port_cannot_carry_is_refused(echo):
    rows = commands(10, 6)
    rows[7, 1] = 256
    with pytest.raises(ValueError, match=r"command 7 sets ops__payload__b to 256, outside its"):
        run(echo, rows, 6)


def test_every_input_must_be_driven_every_leaf_read_and_every_name_a_port():
    undriven = harness.StreamFormat("ops", (("a",), ("b",)))
    with pytest.raises(ValueError, match="no command column drives defect"):
        harness.harness_top(Echo(), "echo", undriven, BEATS)
    with pytest.raises(ValueError, match="results__payload__sum is not an input port"):
        side = (("results", "payload", "sum"),)
        harness.harness_top(Echo(), "echo", COMMANDS._replace(side=side), BEATS)
    with pytest.raises(ValueError, match="the beat row leaves out results__payload__diff"):
        harness.harness_top(Echo(), "echo", COMMANDS, BEATS._replace(paths=(("sum",),)))
    with pytest.raises(ValueError, match="results__payload__product is not an output port"):
        harness.harness_top(Echo(), "echo", COMMANDS, BEATS._replace(paths=(("product",),)))
