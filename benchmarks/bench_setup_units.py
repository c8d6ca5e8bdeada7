"""Columns and edges per clock by setup units: built-in text and starburst (the renderer's
deltas core, edges as `edgeaa render` sends them), random short edges (1-4 columns), long."""

import random

from edgeaa.model import Edge, EdgeConfig, setup, timing
from edgeaa.model.beat import DELTAS
from edgeaa.render.builtin import builtin
from edgeaa.render.render import plan_scene, render_scene

config = EdgeConfig()


def shapes_of(name):
    plan = plan_scene(builtin(name, config), config)
    result = render_scene(plan, engine="model", skip=True)
    shapes = []
    for e in result.sent:
        st = setup(config, plan.edge(int(e), clip=True))
        shapes.append((st.columns, st.clipped_start))
    return shapes


rng = random.Random(1)
S = config.subpixel_scale


def short_edges(n=2000):
    out = []
    for _ in range(n):
        c = rng.randint(1, 4)
        x = rng.randint(0, 2000)
        y = rng.randint(0, 2000)
        dy = rng.randint(-(c - 1) * S, (c - 1) * S)
        x0 = x * S
        x1 = x0 + max(1, (c - 1) * S)
        out.append(Edge(x0, y * S, x1, max(0, y * S + dy)))
    return out


streams = {}
for name in ("text", "starburst"):
    streams[name] = shapes_of(name)
se = short_edges()
streams["random 1-4 columns"] = [(setup(config, e).columns, False) for e in se]
streams["long (200 columns)"] = [(200, False)] * 50
for name, shapes in streams.items():
    cols = sum(c for c, _ in shapes)
    print(f"{name}: {len(shapes)} edges, {cols} columns, {cols / len(shapes):.2f} columns/edge")
    for units in (1, 2, 4, 9, 12):
        t = timing.schedule(config, shapes, fmt=DELTAS, setup_units=units)
        b = timing.clock_breakdown(t, timing.pipeline_depth(config, DELTAS))
        print(
            f"  units {units:2d}: {b.clocks:7d} clocks {b.columns_per_clock:.3f} col/clk "
            f"{b.edges_per_clock:.4f} edges/clk; setup-bound {b.setup_bound}, "
            f"stepping {b.stepping}, latency {b.latency}"
        )
