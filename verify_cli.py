"""`edgeaa verify`: N random edges in K seeded shards through the simulated core against the
model, on a local process pool or a Dask cluster, resumable from a directory.

The shards and their checks are `edgeaa.sim.verification.shards`; planning, running and
resuming them `edgeaa.sim.verification.regress`. This module reads the options, prints the
result and sets the exit status: 0 when every shard agrees, 1 for a mismatch (each printed with
its reproducers) or a simulator that failed, 2 for bad input, 130 when interrupted.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

from .command import (
    Command,
    ProgressBar,
    add_config_options,
    config_from_args,
    integer_type,
    read_integer,
    require_extra,
    require_verilator_cache,
    shown,
    usage_error,
)

EXIT_MISMATCH = 1
EXIT_INTERRUPTED = 130  # the shell's status for Ctrl-C
DEFAULT_EDGES = 10_000
DEFAULT_SEED = 1
MAX_EDGES = 10**12  # a thousand times the 10^9: weeks on a large cluster
# Processes on one machine: more only add memory (a cluster scales further, --cluster).
MAX_WORKERS = 256
# A shard draws its edges and their expected beats at once, about 1.1 KB an edge (measured,
# `verify --edges N --shards 1 --workers 0`: 151 MB peak at 20,000 edges, 219 MB at 80,000):
# at most about 400 MB a shard.
MAX_SHARD_EDGES = 250_000


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
    help = "check N random edges on the simulated core against the model, in parallel shards"
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
        "command skips them. The polygon pipeline (EdgePipeline) is checked scene by scene "
        "by `edgeaa render --engine verilator`, not here. docs/hardware.md, 'Regressions at "
        "scale'."
    )

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        from .sim.verification.shards import ENGINES, SHARD_EDGES

        parser.add_argument(
            "--edges",
            type=integer_type(),
            default=DEFAULT_EDGES,
            help=f"random edges in all (default {DEFAULT_EDGES:,}); with --shard-seed, the "
            "shard's edges",
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
            help=f"shards, 1 to N (default: one per {SHARD_EDGES:,} edges; it depends on N only, "
            "so a rerun with other --workers resumes the same shards)",
        )
        parser.add_argument(
            "--shard-seed",
            type=shard_seed,
            default=None,
            metavar="SEED",
            help="run the one shard with this seed (as printed with a mismatch) instead of "
            "shards derived from --seed",
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
            "slower and without stalls (every edge in the always-ready stream)",
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
        from .sim.verification.regress import ClusterUnavailable, RunMismatch, ShardStore

        plan, workers, cluster = self._plan(args)
        try:
            store = ShardStore(args.out, plan.manifest())
        except RunMismatch as error:
            raise usage_error(self.prog, str(error)) from None
        except OSError as error:  # not a directory, no permission, ...
            raise usage_error(self.prog, f"--out {args.out}: {error.strerror}") from None
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
        from .sim.verification.regress import ADDRESS_VARIABLE, Plan
        from .sim.verification.shards import default_shards

        if not 1 <= args.edges <= MAX_EDGES:
            raise usage_error(self.prog, f"--edges must be in [1, 10**12], not {args.edges}")
        if args.shard_seed is not None and (args.seed is not None or args.shards is not None):
            raise usage_error(
                self.prog, "--shard-seed runs one shard: give it without --seed and --shards"
            )
        shards = default_shards(args.edges) if args.shards is None else args.shards
        if args.shard_seed is not None:
            shards = 1
        if not 1 <= shards <= args.edges:
            raise usage_error(
                self.prog, f"--shards must be in [1, --edges = {args.edges}], not {shards}"
            )
        if -(-args.edges // shards) > MAX_SHARD_EDGES:
            raise usage_error(
                self.prog,
                f"{args.edges:,} edges in {shards} shard(s) is more than {MAX_SHARD_EDGES:,} a "
                "shard (a shard holds its edges in memory, about 1.1 KB each): give more "
                "--shards or fewer --edges",
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
        config = config_from_args(args)
        if args.engine == "verilator":
            require_extra(self.prog, "sim", ("verilator",))
            require_verilator_cache(self.prog)
        if cluster is not None:
            require_extra(self.prog, "cluster", ("distributed",))
        plan = Plan(config, args.edges, shards, seed, args.engine, args.shard_seed)
        return plan, workers, cluster


def _run(plan, store, workers: int, cluster: str | None, *, quiet: bool) -> dict:
    """Open the runner (the core is built here), run the plan with a progress bar, close."""
    from .sim.verification.regress import open_runner, run_plan

    runner = open_runner(plan.config, plan.engine, workers, cluster)
    bar = ProgressBar("edgeaa verify", enabled=not quiet)
    try:
        return run_plan(plan, runner, store, progress=bar)
    finally:
        bar.close()
        runner.close()


def _interrupted(plan, store, out: str | None) -> str:
    finished = f"{len(store.finished)} of {plan.count} shards finished"
    if out is None:
        return f"{finished}, none recorded (give --out DIR to resume a run)"
    return f"{finished} and recorded in {out}; rerun the same command to finish"


def _heading(plan, workers: int, cluster: str | None, finished: int) -> str:
    if plan.shard_seed is not None:
        what = f"one shard of {plan.edges:,} edges, shard seed {plan.shard_seed}"
    else:
        noun = "shard" if plan.shards == 1 else "shards"
        what = f"{plan.edges:,} edges in {plan.shards} {noun}, seed {plan.seed}"
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
        lines.append(
            f"MISMATCH in shard {mismatch['shard']} (shard seed {mismatch['seed']}{stream}): "
            f"{mismatch['message']}"
        )
        if mismatch["reproduce"]:
            lines.append(f"  the edge:  {mismatch['reproduce']}")
        lines.append(f"  the shard: {mismatch['reproduce_shard']}")
    count = len(summary["mismatches"])
    noun = "mismatch" if count == 1 else "mismatches"
    lines.append("PASSED" if summary["passed"] else f"FAILED: {count} {noun}")
    return "\n".join(lines)
