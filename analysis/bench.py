"""Accuracy and run time of every method on one seeded set of random edges: `edgeaa bench`.

Edges: `geometry.random_image_edges` (P0 uniform in a 512 px square, direction uniform, length
uniform in [8, 200] px, vertices on the configuration's sub-pixel grid, inside side random,
full-scale inside on a 0 background). Pixels: the common set of `evaluate` (the pixels
each edge crosses, columns strictly between its endpoints). Errors are against the exact
area, on what each method outputs: edgeaa's written intensity as a fraction of full scale
(I bits, 8 by default), the sample methods' exact sample fraction, the peers' 8-bit masks.

Run time: each method runs `repeats` times, interleaved round by round so that load from
other processes hits every method alike, and the minimum is kept. Times are reported as
ratios to edgeaa's vectorized model (`model.vector.run_edges`) in the configured mode,
measured in the same run: absolute times on a shared machine are noisy, ratios less so.
What is timed:

- edgeaa: `run_edges(config, edges)`: setup of every edge (a Python loop) and the numpy
  stepping; its writes are the intensities.
- sample methods: the sample tests on the given pixel set only (they are handed the
  pixels; a real supersampler would also have to find them).
- peers: building the path, rasterizing into a fresh mask the size of the edge's writes
  plus one pixel, and reading the mask back into numpy, per edge.
- the seeds' image methods (`aa_methods`: MLAA, FXAA, TAA): point sampling each edge's image
  and post-processing it; they take seconds, so they run once, not `repeats` times.

A second table compares lines (1 px wide, integer endpoints: the edges rounded to pixel
centres) where scikit-image's `draw.line_aa` makes sense, against Skia's and AGG's
strokes and the exact area of the 1 px wide strip.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..model import Edge, EdgeConfig
from ..model.vector import run_edges
from ..progress import ProgressBar
from . import aa_methods, msaa, peers, sampling
from .aa_methods import run_method
from .evaluate import EDGEAA_METHODS, SAMPLE_METHODS, MethodRun, mode_of, pixel_set, timed
from .geometry import random_image_edges
from .hardware import hardware_figures
from .report import fmt_float, pyplot, save, table

FILL_METHODS = EDGEAA_METHODS + SAMPLE_METHODS + aa_methods.METHODS + peers.FILL_PEERS
DEFAULT_EDGES, QUICK_EDGES = 1000, 60
DEFAULT_REPEATS, QUICK_REPEATS = 5, 2


def output_kind(config: EdgeConfig, name: str) -> str:
    if mode_of(name):
        return f"{config.intensity_bits}-bit value"
    if name in sampling.PATTERNS:
        count = len(sampling.PATTERNS[name])
        return f"{count} sample" + ("s" if count > 1 else "")
    if name in msaa.PATTERNS:
        return f"{len(msaa.PATTERNS[name].units)} taps"
    if name in aa_methods.IMAGE_METHODS:
        return "image post-pass" if name != "taa" else "1 sample/frame"
    if name == "skimage-line_aa":
        return "float"
    return "8-bit mask"


def values_per_pixel(name: str) -> float:
    """Values a pixel holds before it is resolved: samples stored (after sharing), the
    frame and history of TAA, 1 for a method that writes the pixel once."""
    if name in sampling.PATTERNS:
        return len(sampling.PATTERNS[name])
    return aa_methods.VALUES_PER_PIXEL.get(name, 1)


@dataclass
class Row:
    name: str
    max_err: float
    rms_err: float
    seconds: float
    outputs: int
    ratio: float = float("nan")
    hardware: object = None


@dataclass
class BenchResult:
    config: EdgeConfig
    seed: int
    edges: int
    pixels: int
    repeats: int
    baseline: str
    rows: list[Row] = field(default_factory=list)
    line_rows: list[Row] = field(default_factory=list)
    lines: int = 0
    line_pixels: int = 0
    convention: dict[str, float] = field(default_factory=dict)


def run_bench(
    config: EdgeConfig,
    *,
    count: int = DEFAULT_EDGES,
    seed: int = 1,
    repeats: int = DEFAULT_REPEATS,
    methods: tuple[str, ...] = FILL_METHODS,
    lines: bool = True,
    progress: bool = True,
    hardware: bool = True,
    synthesis: bool = True,
) -> BenchResult:
    if count < 1:
        raise ValueError(f"--edges must be at least 1, not {count}")
    if repeats < 1:
        raise ValueError(f"--repeats must be at least 1, not {repeats}")
    baseline = f"edgeaa-{config.mode}"
    if baseline not in methods:
        methods = (baseline, *methods)
    bar = ProgressBar("bench", enabled=progress)
    with bar.ticking("edges and exact areas"):
        edges = random_image_edges(config, count, seed)
        pixels, batch = pixel_set(config, edges)
        jobs = peers.fill_jobs(config, edges, batch)
        result = BenchResult(config, seed, len(edges), len(pixels), repeats, baseline)
        result.convention = peers.convention_check(config)

        line_list = peers.integer_lines(config, edges) if lines else []
        line_px = peers.line_pixels(line_list) if line_list else None
        line_jobs = peers.line_jobs(line_list, line_px) if line_list else []
        line_edges = [Edge(*(v * config.subpixel_scale for v in line)) for line in line_list]

    best: dict[str, MethodRun] = {}
    line_best: dict[str, tuple[float, list]] = {}
    steps = repeats * (len(methods) + (len(peers.LINE_PEERS) + 1 if line_list else 0))
    bar(0, steps)
    for round_ in range(repeats):
        for name in methods:
            if round_ and name in aa_methods.IMAGE_METHODS:
                bar.step(name)  # seconds per run, 100 times edgeaa's: once is enough
                continue
            with bar.doing(name):
                run = run_method(config, edges, pixels, name, coverage="output", jobs=jobs)
            if name not in best or run.seconds < best[name].seconds:
                best[name] = run
        if line_list:
            with bar.doing("edgeaa on the line edges"):
                seconds, _ = timed(lambda: run_edges(config, line_edges))
            key = "edgeaa-lines"
            if key not in line_best or seconds < line_best[key][0]:
                line_best[key] = (seconds, [])
            for name in peers.LINE_PEERS:
                with bar.doing(name):
                    seconds, masks = timed(lambda name=name: peers.render(name, line_jobs))
                if name not in line_best or seconds < line_best[name][0]:
                    line_best[name] = (seconds, masks)

    base_seconds = best[baseline].seconds
    bar = ProgressBar("bench", len(methods) if hardware else 0, enabled=progress)
    for name in methods:
        run = best[name]
        err = np.abs(run.coverage - pixels.exact)
        result.rows.append(
            Row(
                name,
                float(err.max()),
                float(np.sqrt(np.mean(err * err))),
                run.seconds,
                run.outputs,
                run.seconds / base_seconds,
                _hardware(bar, config, name, edges, synthesis) if hardware else None,
            )
        )
    bar.close()
    if line_list:
        result.lines, result.line_pixels = len(line_list), len(line_px.edge_index)
        edge_seconds = line_best["edgeaa-lines"][0]
        for name in peers.LINE_PEERS:
            seconds, masks = line_best[name]
            cov = peers.gather(name, line_jobs, masks, line_px.edge_index, line_px.x, line_px.y)
            err = np.abs(cov - line_px.exact)
            outputs = sum(w * h for w, h in (j.size for j in line_jobs))
            result.line_rows.append(
                Row(
                    name,
                    float(err.max()),
                    float(np.sqrt(np.mean(err * err))),
                    seconds,
                    outputs,
                    seconds / edge_seconds,
                )
            )
    return result


def _hardware(bar: ProgressBar, config: EdgeConfig, name: str, edges, synthesis: bool):
    """One method's hardware figures (a synthesis run, minutes the first time), named on the
    bar while it runs."""
    with bar.doing(f"hardware figures of {name}"):
        return hardware_figures(config, name, edges, synthesis=synthesis)


def _hw(row: Row, attr: str, digits: int) -> str:
    value = getattr(row.hardware, attr, None) if row.hardware is not None else None
    if value is None:
        return "-"
    return f"{value:.{digits}f}" if digits else str(value)


def bench_tables(result: BenchResult) -> str:
    cfg = result.config
    lines = [
        f"edges: {result.edges} random (seed {result.seed}), {result.pixels} compared pixels "
        "(crossed pixels, columns strictly between the endpoints)",
        f"config: W={cfg.coord_bits} s={cfg.subpixel_bits} I={cfg.intensity_bits} F={cfg.F} "
        f"accumulator={cfg.accumulator}; times: min of {result.repeats} interleaved runs; "
        f"ratio = time / time of {result.baseline} (vectorized model) in this run",
        "pixel-centre convention, half-plane x < 10.25, pixel column 10 (exact 0.75): "
        + ", ".join(f"{k} {v:.4f}" for k, v in result.convention.items()),
        "",
    ]
    headers = [
        "method",
        "output",
        "max abs err",
        "RMS err",
        "time ms",
        "ns/px out",
        "x edgeaa",
        "values/px",
        "cycles/col",
        "LUTs",
        "Fmax MHz",
    ]
    rows = []
    for row in result.rows:
        rows.append(
            [
                row.name,
                output_kind(cfg, row.name),
                fmt_float(row.max_err),
                fmt_float(row.rms_err),
                f"{row.seconds * 1e3:.2f}",
                f"{row.seconds / max(row.outputs, 1) * 1e9:.0f}",
                f"{row.ratio:.3f}",
                f"{values_per_pixel(row.name):g}",
                _hw(row, "cycles_per_column", 2),
                _hw(row, "luts", 0),
                _hw(row, "fmax_mhz", 1),
            ]
        )
    lines.append(table(headers, rows, align="llrrrrrrrrr"))
    lines.append(
        "ns/px out: time per pixel the method produced (edgeaa: its writes; sample methods: "
        "the compared pixels; image methods: the pixels of their images; peers: mask pixels). "
        "values/px: values a pixel holds before it is resolved (samples stored after "
        "sharing; TAA: frame and history). Hardware: cycles/column measured on "
        "the compiled core with these edges; LUT4 and Fmax for iCE40 HX8K (edgeaa synth)."
    )
    if result.line_rows:
        lines += [
            "",
            f"lines: {result.lines} lines of width 1 px with integer endpoints (the edges "
            f"rounded), {result.line_pixels} compared pixels (columns strictly between the "
            "endpoints, 2 rows either side), against the exact area of the 1 px wide strip; "
            "ratio = time / time of edgeaa's vectorized model on the same lines as edges",
            "",
            table(
                ["line method", "output", "max abs err", "RMS err", "time ms", "x edgeaa"],
                [
                    [
                        row.name,
                        output_kind(cfg, row.name),
                        fmt_float(row.max_err),
                        fmt_float(row.rms_err),
                        f"{row.seconds * 1e3:.2f}",
                        f"{row.ratio:.3f}",
                    ]
                    for row in result.line_rows
                ],
                align="llrrrr",
            ),
        ]
    return "\n".join(lines)


def pareto_front(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the points no other point beats on both coordinates (lower is better),
    sorted by the first coordinate."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], float("inf")
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def _colour(name: str) -> str:
    if mode_of(name):
        return "tab:red"
    if name in sampling.PATTERNS:
        return "tab:blue"
    return "tab:purple" if name in aa_methods.METHODS else "tab:green"


def plot_pareto(result: BenchResult, path: str) -> None:
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(10, 6.5))
    rows = result.rows
    xs = [row.ratio for row in rows]
    for attr, marker, label in (("max_err", "o", "max |err|"), ("rms_err", "s", "RMS err")):
        ys = [getattr(row, attr) for row in rows]
        colours = [_colour(r.name) for r in rows]
        ax.scatter(
            xs,
            ys,
            c=colours,
            marker=marker,
            s=40 if marker == "o" else 22,
            alpha=1.0 if marker == "o" else 0.5,
            zorder=3,
        )
        if attr == "max_err":
            for row, x, y in zip(rows, xs, ys, strict=True):
                ax.annotate(row.name, (x, y), textcoords="offset points", xytext=(5, 3), fontsize=8)
        front = pareto_front(list(zip(xs, ys, strict=True)))
        ax.step(
            [xs[i] for i in front],
            [ys[i] for i in front],
            where="post",
            color="black",
            linestyle="--" if attr == "max_err" else ":",
            linewidth=1.0,
            label=f"Pareto front ({label})",
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(f"run time relative to {result.baseline} (vectorized model), same run")
    ax.set_ylabel("coverage error against the exact area (fraction of a pixel)")
    from matplotlib.lines import Line2D

    handles, labels = ax.get_legend_handles_labels()
    handles += [
        Line2D([], [], color="gray", marker="o", linestyle=""),
        Line2D([], [], color="gray", marker="s", linestyle="", alpha=0.5),
    ]
    labels += ["max |err| (circles, labelled)", "RMS err (squares)"]
    handles += [
        Line2D([], [], color=c, marker="o", linestyle="")
        for c in ("tab:red", "tab:blue", "tab:purple", "tab:green")
    ]
    labels += [
        "edgeaa model",
        "sample patterns (numpy)",
        "MSAA patterns, MLAA, FXAA, TAA (numpy)",
        "peers (Skia, AGG)",
    ]
    ax.legend(handles, labels, fontsize=8, loc="lower left")
    ax.grid(True, which="both", alpha=0.3)
    cfg = result.config
    ax.set_title(
        f"Error against run time: {result.edges} random edges (seed {result.seed}), "
        f"{result.pixels} pixels; W={cfg.coord_bits} s={cfg.subpixel_bits} "
        f"I={cfg.intensity_bits}\nedgeaa: written {cfg.intensity_bits}-bit values; "
        "peers: 8-bit masks; sample methods: exact fractions",
        fontsize=10,
    )
    fig.tight_layout()
    save(fig, path)
    plt.close(fig)
