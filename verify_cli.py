"""`edgeaa verify`: N random edges through the simulated core, or N random scenes through the
Verilated polygon pipeline (`--scenes`), in K seeded shards against the model, on a local
process pool or a Dask cluster, resumable from a directory.

The shards and their checks are `edgeaa.sim.verification.shards` (edges) and
`edgeaa.sim.verification.scene_shards` (scenes); planning, running and resuming them
`edgeaa.sim.verification.regress`. This module reads the options, prints the
result and sets the exit status: 0 when every shard agrees, 1 for a mismatch (each printed with
its reproducers) or a simulator that failed, 2 for bad input, 130 when interrupted.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys

from .command import (
    Command,
    add_config_options,
    config_from_args,
    integer_type,
    read_integer,
    require_extra,
    require_verilator,
    shown,
    usage_error,
)
from .progress import ProgressBar

EXIT_MISMATCH = 1
EXIT_INTERRUPTED = 130  # the shell's status for Ctrl-C
DEFAULT_EDGES = 10_000
DEFAULT_SEED = 1
MAX_EDGES = 10**12  # a thousand times the 10^9: weeks on a large cluster
# Edges in one shard: its time is what an interrupted run loses (a shard is recorded whole).
# One core checks an edge in about 0.4 ms (100,000 edges in one shard, default
# configuration: 42.7 s, 2,343 edges/s on a shared 2-core machine), so the largest shard
# takes about 7 minutes; its memory is bounded anyway (shards.CHUNK_EDGES).
MAX_SHARD_EDGES = 1_000_000
EDGE_MS = 0.4
# Scenes: one takes 93 ms of worker time on average (the Verilated pipeline and the model;
# `--scenes 1000 --workers 2` on the shared 2-core machine), so the largest shard takes about
# 8 minutes.
MAX_SCENES = 10**9
MAX_SHARD_SCENES = 5_000
SCENE_MS = 93
# Processes on one machine: more only add memory (a cluster scales further, --cluster).
MAX_WORKERS = 256


def shard_seed(text: str) -> int:
    """An argparse type: a shard seed, a whole number below 2**64 (20 ASCII digits at most)."""
    try:
        return read_integer(text, 0, (1 << 64) - 1, digits=20)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be a whole number below 2**64, not {shown(text)}"
        ) from None


class VerifyCommand(Command):
    name = "verify"
    help = (
        "check N random edges on the simulated core, or N random scenes through the "
        "simulated pipeline, against the model, in parallel shards"
    )
    description = (
        "Draw N random edges (every octant, sub-pixel vertices, random sides and intensities, "
        "clip windows of every kind, about 2 % bad commands) in K seeded shards and run each "
        "shard through the simulated core: half of it with random source idles and sink "
        "back-pressure, checked beat for beat against the model with the bad commands "
        "counted; the other half back to back into an always-ready sink, also checked clock "
        "for clock against the timing model (model/timing.py). Shards run on a local process "
        "pool (all cores) or a Dask distributed cluster, the core compiled once and shared. A "
        "mismatch stops nothing: it is printed at the end with an `edgeaa edge` command for "
        "the edge and an `edgeaa verify --shard-seed` command for its shard, and the exit "
        "status is 1. With --out, finished shards are recorded and a rerun of the same "
        "command skips them; a record it did not write is refused, never overwritten. With "
        "--scenes N instead of --edges, N seeded random scenes (simple and self-intersecting "
        "polygons, both fill rules, a few intensities, up to 160 x 80 pixels: several tiles) "
        "go through the polygon pipeline (hdl/pipeline.py) compiled by Verilator, as `edgeaa "
        "render SCENE --engine verilator` renders them, and every pixel is compared with the "
        "model's image (`edgeaa render`); a shard is a range of scene seeds, and a mismatch "
        "names the scene seed, its first differing pixel and the command that reruns that "
        "scene. A run checks edges or scenes, not both: give --edges or --scenes. "
        "docs/hardware.md, 'Regressions at scale'."
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        from .sim.verification.scene_shards import SHARD_SCENES
        from .sim.verification.shards import ENGINES, SHARD_EDGES

        parser.add_argument(
            "--edges",
            type=integer_type(),
            default=None,
            help=f"random edges in all (default {DEFAULT_EDGES:,}); with --shard-seed, the "
            "shard's edges",
        )
        parser.add_argument(
            "--scenes",
            type=integer_type(),
            default=None,
            metavar="N",
            help="check N random scenes through the Verilated pipeline instead of edges "
            f"(default shards of {SHARD_SCENES} scenes); with --shard-seed, the shard's "
            "scenes, from that scene seed on",
        )
        parser.add_argument(
            "--seed",
            type=integer_type(),
            default=None,
            help=f"seed of the run: shard i's seed derives from it (default {DEFAULT_SEED})",
        )
        parser.add_argument(
            "--shards",
            type=integer_type(),
            default=None,
            help=f"shards, 1 to N (default: one per {SHARD_EDGES:,} edges or {SHARD_SCENES} "
            "scenes; it depends on N only, so a rerun with other --workers resumes the same "
            "shards)",
        )
        parser.add_argument(
            "--shard-seed",
            type=shard_seed,
            default=None,
            metavar="SEED",
            help="run the one shard with this seed (as printed with a mismatch; with --scenes "
            "the seed of its first scene) instead of shards derived from --seed",
        )
        parser.add_argument(
            "--workers",
            type=integer_type(),
            default=None,
            help="worker processes: of the local pool (default: all cores, "
            f"{os.cpu_count()} here) or of --cluster local, at most {MAX_WORKERS}; 0 runs the "
            "shards in this process",
        )
        parser.add_argument(
            "--cluster",
            metavar="ADDRESS",
            default=None,
            help="run on the Dask distributed scheduler at ADDRESS (e.g. tcp://host:8786), or "
            "'local' for a new local Dask cluster of --workers workers; default: "
            "$DASK_SCHEDULER_ADDRESS if set, else the local pool. Needs the 'cluster' extra "
            '(pip install -e ".[cluster]") here and edgeaa on every worker',
        )
        parser.add_argument(
            "--engine",
            choices=ENGINES,
            default="verilator",
            help="verilator (default): the core compiled by Verilator, built once per "
            "configuration; amaranth: Amaranth's Python simulator, about a thousand times "
            "slower and without stalls (every edge in the always-ready stream; edges only)",
        )
        parser.add_argument(
            "--out",
            metavar="DIR",
            default=None,
            help="record the run in DIR (run.json, shards.jsonl) and resume it from there: a "
            "rerun of the same command skips finished shards (default: nothing recorded)",
        )
        parser.add_argument("--json", action="store_true", help="print the summary as JSON")
        parser.add_argument("--quiet", action="store_true", help="no progress bar on stderr")
        add_config_options(parser)

    def run(self, args: argparse.Namespace) -> int:
        from .sim.verification.records import RunMismatch, ShardStore
        from .sim.verification.regress import ClusterUnavailable

        plan, workers, cluster = self._plan(args)
        try:
            store = ShardStore(args.out, plan.manifest())
        except RunMismatch as error:
            raise usage_error(self.prog, str(error)) from None
        except OSError as error:  # not a directory, no permission, ...
            raise usage_error(self.prog, f"--out {args.out}: {error.strerror}") from None
        for note in store.notes:
            print(f"{self.prog}: note: {note}", file=sys.stderr)
        if not args.json:
            print(_heading(plan, workers, cluster, len(store.finished)))
        try:
            summary = _run(plan, store, workers, cluster, quiet=args.quiet)
        except ClusterUnavailable as error:
            raise usage_error(self.prog, str(error)) from None
        except KeyboardInterrupt:
            print(
                f"\n{self.prog}: interrupted: {_interrupted(plan, store, args.out)}",
                file=sys.stderr,
            )
            return EXIT_INTERRUPTED
        summary["workers"], summary["cluster"] = workers, cluster
        if args.json:
            json.dump(summary, sys.stdout, indent=1)
            sys.stdout.write("\n")
        else:
            print(_report(summary))
        return 0 if summary["passed"] else EXIT_MISMATCH

    def _plan(self, args: argparse.Namespace):
        """The plan, the worker count and the cluster address; bad input as one line."""
        from .sim.verification.regress import ADDRESS_VARIABLE

        if args.scenes is not None and args.edges is not None:
            raise usage_error(self.prog, "--edges and --scenes are separate runs: give one of them")
        if args.shard_seed is not None and (args.seed is not None or args.shards is not None):
            raise usage_error(
                self.prog, "--shard-seed runs one shard: give it without --seed and --shards"
            )
        workers = (os.cpu_count() or 1) if args.workers is None else args.workers
        if not 0 <= workers <= MAX_WORKERS:
            raise usage_error(
                self.prog,
                f"--workers must be 0 (this process) to {MAX_WORKERS}, not {workers}",
            )
        cluster = args.cluster or os.environ.get(ADDRESS_VARIABLE) or None
        if cluster is not None and workers == 0:
            raise usage_error(self.prog, "--workers 0 runs in this process: not with a cluster")
        seed = DEFAULT_SEED if args.seed is None else args.seed
        if args.engine == "verilator":
            require_verilator(self.prog)
        if cluster is not None:
            require_extra(self.prog, "cluster", ("distributed",))
        if args.scenes is not None:
            return self._scene_plan(args, seed), workers, cluster
        return self._edge_plan(args, seed), workers, cluster

    def _shards(self, args, unit: str, total: int, default: int) -> int:
        """The shard count of `total` edges or scenes (`unit`), checked: 1 to `total`, none
        holding more than `_SHARD_LIMITS` allows."""
        shards = 1 if args.shard_seed is not None else default
        shards = shards if args.shards is None else args.shards
        if not 1 <= shards <= total:
            raise usage_error(
                self.prog, f"--shards must be in [1, --{unit} = {total}], not {shards}"
            )
        if -(-total // shards) > _SHARD_LIMITS[unit][0]:
            raise usage_error(self.prog, _too_large_shards(unit, total, shards, args))
        return shards

    def _edge_plan(self, args: argparse.Namespace, seed: int):
        from .sim.verification.regress import Plan
        from .sim.verification.shards import default_shards

        edges = DEFAULT_EDGES if args.edges is None else args.edges
        if not 1 <= edges <= MAX_EDGES:
            raise usage_error(self.prog, f"--edges must be in [1, 10**12], not {edges}")
        shards = self._shards(args, "edges", edges, default_shards(edges))
        config = config_from_args(args)
        return Plan(config, edges, shards, seed, args.engine, args.shard_seed)

    def _scene_plan(self, args: argparse.Namespace, seed: int):
        from .sim.verification.regress import ScenePlan
        from .sim.verification.scene_shards import default_scene_shards

        if args.engine != "verilator":
            raise usage_error(
                self.prog, "--scenes runs the Verilated pipeline: --engine amaranth is for edges"
            )
        if not 1 <= args.scenes <= MAX_SCENES:
            raise usage_error(self.prog, f"--scenes must be in [1, 10**9], not {args.scenes}")
        default = default_scene_shards(args.scenes)
        shards = self._shards(args, "scenes", args.scenes, default)
        return ScenePlan(config_from_args(args), args.scenes, shards, seed, args.shard_seed)


def _shard_limit(most: int, ms: float, unit: str) -> tuple[int, str]:
    """The most a shard holds, and why: the minutes of one core it takes at the measured rate
    (a shard is the unit a rerun resumes)."""
    return most, f"about {round(most * ms / 60_000)} min of one core at the measured {ms} ms {unit}"


_SHARD_LIMITS = {
    "edges": _shard_limit(MAX_SHARD_EDGES, EDGE_MS, "an edge"),
    "scenes": _shard_limit(MAX_SHARD_SCENES, SCENE_MS, "a scene"),
}


def _too_large_shards(unit: str, total: int, shards: int, args) -> str:
    """Why shards of total / shards edges or scenes are refused, and what to give instead."""
    most, why = _SHARD_LIMITS[unit]
    largest = -(-total // shards)
    text = f"a shard holds at most {most:,} {unit} ({why}; a shard is the unit a rerun resumes)"
    if args.shard_seed is not None:
        return f"--{unit} {total:,} for one shard: {text}"
    least = -(-total // most)
    return f"--shards {shards} makes shards of {largest:,} {unit}: {text}; give --shards >= {least}"


def _run(plan, store, workers: int, cluster: str | None, *, quiet: bool) -> dict:
    """Open the runner (the core is built here), run the plan with a progress bar, close."""
    from .sim.verification.regress import open_runner, run_plan

    resumed = store.totals.sums[plan.unit]
    bar = ProgressBar("edgeaa verify", enabled=not quiet, unit=plan.unit)
    what = "pipeline" if plan.unit == "scenes" else "core"
    with contextlib.ExitStack() as cleanup:
        cleanup.callback(bar.close)  # an error's line starts on a line of its own
        with bar.ticking(f"build the {plan.engine} {what}"):
            runner = open_runner(plan.config, plan.engine, workers, cluster, build=plan.build_core)
        cleanup.callback(runner.close)
        bar(resumed, plan.total)  # the rate counts this run's edges or scenes from here
        with bar.ticking("check"):  # a shard takes seconds: the time runs between them
            return run_plan(plan, runner, store, progress=bar)


def _interrupted(plan, store, out: str | None) -> str:
    finished = f"{len(store.finished)} of {plan.count} shards finished"
    if out is None:
        return f"{finished}, none recorded (give --out DIR to resume a run)"
    return f"{finished} and recorded in {out}; rerun the same command to finish"


def _heading(plan, workers: int, cluster: str | None, finished: int) -> str:
    unit = plan.unit
    if plan.shard_seed is not None:
        seed = "first scene seed" if unit == "scenes" else "shard seed"
        what = f"one shard of {plan.total:,} {unit}, {seed} {plan.shard_seed}"
    else:
        noun = "shard" if plan.shards == 1 else "shards"
        what = f"{plan.total:,} {unit} in {plan.shards} {noun}, seed {plan.seed}"
    if cluster == "local":
        where = f"on a local Dask cluster of {workers} workers"
    elif cluster is not None:
        where = f"on the Dask cluster at {cluster}"
    else:
        processes = "process" if workers == 1 else "processes"
        where = "in this process" if workers == 0 else f"on a local pool of {workers} {processes}"
    resumed = f"; {finished} shards finished already" if finished else ""
    return f"edgeaa verify: {what}; engine {plan.engine} {where}{resumed}\n{plan.config}"


def _report(summary: dict) -> str:
    lines = _scene_lines(summary) if "scenes" in summary else _edge_lines(summary)
    count = summary["mismatch_count"]
    noun = "mismatch" if count == 1 else "mismatches"
    shown_ = len(summary["mismatches"])
    listed = f" (the first {shown_} listed)" if count > shown_ else ""
    lines.append("PASSED" if summary["passed"] else f"FAILED: {count} {noun}{listed}")
    return "\n".join(lines)


def _scene_lines(summary: dict) -> list[str]:
    lines = [
        f"{summary['scenes_checked']:,} scenes in {summary['shards_done']} shard(s) "
        f"({summary['shards_resumed']} resumed) through the Verilated pipeline: "
        f"{summary['pixels_checked']:,} pixels against the model's image, "
        f"{summary['clocks_checked']:,} clocks simulated; {summary['failed_scenes_checked']:,} "
        f"scenes differ in {summary['wrong_pixels_checked']:,} pixels",
        f"this session: {summary['scenes_run']:,} scenes in {summary['seconds']:.1f} s, "
        f"{summary['scenes_per_second']:,.1f} scenes/s",
    ]
    for mismatch in summary["mismatches"]:
        lines += _mismatch_lines(mismatch, "first scene seed", "the scene:")
    return lines


def _edge_lines(summary: dict) -> list[str]:
    lines = [
        f"{summary['edges_checked']:,} edges in {summary['shards_done']} shard(s) "
        f"({summary['shards_resumed']} resumed): {summary['beats_checked']:,} beats bit for "
        f"bit against the model, {summary['dropped_checked']:,} bad commands dropped and "
        f"counted; {summary['timed_edges_checked']:,} of the edges also clock for clock "
        f"against the timing model (always-ready sink); {summary['clocks_checked']:,} clocks "
        "simulated",
        f"this session: {summary['edges_run']:,} edges in {summary['seconds']:.1f} s, "
        f"{summary['edges_per_second']:,.0f} edges/s",
    ]
    for mismatch in summary["mismatches"]:
        stream = f", {mismatch['stream']} stream" if mismatch["stream"] else ""
        lines += _mismatch_lines(mismatch, "shard seed", "the edge: ", stream)
    return lines


def _mismatch_lines(mismatch: dict, seed_is: str, item: str, stream: str = "") -> list[str]:
    """A mismatch of either kind of run: where, what, and the commands that rerun it (the
    scene or edge alone, when known, and its shard)."""
    lines = [
        f"MISMATCH in shard {mismatch['shard']} ({seed_is} {mismatch['seed']}{stream}): "
        f"{mismatch['message']}"
    ]
    if mismatch["reproduce"]:
        lines.append(f"  {item} {mismatch['reproduce']}")
    lines.append(f"  the shard: {mismatch['reproduce_shard']}")
    return lines
