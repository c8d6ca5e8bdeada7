"""`edgeaa render`: a scene in, an antialiased image out (docs/scenes.md).

The command registers itself (`edgeaa.command.Command`) when this module is imported. Bad
input is a `usage_error` (one line, exit status 2); a simulator that cannot run is reported in
one line with exit status 1.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace

import numpy as np

from ..command import (
    PEER_MODULES,
    Command,
    add_config_options,
    add_pipeline_option,
    atomic_output,
    check_output,
    config_from_args,
    integer_type,
    pipeline_from_args,
    read_integer,
    require_extra,
    require_verilator,
    shown,
    tile_size,
    usage_error,
)
from ..command import PROG as COMMAND_PROG
from ..progress import ProgressBar
from .builtin import BUILTINS

PROG = f"{COMMAND_PROG} render"  # RenderCommand.prog, for the helpers below
# The side-by-side figure supersamples 16 x 16 and the exact reference cuts one shapely box
# per pixel: both need far more memory per pixel than a render (docs/scenes.md).
MAX_COMPARE_PIXELS = 1 << 16  # 65,536 (256 x 256)
MAX_ERROR_PIXELS = 1 << 20  # 1,048,576 (1024 x 1024)


MAX_CROP = 1 << 20  # past any image (the coordinates' +-2**20 px)


def crop_box(text: str) -> tuple[int, int, int, int]:
    """An argparse type: `--crop X0,Y0,X1,Y1`, 0 <= X0 < X1 and 0 <= Y0 < Y1 (the image's
    size is checked once the scene is read)."""
    parts = text.split(",")
    try:
        if len(parts) != 4:
            raise ValueError
        x0, y0, x1, y1 = (read_integer(part, 0, MAX_CROP) for part in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be X0,Y0,X1,Y1, integers in [0, {MAX_CROP}], not {shown(text)}"
        ) from None
    if x1 <= x0 or y1 <= y0:
        raise argparse.ArgumentTypeError(f"{shown(text)}: need X0 < X1 and Y0 < Y1")
    return x0, y0, x1, y1


def write_png(image: np.ndarray, full_scale: int, intensity_bits: int, path) -> str:
    """8-bit greyscale PNG (16-bit when intensity_bits > 8); other widths are scaled to the
    PNG's full scale, rounding half up, to `path` (a file name or a binary file). Returns a
    description."""
    from .png import write_png_file

    if image.ndim == 3:
        return _write_colour_png(image, full_scale, path)
    bits = 8 if intensity_bits <= 8 else 16
    top = (1 << bits) - 1
    dtype = np.uint8 if bits == 8 else np.uint16
    if full_scale != top:
        data = image.astype(np.int64)
        array = ((2 * data * top + full_scale) // (2 * full_scale)).astype(dtype)
    else:  # the values as they are (no int64 copy of the image)
        array = image.astype(dtype, copy=False)
    write_png_file(array, path)
    scaled = "" if full_scale == top else f", scaled from {intensity_bits} bits"
    return f"{bits}-bit greyscale{scaled}"


def _write_colour_png(image: np.ndarray, full_scale: int, path) -> str:
    """A colour canvas (premultiplied, `paint`) as an 8-bit RGB PNG, RGBA where any pixel is
    not opaque; channels scaled from full scale to 255 half up."""
    from .paint import straight
    from .png import write_png_file

    data, opaque = straight(image, full_scale)
    if full_scale != 255:
        data = (2 * data * 255 + full_scale) // (2 * full_scale)
    mode = "RGB" if opaque else "RGBA"
    array = data[..., :3] if opaque else data
    write_png_file(array.astype(np.uint8), path)
    return f"8-bit {mode}"


def _load(args, config, warnings: list[str]):
    from .builtin import builtin
    from .scene import load_scene

    if (args.scene is None) == (args.builtin is None):
        raise usage_error(
            PROG,
            f"give a scene file or --builtin NAME (one of them; built-ins: {', '.join(BUILTINS)})",
        )
    if args.builtin is not None:
        return builtin(args.builtin, config)
    if is_svg(args.scene):
        from .svg import load_svg

        return load_svg(args.scene, args.size, args.scale, args.lenient, warnings.append)
    return load_scene(args.scene)


def is_svg(path: str | None) -> bool:
    """Whether the scene file is read as SVG (by its suffix, any case); JSON otherwise."""
    return path is not None and path.lower().endswith(".svg")


MAX_SCALE = 1024.0  # --scale: a 4 px icon to the 4096 px limit; larger images are refused


def svg_size(text: str) -> tuple[int, int]:
    """An argparse type: `--size WxH`, the image of an SVG file in pixels."""
    parts = text.split("x")
    try:
        if len(parts) != 2:
            raise ValueError
        return tuple(read_integer(part, 1, 1 << 16) for part in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be WIDTHxHEIGHT, integers in [1, 65536], not {shown(text)}"
        ) from None


def svg_scale(text: str) -> float:
    """An argparse type: `--scale S`, a number in (0, MAX_SCALE]."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 < value <= MAX_SCALE:
        raise argparse.ArgumentTypeError(
            f"must be a number in (0, {MAX_SCALE:g}], not {shown(text)}"
        )
    return value


class RenderCommand(Command):
    name = "render"
    help = "render a scene (polygons, text) to an antialiased PNG with the model or the core"
    description = (
        "Render a scene (a JSON file of polygons and SVG paths, an SVG file with shapes, "
        "arcs, strokes and colour, or a built-in) "
        "through the model or the cycle-accurate hardware pipeline: each edge adds the "
        "signed area of its own piece into an accumulation buffer, a prefix sum per row "
        "gives the coverage, the fill rule and intensity apply, and polygons are "
        "composited in order. With --engine verilator or amaranth the pixels come out of "
        "the simulated hardware (tile by tile) and are checked against the model's, bit for "
        "bit. Format and rules: docs/scenes.md; the pipeline: docs/hardware.md."
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        from .engines import ENGINES

        parser.add_argument(
            "scene", nargs="?", help="scene file: JSON, or an .svg file (docs/scenes.md)"
        )
        parser.add_argument(
            "--size",
            type=svg_size,
            metavar="WxH",
            help="an SVG file's image in pixels, the drawing fitted by its preserveAspectRatio "
            "(default: the SVG's width and height)",
        )
        parser.add_argument(
            "--scale", type=svg_scale, help="an SVG file's width and height times S"
        )
        parser.add_argument(
            "--lenient",
            action="store_true",
            help="skip, with a warning, the SVG elements outside the subset (text, images, "
            "gradients, masks, filters, clip paths) instead of refusing the file",
        )
        parser.add_argument(
            "--builtin", choices=BUILTINS, help="a built-in scene instead of a file"
        )
        parser.add_argument(
            "--engine",
            choices=ENGINES,
            default="model",
            help="model (default), verilator (the whole polygon pipeline, stepper, "
            "accumulation memory and resolve, compiled by Verilator, cycle-accurate: the "
            "pixels come from the hardware; first build about 30 s, cached) or amaranth (the "
            "pipeline in Amaranth's Python simulator: slow, small scenes only)",
        )
        parser.add_argument(
            "--tile",
            type=tile_size,
            metavar="WxH",
            help="with --engine verilator or amaranth: the pipeline's tile WIDTHxHEIGHT, "
            "powers of two (default 64x32; limits: docs/hardware.md)",
        )
        add_pipeline_option(parser, "with --engine verilator or amaranth")
        parser.add_argument("-o", "--output", help="PNG file to write (the figure with --compare)")
        parser.add_argument(
            "--stats",
            action="store_true",
            help="also render without skipping and print cycles, writes and time with and "
            "without, as ratios, and the saving of each rule",
        )
        parser.add_argument(
            "--error",
            action="store_true",
            help="measure the image against the exact per-pixel polygon area (shapely): max "
            "and RMS, split into pixels written by one edge, by several, and fill only",
        )
        parser.add_argument(
            "--no-skip",
            action="store_true",
            help="send every boundary edge to the engine, unclipped, and composite over the "
            "whole image (same image, more work)",
        )
        parser.add_argument(
            "--compare",
            action="store_true",
            help="write a figure to -o instead: no antialiasing, edgeaa paper and seg4, 16x16 "
            "supersampling, Skia and AGG side by side, with error heat maps",
        )
        parser.add_argument(
            "--crop", type=crop_box, help="with --compare: the pixels X0,Y0,X1,Y1 to show"
        )
        parser.add_argument(
            "--json",
            action="store_true",
            help="print one JSON object instead of text: the render's figures (edges, columns, "
            "cycles, writes, ...), with --error max_abs_lsb, rms_lsb, pixels and the split "
            "by edges per pixel, with --stats the render without skipping and each rule's "
            "saving",
        )
        parser.add_argument(
            "--linear-light",
            action="store_true",
            help="composite a colour scene in linear light (sRGB decoded before the composite "
            "and encoded after it; docs/scenes.md section 9) instead of on the sRGB values",
        )
        parser.add_argument(
            "--workers",
            type=integer_type(1, 64),
            default=1,
            metavar="N",
            help="threads rendering the model's bands of rows (default 1; on 2 cores 2 took "
            "15-27%% less wall time for 15-25%% more CPU time and memory, docs/results.md "
            "section 7)",
        )
        parser.add_argument("--quiet", action="store_true", help="no progress bar on stderr")
        add_config_options(parser)

    def run(self, args: argparse.Namespace) -> int:
        from .render import edges_to_send, keep_freed_memory, plan_scene
        from .scene import SceneError, check_pixels

        keep_freed_memory()  # numpy's temporaries reuse pages instead of faulting in new ones
        config = config_from_args(args)
        _check_options(args, config)
        crop = args.crop
        warnings: list[str] = []  # what --lenient skipped, said when the render succeeded
        try:
            scene = _load(args, config, warnings)
            if args.linear_light:
                if not scene.colour:
                    raise SceneError(
                        "--linear-light blends colours: this scene is grey (an SVG file, or "
                        "colors in a JSON scene, make a colour scene)"
                    )
                scene = replace(scene, linear_light=True)
            if args.compare:
                check_pixels("--compare", scene.width, scene.height, MAX_COMPARE_PIXELS)
            if args.error:
                check_pixels("--error", scene.width, scene.height, MAX_ERROR_PIXELS)
            bar = ProgressBar("render", enabled=not args.quiet)
            with bar.ticking("plan"):
                plan = plan_scene(_outlines(scene), config)
            bar.close()
            if args.stats or args.no_skip:
                edges_to_send(plan, skip=False)  # refused if not every edge fits the range
        except SceneError as error:
            raise usage_error(PROG, str(error)) from None
        if crop and (crop[2] > scene.width or crop[3] > scene.height):
            raise usage_error(
                PROG,
                f"--crop {','.join(map(str, crop))} is outside the {scene.width} x "
                f"{scene.height} image",
            )
        boundary = int(plan.boundary.sum())
        print_text = print if not args.json else (lambda *a, **k: None)
        print_text(
            f"{PROG}: {scene.name}, {scene.width} x {scene.height} px, "
            f"{len(scene.polygons)} polygons, {plan.edge_count} edges ({boundary} boundary); "
            f"engine {args.engine}; {config}"
        )
        if args.compare:
            status = _compare(args, scene, config, crop, bar)
        else:
            status = _render(args, scene, plan, bar)
        for message in warnings if status == 0 else ():  # a failure says one line only
            print(f"{PROG}: warning: {message}", file=sys.stderr)
        return status


# Options that do nothing or contradict each other: (given, with, why they cannot be mixed).
CONFLICTS = (
    ("compare", "error", "--compare already measures every method against the exact area"),
    ("compare", "stats", "--compare renders with the model in two modes, not one engine"),
    ("compare", "no_skip", "--compare renders with the model in two modes, not one engine"),
    ("stats", "no_skip", "--stats renders both with and without skipping"),
    ("compare", "json", "--compare writes a figure and prints a table of every method"),
    ("compare", "linear_light", "--compare draws the outlines' coverage, not their colours"),
)


def _check_options(args: argparse.Namespace, config) -> None:
    """Refuse conflicting or no-op options, a bad tile and unwritable outputs, before any
    work."""
    for first, second, why in CONFLICTS:
        if getattr(args, first) and getattr(args, second):
            names = (f"--{n.replace('_', '-')}" for n in (first, second))
            raise usage_error(PROG, f"{' and '.join(names)} cannot be combined: {why}")
    if args.compare and args.engine != "model":
        raise usage_error(PROG, "--compare renders with the model: --engine does not apply")
    if args.tile is not None and args.engine == "model":
        raise usage_error(PROG, "--tile sizes the hardware pipeline: add --engine verilator")
    if args.pipeline is not None and args.engine == "model":
        raise usage_error(
            PROG, "--pipeline configures the hardware pipeline: add --engine verilator"
        )
    if args.engine == "verilator":
        require_verilator(PROG)
    if args.linear_light and args.engine != "model":
        raise usage_error(
            PROG, "--linear-light composites in the model: the hardware pipeline blends sRGB values"
        )
    if args.workers > 1 and (args.engine != "model" or args.compare or args.no_skip):
        raise usage_error(
            PROG,
            "--workers renders the model's bands: not with --engine verilator or amaranth, "
            "--compare or --no-skip",
        )
    if args.no_skip and args.engine != "model":
        raise usage_error(
            PROG, "--no-skip applies to the model: the pipeline always skips (docs/hardware.md)"
        )
    for option in ("size", "scale", "lenient"):
        if getattr(args, option) not in (None, False) and not is_svg(args.scene):
            raise usage_error(PROG, f"--{option} applies to an .svg scene file")
    if args.size is not None and args.scale is not None:
        raise usage_error(PROG, "--size and --scale cannot be combined: each sets the image size")
    if args.crop is not None and not args.compare:
        raise usage_error(PROG, "--crop selects the pixels of the --compare figure; add --compare")
    if args.output is not None:
        check_output(PROG, args.output, (".png",), inputs=(args.scene,))
    if args.compare and args.output is None:
        raise usage_error(PROG, "--compare needs -o FIGURE.png")
    if args.compare:
        require_extra(PROG, "peers", PEER_MODULES)


def _outlines(scene):
    """What is planned: a grey scene itself; a colour scene's coverage (`paint`)."""
    from .paint import coverage_scene

    return coverage_scene(scene) if scene.colour else scene


def _compare(args: argparse.Namespace, scene, config, crop, bar: ProgressBar) -> int:
    from ..analysis.compare import plot_compare

    with atomic_output(PROG, args.output) as temporary:  # a colour scene: its coverage
        rows = plot_compare(_outlines(scene), config, temporary, crop, bar)
    bar.close()
    print(f"{'method':22} {'max |err| LSB':>14} {'RMS LSB':>8}")
    for label, worst, rms in rows:
        print(f"{label:22} {worst:14.3f} {rms:8.3f}")
    print(f"wrote {args.output}")
    return 0


def _cause(error: Exception) -> str:
    """One line for a simulator's failure: its first line, and the compiler's first error
    when the first line only says that the build failed."""
    lines = [line.strip() for line in str(error).splitlines() if line.strip()]
    if not lines:
        return repr(error)
    errors = [line for line in lines[1:] if "error" in line.lower()]
    cause = (errors or lines[1:2] or [None])[0]
    return f"{lines[0].rstrip(':')}: {cause}" if cause and lines[0].endswith(":") else lines[0]


def _build_engine(engine: str, pipeline, bar: ProgressBar) -> None:
    """Compile the Verilator harness first (cached; the first build takes half a minute), with
    the bar running, so that the engine's time is the simulation's alone."""
    if engine == "verilator":
        from ..sim.simulators import pipeline_harness

        with bar.ticking("verilator build of the pipeline (first time only, then cached)"):
            pipeline_harness.build(pipeline)
        bar.close()


def _run_engine(args: argparse.Namespace, scene, plan, bar: ProgressBar):
    """The render (the model's, or the hardware pipeline's) and with --stats the model's
    render without skipping; a colour scene composited on a canvas (`paint`)."""
    from .paint import Canvas
    from .pipeline import check_clocks, render_pipeline, tile_paints
    from .render import render_scene

    def canvas():
        return Canvas(scene, plan.config.full_scale) if scene.colour else None

    baseline = None
    if args.stats:
        baseline = render_scene(plan, skip=False, progress=bar, canvas=canvas())
    if args.engine == "model":
        render = render_scene(
            plan, skip=not args.no_skip, progress=bar, canvas=canvas(), workers=args.workers
        )
        return render, baseline
    pipeline = pipeline_from_args(args.pipeline, args.tile, plan.config)
    paint = canvas()
    if paint is not None:  # red, green, blue; alpha too for a translucent background
        channels = 3 if paint.background[3] == paint.full else 4
        pipeline = replace(pipeline, tile=replace(pipeline.tile, channels=channels))
    check_clocks(plan, pipeline, args.engine)  # before the build
    tile_paints(plan, pipeline.tile, paint)  # what it cannot draw is refused before the build
    _build_engine(args.engine, pipeline, bar)
    return render_pipeline(plan, args.engine, pipeline, progress=bar, canvas=paint), baseline


def _engine_line(result, stats: bool, units: int) -> str:
    """What the engine did; the stepper's cycles (the timing model, work of its own) only
    with --stats; the pipeline's `units` setup units."""
    cycles = f"{result.cycles:,} stepper cycles (timing model), " if stats else ""
    workers = f"{result.workers} worker{'s' * (result.workers > 1)}"
    bands = f"; {result.bands} band{'s' * (result.bands > 1)} of rows, {workers}" if stats else ""
    line = (
        f"engine: {len(result.sent)} edges, {cycles}"
        f"{result.delta_count:,} nonzero deltas; accumulation: {result.rows_scanned:,} rows, "
        f"{result.cells_scanned:,} cells scanned; {result.seconds:.3f} s{bands}"
    )
    hw = result.pipeline
    if hw is None:
        return line
    counters = ", ".join(f"{name} {value:,}" for name, value in hw.stats.items())
    return (
        f"{line}\npipeline ({result.engine}): {units} setup unit{'s' * (units > 1)}, "
        f"{hw.clocks:,} clocks simulated in "
        f"{hw.seconds:.2f} s ({hw.clocks_per_second / 1e6:.2f} M clocks/s); {counters}"
    )


def _stats(plan, result, baseline, figures: dict) -> list[str]:
    """--stats: the report's texts, and its figures added to `figures`."""
    from .stats import rule_savings, stats_numbers, stats_report

    report = [stats_report(baseline, result)]
    figures["without_skipping"] = stats_numbers(baseline)
    figures["savings"] = [vars(saving) for saving in rule_savings(baseline, result)]
    if result.pipeline is not None:
        from .pipeline import pipeline_savings, savings_table

        savings = pipeline_savings(plan, result.pipeline_tile)
        report.append("\n" + savings_table(savings))
        figures["pipeline_savings"] = [vars(saving) for saving in savings]
    return report


def _render(args: argparse.Namespace, scene, plan, bar: ProgressBar) -> int:
    """Render the plan (and without skipping with --stats), write the PNG and print what was
    asked for."""
    from .scene import SceneError

    try:
        result, baseline = _run_engine(args, scene, plan, bar)
    except SceneError as error:  # beyond an engine's limit
        bar.close()
        raise usage_error(PROG, str(error)) from None
    except RuntimeError as error:  # a simulator failed to build or run
        bar.close()
        print(f"{PROG}: error: the {args.engine} engine failed: {_cause(error)}", file=sys.stderr)
        return 1
    bar.close()
    config = plan.config
    if result.mismatches:
        print(
            f"{PROG}: error: the {args.engine} pipeline's image differs from the model's in "
            f"{result.mismatches} pixels (a bug: please report it with the scene)",
            file=sys.stderr,
        )
        return 1
    if not args.json:
        print(_engine_line(result, args.stats, _setup_units(args)))
    say = print if not args.json else (lambda *a, **k: None)
    figures = _figures(result, _setup_units(args)) if args.json else {}
    report = _stats(plan, result, baseline, figures) if baseline is not None else []
    if args.output is not None:  # after the work that can fail: no file from a failed command
        with atomic_output(PROG, args.output) as temporary:
            kind = write_png(result.image, config.full_scale, config.intensity_bits, temporary)
        say(f"wrote {args.output} ({kind})")
    for text in report:
        say(text)
    if args.error:
        figures.update(_error(result, scene, plan, bar, say))
    if args.json:
        print(json.dumps(figures, indent=1))
    elif args.output is None and not args.quiet:  # the last line: what happened to the image
        scene = plan.scene
        print(
            f"{PROG}: rendered {scene.width}x{scene.height} px ({args.engine}); give -o FILE.png "
            "to save it",
            file=sys.stderr,
        )
    return 0


def _setup_units(args: argparse.Namespace) -> int:
    """The setup units of the --pipeline configuration (compact if not given)."""
    from ..model.pipeline import PIPELINES

    return PIPELINES[args.pipeline or "compact"]["setup_units"]


def _figures(result, units: int) -> dict:
    from .stats import stats_numbers

    plan = result.plan
    numbers = stats_numbers(result)
    return {
        "scene": plan.scene.name,
        "width": plan.scene.width,
        "height": plan.scene.height,
        "engine": result.engine,
        "config": str(plan.config),
        **numbers,
        "writes": numbers["deltas"],  # the accumulation buffer's writes
        **_pipeline_figures(result, units),
    }


def _pipeline_figures(result, units: int) -> dict:
    hw = result.pipeline
    if hw is None:
        return {}
    return {
        "pipeline_setup_units": units,
        "pipeline_clocks": hw.clocks,
        "pipeline_seconds": round(hw.seconds, 6),
        "pipeline_stats": dict(hw.stats),
        "pipeline_mismatches": result.mismatches,
    }


def _error(result, scene, plan, bar: ProgressBar, say) -> dict:
    """Measure against the exact area (a colour scene: per channel, premultiplied, the worst
    channel of each pixel); print the table (text mode) and return the figures."""
    from .exact import error_rows, error_table, exact_image
    from .paint import exact_colour

    start = time.perf_counter()
    exact = exact_colour(plan, scene) if scene.colour else exact_image(plan, progress=bar)
    bar.close()
    rows = error_rows(result, exact)
    say(
        f"error against the exact area (shapely, {time.perf_counter() - start:.1f} s); "
        "pixels by the number of edges passing through them:"
    )
    say(error_table(rows))
    every = rows[0]
    return {
        "max_abs_lsb": every.max_abs,
        "rms_lsb": every.rms,
        "pixels": every.pixels,
        "by_edges_per_pixel": [
            {"pixels": r.label, "count": r.pixels, "max_abs_lsb": r.max_abs, "rms_lsb": r.rms}
            for r in rows
        ],
    }
