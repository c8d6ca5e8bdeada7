"""Simulated clocks per second rendering the built-in scenes: compiled Verilator vs Amaranth.

For each scene, the edges the renderer sends to the engine (with skipping) run through the
compiled Verilator harness (`edgeaa.sim.simulators.verilator_harness.run`, the `verilator`
engine) and through Amaranth's Python simulator (`edgeaa.sim.simulators.amaranth_sim.run`,
the `amaranth` engine); both must
give the same beats, in the clocks the timing model predicts. A scene alone is a short run,
so process start-up weighs on the compiled rate; the scene repeated (`--repeat` frames as one
stream) shows the steady rate. The build is cached and excluded from the timings (`seconds`
is the harness process's wall time, start-up included); each compiled timing is the best
of `--tries`, since the machine may be shared.

    python benchmarks/bench_render.py [--scenes starburst,text] [--amaranth starburst,text]
                                      [--repeat 40] [--tries 3]

Target: at least 2 million simulated clocks per second on the default core.
"""

from __future__ import annotations

import argparse
import platform
import sys

import numpy as np

from edgeaa.model import EdgeConfig
from edgeaa.progress import ProgressBar
from edgeaa.render import builtin, plan_scene, render_scene
from edgeaa.render.engines import beat_clocks
from edgeaa.sim.simulators import amaranth_sim, verilator_harness

TARGET = 2_000_000


def best_run(config, edges, tries):
    runs = [verilator_harness.run(config, edges) for _ in range(tries)]
    return min(runs, key=lambda run: run.seconds)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", default="starburst,text")
    parser.add_argument("--amaranth", default="starburst,text", help="scenes for Amaranth too")
    parser.add_argument("--repeat", type=int, default=40, help="frames in the long stream")
    parser.add_argument("--tries", type=int, default=3)
    args = parser.parse_args()
    config = EdgeConfig()
    print(f"core: {config}; machine: {platform.machine()}, Python {platform.python_version()}")
    rows = []
    for name in args.scenes.split(","):
        plan = plan_scene(builtin(name, config), config)
        sent = render_scene(plan, engine="model").sent
        edges = [plan.edge(int(e), clip=True) for e in sent]
        print(f"{name}: {len(edges)} edges sent", file=sys.stderr)
        verilator_harness.build(config)  # cached
        fast = best_run(config, edges, args.tries)
        if not np.array_equal(fast.beats[:, 0], beat_clocks(config, edges)):
            print(f"{name}: beat clocks differ from the timing model", file=sys.stderr)
            return 1
        long = best_run(config, edges * args.repeat, args.tries)
        rows.append((name, "verilator", len(edges), fast))
        rows.append((name, f"verilator x{args.repeat}", len(edges) * args.repeat, long))
        if name in args.amaranth.split(","):
            bar = ProgressBar(f"amaranth {name}")
            slow = amaranth_sim.run(config, edges, progress=bar)
            bar.close()
            if not np.array_equal(slow.beats, fast.beats):
                print(f"{name}: the two simulators disagree", file=sys.stderr)
                return 1
            rows.append((name, "amaranth (pysim)", len(edges), slow))
    print(
        f"{'scene':10} {'simulator':20} {'edges':>6} {'clocks':>9} {'seconds':>8} {'clocks/s':>11}"
    )
    for name, label, count, run in rows:
        print(
            f"{name:10} {label:20} {count:6d} {run.clocks:9d} {run.seconds:8.3f} "
            f"{run.clocks_per_second:11,.0f}"
        )
    for name in args.scenes.split(","):
        mine = {label: run for n, label, _, run in rows if n == name}
        if "amaranth (pysim)" in mine:
            slow = mine["amaranth (pysim)"].clocks_per_second
            for label in ("verilator", f"verilator x{args.repeat}"):
                ratio = mine[label].clocks_per_second / slow
                print(f"{name}: {label} / amaranth = {ratio:,.0f}x clocks per second")
    best = max(run.clocks_per_second for _, label, _, run in rows if "verilator" in label)
    verdict = "met" if best >= TARGET else "NOT met"
    print(f"target {TARGET:,} clocks/s: best compiled rate {best:,.0f} ({verdict})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
