"""Speed of the step model against the vectorized model on the same seeded random edges.

Not a test: prints writes per second of each (wall clock, and per CPU second, which is steadier
on a shared machine) and their ratio, and checks that both produced the same writes.
Usage: python benchmarks/bench_model.py [--edges 2000] [--seed 1] [--mode paper]
"""

from __future__ import annotations

import argparse
import random
import time

from edgeaa.model.config import ACCUMULATORS, MODES, EdgeConfig
from edgeaa.model.edge import Edge
from edgeaa.model.step import run_edge
from edgeaa.model.vector import run_edges


def random_full_range_edges(config: EdgeConfig, count: int, seed: int) -> list[Edge]:
    """Vertices uniform over the whole coordinate range; intensities and side random."""
    rng = random.Random(seed)
    hi, fs = config.max_vertex, config.full_scale
    edges = []
    while len(edges) < count:
        x0, y0, x1, y1 = (rng.randint(0, hi) for _ in range(4))
        i_in, i_out = rng.randint(0, fs), rng.randint(0, fs)
        if (x0, y0) == (x1, y1) or i_in == i_out:
            continue
        edges.append(Edge(x0, y0, x1, y1, rng.choice(["left", "right"]), i_in, i_out))
    return edges


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--edges", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--mode", choices=MODES, default="paper")
    parser.add_argument("--accumulator", choices=ACCUMULATORS, default="exact")
    args = parser.parse_args()
    config = EdgeConfig(mode=args.mode, accumulator=args.accumulator)
    edges = random_full_range_edges(config, args.edges, args.seed)

    # The vector model runs first: timed after the step model, the garbage collector would
    # walk the step model's millions of Write tuples during it.
    start, cpu = time.perf_counter(), time.process_time()
    batch = run_edges(config, edges)
    vector_seconds, vector_cpu = time.perf_counter() - start, time.process_time() - cpu

    start, cpu = time.perf_counter(), time.process_time()
    step_writes = [tuple(w) for edge in edges for w in run_edge(config, edge).writes]
    step_seconds, step_cpu = time.perf_counter() - start, time.process_time() - cpu

    columns = (batch.x, batch.y, batch.value, batch.area)
    vector_writes = list(zip(*(column.tolist() for column in columns), strict=True))
    identical = vector_writes == step_writes
    writes = len(step_writes)
    print(f"config {config}")
    print(f"{len(edges)} edges (seed {args.seed}), {writes} writes, identical: {identical}")
    for name, seconds, cpu in (
        ("step model:  ", step_seconds, step_cpu),
        ("vector model:", vector_seconds, vector_cpu),
    ):
        print(
            f"{name} {seconds:8.3f} s wall {writes / seconds:12,.0f} writes/s   "
            f"({cpu:.3f} s CPU, {writes / cpu:12,.0f} writes/CPU-s)"
        )
    print(
        f"speed-up:     {step_seconds / vector_seconds:8.1f}x wall, "
        f"{step_cpu / vector_cpu:.1f}x CPU"
    )
    if not identical:
        raise SystemExit("the vectorized model's writes differ from the step model's")


if __name__ == "__main__":
    main()
