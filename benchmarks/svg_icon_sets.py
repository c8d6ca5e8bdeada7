"""The icon sets people use, from their SVG files: what loads, what is refused, and seg4's error
against the exact area beside resvg, AGG and Skia (docs/results.md, "SVG files").

The sets come from the npm registry (they are not on PyPI; the project does not ship them):

    npm install --prefix /tmp/icons bootstrap-icons heroicons @tabler/icons feather-icons
    python benchmarks/svg_icon_sets.py --root /tmp/icons [--size 48] [--sample 100] [--seed S]
        [--jobs N] [--write FILE]

Filled: Bootstrap Icons, Heroicons solid (24, 20 and 16 px), Tabler filled; outline (strokes):
Heroicons outline, Tabler outline, Feather. Every icon is read by `load_svg` as `edgeaa
render ICON.svg --size SxS` reads it (not lenient): loaded, or refused with its one-line
reason (grouped, the file's path and ids taken out). Of the loaded icons, all (`--sample 0`)
or a seeded sample of N per set (the seed is printed) is measured as `svg_accuracy.py`
measures a file (`outline_images`: paper, seg4, Skia, AGG and resvg on the same quantized
outlines, |image - exact| in LSB over the pixels an edge passes through), and the worst icon
for seg4 is named. `reading` compares how edgeaa and resvg read the SVG: resvg's own render of
the file (its parser, stroker and flattening; its alpha channel) against resvg's render of
edgeaa's outlines (`outline_svg`, white on black), both at 8 times the size and averaged over
each 8 x 8 block. Supersampled, neither counts twice the edge pixels where two elements
overlap (a round cap on a round join; at 1 x, composited element by element, both do), and
resvg's coverage in quarters of its pixel is 1/32 px here: up to 8 LSB where an edge
crosses a pixel, 16 for the two renders. edgeaa's vertices on the 1/16 px grid move an edge
by up to 1/32 px (8 LSB) and its chords lie within the 1/16 px tolerance where resvg's
flattening has its own, so where the two read the same outline they agree within about
40 LSB; a misread shape, stroke or cap gives more. It is taken on icons whose paints are all
opaque (then the alpha is the outlines' union either way): the largest difference (LSB) and
the largest ink difference in per cent of the icon's ink.
`--write FILE` writes one CSV row per measured icon.
"""

from __future__ import annotations

import argparse
import csv
import functools
import json
import multiprocessing
import os
import random
import re
import sys
import time

import numpy as np

from edgeaa.model import EdgeConfig
from edgeaa.progress import ProgressBar, duration
from edgeaa.render.scene import SceneError
from edgeaa.render.svg import load_svg

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from svg_accuracy import outline_images, outline_svg, resvg_image

# (set, kind, package, folder of its SVG files inside the package)
SETS = (
    ("Bootstrap Icons", "filled", "bootstrap-icons", "icons"),
    ("Heroicons 24 solid", "filled", "heroicons", "24/solid"),
    ("Heroicons 20 solid", "filled", "heroicons", "20/solid"),
    ("Heroicons 16 solid", "filled", "heroicons", "16/solid"),
    ("Tabler filled", "filled", "@tabler/icons", "icons/filled"),
    ("Heroicons outline", "outline", "heroicons", "24/outline"),
    ("Tabler outline", "outline", "@tabler/icons", "icons/outline"),
    ("Feather", "outline", "feather-icons", "dist/icons"),
)
METHODS = ("paper", "seg4", "Skia", "AGG", "resvg")
PACKAGES = ("bootstrap-icons", "heroicons", "@tabler/icons", "feather-icons")


def find_sets(root: str) -> list[tuple[str, str, str, list[str]]]:
    """Each set's name with its package's version, its kind and its files (sorted)."""
    modules = os.path.join(root, "node_modules")
    modules = modules if os.path.isdir(modules) else root
    out = []
    for name, kind, package, folder in SETS:
        where = os.path.join(modules, package)
        if not os.path.isfile(os.path.join(where, "package.json")):
            raise ValueError(
                f"--root {root}: no {package} there; install the sets "
                f"with npm install --prefix {root} {' '.join(PACKAGES)}"
            )
        with open(os.path.join(where, "package.json")) as meta:
            version = json.load(meta)["version"]
        folder = os.path.join(where, folder)
        files = sorted(os.path.join(folder, f) for f in os.listdir(folder) if f.endswith(".svg"))
        out.append((f"{name} {version}", kind, package, files))
    return out


def reason(error: SceneError, path: str) -> str:
    """A refusal's line without the file's path and ids, so that like refusals group."""
    text = str(error).replace(path, "FILE")
    return re.sub(r"id='[^']*'", "id=...", text)


SUPERSAMPLE = 8  # resvg's render of the file, per pixel and axis


def reading(scene, path: str, size: int, plan) -> tuple[np.ndarray, float] | None:
    """|resvg's alpha of the file - resvg's render of the outlines| per pixel, both
    supersampled, and the ink difference relative to the outlines' ink; None when a paint is
    translucent (the two then differ by the paints, not the reading)."""
    if any(p.paint is not None and p.paint[3] < 1 for p in scene.polygons):
        return None
    k = SUPERSAMPLE

    def down(image):
        return image.reshape(size, k, size, k).mean(axis=(1, 3))

    theirs = down(resvg_image(path=path, size=(size * k, size * k))[..., 3])
    ours = down(resvg_image(outline_svg(plan), size=(size * k, size * k))[..., 0])
    return np.abs(theirs - ours).ravel(), float((theirs.sum() - ours.sum()) / ours.sum())


def measure(path: str, size: int, config: EdgeConfig) -> dict[str, np.ndarray]:
    scene = load_svg(path, size=(size, size))
    plan, exact, edged, images = outline_images(scene, config)
    errors = {m: np.abs(images[m].astype(np.float64) - exact)[edged] for m in METHODS}
    apart = reading(scene, path, size, plan)
    errors["reading"] = apart
    return errors


def stats(values: list[np.ndarray]) -> str:
    if not values or not sum(map(len, values)):
        return f"{'-':>6} {'-':>5}"
    cells = np.concatenate(values)
    return f"{cells.max():6.2f} {np.sqrt(np.mean(cells**2)):5.2f}"


def reading_stats(rows) -> str:
    """The largest per-pixel difference (LSB) and the largest ink difference (per cent)."""
    apart = [errors["reading"] for _, errors in rows if errors["reading"] is not None]
    if not apart:
        return f"{'-':>6} {'-':>6}"
    return f"{max(a.max() for a, _ in apart):6.1f} {max(abs(i) for _, i in apart):6.2%}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", required=True, help="the npm prefix the sets are installed in")
    parser.add_argument("--size", type=int, default=48, help="icons drawn at SIZE x SIZE px")
    parser.add_argument("--sample", type=int, default=100, help="icons measured per set (0: all)")
    parser.add_argument("--seed", type=int, default=None, help="the sample's seed (default random)")
    parser.add_argument("--write", metavar="FILE", help="one CSV row per measured icon")
    parser.add_argument("--jobs", type=int, default=1, help="processes measuring (default 1)")
    args = parser.parse_args(argv)
    for name, least in (("size", 1), ("sample", 0), ("jobs", 1)):
        if getattr(args, name) < least:
            parser.error(f"--{name} must be at least {least}, not {getattr(args, name)}")
    try:
        sets = find_sets(args.root)
    except ValueError as error:
        parser.error(str(error))
    seed = args.seed if args.seed is not None else random.randrange(1 << 32)
    print(f"size {args.size} px; sample {args.sample or 'all'} per set; seed {seed}")
    config, rng, start = EdgeConfig(), random.Random(seed), time.perf_counter()
    refusals: dict[str, list[str]] = {}
    loaded = {}
    bar = ProgressBar("loading", sum(len(files) for *_, files in sets), unit="icons")
    for name, _, _, files in sets:
        loaded[name] = []
        for path in files:
            bar.step(name)
            try:
                load_svg(path, size=(args.size, args.size))
                loaded[name].append(path)
            except SceneError as error:
                refusals.setdefault(reason(error, path), []).append(path)
    bar.close()
    load_time = time.perf_counter() - start
    samples = {}
    for name, *_ in sets:
        count = len(loaded[name]) if args.sample == 0 else min(args.sample, len(loaded[name]))
        samples[name] = sorted(rng.sample(loaded[name], count))
    bar = ProgressBar("measuring", sum(map(len, samples.values())), unit="icons")
    results: dict[str, list[tuple[str, dict]]] = {name: [] for name, *_ in sets}
    jobs = [(name, path) for name, *_ in sets for path in samples[name]]
    with multiprocessing.Pool(args.jobs) as pool:
        work = functools.partial(measure, size=args.size, config=config)
        measured = pool.imap(work, [path for _, path in jobs], chunksize=4)
        for (name, path), errors in zip(jobs, measured, strict=True):
            bar.step(name)
            results[name].append((path, errors))
    bar.close()
    report(sets, loaded, refusals, results)
    if args.write:
        write_csv(args.write, results)
    print(f"loading {duration(load_time)}; measuring "
          f"{duration(time.perf_counter() - start - load_time)}")  # fmt: skip
    return 0


def report(sets, loaded, refusals, results) -> None:
    head = " ".join(f"{m:>12}" for m in METHODS)
    print(f"\n{'set':28} {'icons':>6} {'loaded':>6} {'measured':>8} {'edged':>7} {head}"
          f" {'reading':>13}")  # fmt: skip
    print(f"{'':59} " + " ".join(f"{'max':>6} {'RMS':>5}" for _ in METHODS) + "    max    ink")
    groups = {"all filled": [], "all outline": [], "all": []}
    counts = {g: [0, 0] for g in groups}
    for name, kind, _, files in sets:
        rows = results[name]
        line(name, len(files), len(loaded[name]), rows)
        for group in (f"all {kind}", "all"):
            groups[group] += rows
            counts[group][0] += len(files)
            counts[group][1] += len(loaded[name])
    for group, rows in groups.items():
        line(group, *counts[group], rows)
    print("\nworst icon per set: seg4's max (LSB) and reading's max (LSB)")
    for name, *_ in sets:
        if results[name]:
            path, errors = max(results[name], key=lambda r: r[1]["seg4"].max(initial=0))
            worst = f"  {name:28} {errors['seg4'].max(initial=0):6.2f} {os.path.basename(path):32}"
            read = [r for r in results[name] if r[1]["reading"] is not None]
            if read:
                path, errors = max(read, key=lambda r: r[1]["reading"][0].max())
                worst += f" {errors['reading'][0].max():6.1f} {os.path.basename(path)}"
            print(worst)
    if refusals:
        print(f"\nrefused: {sum(map(len, refusals.values()))}")
        for why, paths in sorted(refusals.items(), key=lambda r: -len(r[1])):
            print(f"  {len(paths):5} {why} (e.g. {os.path.basename(paths[0])})")
    else:
        print("\nrefused: none")


def line(name: str, icons: int, loaded: int, rows) -> None:
    edged = sum(len(errors["seg4"]) for _, errors in rows)
    cells = " ".join(stats([errors[m] for _, errors in rows]) for m in METHODS)
    print(
        f"{name:28} {icons:>6} {loaded:>6} {len(rows):>8} {edged:>7} {cells} {reading_stats(rows)}"
    )


def write_csv(path: str, results) -> None:
    with open(path, "w", newline="") as out:
        writer = csv.writer(out)
        head = [f"{m} {s}" for m in METHODS for s in ("max", "RMS")]
        writer.writerow(["set", "icon", *head, "reading max", "ink apart"])
        for name, rows in results.items():
            for icon, errors in rows:
                cells = []
                for m in METHODS:
                    v = errors[m]
                    cells += (
                        [f"{v.max():.3f}", f"{np.sqrt(np.mean(v**2)):.3f}"] if len(v) else ["", ""]
                    )
                apart = errors["reading"]
                cells += [f"{apart[0].max():.1f}", f"{apart[1]:.5f}"] if apart else ["", ""]
                writer.writerow([name, os.path.basename(icon)] + cells)


if __name__ == "__main__":
    raise SystemExit(main())
