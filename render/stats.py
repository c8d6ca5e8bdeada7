"""What skipping saves: a render without skipping beside one with it (`edgeaa render --stats`).

Cycles are the timing model's (first command to last write, back-to-back source, ready
sink) for every engine, so the model engine reports them too; the saving of each rule is
measured alone, as the cycles of the full edge list minus the cycles without that rule's
edges, or (clipping) with every edge clipped to the image (the saves do not add up exactly:
short edges are setup-bound and long ones stepping-bound).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model import setup
from .engines import cycles
from .render import Render


@dataclass(frozen=True)
class RuleSaving:
    rule: str
    edges: int
    cycles: int  # saved, alone
    engine_writes: int  # engine writes not produced


def _writes_per_edge(result: Render, count: int) -> np.ndarray:
    run = result.engine_run
    return np.bincount(result.sent[run.edge_index], minlength=count)


def rule_savings(baseline: Render, skipping: Render) -> list[RuleSaving]:
    plan = baseline.plan
    config = plan.config
    per_edge = _writes_per_edge(baseline, plan.edge_count)
    everything = [int(e) for e in baseline.sent]
    total = cycles(config, [plan.edge(e) for e in everything])
    groups = (
        ("polygons equal to the background (I_in = I_out)", skipping.skipped_equal),
        ("edges wholly outside the viewport (culled)", skipping.culled),
        ("horizontal / vertical edges (fill path)", skipping.fill_path),
    )
    out = []
    for label, ids in groups:
        drop = set(int(e) for e in ids)
        rest = [plan.edge(e) for e in everything if e not in drop]
        out.append(
            RuleSaving(label, len(drop), total - cycles(config, rest), int(per_edge[ids].sum()))
        )
    clipped = [plan.edge(e, clip=True) for e in everything]
    cut_edges, cut_writes = _clipped_writes(baseline)
    out.append(
        RuleSaving(
            "edges partly outside (clipped in setup)",
            cut_edges,
            total - cycles(config, clipped),
            cut_writes,
        )
    )
    return out


def _clipped_writes(baseline: Render) -> tuple[int, int]:
    """Edges of an unclipped render with writes in columns the viewport clip removes, and
    how many such writes (the major-axis coordinate of the write outside the image)."""
    plan, run = baseline.plan, baseline.engine_run
    clip = plan.viewport
    x_major = np.array([setup(plan.config, plan.edge(int(e))).x_major for e in baseline.sent])
    if not len(run):
        return 0, 0
    xm = x_major[run.edge_index]
    major = np.where(xm, run.x, run.y)
    lo = np.where(xm, clip.x_min, clip.y_min)
    hi = np.where(xm, clip.x_max, clip.y_max)
    cut = (major < lo) | (major > hi)
    return len(np.unique(run.edge_index[cut])), int(cut.sum())


def _ratio(a: float, b: float) -> str:
    return f"{b / a:8.3f}" if a else "       -"


def stats_report(baseline: Render, skipping: Render) -> str:
    plan = baseline.plan
    same = np.array_equal(baseline.image, skipping.image)
    lines = [
        "",
        f"skipping: {plan.scene.name}, {baseline.engine} engine (without = every boundary edge "
        "to the engine, every write applied, each polygon composited over the whole image)",
        f"{'':34} {'without':>11} {'with':>11} {'with/without':>12}",
    ]

    def row(label, a, b, fmt="{:11,d}"):
        lines.append(f"{label:34} {fmt.format(a)} {fmt.format(b)} {_ratio(a, b):>12}")

    row("edges to the engine", len(baseline.sent), len(skipping.sent))
    row("cycles (timing model)", baseline.cycles, skipping.cycles)
    if baseline.engine_run.clocks is not None:
        row("clocks simulated (with drain)", baseline.engine_run.clocks, skipping.engine_run.clocks)
    row("engine writes", baseline.engine_writes, skipping.engine_writes)
    row("fill-path writes", baseline.fill_path_writes, skipping.fill_path_writes)
    applied_b = len(baseline.writes) - baseline.not_applied
    applied_s = len(skipping.writes) - skipping.not_applied
    row("writes applied to the image", applied_b, applied_s)
    row("pixel stores", baseline.pixel_stores, skipping.pixel_stores)
    row("pixels touched", baseline.pixels_touched, skipping.pixels_touched)
    row("engine time (s)", baseline.engine_run.seconds, skipping.engine_run.seconds, "{:11.3f}")
    row("render time (s)", baseline.seconds, skipping.seconds, "{:11.3f}")
    lines.append(f"images identical: {'yes' if same else 'NO'}")
    lines.append("")
    lines.append(f"{'saving of each rule alone':50} {'edges':>6} {'cycles':>8} {'writes':>8}")
    for saving in rule_savings(baseline, skipping):
        lines.append(
            f"{saving.rule:50} {saving.edges:6d} {saving.cycles:8,d} {saving.engine_writes:8,d}"
        )
    boundary_axis = int((plan.pixel_boundary & plan.boundary)[skipping.fill_path].sum())
    lines.append(f"  of the fill-path edges, on pixel boundaries: {boundary_axis}")
    zero = skipping.zero_writes
    lines.append(
        f"{'writes equal to the fill (not applied)':50} {'':6} {'':8} {skipping.not_applied:8,d}"
    )
    lines.append(f"  of all {len(skipping.writes):,} writes in the image; coverage 0: {zero:,}")
    lines.append(
        f"{'not a boundary by the fill rule (never sent)':50} {int((~plan.boundary).sum()):6d}"
    )
    partly = _partly_outside(skipping)
    lines.append(
        f"left: {partly[1]:,} writes of {partly[0]} clipped edges land off the image on their "
        "minor axis (the core clips the major axis only; the renderer drops them)"
    )
    return "\n".join(lines)


def _partly_outside(result: Render) -> tuple[int, int]:
    """Edges sent that still write off the image, and how many such writes."""
    plan, run = result.plan, result.engine_run
    ox, oy = plan.offset
    x, y = run.x - ox, run.y - oy
    off = (x < 0) | (x >= plan.scene.width) | (y < 0) | (y >= plan.scene.height)
    return len(np.unique(run.edge_index[off])), int(off.sum())
