"""What skipping saves: a render without skipping beside one with it (`edgeaa render --stats`).

Cycles are the timing model's (first command to last beat, back-to-back source, ready
sink) for every engine, so the model engine reports them too; the saving of each rule is
measured alone, as the cycles of the full edge list minus the cycles without that rule's
edges, or (clipping, projection) with only that change made (the savings do not add up
exactly: short edges are setup-bound and long ones stepping-bound).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import setup
from ..model.beat import DELTAS
from ..model.timing import (
    DEFAULT_SETUP_UNITS,
    ClockBreakdown,
    clock_breakdown,
    pipeline_depth,
    write_cycles,
)
from .engines import cycles
from .render import Render


def _cycles(config, edges) -> int:
    """Cycles of the polygon renderer's core (the one emitting deltas)."""
    return cycles(config, edges, DELTAS)


@dataclass(frozen=True)
class RuleSaving:
    rule: str
    edges: int
    cycles: int  # saved, alone
    deltas: int  # nonzero deltas not produced


def rule_savings(baseline: Render, skipping: Render) -> list[RuleSaving]:
    """Each skipping rule's saving on its own, against the render without skipping."""
    plan = baseline.plan
    config = plan.config
    per_edge = np.bincount(baseline.deltas.edge, minlength=plan.edge_count)
    everything = [int(e) for e in baseline.sent]
    total = _cycles(config, [plan.edge(e) for e in everything])
    out = []
    for label, ids in (
        ("polygons equal to the background (I_in = I_out)", skipping.skipped_equal),
        ("edges above, below or right of the viewport (culled)", skipping.culled),
        ("horizontal edges (add nothing)", skipping.horizontal),
    ):
        drop = set(int(e) for e in ids)
        rest = [plan.edge(e) for e in everything if e not in drop]
        saved = int(per_edge[np.asarray(ids, dtype=np.int64)].sum())
        out.append(RuleSaving(label, len(drop), total - _cycles(config, rest), saved))
    projected = set(int(e) for e in skipping.projected)
    moved = [plan.edge(e, clip=e in projected) for e in everything]
    out.append(
        RuleSaving(
            "edges left of the viewport (projected to its edge)",
            len(projected),
            total - _cycles(config, moved),
            0,
        )
    )
    # An edge wholly left of the image, clipped, is its projection: not an edge cut in setup
    # (and a horizontal one would be of zero length).
    kept = [e for e in everything if e not in projected and not plan.left[e]]
    clipped = [plan.edge(e, clip=True) for e in kept]
    whole = [plan.edge(e) for e in kept]
    cut = sum(
        setup(config, a).columns != setup(config, b).columns
        for a, b in zip(clipped, whole, strict=True)
    )
    out.append(
        RuleSaving(
            "edges partly outside (clipped in setup)",
            cut,
            _cycles(config, whole) - _cycles(config, clipped),
            0,
        )
    )
    return out


def stats_numbers(result: Render) -> dict:
    """The figures of one render, for --stats and --json: besides the counts, the core's
    throughput (``columns_per_clock``, ``edges_per_clock``) and where its clocks went
    (``clocks_stepping``, ``clocks_setup_bound``: the stepper idle waiting for the next
    bank, ``clocks_latency``: before the first column and the pipeline after the last,
    ``clocks_stalled``: sink back-pressure, 0 for the timing model's ready sink), by the
    timing model with the core's default `setup_units`."""
    split = clock_split(result)
    return {
        "edges": len(result.sent),
        "columns": split.stepping,
        "cycles": result.cycles,
        "setup_units": DEFAULT_SETUP_UNITS,
        "columns_per_clock": round(split.columns_per_clock, 6),
        "edges_per_clock": round(split.edges_per_clock, 6),
        "clocks_stepping": split.stepping,
        "clocks_setup_bound": split.setup_bound,
        "clocks_latency": split.latency,
        "clocks_stalled": split.stalls,
        "deltas": result.delta_count,
        "rows_scanned": result.rows_scanned,
        "cells_scanned": result.cells_scanned,
        "pixel_stores": result.pixel_stores,
        "seconds": round(result.seconds, 6),
        "bands": result.bands,  # of rows (`render.bands`)
        "workers": result.workers,  # threads that rendered them
    }


def clock_split(result: Render) -> ClockBreakdown:
    """The timing model's clocks of the render's edges (the polygon core, as sent: clipped
    when skipping), split by `edgeaa.model.timing.clock_breakdown`."""
    plan = result.plan
    edges = [plan.edge(int(e), clip=result.skip) for e in result.sent]
    timings = write_cycles(plan.config, edges, fmt=DELTAS)
    split = clock_breakdown(timings, pipeline_depth(plan.config, DELTAS))
    if split.clocks != result.cycles:
        raise AssertionError(f"clock split {split.clocks} != render cycles {result.cycles}")
    return split


FLOAT = "{:11.3f}"


def _ratio(a: float, b: float) -> str:
    return f"{b / a:8.3f}" if a else "       -"


def stats_report(baseline: Render, skipping: Render) -> str:
    plan = baseline.plan
    same = np.array_equal(baseline.image, skipping.image)
    lines = [
        "",
        f"skipping: {plan.scene.name}, {baseline.engine} engine (without = every boundary edge "
        "to the engine unclipped, each polygon accumulated over the whole image); clocks: "
        f"timing model, deltas core with {DEFAULT_SETUP_UNITS} setup units",
        f"{'':34} {'without':>11} {'with':>11} {'with/without':>12}",
    ]

    def row(label, a, b, fmt="{:11,d}"):
        lines.append(f"{label:34} {fmt.format(a)} {fmt.format(b)} {_ratio(a, b):>12}")

    without, with_ = stats_numbers(baseline), stats_numbers(skipping)
    row("edges to the engine", without["edges"], with_["edges"])
    row("columns stepped", without["columns"], with_["columns"])
    row("cycles (timing model)", without["cycles"], with_["cycles"])
    row("columns per clock", without["columns_per_clock"], with_["columns_per_clock"], FLOAT)
    row("edges per clock", without["edges_per_clock"], with_["edges_per_clock"], FLOAT)
    row("  clocks stepping", without["clocks_stepping"], with_["clocks_stepping"])
    row("  clocks setup-bound", without["clocks_setup_bound"], with_["clocks_setup_bound"])
    row("  clocks latency", without["clocks_latency"], with_["clocks_latency"])
    row("  clocks stalled (sink)", without["clocks_stalled"], with_["clocks_stalled"])
    if baseline.deltas.clocks is not None:
        row("clocks simulated (with drain)", baseline.deltas.clocks, skipping.deltas.clocks)
    row("nonzero deltas", without["deltas"], with_["deltas"])
    row("buffer rows scanned", without["rows_scanned"], with_["rows_scanned"])
    row("buffer cells scanned", without["cells_scanned"], with_["cells_scanned"])
    row("pixel stores", without["pixel_stores"], with_["pixel_stores"])
    row("engine time (s)", baseline.engine_seconds, skipping.engine_seconds, "{:11.3f}")
    row("render time (s)", baseline.seconds, skipping.seconds, "{:11.3f}")
    lines.append(f"images identical: {'yes' if same else 'NO'}")
    lines.append("")
    lines.append(f"{'saving of each rule alone':54} {'edges':>6} {'cycles':>8} {'deltas':>8}")
    for saving in rule_savings(baseline, skipping):
        lines.append(f"{saving.rule:54} {saving.edges:6d} {saving.cycles:8,d} {saving.deltas:8,d}")
    lines.append(
        f"{'not a boundary by the fill rule (never sent)':54} {int((~plan.boundary).sum()):6d}"
    )
    return "\n".join(lines)
