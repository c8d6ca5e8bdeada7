"""Seeded edge streams for co-simulation and benchmarks (replayable from the seed alone)."""

from __future__ import annotations

import random

from ..model import Edge, EdgeConfig


def random_edges(
    config: EdgeConfig,
    count: int,
    seed: int,
    *,
    max_pixels: int = 48,
    bad_fraction: float = 0.0,
) -> list[Edge]:
    """`count` edges in all octants with sub-pixel endpoints, random sides and intensities.

    Major deltas are up to `max_pixels` pixels (the simulators' time goes into columns);
    about `bad_fraction` of the commands are bad (zero length or I_in == I_out), which the core
    must drop and count.
    """
    rng = random.Random(seed)
    hi = config.max_vertex
    span = min(hi, max_pixels * config.subpixel_scale)
    full = config.full_scale
    edges = []
    for _ in range(count):
        x0, y0 = rng.randint(0, hi), rng.randint(0, hi)
        x1 = min(hi, max(0, x0 + rng.randint(-span, span)))
        y1 = min(hi, max(0, y0 + rng.randint(-span, span)))
        i_in, i_out = rng.randint(0, full), rng.randint(0, full)
        if rng.random() < bad_fraction:
            if rng.random() < 0.5:
                x1, y1 = x0, y0
            else:
                i_out = i_in
        elif (x0, y0) == (x1, y1):
            x1 = x0 + 1 if x0 < hi else x0 - 1
        elif i_in == i_out:
            i_out = full - i_in if 2 * i_in != full else 0
        inside = rng.choice(("left", "right"))
        edges.append(Edge(x0, y0, x1, y1, inside=inside, i_in=i_in, i_out=i_out))
    return edges
