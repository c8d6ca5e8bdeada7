"""Coverage error against the edge angle: `edgeaa plot error-vs-slope`.

For every angle from 0 to 90 degrees (image coordinates, y down) a family of edges of one
length is drawn from a set of sub-pixel start offsets; all share the slope. Every method is
evaluated on the common pixel set of `evaluate` (the pixels the edge crosses, in the
columns strictly between its endpoints) and its maximum and RMS error against the exact
area is taken per angle. edgeaa's coverage is the model's before output rounding, the
quantity its bounds c_N k are about; the sample methods report their exact sample
fraction; the peers their 8-bit masks.

Edges with angle a <= 45 degrees step along x (dx = L, dy = round(L tan a) sub-pixel
units), the others along y; the plotted angle is the exact atan2(dy, dx). Start offsets:
offset j of n is ((5 j + j // S) mod S, j mod S) / S px, S = 2**subpixel_bits; n = S**2
gives every pair of phases. The default n = 64 (S = 16) visits every row phase and every
column phase 4 times and every phase of y - x (the only one that matters at 45 degrees,
where each edge's line keeps one fractional position) 4 times.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..model import Edge, EdgeConfig
from ..progress import ProgressBar
from . import aa_methods, peers
from .aa_methods import run_method
from .evaluate import BOUND_PER_K, EDGEAA_METHODS, SAMPLE_METHODS, mode_of, pixel_set
from .report import fmt_float, pyplot, save, table

# The peers stay last: `edgeaa plot error-vs-slope --no-peers` drops the last two.
DEFAULT_METHODS = EDGEAA_METHODS + SAMPLE_METHODS + aa_methods.METHODS + ("skia", "agg")


def slope_edges(
    config: EdgeConfig, step: float = 1.0, length: int = 64, offsets: int = 64
) -> tuple[list[Edge], np.ndarray, np.ndarray]:
    """The sweep's edges, the angle index of each, and the exact angle (degrees) per index."""
    scale = config.subpixel_scale
    du = length * scale
    base = 2 * scale
    if base + scale + du > config.max_vertex:
        raise ValueError(
            f"edges of {length} px do not fit coordinates of {config.coord_bits} bits; "
            "use a shorter --length or more --coord-bits"
        )
    if not 0 < step <= 45:
        raise ValueError(f"--step must be in (0, 45] degrees, not {step}")
    if offsets < 1:
        raise ValueError(f"--offsets must be at least 1, not {offsets}")
    count = int(math.floor(90 / step + 1e-9)) + 1
    edges, index, angles = [], [], []
    for i in range(count):
        a = min(i * step, 90.0)
        if a <= 45:
            dx, dy = du, round(du * math.tan(math.radians(a)))
        else:
            dx, dy = round(du * math.tan(math.radians(90 - a))), du
        angles.append(math.degrees(math.atan2(dy, dx)))
        for j in range(offsets):
            ox, oy = (5 * j + j // scale) % scale, j % scale
            x0, y0 = base + ox, base + oy
            edges.append(Edge(x0, y0, x0 + dx, y0 + dy, inside="left"))
            index.append(i)
    return edges, np.array(index), np.array(angles)


@dataclass
class SlopeSweep:
    config: EdgeConfig
    angles: np.ndarray  # degrees, one per angle index
    k: np.ndarray  # folded slope per angle index
    max_err: dict[str, np.ndarray] = field(default_factory=dict)
    rms_err: dict[str, np.ndarray] = field(default_factory=dict)
    worst: dict[str, float] = field(default_factory=dict)  # max over everything
    rms: dict[str, float] = field(default_factory=dict)  # RMS over every pixel
    worst_over_k: dict[str, float] = field(default_factory=dict)  # max of err/k, k > 0
    pixels: int = 0
    edges: int = 0


def error_vs_slope(
    config: EdgeConfig,
    *,
    step: float = 1.0,
    length: int = 64,
    offsets: int = 64,
    methods: tuple[str, ...] = DEFAULT_METHODS,
    progress: bool = True,
) -> SlopeSweep:
    bar = ProgressBar("error-vs-slope", enabled=progress)
    with bar.ticking("edges and exact areas"):
        edges, index, angles = slope_edges(config, step, length, offsets)
        pixels, batch = pixel_set(config, edges)
    angle_of_pixel = index[pixels.edge_index]
    n_angles = len(angles)
    k_per_angle = np.zeros(n_angles)
    k_per_angle[index] = [
        min(abs(e.x1 - e.x0), abs(e.y1 - e.y0)) / max(abs(e.x1 - e.x0), abs(e.y1 - e.y0))
        for e in edges
    ]
    sweep = SlopeSweep(config, angles, k_per_angle, pixels=len(pixels), edges=len(edges))
    with bar.ticking("peer jobs"):
        peer = set(methods) & set(peers.FILL_PEERS)
        jobs = peers.fill_jobs(config, edges, batch) if peer else None
    bar(0, len(methods))
    counts = np.bincount(angle_of_pixel, minlength=n_angles)
    for name in methods:
        with bar.doing(name):
            run = run_method(config, edges, pixels, name, coverage="model", jobs=jobs)
        err = np.abs(run.coverage - pixels.exact)
        worst = np.zeros(n_angles)
        np.maximum.at(worst, angle_of_pixel, err)
        sq = np.bincount(angle_of_pixel, weights=err * err, minlength=n_angles)
        sweep.max_err[name] = worst
        sweep.rms_err[name] = np.sqrt(sq / np.maximum(counts, 1))
        sweep.worst[name] = float(err.max())
        sweep.rms[name] = float(np.sqrt(np.mean(err * err)))
        positive = pixels.k > 0
        sweep.worst_over_k[name] = float((err[positive] / pixels.k[positive]).max())
    return sweep


def sweep_table(sweep: SlopeSweep) -> str:
    rows = []
    for name in sweep.max_err:
        mode = mode_of(name)
        bound = BOUND_PER_K.get(mode) if mode else None
        rows.append(
            [
                name,
                fmt_float(sweep.worst[name]),
                fmt_float(sweep.rms[name]),
                fmt_float(sweep.worst_over_k[name]),
                fmt_float(bound),
                fmt_float(sweep.worst_over_k[name] / bound, 6) if bound else "-",
            ]
        )
    headers = ["method", "max abs err", "RMS err", "max err/k", "c_N", "(max err/k)/c_N"]
    return table(headers, rows)


STYLE = {
    "edgeaa-pw": ("tab:blue", "-"),
    "edgeaa-paper": ("tab:orange", "-"),
    "edgeaa-seg2": ("tab:green", "-"),
    "edgeaa-seg4": ("tab:red", "-"),
    "point": ("black", ":"),
    "grid2": ("tab:purple", ":"),
    "grid4": ("tab:brown", ":"),
    "grid8": ("tab:pink", ":"),
    "grid16": ("tab:gray", ":"),
    "rgss4": ("tab:olive", "-."),
    "rooks8": ("tab:cyan", "-."),
    "skia": ("darkgoldenrod", "--"),
    "agg": ("navy", "--"),
    "agg-default": ("slategray", "--"),
    "msaa2": ("yellowgreen", "-."),
    "quincunx": ("teal", "-."),
    "flipquad": ("crimson", "-."),
    "mlaa": ("darkviolet", (0, (1, 1))),
    "mlaa-slope": ("magenta", (0, (3, 1, 1, 1))),
    "fxaa": ("sienna", (0, (1, 1))),
    "fxaa-geom": ("peru", (0, (3, 1, 1, 1))),
    "taa": ("lime", (0, (5, 1))),
}
FLOOR = 1e-5


def plot_sweep(sweep: SlopeSweep, path: str) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(12, 9), sharex=True)
    k = sweep.k
    for ax, data, what in (
        (axes[0], sweep.max_err, "maximum"),
        (axes[1], sweep.rms_err, "RMS"),
    ):
        for name, values in data.items():
            colour, style = STYLE.get(name, (None, "-"))
            ax.semilogy(
                sweep.angles,
                np.maximum(values, FLOOR),
                linestyle=style,
                color=colour,
                linewidth=2.0 if name.startswith("edgeaa") else 1.1,
                label=name,
            )
        ax.set_ylabel(f"{what} |coverage - exact area|\n(fraction of a pixel)")
        ax.grid(True, which="both", alpha=0.3)
        ax.set_ylim(FLOOR * 0.8, 1.0)
    first = True
    for name in sweep.max_err:
        mode = mode_of(name)
        if mode:
            bound = BOUND_PER_K[mode]
            axes[0].semilogy(
                sweep.angles,
                np.maximum(bound * k, FLOOR),
                color="black",
                linestyle=(0, (4, 3)),
                linewidth=0.9,
                label="bounds k/8, k/64, k/256, k/1024" if first else None,
            )
            axes[0].annotate(
                f"k/{round(1 / bound)}",
                (45, bound),
                textcoords="offset points",
                xytext=(4, 4),
                fontsize=8,
            )
            first = False
    axes[1].set_xlabel("edge angle (degrees from the x axis; k = tan or cot folded to [0, 1])")
    axes[1].set_xticks(range(0, 91, 15))
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="center right", fontsize=8, title="method")
    cfg = sweep.config
    fig.suptitle(
        "Coverage error against edge angle, over sub-pixel offsets "
        f"({sweep.edges} edges, {sweep.pixels} pixels; W={cfg.coord_bits}, "
        f"s={cfg.subpixel_bits}, I={cfg.intensity_bits}, F={cfg.F}, {cfg.accumulator})\n"
        f"edgeaa before output rounding; values below {FLOOR:g} drawn at {FLOOR:g}",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0, 0.84, 1))
    save(fig, path)
    plt.close(fig)
