"""Figures and the one table of the seeds' methods beside edgeaa and the peers.

- `method_table` (`edgeaa plot aa-methods`): every method's max and RMS coverage error on the
  bench's random edges (as `edgeaa bench` measures them, output values), on the built-in
  text, starburst and hatch scenes (against shapely's exact composite, intensity LSB), its
  run time per image pixel on the starburst (this run, numpy or the peer's library) and the
  values a pixel holds before it is resolved.
- `taa_sequence` (`edgeaa plot taa`): the starburst turning by a fraction of a degree per
  frame, rendered per frame by point sampling, MSAA 4x, TAA (one jittered sample per frame,
  history carried across frames, with and without reprojection by the known rotation) and
  edgeaa (analytic, each frame on its own); per frame the
  RMS error against that frame's exact image, and the flicker: the RMS over pixels of the
  frame-to-frame change beyond the exact image's own change.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from ..model import EdgeConfig
from ..progress import ProgressBar
from ..render.builtin import builtin
from ..render.exact import exact_image
from ..render.render import plan_scene, render_scene
from ..render.scene import Polygon, Scene
from . import aa_methods, aa_scenes, compare, evaluate
from .bench import values_per_pixel
from .geometry import random_image_edges
from .report import fmt_float, pyplot, save, table

TABLE_METHODS = (
    "edgeaa-paper",
    "edgeaa-seg4",
    "point",
    "grid16",
    "msaa2",
    "rgss4",
    "rooks8",
    "quincunx",
    "flipquad",
    "mlaa",
    "mlaa-slope",
    "fxaa",
    "fxaa-geom",
    "taa",
    "skia",
    "agg",
)
LABELS = {"rgss4": "rgss4 (MSAA 4x)", "rooks8": "rooks8 (MSAA 8x)", "taa": "taa (still)"}
SEQUENCE_LABELS = {**LABELS, "taa": "TAA, reprojected", "taa-in-place": "TAA, no reprojection"}
SCENES = ("text", "starburst", "hatch")


def scene_image(plan, name: str) -> np.ndarray:
    mode = evaluate.mode_of(name)
    if mode:
        return render_scene(plan_scene(plan.scene, plan.config.with_(mode=mode))).image
    if name == "grid16":
        return compare.supersampled(plan)
    if name == "skia":
        return compare.skia_scene(plan)
    if name == "agg":
        return compare.agg_scene(plan)
    return aa_scenes.method_image(plan, name)


@dataclass
class TableRow:
    name: str
    edges: tuple[float, float]  # max, RMS (fraction of a pixel)
    scenes: dict[str, tuple[float, float]]  # scene -> max, RMS (intensity LSB)
    ns_per_pixel: float


def method_table(config: EdgeConfig, edges: int = 1000, seed: int = 1, progress: bool = True):
    bar = ProgressBar("aa-methods", enabled=progress)
    with bar.ticking("edges, scenes and exact areas"):
        edge_list = random_image_edges(config, edges, seed)
        pixels, batch = evaluate.pixel_set(config, edge_list)
        jobs = aa_methods.evaluate.peers.fill_jobs(config, edge_list, batch)
        plans = {name: plan_scene(builtin(name, config), config) for name in SCENES}
        exact = {name: exact_image(plan) for name, plan in plans.items()}
    bar(0, len(TABLE_METHODS))
    rows = []
    for name in TABLE_METHODS:
        with bar.doing(name):
            rows.append(_method_row(config, name, edge_list, pixels, jobs, plans, exact))
    return rows


def _method_row(config: EdgeConfig, name: str, edge_list, pixels, jobs, plans, exact):
    """One method's row of `method_table`: its error on the edges and on each scene."""
    run = aa_methods.run_method(config, edge_list, pixels, name, coverage="output", jobs=jobs)
    err = np.abs(run.coverage - pixels.exact)
    row = TableRow(name, (float(err.max()), float(np.sqrt(np.mean(err**2)))), {}, 0.0)
    for scene, plan in plans.items():
        start = time.perf_counter()
        image = scene_image(plan, name)
        seconds = time.perf_counter() - start
        e = np.abs(image - exact[scene])
        row.scenes[scene] = (float(e.max()), float(np.sqrt(np.mean(e**2))))
        if scene == "starburst":
            row.ns_per_pixel = seconds / image.size * 1e9
    return row


def table_text(rows: list[TableRow]) -> str:
    headers = ["method", "edges max", "edges RMS"]
    for scene in SCENES:
        headers += [f"{scene} max", f"{scene} RMS"]
    headers += ["ns/px", "values/px"]
    body = []
    for row in rows:
        cells = [LABELS.get(row.name, row.name), fmt_float(row.edges[0], 4)]
        cells.append(fmt_float(row.edges[1], 4))
        for scene in SCENES:
            cells += [f"{row.scenes[scene][0]:.1f}", f"{row.scenes[scene][1]:.2f}"]
        cells += [f"{row.ns_per_pixel:.0f}", f"{values_per_pixel(row.name):g}"]
        body.append(cells)
    return table(headers, body, align="l" + "r" * (len(headers) - 1))


def plot_table(rows: list[TableRow], path: str) -> None:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(12, 5))
    x = np.arange(len(rows))
    series = [("edges (x 255)", [r.edges[1] * 255 for r in rows])]
    series += [(scene, [r.scenes[scene][1] for r in rows]) for scene in SCENES]
    for k, (label, values) in enumerate(series):
        ax.bar(x + (k - 1.5) * 0.2, np.maximum(values, 1e-3), 0.2, label=label)
    ax.set_yscale("log")
    ax.set_xticks(x, [LABELS.get(r.name, r.name) for r in rows], rotation=45, ha="right")
    ax.set_ylabel("RMS error (intensity LSB of 255)")
    ax.legend(title="RMS error on", fontsize=8)
    ax.grid(True, axis="y", which="both", alpha=0.3)
    ax.set_title("Every method: RMS error on random edges and on the built-in scenes", fontsize=10)
    fig.tight_layout()
    save(fig, path)
    plt.close(fig)


# -- TAA on a turning starburst --------------------------------------------------------------------


def rotated(scene: Scene, degrees: float) -> Scene:
    """The scene turned about the image centre (vertices rounded to 2**-20 px)."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    cx, cy = (scene.width - 1) / 2, (scene.height - 1) / 2

    def turn(p):
        dx, dy = p[0] - cx, p[1] - cy
        x, y = cx + c * dx - s * dy, cy + s * dx + c * dy
        return (round(x * 2**20) / 2**20, round(y * 2**20) / 2**20)

    polygons = tuple(
        Polygon(
            tuple(tuple(map(turn, ring)) for ring in p.contours), p.intensity, p.fill_rule, p.name
        )
        for p in scene.polygons
    )
    return replace(scene, polygons=polygons)


@dataclass
class Sequence:
    frames: int
    step: float
    images: dict[str, list[np.ndarray]]  # method -> per frame
    exact: list[np.ndarray]

    def rms(self, name: str) -> np.ndarray:
        return np.array([_rms(i - e) for i, e in zip(self.images[name], self.exact, strict=True)])

    def flicker(self, name: str) -> np.ndarray:
        imgs, ex = self.images[name], self.exact
        return np.array(
            [_rms((imgs[t] - imgs[t - 1]) - (ex[t] - ex[t - 1])) for t in range(1, len(ex))]
        )


def _rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(a, dtype=np.float64))))


SEQUENCE_METHODS = ("point", "rgss4", "taa-in-place", "taa", "edgeaa-paper")


def taa_sequence(config: EdgeConfig, frames: int = 32, step: float = 0.2, progress: bool = True):
    bar = ProgressBar("taa", enabled=progress)
    base = builtin("starburst", config)
    with bar.ticking("plan the frames"):
        plans = [plan_scene(rotated(base, f * step), config) for f in range(frames)]
    images: dict[str, list[np.ndarray]] = {name: [] for name in SEQUENCE_METHODS}
    exact = []
    bar(0, frames)
    for f, plan in enumerate(plans):
        with bar.doing(f"frame {f}"):
            exact.append(exact_image(plan))
            for name in ("point", "rgss4", "edgeaa-paper"):
                images[name].append(scene_image(plan, name).astype(np.float64))
    bar(0, 0)  # no count of its own
    with bar.ticking("TAA over the frames"):
        images["taa-in-place"] = [np.floor(i + 0.5) for i in aa_scenes.taa_frames(plans)]
        back = _turned_back(base.width, base.height, step)
        images["taa"] = [np.floor(i + 0.5) for i in aa_scenes.taa_frames(plans, previous=back)]
    bar.close()
    return Sequence(frames, step, images, exact)


def _turned_back(width: int, height: int, step: float):
    """Motion vectors of the turning scene: each pixel centre turned back by one step."""
    ys, xs = np.indices((height, width), dtype=np.float64)
    cx, cy = (width - 1) / 2, (height - 1) / 2
    c, s = math.cos(math.radians(-step)), math.sin(math.radians(-step))
    prev = (cy + s * (xs - cx) + c * (ys - cy), cx + c * (xs - cx) - s * (ys - cy))
    return lambda frame: prev


def sequence_text(seq: Sequence) -> str:
    headers = ["method", "RMS err first", "RMS err last", "RMS err mean", "flicker mean"]
    rows = []
    for name in SEQUENCE_METHODS:
        rms, flicker = seq.rms(name), seq.flicker(name)
        label = SEQUENCE_LABELS.get(name, name)
        cells = [label, f"{rms[0]:.2f}", f"{rms[-1]:.2f}", f"{rms.mean():.2f}"]
        rows.append([*cells, f"{flicker.mean():.2f}"])
    per_frame = ["frame " + " ".join(f"{f:5d}" for f in range(seq.frames))]
    for name in SEQUENCE_METHODS:
        per_frame.append(f"{name:>5} " + " ".join(f"{v:5.2f}" for v in seq.rms(name)))
    return (
        f"starburst turning {seq.step} degrees per frame, {seq.frames} frames; intensity LSB of "
        "255; flicker: RMS of (change of the image - change of the exact image) per frame\n"
        + table(headers, rows)
        + "\nRMS error per frame:\n"
        + "\n".join(per_frame)
    )


STRIP = (96, 96, 160, 160)  # the crop drawn in the strip (the star's centre)


def plot_sequence(seq: Sequence, path: str) -> None:
    plt = pyplot()
    shown = np.linspace(0, seq.frames - 1, 6).round().astype(int)
    rows = ("exact", *SEQUENCE_METHODS)
    fig = plt.figure(figsize=(13, 2.0 * len(rows) + 3))
    grid = fig.add_gridspec(len(rows) + 2, len(shown))
    x0, y0, x1, y1 = STRIP
    for r, name in enumerate(rows):
        frames = seq.exact if name == "exact" else seq.images[name]
        for c, f in enumerate(shown):
            ax = fig.add_subplot(grid[r, c])
            ax.imshow(frames[f][y0:y1, x0:x1], cmap="gray", vmin=0, vmax=255)
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(f"frame {f}", fontsize=9)
            if c == 0:
                ax.set_ylabel(SEQUENCE_LABELS.get(name, name), fontsize=9)
    ax_err = fig.add_subplot(grid[len(rows) :, : len(shown) // 2])
    ax_fl = fig.add_subplot(grid[len(rows) :, len(shown) // 2 :])
    for name in SEQUENCE_METHODS:
        label = SEQUENCE_LABELS.get(name, name)
        ax_err.plot(seq.rms(name), label=label)
        ax_fl.plot(range(1, seq.frames), seq.flicker(name), label=label)
    ax_err.set(xlabel="frame", ylabel="RMS error (LSB)", yscale="log")
    ax_fl.set(xlabel="frame", ylabel="flicker (LSB)", yscale="log")
    ax_err.legend(fontsize=8)
    ax_err.grid(True, alpha=0.3)
    ax_fl.grid(True, alpha=0.3)
    fig.suptitle(
        f"The starburst turning {seq.step} degrees per frame (pixels {x0}..{x1 - 1} shown): "
        "TAA's history against per-frame rendering",
        fontsize=10,
    )
    fig.tight_layout()
    save(fig, path)
    plt.close(fig)
