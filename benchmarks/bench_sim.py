"""Simulated clocks per second: Amaranth's Python simulator against the compiled Verilator run.

Both simulators run the same seeded edges on the same core (default configuration unless
given) and must produce the same beats; the compiled run then also runs a long stream to
show its steady-state rate. The build is cached and excluded from the timings.

    python benchmarks/bench_sim.py [--edges 40] [--long-edges 20000] [--seed 1]
"""

from __future__ import annotations

import argparse
import platform
import sys

from edgeaa.model import EdgeConfig
from edgeaa.sim.simulators import amaranth_sim, verilator_harness
from edgeaa.sim.verification.workloads import random_sim_edges


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--edges", type=int, default=40, help="edges for both simulators")
    parser.add_argument("--long-edges", type=int, default=20000, help="edges, compiled only")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    config = EdgeConfig()
    edges = random_sim_edges(config, args.edges, args.seed, max_pixels=64)
    print(f"core: {config}; machine: {platform.machine()}, {platform.python_version()}")
    print("building the Verilated harness (cached) ...", file=sys.stderr)
    verilator_harness.build(config)

    def progress(done, total):
        print(f"\ramaranth: {done}/{total} edges", end="", file=sys.stderr, flush=True)

    slow = amaranth_sim.run(config, edges, progress=progress)
    print(file=sys.stderr)
    fast = verilator_harness.run(config, edges)
    if not (slow.beats == fast.beats).all():
        print("the two simulators disagree", file=sys.stderr)
        return 1
    long = verilator_harness.run(
        config, random_sim_edges(config, args.long_edges, args.seed, max_pixels=64)
    )
    print(f"{'simulator':26} {'edges':>7} {'clocks':>10} {'seconds':>8} {'clocks/s':>12}")
    for name, count, run in (
        ("amaranth (pysim)", args.edges, slow),
        ("verilator (same edges)", args.edges, fast),
        ("verilator (long stream)", args.long_edges, long),
    ):
        print(
            f"{name:26} {count:7d} {run.clocks:10d} {run.seconds:8.3f} "
            f"{run.clocks_per_second:12,.0f}"
        )
    ratio = long.clocks_per_second / slow.clocks_per_second
    print(f"compiled / Python simulator: {ratio:,.0f}x clocks per second")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
