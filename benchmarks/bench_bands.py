"""Whether rendering the bands of rows (`render/bands.py`) in parallel pays: the bands of a
model render one after the other, in threads, and in forked processes writing into a shared
image, wall and CPU seconds (the processes' own included), the median over `--repeats`, the
images checked equal (`edgeaa render --workers N` renders them in threads; one by default,
docs/results.md section 7 says why).

    python benchmarks/bench_bands.py SCENE.json [...] [--workers 2] [--repeats 5]
"""

from __future__ import annotations

import argparse
import mmap
import os
import resource
import statistics
import time

import numpy as np

from edgeaa.model import EdgeConfig
from edgeaa.render import render as renderer
from edgeaa.render.scene import load_scene


def render_bands(plan, workers: int, how: str) -> tuple[np.ndarray, int]:
    """The image of `plan` with its bands rendered by `how`: "serial" and "threads" are
    `render_scene` with one and `workers` threads; "processes" forks `workers` children
    that render every workers-th band into a shared image. And the number of bands."""
    if how != "processes":
        result = renderer.render_scene(plan, workers=workers if how == "threads" else 1)
        return result.image, result.bands
    sent = renderer.edges_to_send(plan, True)["sent"]
    height, width = plan.scene.height, plan.scene.width
    shared = mmap.mmap(-1, height * width)  # anonymous and shared: forked children write here
    image = np.frombuffer(shared, dtype=np.uint8).reshape(height, width)
    image[:] = plan.scene.background
    bands = renderer._bands(plan, sent, None)
    windows = np.array([p.window for p in plan.polygons], dtype=np.int64).reshape(-1, 4)
    children = []
    for k in range(workers):
        pid = os.fork()
        if pid == 0:  # the child: every workers-th band, then out without cleanup
            for band in bands[k::workers]:
                renderer._render_band(plan, windows, image, "model", True, None, None, 2, band)
            os._exit(0)
        children.append(pid)
    for pid in children:
        os.waitpid(pid, 0)
    return image.copy(), len(bands)


def children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="+")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    if args.workers < 2 or args.repeats < 1:
        parser.error("--workers is at least 2 and --repeats at least 1")
    renderer.keep_freed_memory()  # as `edgeaa render` does
    print(f"{'scene':24} {'bands':>5} {'how':10} {'wall ms':>8} {'CPU ms':>8}")
    for path in args.scenes:
        plan = renderer.plan_scene(load_scene(path), EdgeConfig())
        reference, _ = render_bands(plan, 1, "serial")
        figures = {how: ([], []) for how in ("serial", "threads", "processes")}
        for _ in range(args.repeats):
            for how, (walls, cpus) in figures.items():  # interleaved: the load drifts
                wall, cpu, kids = time.perf_counter(), time.process_time(), children_cpu()
                image, bands = render_bands(plan, args.workers, how)
                walls.append(time.perf_counter() - wall)
                cpus.append(time.process_time() - cpu + children_cpu() - kids)
                if not np.array_equal(image, reference):
                    raise SystemExit(f"{path}: the {how} image differs")
        for how, (walls, cpus) in figures.items():
            wall, cpu = 1000 * statistics.median(walls), 1000 * statistics.median(cpus)
            print(f"{path[-24:]:24} {bands:5d} {how:10} {wall:8.0f} {cpu:8.0f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
