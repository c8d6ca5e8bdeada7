"""Sharded regressions (`edgeaa verify`): plan the shards, run them in this process, on a local
process pool or on a Dask distributed cluster, record each finished shard in a directory so a
rerun resumes, and merge the results.

A plan is of edges (`Plan`: shards of `edgeaa.sim.verification.shards`) or of scenes
(`ScenePlan`: shards of `edgeaa.sim.verification.scene_shards`); the store, the runners and the
summary serve both, the records' schema chosen by the plan (`schema_of`).

The directory's records (``run.json``, ``shards.jsonl``) and their schema are
`edgeaa.sim.verification.records`.

Why Dask distributed and not Ray: the work is independent shards of a few seconds each, which
both run equally well; Dask is pure Python wheels (Ray is a large binary wheel with its own
daemons and narrower Python support), its `Client.submit`/`wait` mirror `concurrent.futures`
so the local pool and the cluster share one loop here, a `LocalCluster` of two workers starts
in a few seconds inside a test, and ``DASK_SCHEDULER_ADDRESS`` is the usual way to point at a
running scheduler.
"""

from __future__ import annotations

import logging
import queue
import signal
import time
import traceback
from collections.abc import Callable, Iterable, Iterator
from concurrent import futures
from dataclasses import dataclass, fields
from multiprocessing import get_context
from typing import ClassVar

from ...model import EdgeConfig
from .records import FORMAT, MAX_LISTED, TIMES, ShardStore, Totals
from .scene_shards import SceneTask, build_pipeline, scene_range, scene_workload
from .shards import (
    BAD_FRACTION,
    CHUNK_EDGES,
    CLIP_FRACTION,
    IDLE,
    MAX_PIXELS,
    STALL,
    CompiledCore,
    ShardTask,
    shard_seed,
    shard_size,
)

ADDRESS_VARIABLE = "DASK_SCHEDULER_ADDRESS"


class ClusterUnavailable(RuntimeError):
    """Dask is not installed, or its scheduler cannot be reached (one line)."""


# -- the plan --------------------------------------------------------------------------------


@dataclass(frozen=True)
class Plan:
    """`edges` random edges in `shards` shards whose seeds derive from `seed`; or, with
    `shard_seed`, one shard of `edges` edges with that seed (the rerun of a reported shard)."""

    config: EdgeConfig
    edges: int
    shards: int
    seed: int
    engine: str = "verilator"
    shard_seed: int | None = None

    unit: ClassVar[str] = "edges"  # what a shard holds; its records and summary count them

    @property
    def total(self) -> int:
        return self.edges

    @property
    def count(self) -> int:
        """Shards in the plan."""
        return 1 if self.shard_seed is not None else self.shards

    def build_core(self, *, ship: bool = False) -> CompiledCore | None:
        """The compiled core the shards run on (None: the Amaranth engine builds nothing)."""
        return CompiledCore.build(self.config, ship=ship) if self.engine == "verilator" else None

    def tasks(self) -> Iterator[ShardTask]:
        """The shards in order, made as they are asked for (a plan may hold millions)."""
        if self.shard_seed is not None:
            yield ShardTask(0, self.shard_seed, self.edges, self.config, self.engine)
            return
        for index in range(self.shards):
            size = shard_size(self.edges, self.shards, index)
            yield ShardTask(index, shard_seed(self.seed, index), size, self.config, self.engine)

    def manifest(self) -> dict:
        """Everything that decides the shards' edges and checks (not the workers)."""
        config = _config_fields(self.config)
        workload = {"idle": IDLE, "stall": STALL, "bad_fraction": BAD_FRACTION}
        workload.update(clip_fraction=CLIP_FRACTION, max_pixels=list(MAX_PIXELS))
        workload["chunk_edges"] = CHUNK_EDGES  # a longer stream runs in pieces from reset
        return {
            "format": FORMAT,
            "config": config,
            "edges": self.edges,
            "shards": self.shards,
            "seed": self.seed,
            "shard_seed": self.shard_seed,
            "engine": self.engine,
            "workload": workload,
        }


def _config_fields(config: EdgeConfig) -> dict:
    """The configuration as run.json records it: every field given to `EdgeConfig`."""
    return {f.name: getattr(config, f.name) for f in fields(config) if f.init}


@dataclass(frozen=True)
class ScenePlan:
    """`scenes` random scenes (`random_scene`) through the Verilated pipeline in `shards`
    shards, each a range of scene seeds: from the run `seed`'s first scene seed on; or, with
    `shard_seed`, one shard of the scenes of the seeds from `shard_seed` on."""

    config: EdgeConfig
    scenes: int
    shards: int
    seed: int
    shard_seed: int | None = None

    engine: ClassVar[str] = "verilator"  # the pipeline in Amaranth's simulator is too slow
    unit: ClassVar[str] = "scenes"

    @property
    def total(self) -> int:
        return self.scenes

    @property
    def count(self) -> int:
        return 1 if self.shard_seed is not None else self.shards

    def tasks(self) -> Iterator[SceneTask]:
        for index in range(self.count):
            seed, scenes = scene_range(self.scenes, self.shards, self.seed, self.shard_seed, index)
            yield SceneTask(index, seed, scenes, self.config)

    def manifest(self) -> dict:
        config = _config_fields(self.config)
        return {
            "format": FORMAT,
            "config": config,
            "scenes": self.scenes,
            "shards": self.shards,
            "seed": self.seed,
            "shard_seed": self.shard_seed,
            "engine": self.engine,
            "workload": scene_workload(),
        }

    def build_core(self, *, ship: bool = False) -> CompiledCore:
        return build_pipeline(self.config, ship=ship)


# -- where the shards run --------------------------------------------------------------------


def _results(submit: Callable, wait_any: Callable, tasks: Iterable[ShardTask], limit: int):
    """Yield (task, future) as they finish, with at most `limit` in flight (a run of a million
    shards does not hold a million futures)."""
    pending: dict = {}
    queue = iter(tasks)
    for task in queue:
        pending[submit(task)] = task
        if len(pending) >= limit:
            break
    while pending:
        done, _ = wait_any(list(pending))
        for future in done:
            task = pending.pop(future)
            following = next(queue, None)
            if following is not None:
                pending[submit(following)] = following
            yield task, future


Task = ShardTask | SceneTask  # a shard of edges or of scenes: `task.check(core, report)`


def check_task(task: Task, core: CompiledCore | None, report: Callable | None = None) -> dict:
    """Check one shard (a module function: what a pool or a cluster sends to its workers)."""
    return task.check(core, report)


class InProcess:
    """Shards one after the other in this process (``--workers 0``: for debugging)."""

    def __init__(self, core: CompiledCore | None):
        self.core = core

    def results(
        self, tasks: Iterable[Task], piece: Callable | None = None
    ) -> Iterator[tuple[Task, Callable]]:
        """(task, its result) as each finishes; `piece(index, done)` after each piece."""
        for task in tasks:
            try:
                result = check_task(task, self.core, report=piece)
            except Exception as error:  # reported like a worker's exception
                yield task, _raise(error)
            else:
                yield task, (lambda result=result: result)

    def close(self) -> None:
        pass


def _raise(error: Exception) -> Callable:
    def result():
        raise error

    return result


_PIECES = None  # a pool worker's queue to the driver: (shard index, edges checked so far)


def _start_worker(pieces) -> None:
    """Workers leave Ctrl-C to the driver, which stops handing out shards and shuts them down
    (otherwise each prints a traceback); they report pieces on `pieces`."""
    global _PIECES
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _PIECES = pieces


def _check_in_worker(task: Task, core: CompiledCore | None) -> dict:
    return check_task(task, core, report=lambda index, done: _PIECES.put((index, done)))


class LocalPool:
    """A pool of `workers` processes on this machine (started fresh: `spawn`, so they do not
    inherit the driver's threads or open files). Workers report each piece of a shard on a
    queue, which the driver reads while it waits (`WAIT` seconds at a time)."""

    WAIT = 1.0

    def __init__(self, workers: int, core: CompiledCore | None):
        self.workers, self.core = workers, core
        context = get_context("spawn")
        self.pieces = context.Queue()
        self.pool = futures.ProcessPoolExecutor(
            workers, mp_context=context, initializer=_start_worker, initargs=(self.pieces,)
        )

    def results(self, tasks: Iterable[Task], piece: Callable | None = None):
        def submit(task):
            return self.pool.submit(_check_in_worker, task, self.core)

        def wait_any(pending):
            done, rest = futures.wait(pending, self.WAIT, return_when=futures.FIRST_COMPLETED)
            # A worker puts its pieces before it returns: all of a finished shard's are here.
            while True:
                try:
                    index, edges = self.pieces.get(timeout=0.05 if done else 0)
                except queue.Empty:
                    break
                if piece is not None:
                    piece(index, edges)
            return done, rest

        for task, future in _results(submit, wait_any, tasks, 2 * self.workers):
            yield task, future.result

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)
        self.pieces.close()


class DaskCluster:
    """A Dask distributed cluster: the scheduler at `address`, or ``"local"`` for a new
    `LocalCluster` of `workers` single-threaded worker processes on this machine. The compiled
    core is sent to every worker once (`Client.scatter`); workers must have edgeaa installed."""

    def __init__(self, address: str, workers: int, build: Callable):
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            raise ClusterUnavailable(
                '--cluster needs Dask distributed: pip install -e ".[cluster]"'
            ) from None
        self.cluster = None
        if address == "local":
            self.cluster = LocalCluster(
                n_workers=workers,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
            )
            self.client = Client(self.cluster)
        else:
            try:
                self.client = Client(address, timeout="10s")
            except (OSError, TimeoutError) as error:
                raise ClusterUnavailable(
                    f"cannot reach the Dask scheduler at {address}: {error}"
                ) from None
        core = build(ship=True)
        self.core = None if core is None else self.client.scatter(core, broadcast=True)
        self.threads = max(1, sum(self.client.nthreads().values()))

    def results(self, tasks: Iterable[Task], piece: Callable | None = None):
        """(task, its result) as each finishes; pieces are not reported from a cluster."""
        from distributed import wait

        def submit(task):
            return self.client.submit(check_task, task, self.core, pure=False)

        def wait_any(pending):
            return wait(pending, return_when="FIRST_COMPLETED")

        for task, future in _results(submit, wait_any, tasks, 2 * self.threads):
            yield task, future.result

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def open_runner(
    config: EdgeConfig,
    engine: str,
    workers: int,
    cluster: str | None,
    *,
    build: Callable | None = None,
) -> InProcess | LocalPool | DaskCluster:
    """Where the shards run: a Dask cluster if `cluster` is given, else the local pool (or, for
    ``workers == 0``, this process). The compiled core is built here, once: `build(ship=...)`
    (a plan's `build_core`; default the edge core of `config` on `engine`)."""
    if build is None:
        build = Plan(config, 1, 1, 0, engine).build_core  # (no seed, shard or edge in a build)
    if cluster is not None:
        return DaskCluster(cluster, workers, build)
    core = build(ship=False)
    return InProcess(core) if workers == 0 else LocalPool(workers, core)


# -- running a plan --------------------------------------------------------------------------


def crash_result(task: Task, error: BaseException) -> dict:
    """A shard whose worker raised: a failure of this run, not recorded (a rerun retries it)."""
    lines = traceback.format_exception_only(type(error), error)
    mismatch = {"kind": "crash", "message": f"the worker raised {lines[-1].strip()}"}
    mismatch.update(task.blank_mismatch(), reproduce_shard=task.reproduce())
    mismatch.update(shard=task.index, seed=task.seed)
    return task.blank_result() | {"mismatches": [mismatch], "crashed": True}


def run_plan(
    plan: Plan | ScenePlan, runner, store: ShardStore, progress: Callable | None = None
) -> dict:
    """Run the shards `store` has not finished; return the merged summary. `progress(done,
    total, stage)` is called with edges or scenes (`plan.unit`; finished ones included) after
    each shard and, from this process or a local pool, after each piece of a shard
    (`ShardTask.chunks`, a scene); the stage is the count of mismatches once there are any
    (else None: the rate is the bar's)."""
    tasks = (task for task in plan.tasks() if task.index not in store.finished)
    resumed = len(store.finished)
    unit, resumed_units = plan.unit, store.totals.sums[plan.unit]
    # this session's shards; those whose worker raised
    session, crashed = Totals(store.totals.summed), Totals(store.totals.summed)
    running: dict[int, int] = {}  # edges or scenes checked so far in shards still running
    start = time.perf_counter()

    def show() -> None:
        if progress is not None:
            done = resumed_units + session.sums[unit] + sum(running.values())
            failed = store.totals.mismatch_count + crashed.mismatch_count
            progress(done, plan.total, f"{failed} MISMATCHES" if failed else None)

    def piece(index: int, done: int) -> None:
        running[index] = done
        show()

    for task, result in runner.results(tasks, piece):
        try:
            record = result()
        except Exception as error:
            record = crash_result(task, error)
            crashed.add(record)
        else:
            store.record(record)
        running.pop(task.index, None)
        session.add(record)
        show()
    return summarize(plan, store.totals, crashed, session, resumed, time.perf_counter() - start)


def summarize(
    plan: Plan | ScenePlan,
    recorded: Totals,
    crashed: Totals,
    session: Totals,
    resumed: int,
    seconds: float,
) -> dict:
    """The run's figures, merged over every finished shard (`recorded`, resumed ones
    included, and the `crashed` ones of this session); rates and times are this session's.
    Mismatches are listed by shard, at most `MAX_LISTED`, and all counted."""
    listed = recorded.mismatches + crashed.mismatches
    listed = sorted(listed, key=lambda mismatch: mismatch["shard"])[:MAX_LISTED]
    count = recorded.mismatch_count + crashed.mismatch_count
    done = recorded.shards + crashed.shards
    units_run = session.sums[plan.unit]
    return {
        "passed": not count and done == plan.count,
        **plan.manifest(),
        "shards_done": done,
        "shards_resumed": resumed,
        "shards_run": session.shards,
        **{
            f"{key}_checked": recorded.sums[key] + crashed.sums[key]
            for key in recorded.summed
            if key not in TIMES
        },
        f"{plan.unit}_run": units_run,
        "seconds": seconds,
        f"{plan.unit}_per_second": units_run / seconds if seconds > 0 else 0.0,
        "worker_seconds": session.sums["seconds"],
        "sim_seconds": session.sums["sim_seconds"],
        "mismatch_count": count,
        "mismatches": listed,
    }


__all__ = [
    "ADDRESS_VARIABLE",
    "ClusterUnavailable",
    "DaskCluster",
    "InProcess",
    "LocalPool",
    "Plan",
    "ScenePlan",
    "open_runner",
    "run_plan",
]
