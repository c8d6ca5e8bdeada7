# amaranth: UnusedElaboratable=no
"""Formal checks of the tile stages (`edgeaa.hdl.accumulator.TileAccumulator`,
`edgeaa.hdl.resolve.TileResolve`) with SymbiYosys: `TileHarness`, `TILE_PROOFS`,
`run_tile_proof` (``python -m edgeaa.sim.verification.formal.tile [proof ...]``). The
``stream`` groups are black-box (only the stages' ports); the accumulator's ``deltas`` and
``sums`` groups (`accumulator`) and the resolve's ``pixels`` group (`resolve`) also state
invariants of the stage's internals (its observation points, ``observe``, and its memories
read through combinational read ports the harness adds), which make them inductive; those
modules state their groups and invariants.

`TileHarness` wraps one stage of a `TileConfig`. Its input stream is free in every clock
(``AnySeq``) except for the hold rule, which is assumed of the source (a valid transfer not
taken stays valid with the same payload); the output's ready is free. The ``stream`` group
of each stage asserts the hold rule of its output (``cells``, ``pixels``): a valid output
not taken stays valid with the same payload in the next clock (the reset is a free input; a
reset in between lifts the rule).

Faults (``fault``; each must make its proof fail): ``stall_cell`` / ``stall_pixel`` flip a
payload bit of a held output as the harness sees it; ``lost_delta`` gives the accumulator
the beat with cell 3's delta zeroed while the shadow counts it (a stage that loses a
delta); ``stale_origin`` gives it every op with x0 zeroed (a stage that ignores a tile's x
origin: cells land in the wrong columns); ``wide_range`` assumes the prefix sums within
``[-2 L, 2 L)``, twice the documented range; ``lost_first`` gives the resolve every cell
with ``first`` cleared (a stage that takes a polygon's first cell while the previous
polygon's cells are in flight, so its pixel read may miss their writes); ``swap_lanes``
gives the ``pixels`` group the resolve's beats with lanes 0 and 1 swapped (a flush of two
or more pixel lanes that sends a beat's pixels in each other's places); ``swap_sums`` gives
the resolve of two scan lanes each beat of cells with its two sums swapped (a resolve that
composites a beat's cells in each other's columns); ``swap_cells`` gives the accumulator's
groups its beats of two cells with their sums swapped (a scan that sends a beat's cells in
each other's places, or reads the banks the wrong way round).

Scan lanes (``scan_lanes`` 2, `PipelineConfig.scan_lanes`): every group covers them (the
accumulator's beats of two cells from its memories banked by column parity, the
resolve's two cells a clock); `TILE_PROOFS` names those runs ``*_scan``. The resolve's
products take two clocks (``product_stages`` 2, both pipelines') in ``res_stream``,
``res_pixels`` and the ``*_scan`` runs, one in the ``*_lanes`` runs.

All groups are proved by k-induction for every reachable state (``pixels`` from power-on,
the memories and registers at their initial values, no reset; the accumulator's from
power-on under a free reset, so its clear pass after a reset mid-polygon is proved).
`TILE_PROOFS` lists the runs and their configurations; `run_tile_proof` runs one.
"""

from __future__ import annotations

import types
from dataclasses import dataclass
from pathlib import Path

from amaranth.asserts import AnySeq
from amaranth.hdl import Array, Assert, Assume, Module, Mux, Signal, Value

from ....hdl.accumulator import TileAccumulator
from ....hdl.resolve import TileResolve
from ....model.tile import TileConfig, resolve_latency
from .accumulator import check_cells, nonzero_flags
from .harness import ClockedHarness
from .resolve import check_pixels
from .run import FormalResult, find_tools, report, run_harness, sby_script
from .stream import held, hold_rule
from .tile_common import (
    SMALL_TILE,
    TILE_CHECKS,
    TILE_FAULTS,
    free_source,
    memory_reader,
)

__all__ = [
    "SMALL_TILE",
    "TILE_CHECKS",
    "TILE_FAULTS",
    "TILE_PROOFS",
    "TileHarness",
    "TileProof",
    "main",
    "run_tile_proof",
]


class TileHarness(ClockedHarness):
    """One tile stage (``"accumulator"`` or ``"resolve"``) with a free input stream and the
    check groups of `TILE_CHECKS` (the module docstring). ``reset``: the reset is a free
    input (else the registers and memories start at their initial values and never reset).
    ``invariants``: with the ``deltas`` or ``sums`` group, also assert the invariants of the
    accumulator's state that make the group inductive (off: the group's own assertions only,
    to show that they catch a fault by themselves). ``covers``: also cover each invariant's
    premise with its conclusion (for sby's cover mode: no invariant is vacuous).
    """

    def __init__(
        self,
        tile: TileConfig,
        stage: str,
        checks,
        *,
        reset=False,
        fault=None,
        invariants=True,
        covers=False,
        lanes=1,
        scan_lanes=1,
        product_stages=1,
    ):
        if not isinstance(tile, TileConfig):
            raise TypeError(f"tile must be a TileConfig, not {tile!r}")
        if stage not in TILE_CHECKS:
            raise ValueError(f"stage must be one of {', '.join(TILE_CHECKS)}, not {stage!r}")
        checks = tuple(checks)
        unknown = [c for c in checks if c not in TILE_CHECKS[stage]]
        if unknown:
            raise ValueError(f"checks must be among {', '.join(TILE_CHECKS[stage])}: {unknown}")
        if fault is not None and TILE_FAULTS.get(fault) != stage:
            faults = [f for f, s in TILE_FAULTS.items() if s == stage]
            raise ValueError(f"fault must be one of {', '.join(faults)} or None, not {fault!r}")
        self.tile, self.stage, self.checks = tile, stage, checks
        super().__init__(reset)
        self.fault, self.invariants = fault, invariants
        self.covers = covers and invariants
        if lanes != 1 and stage != "resolve":
            raise ValueError(f"pixel lanes are the resolve's, not the {stage}'s")
        if fault == "swap_lanes" and lanes == 1:
            raise ValueError("fault swap_lanes needs two or more pixel lanes")
        if fault in ("swap_sums", "swap_cells") and scan_lanes == 1:
            raise ValueError(f"fault {fault} needs two scan lanes")
        if stage == "accumulator":
            self.dut = TileAccumulator(tile, scan_lanes)
        else:
            self.dut = TileResolve(tile, lanes, scan_lanes, product_stages)

    def elaborate(self, platform):
        m = Module()
        dut = self.dut
        groups = {"deltas", "sums"} & set(self.checks)
        read = None
        if self.invariants and (groups or "pixels" in self.checks):
            # elaborated here: the invariants read its observation points, and the harness
            # adds read ports to its memories
            m.submodules.dut = dut.elaborate(platform)
            if "sums" in self.checks:
                read = _cell_reader(m, dut)
            elif "pixels" in self.checks:  # the resolve's two pixel memories, by bank
                read = _pixel_reader(m, dut)
        else:
            m.submodules.dut = dut
        m.domains.sync = self.domain
        if self.reset:
            m.d.comb += self.domain.rst.eq(AnySeq(1))
        source, sink = (dut.ops, dut.cells) if self.stage == "accumulator" else (dut.cells, None)
        sink = sink if sink is not None else dut.pixels
        payload, held_in = free_source(m, source, self.fault)
        if self.stage == "accumulator":  # the deltas stream's contract (the core's `dbeat`)
            m.d.comb += Assume(payload.beat.nonzero == nonzero_flags(payload.beat))
        m.d.comb += sink.ready.eq(AnySeq(1))
        seen = Value.cast(sink.payload)
        was_held = held(m, sink, "held_out")
        if self.fault in ("stall_cell", "stall_pixel"):
            seen = seen ^ was_held
        if "stream" in self.checks:

            def check(condition, message):
                m.d.comb += Assert(condition, message)

            hold_rule(m, sink.valid, seen, was_held, check, "output")
        if groups:
            cells = None
            if self.fault == "swap_cells":
                cells = _swapped(m, dut.cells, "sum", "sum1", "cells_swapped")
            check_cells(
                m, self.tile, dut, payload, held_in, read, self.checks,
                invariants=self.invariants, covers=self.covers, cells=cells,
            )  # fmt: skip
        if "pixels" in self.checks:
            pixels = None
            if self.fault == "swap_lanes":
                pixels = _swapped(m, dut.pixels, "value", "value1", "pixels_swapped")
            check_pixels(
                m, self.tile, dut, payload, read, wide=self.fault == "wide_range",
                invariants=self.invariants, covers=self.covers, pixels=pixels,
            )  # fmt: skip
        return m


def _swapped(m, stream, first: str, second: str, name: str):
    """`stream` as faults ``swap_lanes`` and ``swap_cells`` show it: its payload's fields
    `first` and `second` (lanes 0 and 1) swapped."""
    payload = Signal(stream.payload.shape(), name=name)
    m.d.comb += payload.eq(stream.payload)
    m.d.comb += [
        payload[first].eq(stream.payload[second]),
        payload[second].eq(stream.payload[first]),
    ]
    return types.SimpleNamespace(valid=stream.valid, ready=stream.ready, payload=payload)


def _cell_reader(m, dut):
    """``read(address)``: cell `address` of the accumulation memory, from the memory of its
    lane (the address's low bits, with scan lanes) at its word (the rest)."""
    if dut.lanes == 1:
        return memory_reader(m, dut.observe.memory)
    lane_bits = dut.lanes.bit_length() - 1
    readers = [memory_reader(m, mem) for mem in dut.observe.memories]

    def read(address):
        words = [reader(address[lane_bits:]) for reader in readers]
        return Array(words)[address[:lane_bits]]

    return read


def _pixel_reader(m, dut):
    """``read(address, bank)``: pixel `address` of the resolve's pixel memory `bank`, from
    the memory of its lane (the address's low bits) at its word (the rest)."""
    lanes = dut.lanes
    lane_bits = lanes.bit_length() - 1
    readers = [[memory_reader(m, mem) for mem in bank] for bank in dut.observe.memories]

    def read_bank(k, address):
        if lanes == 1:
            return readers[k][0](address)
        words = [reader(address[lane_bits:]) for reader in readers[k]]
        return Array(words)[address[:lane_bits]]

    def read(address, bank):
        return Mux(bank, read_bank(1, address), read_bank(0, address))

    return read


# -- running ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class TileProof:
    """One SymbiYosys run of a `TileHarness`."""

    name: str
    stage: str
    checks: tuple[str, ...]
    mode: str  # prove (k-induction) or bmc
    depth: int
    tile: TileConfig = SMALL_TILE
    reset: bool = False
    memory_map: bool = True
    description: str = ""
    lanes: int = 1  # the resolve's pixel lanes (`PipelineConfig.pixel_lanes`)
    scan_lanes: int = 1  # both stages' scan lanes (`PipelineConfig.scan_lanes`)
    product_stages: int = 1  # the resolve's (`PipelineConfig.product_stages`)


WIDE_TILE = TileConfig(SMALL_TILE.config, 8, 2)  # `SMALL_TILE` with two beats of four a row

TILE_PROOFS: dict[str, TileProof] = {
    proof.name: proof
    for proof in (
        TileProof(
            "acc_stream",
            "accumulator",
            ("stream",),
            "prove",
            1,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="cells hold rule, any reachable state (k-induction), default tile",
        ),
        TileProof(
            "res_stream",
            "resolve",
            ("stream",),
            "prove",
            1,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="pixels hold rule (the compact pipeline's resolve: its products over "
            "two clocks), any reachable state (k-induction), default tile",
            product_stages=2,
        ),
        TileProof(
            "res_stream_lanes",
            "resolve",
            ("stream",),
            "prove",
            1,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="pixels hold rule with two pixel lanes (the fast pipeline's), any "
            "reachable state (k-induction), default tile",
            lanes=2,
        ),
        TileProof(
            "acc_stream_scan",
            "accumulator",
            ("stream",),
            "prove",
            1,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="cells hold rule with two scan lanes (the fast pipeline's: a beat of "
            "two cells from the memories banked by column parity, both sums), any reachable "
            "state (k-induction), default tile",
            scan_lanes=2,
        ),
        TileProof(
            "res_stream_scan",
            "resolve",
            ("stream",),
            "prove",
            1,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="pixels hold rule with two scan lanes and four pixel lanes (the fast "
            "pipeline's resolve, its products over two clocks), any reachable state "
            "(k-induction), default tile",
            lanes=4,
            scan_lanes=2,
            product_stages=2,
        ),
        TileProof(
            "acc_deltas",
            "accumulator",
            ("deltas",),
            "prove",
            2,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="every touched cell sent once per end and before the next op, "
            "untouched rows not sent, order, fields, tile and flush passed on (k-induction "
            "with the scan's invariants)",
        ),
        TileProof(
            "acc_sums",
            "accumulator",
            ("sums",),
            "prove",
            2,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="each cell sent carries the sum of its deltas since the last time it "
            "was sent or the last reset (a reset with deltas kept sends the accumulator through "
            "its clear pass), modulo 2**cell_bits (k-induction with the memory's and "
            "read-modify-write stages' invariants), default tile",
        ),
        TileProof(
            "acc_deltas_scan",
            "accumulator",
            ("deltas",),
            "prove",
            2,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="acc_deltas with two scan lanes (the fast pipeline's): beats of two "
            "cells from even columns, each cell kept sent once per end in its beat",
            scan_lanes=2,
        ),
        TileProof(
            "acc_sums_scan",
            "accumulator",
            ("sums",),
            "prove",
            2,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="acc_sums with two scan lanes: the accumulation memory banked by "
            "column parity, each cell's sum in its lane of the beat",
            scan_lanes=2,
        ),
        TileProof(
            "res_pixels",
            "resolve",
            ("pixels",),
            "prove",
            resolve_latency(SMALL_TILE, 2) + 1,  # a cell in flight is written within k
            description="pixels equal the model's composite of exact prefix sums within the "
            "documented range (no overflow; k-induction with the pipeline's and the pixel "
            "memory's invariants; the compact pipeline's resolve, its products over two "
            "clocks)",
            product_stages=2,
        ),
        TileProof(
            "res_pixels_lanes",
            "resolve",
            ("pixels",),
            "prove",
            resolve_latency(SMALL_TILE) + 1,
            description="res_pixels with two pixel lanes (the fast pipeline's): a flush sends "
            "two pixels a beat, each once, in raster order, from the pixel memories banked by "
            "column parity",
            lanes=2,
        ),
        TileProof(
            "res_pixels_scan",
            "resolve",
            ("pixels",),
            "prove",
            resolve_latency(SMALL_TILE, 2) + 1,
            description="res_pixels with four pixel lanes, two scan lanes and the products "
            "over two clocks (the fast pipeline's resolve): it takes a beat of two cells a "
            "clock, each composited in its lane and written to its pixel lane's memory (of the "
            "pair its column picks), and a flush sends four pixels a beat",
            lanes=4,
            scan_lanes=2,
            product_stages=2,
        ),
        TileProof(
            "acc_stream_scan4",
            "accumulator",
            ("stream",),
            "prove",
            1,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="cells hold rule with four scan lanes (beats of four cells from the "
            "memories banked by column modulo 4), any reachable state (k-induction), default "
            "tile",
            scan_lanes=4,
        ),
        TileProof(
            "acc_deltas_scan4",
            "accumulator",
            ("deltas",),
            "prove",
            2,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="acc_deltas with four scan lanes: a beat's cells taken a cell a bank a "
            "clock, each cell kept sent once per end in its beat of four",
            scan_lanes=4,
        ),
        TileProof(
            "acc_sums_scan4",
            "accumulator",
            ("sums",),
            "prove",
            2,
            TileConfig(),
            reset=True,
            memory_map=False,
            description="acc_sums with four scan lanes: the accumulation memory in four banks "
            "by column modulo 4, the cells of a beat at one cell added, each cell's sum in its "
            "lane of the beat",
            scan_lanes=4,
        ),
        TileProof(
            "res_pixels_scan4",
            "resolve",
            ("pixels",),
            "prove",
            resolve_latency(SMALL_TILE, 2) + 1,
            description="res_pixels with four pixel lanes, four scan lanes and the products "
            "over two clocks: a beat of four cells a clock, each composited in its lane",
            lanes=4,
            scan_lanes=4,
            product_stages=2,
        ),
        *(
            TileProof(
                f"{name}_cover",
                stage,
                (check,),
                "cover",
                depth,
                reset=stage == "accumulator",  # the clear pass's invariants reached too
                description=f"each invariant of {name} (an implication) has its premise reached "
                "with its conclusion (not vacuous; cover from power-on, with resets for the "
                "accumulator)",
                lanes=lanes,
                scan_lanes=scan,
                product_stages=stages,
                # four scan lanes: a row of two beats, so that one can stop before the last
                tile=WIDE_TILE if (stage, scan) == ("accumulator", 4) else SMALL_TILE,
            )
            for name, stage, check, depth, lanes, scan, stages in (
                ("acc_deltas", "accumulator", "deltas", 16, 1, 1, 1),
                ("acc_sums", "accumulator", "sums", 16, 1, 1, 1),
                ("acc_deltas_scan", "accumulator", "deltas", 16, 1, 2, 1),
                ("acc_sums_scan", "accumulator", "sums", 16, 1, 2, 1),
                ("res_pixels", "resolve", "pixels", 14, 1, 1, 2),
                ("res_pixels_lanes", "resolve", "pixels", 14, 2, 1, 1),
                ("res_pixels_scan", "resolve", "pixels", 14, 4, 2, 2),
                ("acc_deltas_scan4", "accumulator", "deltas", 16, 1, 4, 1),
                ("acc_sums_scan4", "accumulator", "sums", 16, 1, 4, 1),
                ("res_pixels_scan4", "resolve", "pixels", 14, 4, 4, 2),
            )
        ),
    )
}


def _lookup(proof) -> TileProof:
    if isinstance(proof, TileProof):
        return proof
    try:
        return TILE_PROOFS[proof]
    except KeyError:
        names = ", ".join(TILE_PROOFS)
        raise ValueError(f"proof must be one of {names} or a TileProof, not {proof!r}") from None


def run_tile_proof(
    proof,
    *,
    tile: TileConfig | None = None,
    fault: str | None = None,
    depth: int | None = None,
    mode: str | None = None,
    solver: str = "yices",
    workdir=None,
    timeout: float | None = None,
    tail: int = 40,
    invariants: bool = True,
) -> FormalResult:
    """Build the harness of `proof` (a `TILE_PROOFS` name or a `TileProof`), run sby, return
    the result (`edgeaa.sim.verification.formal.run.run_proof`'s, for the tile stages).
    ``invariants``: `TileHarness`'s (off: the groups' own assertions only); in ``cover`` mode
    the harness covers each invariant's premise (`TileHarness` ``covers``)."""
    proof = _lookup(proof)
    mode, depth = mode or proof.mode, proof.depth if depth is None else depth
    tools = find_tools(solver)
    harness = TileHarness(
        tile or proof.tile,
        proof.stage,
        proof.checks,
        reset=proof.reset,
        fault=fault,
        invariants=invariants,
        covers=mode == "cover",
        lanes=proof.lanes,
        scan_lanes=proof.scan_lanes,
        product_stages=proof.product_stages,
    )
    script = sby_script(mode, depth, solver=solver)
    if proof.memory_map:  # the memories as flip-flops: faster for the small tiles
        script = script.replace("prep -top formal_top", "prep -top formal_top\nmemory_map")
    return run_harness(
        proof.name, fault, harness, script, tools, mode, depth, workdir, timeout, tail
    )


def main(argv=None) -> int:
    """``python -m edgeaa.sim.verification.formal.tile [proof ...]``."""
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m edgeaa.sim.verification.formal.tile",
        description="Formal proofs of the tile stages.",
        epilog="proofs: " + ", ".join(f"{p.name} ({p.description})" for p in TILE_PROOFS.values()),
    )
    parser.add_argument("proofs", nargs="*", default=list(TILE_PROOFS))
    parser.add_argument("--fault", choices=tuple(TILE_FAULTS))
    parser.add_argument("--depth", type=int)
    parser.add_argument("--mode", choices=("prove", "bmc", "cover"))
    parser.add_argument("--workdir", help="keep the runs in WORKDIR/<proof>")
    parser.add_argument("--timeout", type=float)
    parser.add_argument(
        "--no-invariants",
        dest="invariants",
        action="store_false",
        help="the groups' own assertions only (not inductive)",
    )
    args = parser.parse_args(argv)
    unknown = [name for name in args.proofs if name not in TILE_PROOFS]
    if unknown:  # one line, exit status 2 (not a traceback)
        parser.error(f"no proof named {unknown[0]!r}: {', '.join(TILE_PROOFS)}")
    return report(
        run_tile_proof(
            name,
            fault=args.fault,
            depth=args.depth,
            mode=args.mode,
            workdir=Path(args.workdir) / name if args.workdir else None,
            timeout=args.timeout,
            invariants=args.invariants,
        )
        for name in args.proofs
    )


if __name__ == "__main__":
    raise SystemExit(main())
