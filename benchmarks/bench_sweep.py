"""Planning one polygon whose edges all span the same rows or whose boxes all overlap: the
sweeps of `render/geometry.py` (issue 28) against the banded pairs and the box search they
replace on such polygons.

Not a test. Scenes: a radial star (n vertices alternating 240 px and 20 px from the centre:
every edge spans most rows, so the banded winding numbers' midpoint-edge pairs are
quadratic) and a diamond spiral (two interleaved square spirals joined at both ends, a
simple polygon whose edges' boxes nearly all overlap: the box search's quadratic case).
`plan_scene` CPU seconds (`time.process_time`, minimum over --repeats) with the sweeps
(SWEEP_PAIRS, SWEEP_BOXES as they are) and, up to --old-limit edges, without them (both set
past any count: the code before); the two plans must be the same edges and sides. Prints a
table and the log-log slope per family.

    python benchmarks/bench_sweep.py [--stars 1000,3000,9000] [--spirals 5000,10000,20000]
                                     [--old-limit 9000] [--repeats 3]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from edgeaa.analysis.report import machine_line, table
from edgeaa.model import EdgeConfig
from edgeaa.render import geometry, plan_scene
from edgeaa.render.scene import Polygon, Scene


def radial_star(n: int) -> Scene:
    a = 2 * np.pi * np.arange(n) / n
    r = np.where(np.arange(n) % 2 == 0, 240.0, 20.0)
    points = tuple(zip((256 + r * np.cos(a)).tolist(), (256 + r * np.sin(a)).tolist(), strict=True))
    return Scene(512, 512, (Polygon((points,), 255, "nonzero"),), 0, f"star {n}")


def diamond_spiral(n: int, radius: float = 900.0) -> Scene:
    """n edges: an arm out from the centre through the diamond's corners to `radius` px,
    and back in half a turn's step further out (every edge's box holds the centre)."""
    k = np.arange(n // 2)
    pitch = 4 * (radius - 2) / (n // 2)  # px a turn
    r = 2 + pitch * k / 4
    corner = np.array([(1, 0), (0, 1), (-1, 0), (0, -1)])[k % 4]
    out = corner * r[:, None]
    back = (corner * (r + pitch / 2)[:, None])[::-1]
    side = int(2 * (r[-1] + pitch)) + 8
    points = np.concatenate([out, back]) + side / 2
    polygon = Polygon((tuple(map(tuple, points.tolist())),), 255, "nonzero")
    return Scene(side, side, (polygon,), 0, f"spiral {n}")


def cpu(scene: Scene, repeats: int):
    best, plan = math.inf, None
    for _ in range(repeats):
        start = time.process_time()
        plan = plan_scene(scene, EdgeConfig())
        best = min(best, time.process_time() - start)
    return best, plan


def old_cpu(scene: Scene, repeats: int):
    saved = geometry.SWEEP_PAIRS, geometry.SWEEP_BOXES
    geometry.SWEEP_PAIRS = geometry.SWEEP_BOXES = 1 << 62
    try:
        return cpu(scene, repeats)
    finally:
        geometry.SWEEP_PAIRS, geometry.SWEEP_BOXES = saved


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stars", default="1000,3000,9000")
    parser.add_argument("--spirals", default="5000,10000,20000")
    parser.add_argument("--old-limit", type=int, default=9000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(machine_line())
    rows = []
    for make, sizes in ((radial_star, args.stars), (diamond_spiral, args.spirals)):
        xs, ys = [], []
        for n in map(int, sizes.split(",")):
            scene = make(n)
            new, plan = cpu(scene, args.repeats)
            old = "-"
            if n <= args.old_limit:
                seconds, before = old_cpu(scene, 1)
                same = np.array_equal(before.coords, plan.coords) and (
                    before.inside.tolist() == plan.inside.tolist()
                )
                if not same:
                    raise SystemExit(f"{scene.name}: the plans differ")
                old = f"{seconds:.3f}"
            xs.append(plan.edge_count)
            ys.append(new)
            rows.append(
                [scene.name, f"{plan.edge_count:,}", f"{plan.crossings}", old, f"{new:.3f}"]
            )
            print(*rows[-1], flush=True)
        fit = np.polyfit(np.log(xs), np.log(ys), 1)[0]
        rows.append([f"{make.__name__} slope", "", "", "", f"{fit:.2f}"])
    print(table(["scene", "edges", "crossings", "before s", "after s"], rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
