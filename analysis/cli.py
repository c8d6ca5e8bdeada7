"""The analysis commands of `edgeaa`: plot error-vs-slope, bench, stress.

They register themselves (`edgeaa.command.Command`) when this module is imported.
"""

from __future__ import annotations

import argparse
from functools import partial

from ..command import (
    LINE_PEER_MODULES,
    PEER_MODULES,
    Command,
    add_config_options,
    atomic_output,
    check_output,
    config_from_args,
    integer_list_type,
    integer_type,
    number_type,
    require_extra,
    require_synth,
    require_verilator,
    usage_error,
)
from ..model.config import COORD_BITS_RANGE, INTENSITY_BITS_RANGE
from ..progress import ProgressBar

PLOT_SUFFIXES = (".png", ".svg", ".pdf")
# Upper bounds that keep each job to minutes, not days (every default is far below them).
MAX_OFFSETS = 1024
MAX_EDGES = 100_000
MAX_REPEATS = 100
SEED = integer_type(0, 2**32 - 1)  # numpy's seed range


def _check_output(prog: str, path: str) -> None:
    check_output(prog, path, PLOT_SUFFIXES)


def _write_plot(prog: str, path: str, draw, quiet: bool) -> None:
    """`draw(file)` into `path` whole or not at all, named on a progress bar while it runs
    (a figure of many panels takes seconds)."""
    bar = ProgressBar(prog.removeprefix("edgeaa "), enabled=not quiet)
    with bar.ticking(f"write {path}"), atomic_output(prog, path) as temporary:
        draw(temporary)
    bar.close()
    print(f"wrote {path}")


# -- edgeaa plot error-vs-slope -----------------------------------------------------------------


SLOPE_PROG = "edgeaa plot error-vs-slope"


class PlotCommand(Command):
    name = "plot"
    help = "draw the analysis figures (error-vs-slope)"
    description = "Draw an analysis figure."

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        figures = parser.add_subparsers(dest="figure", metavar="FIGURE", parser_class=type(parser))
        figures.required = True
        slope = figures.add_parser(
            "error-vs-slope",
            help="maximum and RMS coverage error against the edge angle, every method",
            description="Sweep the edge angle from 0 to 90 degrees over sub-pixel offsets and "
            "plot the maximum and RMS coverage error against the exact area of edgeaa's modes "
            "(with their bounds k/8, k/64, k/256, k/1024), the sample-based baselines (point, "
            "ordered grids 2x2..16x16, rotated grid, 8-rooks), the seeds' methods (MSAA 2x, "
            "quincunx, FLIPQUAD, MLAA with and without slope prediction, FXAA with luma or "
            "geometry edges, TAA) and the peers (Skia, AGG).",
        )
        slope.add_argument(
            "-o",
            "--output",
            default="error_vs_slope.png",
            help="plot file (.png, .svg or .pdf; default error_vs_slope.png)",
        )
        slope.add_argument(
            "--step",
            type=number_type(0.01, 45),
            default=1.0,
            help="angle step in degrees, 0.01 to 45 (1)",
        )
        slope.add_argument(
            "--length", type=integer_type(4, 1 << 16), default=64, help="edge length in px (64)"
        )
        slope.add_argument(
            "--offsets",
            type=integer_type(1, MAX_OFFSETS),
            default=64,
            help=f"sub-pixel start offsets, 1 to {MAX_OFFSETS} (64)",
        )
        slope.add_argument(
            "--no-peers", dest="peers", action="store_false", help="leave out Skia and AGG"
        )
        slope.add_argument(
            "--no-post",
            dest="post",
            action="store_false",
            help="leave out the image post-process methods (MLAA, FXAA, TAA), which take most "
            "of the time (about 3 minutes with them, seconds without, at the defaults)",
        )
        slope.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
        add_config_options(slope)
        methods = figures.add_parser(
            "aa-methods",
            help="one table of every method: error on edges, text, starburst, hatch; time",
            description="Max and RMS error of edgeaa, the seeds' methods (MSAA patterns, "
            "MLAA, FXAA, TAA) and the peers on seeded random edges and on the built-in text, "
            "starburst and hatch scenes, time per pixel and values per pixel; a bar chart.",
        )
        methods.add_argument("-o", "--output", default="aa_methods.png", help="bar chart file")
        methods.add_argument(
            "--edges", type=integer_type(1, MAX_EDGES), default=1000, help="random edges (1000)"
        )
        methods.add_argument("--seed", type=SEED, default=1, help="random seed (1)")
        methods.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
        taa = figures.add_parser(
            "taa",
            help="temporal AA on the turning starburst: strip of frames, error and flicker",
            description="Render the starburst turning a fraction of a degree per frame with "
            "point sampling, MSAA 4x, TAA and edgeaa; print the error and flicker per frame and "
            "draw a strip of frames.",
        )
        taa.add_argument("-o", "--output", default="aa_taa.png", help="figure file")
        taa.add_argument("--frames", type=integer_type(2, 256), default=32, help="frames (32)")
        taa.add_argument(
            "--step", type=number_type(0.0, 45), default=0.2, help="degrees per frame (0.2)"
        )
        taa.add_argument("--quiet", action="store_true", help="no progress lines on stderr")

    def run(self, args: argparse.Namespace) -> int:
        figures = {
            "error-vs-slope": _plot_error_vs_slope,
            "aa-methods": _plot_aa_methods,
            "taa": _plot_taa,
        }
        return figures[args.figure](args)


def _plot_error_vs_slope(args: argparse.Namespace) -> int:
    from . import slope
    from .report import machine_line

    config = config_from_args(args)
    _check_output(SLOPE_PROG, args.output)
    if args.peers:
        require_extra(SLOPE_PROG, "peers", PEER_MODULES)
    need = 2 + 1 + args.length
    if args.length < 4 or need > (1 << config.coord_bits) - 1:
        raise usage_error(
            SLOPE_PROG,
            f"--length {args.length} px: must be at least 4 and fit the coordinate range "
            f"[0, {(1 << config.coord_bits) - 1}] px with 3 px to spare",
        )
    from .aa_methods import IMAGE_METHODS

    methods = slope.DEFAULT_METHODS if args.peers else slope.DEFAULT_METHODS[:-2]
    if not args.post:
        methods = tuple(m for m in methods if m not in IMAGE_METHODS)
    sweep = slope.error_vs_slope(
        config,
        step=args.step,
        length=args.length,
        offsets=args.offsets,
        methods=methods,
        progress=not args.quiet,
    )
    print(machine_line())
    print(
        f"error vs slope: {sweep.edges} edges ({len(sweep.angles)} angles x {args.offsets} "
        f"sub-pixel offsets, {args.length} px), {sweep.pixels} pixels; config {config}"
    )
    print(slope.sweep_table(sweep))
    print(
        "c_N k is the estimate's own bound; the fixed-point units add U_N / (|I_d| 2^F) to it "
        "(docs/algorithm.md 9.1), so at small k the ratio can pass 1 by those units."
    )
    _write_plot(SLOPE_PROG, args.output, partial(slope.plot_sweep, sweep), args.quiet)
    return 0


def _plot_aa_methods(args: argparse.Namespace) -> int:
    from ..model import EdgeConfig
    from . import aa_report
    from .report import machine_line

    prog = "edgeaa plot aa-methods"
    _check_output(prog, args.output)
    require_extra(prog, "peers", PEER_MODULES)
    config = EdgeConfig()
    rows = aa_report.method_table(config, args.edges, args.seed, not args.quiet)
    print(machine_line())
    print(
        f"edges: {args.edges} random (seed {args.seed}), output values, fraction of a pixel; "
        "scenes: |image - exact composite| in intensity LSB of 255; ns/px: time to draw the "
        "starburst per image pixel in this run; values/px: held per pixel before resolve"
    )
    print(aa_report.table_text(rows))
    _write_plot(prog, args.output, partial(aa_report.plot_table, rows), args.quiet)
    return 0


def _plot_taa(args: argparse.Namespace) -> int:
    from ..model import EdgeConfig
    from . import aa_report
    from .report import machine_line

    prog = "edgeaa plot taa"
    _check_output(prog, args.output)
    seq = aa_report.taa_sequence(EdgeConfig(), args.frames, args.step, not args.quiet)
    print(machine_line())
    print(aa_report.sequence_text(seq))
    _write_plot(prog, args.output, partial(aa_report.plot_sequence, seq), args.quiet)
    return 0


# -- edgeaa bench ----------------------------------------------------------------------------------


class BenchCommand(Command):
    name = "bench"
    help = "error and run time of every method on seeded random edges, with Skia and AGG"
    description = (
        "On a fixed, seeded set of random edges: maximum and RMS coverage error "
        "against the exact area and run time (as a ratio to edgeaa's vectorized model in the "
        "same run) of edgeaa's modes, the sample-based baselines and the real rasterizers "
        "Skia and AGG (and, on lines, scikit-image's line_aa). Prints the tables; -o also "
        "writes a Pareto plot of error against time."
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument(
            "--quick",
            action="store_true",
            help="few edges and repeats, no hardware columns (seconds)",
        )
        parser.add_argument(
            "--no-synth",
            action="store_true",
            help="skip synthesis for the LUT and Fmax columns (about a minute per mode, cached)",
        )
        parser.add_argument(
            "--edges",
            type=integer_type(1, MAX_EDGES),
            default=None,
            help=f"random edges, 1 to {MAX_EDGES:,} (default 1000, --quick 60)",
        )
        parser.add_argument("--seed", type=SEED, default=1, help="random seed (1)")
        parser.add_argument(
            "--repeats",
            type=integer_type(1, MAX_REPEATS),
            default=None,
            help="timed runs per method, minimum kept (default 5, --quick 2)",
        )
        parser.add_argument("--no-lines", action="store_true", help="skip the line comparison")
        parser.add_argument(
            "-o",
            "--output",
            help="also write the Pareto plot to this file (.png, .svg or .pdf; default: none)",
        )
        parser.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
        add_config_options(parser)

    def run(self, args: argparse.Namespace) -> int:
        from . import bench
        from .report import machine_line

        config = config_from_args(args)
        if args.output is not None:
            _check_output(self.prog, args.output)
        quick = args.quick
        lines = () if args.no_lines else LINE_PEER_MODULES
        require_extra(self.prog, "peers", PEER_MODULES + lines)
        if not quick:  # the hardware columns: the compiled core, and synthesis unless skipped
            require_verilator(self.prog)
            if not args.no_synth:
                require_synth(self.prog, ("ice40",))
        count = (
            args.edges
            if args.edges is not None
            else (bench.QUICK_EDGES if quick else bench.DEFAULT_EDGES)
        )
        repeats = (
            args.repeats
            if args.repeats is not None
            else (bench.QUICK_REPEATS if quick else bench.DEFAULT_REPEATS)
        )
        if config.coord_bits < 6:
            raise usage_error(self.prog, "--coord-bits must be at least 6 (edges of up to 200 px)")
        result = bench.run_bench(
            config,
            count=count,
            seed=args.seed,
            repeats=repeats,
            lines=not args.no_lines,
            progress=not args.quiet,
            hardware=not quick,
            synthesis=not args.no_synth,
        )
        print(machine_line())
        print(bench.bench_tables(result))
        if args.output is not None:
            _write_plot(self.prog, args.output, partial(bench.plot_pareto, result), args.quiet)
        return 0


# -- edgeaa stress ---------------------------------------------------------------------------------


class StressCommand(Command):
    name = "stress"
    help = "numerical stability: extreme edges, drift of the truncated accumulator"
    description = (
        "Check the error bound on extreme edges (longest, slopes 1/L and "
        "(L-1)/L, sub-pixel extremes, every sub-pixel phase) for each coordinate width, "
        "every mode and both accumulators; sweep the fraction bits F of the truncated "
        "accumulator and print the smallest safe F beside the derived one; plot the drift "
        "against length and F (with -o)."
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument(
            "--quick", action="store_true", help="small widths and intensities only (seconds)"
        )
        parser.add_argument(
            "--widths",
            type=integer_list_type(*COORD_BITS_RANGE),
            help="coordinate widths W, e.g. 2,4,8 (default 2,4,6,8,10,11,12,14,16; "
            "--quick 2,4,6,8,11)",
        )
        parser.add_argument(
            "--intensities",
            type=integer_list_type(*INTENSITY_BITS_RANGE),
            help="intensity bits I for the F table, e.g. 4,8 (default 4,8,12,16; --quick 4,8)",
        )
        parser.add_argument(
            "--subpixel-bits", type=integer_type(), default=4, help="sub-pixel bits s (4)"
        )
        parser.add_argument(
            "--plot-coord-bits", type=integer_type(), default=11, help="W of the drift curves (11)"
        )
        parser.add_argument(
            "--plot-intensity-bits",
            type=integer_type(),
            default=8,
            help="I of the drift curves and of the bound check (8)",
        )
        parser.add_argument(
            "--skip-bounds", action="store_true", help="only the word-length sweep and the plot"
        )
        parser.add_argument(
            "-o",
            "--output",
            help="also write the drift plot to this file (.png, .svg or .pdf; default: none)",
        )
        parser.add_argument("--quiet", action="store_true", help="no progress lines on stderr")

    def run(self, args: argparse.Namespace) -> int:
        from . import stress
        from .report import machine_line

        widths, intensities = self._check(args)
        s, plot_i = args.subpixel_bits, args.plot_intensity_bits
        progress = not args.quiet
        print(machine_line())
        print(f"stress: widths {widths}, intensity bits {intensities}, subpixel bits {s}")
        if not args.skip_bounds:
            rows = stress.bound_sweep(widths, s, plot_i, progress=progress)
            print(f"\nbound on the stress edges (intensity bits {plot_i}, derived F):")
            print(stress.bound_table(rows))
        safe = stress.safe_frac_bits(
            widths, intensities, s, full_span_intensity=plot_i, progress=progress
        )
        print("\nsmallest safe fraction bits F of the truncated accumulator, measured and derived:")
        print(stress.safe_table(safe))
        if args.output is not None:
            self._plot(args, safe)
        return 0

    def _plot(self, args: argparse.Namespace, safe) -> None:
        """The drift against length and F (a few seconds: the bar names it)."""
        from ..model.config import EdgeConfig
        from . import stress

        w, s, i = args.plot_coord_bits, args.subpixel_bits, args.plot_intensity_bits
        plot_config = EdgeConfig(coord_bits=w, subpixel_bits=s, intensity_bits=i, mode="paper")

        def draw(path: str) -> None:
            curves = stress.drift_curves(w, s, i)
            shallow = stress.length_curves(w, s, i)
            stress.plot_stress(curves, shallow, safe, plot_config, path)

        _write_plot(self.prog, args.output, draw, args.quiet)

    def _check(self, args: argparse.Namespace) -> tuple[tuple[int, ...], tuple[int, ...]]:
        """The widths and intensity bits to sweep, after checking every option."""
        from ..model.config import COORD_BITS_RANGE, SUBPIXEL_BITS_RANGE
        from . import stress

        prog = self.prog
        if args.output is not None:
            _check_output(prog, args.output)
        widths = args.widths or (stress.QUICK_WIDTHS if args.quick else stress.FULL_WIDTHS)
        intensities = args.intensities or (
            stress.QUICK_INTENSITIES if args.quick else stress.FULL_INTENSITIES
        )
        lo, hi = SUBPIXEL_BITS_RANGE
        if not lo <= args.subpixel_bits <= hi:
            raise usage_error(
                prog, f"--subpixel-bits must be in [{lo}, {hi}], not {args.subpixel_bits}"
            )
        lo, hi = COORD_BITS_RANGE
        if not lo <= args.plot_coord_bits <= hi:
            raise usage_error(prog, f"--plot-coord-bits must be in [{lo}, {hi}]")
        if args.plot_intensity_bits not in intensities:
            raise usage_error(
                prog,
                f"--plot-intensity-bits {args.plot_intensity_bits} must be one of --intensities "
                f"({','.join(map(str, intensities))})",
            )
        return widths, intensities
