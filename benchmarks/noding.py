"""Speed of split_crossings against its earlier quadratic form, and the error of rounding the
inserted crossing points to the vertex grid.

Not a test. Times the reference (tests/test_noding.py) and the current split_crossings on
seeded random n-vertex polygons, checks that both give the same output, prints a table and the
log-log slope of the new one, and measures the per-pixel coverage error of the rounding
(shapely, even-odd fill). Writes both tables into docs/noding.md between its markers.
Usage: python benchmarks/noding.py [--sizes 50,100,...] [--old-limit 20] [--no-write]
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
import time
from fractions import Fraction
from pathlib import Path

import numpy as np
import shapely
from doc_tables import write_section  # this folder: the script's own

from edgeaa.render import geometry
from edgeaa.render.geometry import split_crossings

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
from test_noding import reference_split_crossings  # noqa: E402

DOC = ROOT / "docs" / "noding.md"
SIZES = (50, 100, 200, 300, 500, 1000, 2000)


def soup(rng: np.random.Generator, n: int) -> np.ndarray:
    """Vertices uniform in a 256 px square (16 sub-pixel units per px): k ~ n**2 / 10."""
    return rng.integers(0, 4096, (n, 2))


def walk(rng: np.random.Generator, n: int) -> np.ndarray:
    """A closed random walk, steps up to 2.5 px: short edges, a few crossings per edge."""
    return np.cumsum(rng.integers(-40, 41, (n, 2)), axis=0) + 100000


def outline(rng: np.random.Generator, n: int) -> np.ndarray:
    """A wobbly closed curve flattened into n pieces (a glyph or curve): no crossings."""
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    r = 30000 * (1 + 0.1 * np.sin(5 * a + rng.random()))
    return np.stack([r * np.cos(a), r * np.sin(a)], axis=1).round() + 40000


def hatch(rng: np.random.Generator, n: int) -> np.ndarray:
    """A zigzag of n/4 parallel diagonal teeth 1250 px long: every two edges' boxes meet, yet
    only the closing edge crosses anything (the sweep's quadratic case)."""
    x = 4 * np.arange(n // 4)[:, None] + [0, 20000, 20002, 2] + int(rng.integers(0, 16))
    y = np.broadcast_to([0, 20000, 20000, 0], x.shape)
    return np.stack([x.ravel(), y.ravel()], axis=1)


FAMILIES = {"soup": soup, "walk": walk, "outline": outline, "hatch": hatch}


def timed(fn, contours) -> tuple[float, tuple]:
    """Best wall time of up to 5 runs within about a second, and the result."""
    best, spent, runs = math.inf, 0.0, 0
    while runs < 5 and (runs == 0 or spent < 1.0):
        start = time.perf_counter()
        result = fn(contours)
        took = time.perf_counter() - start
        best, spent, runs = min(best, took), spent + took, runs + 1
    return best, result


def same(a: tuple, b: tuple) -> bool:
    return a[1] == b[1] and [p.tolist() for p in a[0]] == [p.tolist() for p in b[0]]


def speed_rows(sizes, old_limit: float, seed: int) -> list[tuple]:
    """(family, n, crossings inserted, old s or None, new s, ratio) per family and size."""
    rows = []
    for name, make in FAMILIES.items():
        old_last = None
        for n in sizes:
            contours = [make(np.random.default_rng(seed + n), n).astype(np.int64)]
            new_s, new = timed(split_crossings, contours)
            old_s = None
            if old_last is None or old_last[1] * (n / old_last[0]) ** 2 < old_limit:
                old_s, old = timed(reference_split_crossings, contours)
                old_last = (n, old_s)
                assert same(old, new), f"{name} n={n}: outputs differ"
            ratio = old_s / new_s if old_s else None
            rows.append((name, n, new[1], old_s, new_s, ratio))
            print(f"{name:8s} {n:5d} {new[1]:8d} {_s(old_s):>9s} {_s(new_s):>9s} {_x(ratio)}")
    return rows


def _s(seconds: float | None) -> str:
    return "-" if seconds is None else f"{seconds:.4f}"


def _x(ratio: float | None) -> str:
    return "-" if ratio is None else f"{ratio:.1f}x"


def slope(rows, family: str, least: int = 200, column: int = 4) -> float:
    """Least-squares slope of log(row[column]) (new s) over log n for n >= least."""
    pts = [(math.log(r[1]), math.log(r[column])) for r in rows if r[0] == family and r[1] >= least]
    x, y = np.array(pts).T
    return float(np.polyfit(x, y, 1)[0])


# --- the rounding of inserted points ---------------------------------------------------------


def _exact_t(entry: tuple) -> tuple:
    return Fraction(entry[1], entry[2]), entry[3]


def moved_pieces(contour: np.ndarray) -> tuple[list[np.ndarray], int]:
    """Per edge with a rounded split point, the quads (E_k, E_k+1, R_k+1, R_k) between its
    exact pieces E and rounded pieces R (sub-pixel units); and the points inserted. The quads'
    boundaries add up to exact ring - rounded ring, so |w_exact - w_rounded| <= the sum of
    |w| over the quads, which bounds the coverage change under either fill rule."""
    seg = np.concatenate([contour, np.roll(contour, -1, axis=0)], axis=1)
    rows, splits = seg.tolist(), {}
    for i, j in geometry._candidate_pairs(seg):
        geometry._intersect(i, j, rows, splits)
    edges, inserted = [], 0
    for k, (ax, ay, bx, by) in enumerate(rows):
        exact, rounded = [(ax, ay)], [(ax, ay)]
        for _, num, den, point in sorted(splits.get(k, ()), key=_exact_t):
            t = Fraction(num, den)
            exact.append((float(ax + t * (bx - ax)), float(ay + t * (by - ay))))
            rounded.append(point)
        exact.append((bx, by))
        rounded.append((bx, by))
        inserted += len(exact) - 2
        e, r = np.array(exact, float), np.array(rounded, float)
        if np.any(e != r):
            edges.append(np.stack([e[:-1], e[1:], r[1:], r[:-1]], axis=1))
    return edges, inserted


def swept_per_pixel(quads: np.ndarray, S: int, reach: int | None = None) -> dict:
    """Area (px**2) of the quads of one edge in each pixel they meet (pixel (x, y) is the unit
    square centred on (x, y)); a self-crossing quad counts both lobes. With reach, only the
    pixels within reach of the split points (where the quads are widest)."""
    quads = quads / S
    ends = quads[1:, 0] if reach is not None else quads.reshape(-1, 2)
    lo = np.floor(ends.min(axis=0) + 0.5).astype(int) - (reach or 0)
    hi = np.floor(ends.max(axis=0) + 0.5).astype(int) + (reach or 0)
    xs, ys = np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1))
    xs, ys = xs.ravel(), ys.ravel()
    boxes = shapely.box(xs - 0.5, ys - 0.5, xs + 0.5, ys + 0.5)
    shapes = shapely.make_valid(shapely.polygons(quads), method="linework")
    area = np.zeros(len(boxes))
    for shape in shapes:
        area += shapely.area(shapely.intersection(shape, boxes))
    return {(x, y): a for x, y, a in zip(xs.tolist(), ys.tolist(), area.tolist(), strict=True)}


def rounding_rows(S: int, seeds: int) -> list[tuple]:
    """Per family of small dense polygons: polygons, points inserted, the largest area one
    edge's moved pieces sweep in a pixel (times S: the bound is 1) and in a pixel by all
    edges together."""
    makers = {
        "star, 7-15 vertices in 8 px": lambda rng: _star(rng, 8 * S),
        "soup, 10 vertices in 6 px": lambda rng: rng.integers(0, 6 * S, (10, 2)),
    }
    rows = []
    for name, make in makers.items():
        per_edge = per_pixel = 0.0
        inserted = 0
        for seed in range(seeds):
            edges, count = moved_pieces(make(np.random.default_rng(seed)).astype(np.int64))
            inserted += count
            total: dict = {}
            for quads in edges:
                for px, a in swept_per_pixel(quads, S).items():
                    per_edge = max(per_edge, a)
                    total[px] = total.get(px, 0.0) + a
            per_pixel = max([per_pixel, *total.values()])
        rows.append((name, seeds, inserted, per_edge * S, per_pixel))
    return rows


def _star(rng: np.random.Generator, size: int) -> np.ndarray:
    n = int(rng.integers(7, 16))
    m = int(rng.integers(2, (n + 1) // 2))
    a = 2 * np.pi * m * np.arange(n) / n + rng.normal(0, 0.05, n)
    r = size / 2 * (0.7 + 0.3 * rng.random(n))
    return np.stack([np.cos(a) * r, np.sin(a) * r], axis=1).round().astype(np.int64) + size // 2


def worst_single_edge(S: int, trials: int, seed: int) -> tuple[float, list]:
    """The largest area (times S) one rounded crossing makes a long edge sweep in a pixel, over
    random near-45-degree edges from a pixel corner (the worst case) and random crossers."""
    rng = np.random.default_rng(seed)
    best = (0.0, [])
    for _ in range(trials):
        p = np.full(2, -int(rng.integers(32, 64)) * S + S // 2) + [0, int(rng.integers(-2, 3))]
        u = int(rng.integers(64 * S, 128 * S))
        q = p + [u, u + int(rng.integers(-3, 4))]
        c = rng.integers(-2 * S, 2 * S, 2) + [2 * S, -2 * S]
        d = c + rng.integers(-2 * S, 2 * S, 2) - [4 * S, -4 * S]
        contour = np.array([p, q, c, d], dtype=np.int64)
        edges, _ = moved_pieces(contour)
        for quads in edges[:1]:
            if np.array_equal(quads[0, 0], p):  # the long edge p -> q
                area = max(swept_per_pixel(quads, S, reach=2).values()) * S
                if area > best[0]:
                    best = (area, contour.tolist())
    return best


def tie_example(S: int, half_length: int = 4096) -> float:
    """Area (times S) swept in a pixel by the 45-degree edge x + y = S of a long X whose other
    edge, x - y = 1, crosses it at (S/2 + 1/2, S/2 - 1/2), a tie rounded up by (1/2, 1/2)."""
    h, c = S // 2, half_length
    contour = np.array([[h - c, h + c], [h + c, h - c], [c, c - 1], [-c, -c - 1]], np.int64)
    edges, _ = moved_pieces(contour)
    return max(max(swept_per_pixel(q, S, reach=2).values()) for q in edges) * S


# --- the report -------------------------------------------------------------------------------


def speed_table(rows) -> list[str]:
    lines = [
        "| polygon | n | inserted | old s | new s | old / new |",
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for f, n, k, old_s, new_s, ratio in rows:
        lines.append(f"| {f} | {n} | {k} | {_s(old_s)} | {_s(new_s)} | {_x(ratio)} |")
    lines.append("")
    for f in FAMILIES:
        line = f"- {f}: new time ~ n^{slope(rows, f):.2f} (least squares, n >= 200)"
        if all(k for g, _, k, *_ in rows if g == f):
            line += f"; points inserted ~ n^{slope(rows, f, column=2):.2f}"
        lines.append(line)
    return lines


def rounding_table(rows, S: int, worst: tuple) -> list[str]:
    lines = [
        f"S = {S}. Largest area swept in one pixel by the moved pieces of one edge (times S, "
        "bound 1) and by all edges together (px^2):",
        "",
        "| polygons | count | points inserted | one edge x S | all edges |",
        "| --- | ---: | ---: | ---: | ---: |",
    ]
    for name, count, inserted, per_edge, per_pixel in rows:
        lines.append(f"| {name} | {count} | {inserted} | {per_edge:.3f} | {per_pixel:.4f} |")
    lines += [
        "",
        f"- The tie example (two 45-degree edges 512 px long): {tie_example(S):.4f} / S px^2.",
        f"- Random long near-45-degree edges from pixel corners, random crossers: at most "
        f"{worst[0]:.4f} / S, contour {worst[1]}.",
    ]
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default=",".join(map(str, SIZES)))
    parser.add_argument("--old-limit", type=float, default=20.0, help="s, predicted")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--subpixel-scale", type=int, default=16)
    parser.add_argument("--polygons", type=int, default=200, help="per rounding family")
    parser.add_argument("--trials", type=int, default=5000, help="single-crossing search")
    parser.add_argument("--no-write", action="store_true", help="print only")
    args = parser.parse_args()
    sizes = [int(v) for v in args.sizes.split(",")]
    print(f"{'polygon':8s} {'n':>5s} {'inserted':>8s} {'old s':>9s} {'new s':>9s} old/new")
    rows = speed_rows(sizes, args.old_limit, args.seed)
    table = speed_table(rows)
    print("\n".join(table[-len(FAMILIES) :]))
    S = args.subpixel_scale
    worst = worst_single_edge(S, args.trials, args.seed)
    rounding = rounding_table(rounding_rows(S, args.polygons), S, worst)
    print("\n".join(rounding))
    if args.no_write:
        return
    command = "python benchmarks/noding.py " + " ".join(sys.argv[1:])
    machine = f"{platform.processor() or platform.machine()}, Python {platform.python_version()}"
    write_section(DOC, "speed", [f"`{command.strip()}` ({machine}):", "", *table])
    write_section(DOC, "rounding", [f"`{command.strip()}`:", "", *rounding])
    print(f"wrote {DOC.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
