"""`edgeaa verify` throughput: edges per second on 1 and 2 local worker processes, and the
projected time of 10^9 edges on one core.

Each worker count gets its own pool, warmed up with one small shard per worker (process start
and imports excluded), then runs the same seeded plan as `edgeaa verify --edges N --seed S`.
The compiled core's build is cached and excluded. Where a worker's time goes is split into the
simulation (the Verilated harness) and the rest (drawing the edges, the model, the checks).

    python benchmarks/bench_verify.py [--edges 20000] [--workers 1 2] [--seed 1] [--profile]

`--profile` also profiles one shard of 5000 edges in this process (cProfile) and prints the
share of its time in the main steps.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import platform
import pstats

from edgeaa.model import EdgeConfig
from edgeaa.sim.verification import records, regress
from edgeaa.sim.verification.shards import CompiledCore, ShardTask, check_shard, default_shards

PROJECTED_EDGES = 10**9
# The steps a shard's time goes to (function names; cumulative times overlap: `setup` is
# called inside the others).
PROFILED = ("iter_sim_edges", "random_clip", "run_edges", "write_cycles", "setup", "run")


def measure(config: EdgeConfig, edges: int, seed: int, workers: int) -> dict:
    """One plan on a fresh, warmed-up pool of `workers` processes: the run's summary."""
    runner = regress.open_runner(config, "verilator", workers, cluster=None)
    try:
        warm_up = regress.Plan(config, 100 * workers, workers, seed + 1)
        regress.run_plan(warm_up, runner, records.ShardStore(None, warm_up.manifest()))
        plan = regress.Plan(config, edges, default_shards(edges), seed)
        summary = regress.run_plan(plan, runner, records.ShardStore(None, plan.manifest()))
    finally:
        runner.close()
    if not summary["passed"]:
        raise SystemExit(f"mismatches with {workers} workers: {summary['mismatches'][:3]}")
    return summary


def profile(config: EdgeConfig, seed: int) -> None:
    """Where one shard's time goes, in this process (the core built and warmed up first)."""
    core = CompiledCore.build(config)
    task = ShardTask(0, seed, 5000, config)
    check_shard(task, core)
    profiler = cProfile.Profile()
    profiler.runcall(check_shard, task, core)
    stats = pstats.Stats(profiler)
    print(f"one shard of {task.edges} edges, profiled: {stats.total_tt:.2f} s")
    for (path, _, name), (_, calls, _, cumulative, _) in stats.stats.items():
        if name in PROFILED:
            where = f"{os.path.basename(path)}:{name}"
            print(f"  {where:32} {calls:6d} calls {cumulative / stats.total_tt:5.0%}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--edges", type=int, default=20_000, help="edges per measurement")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="pool sizes")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--profile", action="store_true", help="also profile one shard")
    args = parser.parse_args()
    config = EdgeConfig()
    load = os.getloadavg()[0]
    print(f"core: {config}")
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, Python "
        f"{platform.python_version()}, load average {load:.2f} at the start"
    )
    print(
        f"{'workers':>7} {'edges':>8} {'seconds':>8} {'edges/s':>9} {'per worker':>10} "
        f"{'in sim':>7} {'10^9 edges, 1 core':>19}"
    )
    for workers in args.workers:
        summary = measure(config, args.edges, args.seed, workers)
        rate = summary["edges_per_second"]
        per_worker = rate / workers
        sim_share = summary["sim_seconds"] / summary["worker_seconds"]
        hours = PROJECTED_EDGES / per_worker / 3600
        print(
            f"{workers:7d} {summary['edges_run']:8d} {summary['seconds']:8.1f} {rate:9,.0f} "
            f"{per_worker:10,.0f} {sim_share:7.0%} {hours:17.1f} h"
        )
    if args.profile:
        profile(config, args.seed)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
