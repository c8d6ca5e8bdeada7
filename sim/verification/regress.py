"""Sharded regressions (`edgeaa verify`): plan the shards, run them in this process, on a local
process pool or on a Dask distributed cluster, record each finished shard in a directory so a
rerun resumes, and merge the results.

The directory holds ``run.json`` (the plan: configuration, edge count, shards, seed, engine and
workload; a rerun with other options is refused rather than mixed in) and ``shards.jsonl``, one
JSON line per finished shard written as it finishes. A line cut short by an interrupt is
dropped when the run is resumed, and that shard runs again. A shard whose worker raised (rather
than found a mismatch) is reported but not recorded, so a rerun tries it again.

Why Dask distributed and not Ray: the work is independent shards of a few seconds each, which
both run equally well; Dask is pure Python wheels (Ray is a large binary wheel with its own
daemons and narrower Python support), its `Client.submit`/`wait` mirror `concurrent.futures`
so the local pool and the cluster share one loop here, a `LocalCluster` of two workers starts
in a few seconds inside a test, and ``DASK_SCHEDULER_ADDRESS`` is the usual way to point at a
running scheduler.
"""

from __future__ import annotations

import json
import logging
import os
import signal
import time
import traceback
from collections.abc import Callable, Iterable, Iterator
from concurrent import futures
from dataclasses import dataclass, fields
from multiprocessing import get_context
from pathlib import Path

from ...model import EdgeConfig
from .shards import (
    BAD_FRACTION,
    CLIP_FRACTION,
    IDLE,
    MAX_PIXELS,
    STALL,
    CompiledCore,
    ShardTask,
    check_shard,
    reproduce_shard,
    shard_seed,
    shard_size,
)

MANIFEST = "run.json"
RECORDS = "shards.jsonl"
FORMAT = 1  # of run.json and shards.jsonl
ADDRESS_VARIABLE = "DASK_SCHEDULER_ADDRESS"


class RunMismatch(ValueError):
    """The output directory holds a different run (one line saying how it differs)."""


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

    @property
    def count(self) -> int:
        """Shards in the plan."""
        return 1 if self.shard_seed is not None else self.shards

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
        config = {f.name: getattr(self.config, f.name) for f in fields(self.config) if f.init}
        workload = {"idle": IDLE, "stall": STALL, "bad_fraction": BAD_FRACTION}
        workload.update(clip_fraction=CLIP_FRACTION, max_pixels=list(MAX_PIXELS))
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


# -- the record of finished shards -----------------------------------------------------------


class ShardStore:
    """Finished shards by index: in memory, and in `directory` when one is given."""

    def __init__(self, directory: str | os.PathLike | None, manifest: dict):
        self.directory = None if directory is None else Path(directory)
        self.finished: dict[int, dict] = {}
        if self.directory is not None:
            self._open(manifest)

    def _open(self, manifest: dict) -> None:
        self.directory.mkdir(parents=True, exist_ok=True)
        path = self.directory / MANIFEST
        if path.exists():
            try:
                recorded = json.loads(path.read_text())
            except (OSError, ValueError) as error:
                raise RunMismatch(f"{path} is not a run record ({error})") from None
            if recorded != manifest:
                differences = _differences(recorded, manifest)
                raise RunMismatch(
                    f"{self.directory} holds another run ({differences}): rerun with its "
                    "options or give another --out"
                )
        else:
            path.write_text(json.dumps(manifest, indent=1) + "\n")
        self.finished = self._load()

    def _load(self) -> dict[int, dict]:
        """The recorded shards; a line an interrupt cut short is dropped (the file rewritten
        without it, so the next record starts on a line of its own)."""
        path = self.directory / RECORDS
        if not path.exists():
            return {}
        finished, broken = {}, False
        for line in path.read_text().splitlines(keepends=True):
            try:
                record = json.loads(line)
                finished[record["index"]] = record
            except (ValueError, KeyError, TypeError):
                broken = True
            broken |= not line.endswith("\n")
        if broken:
            partial = path.with_suffix(".tmp")
            partial.write_text("".join(json.dumps(r) + "\n" for r in finished.values()))
            os.replace(partial, path)
        return finished

    def record(self, result: dict) -> None:
        self.finished[result["index"]] = result
        if self.directory is not None:
            with open(self.directory / RECORDS, "a") as file:
                file.write(json.dumps(result) + "\n")


def _differences(recorded: dict, wanted: dict) -> str:
    keys = [key for key in wanted if recorded.get(key) != wanted[key]]
    return ", ".join(f"{key} {recorded.get(key)!r} there, {wanted[key]!r} here" for key in keys)


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


class InProcess:
    """Shards one after the other in this process (``--workers 0``: for debugging)."""

    def __init__(self, core: CompiledCore | None):
        self.core = core

    def results(self, tasks: Iterable[ShardTask]) -> Iterator[tuple[ShardTask, Callable]]:
        for task in tasks:
            try:
                result = check_shard(task, self.core)
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


def _ignore_interrupt() -> None:
    """Workers leave Ctrl-C to the driver, which stops handing out shards and shuts them down
    (otherwise each prints a traceback)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class LocalPool:
    """A pool of `workers` processes on this machine (started fresh: `spawn`, so they do not
    inherit the driver's threads or open files)."""

    def __init__(self, workers: int, core: CompiledCore | None):
        self.workers, self.core = workers, core
        self.pool = futures.ProcessPoolExecutor(
            workers, mp_context=get_context("spawn"), initializer=_ignore_interrupt
        )

    def results(self, tasks: Iterable[ShardTask]):
        def submit(task):
            return self.pool.submit(check_shard, task, self.core)

        def wait_any(pending):
            return futures.wait(pending, return_when=futures.FIRST_COMPLETED)

        for task, future in _results(submit, wait_any, tasks, 2 * self.workers):
            yield task, future.result

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)


class DaskCluster:
    """A Dask distributed cluster: the scheduler at `address`, or ``"local"`` for a new
    `LocalCluster` of `workers` single-threaded worker processes on this machine. The compiled
    core is sent to every worker once (`Client.scatter`); workers must have edgeaa installed."""

    def __init__(self, address: str, workers: int, config: EdgeConfig, engine: str):
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
        core = CompiledCore.build(config, ship=True) if engine == "verilator" else None
        self.core = None if core is None else self.client.scatter(core, broadcast=True)
        self.threads = max(1, sum(self.client.nthreads().values()))

    def results(self, tasks: Iterable[ShardTask]):
        from distributed import wait

        def submit(task):
            return self.client.submit(check_shard, task, self.core, pure=False)

        def wait_any(pending):
            return wait(pending, return_when="FIRST_COMPLETED")

        for task, future in _results(submit, wait_any, tasks, 2 * self.threads):
            yield task, future.result

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def open_runner(
    config: EdgeConfig, engine: str, workers: int, cluster: str | None
) -> InProcess | LocalPool | DaskCluster:
    """Where the shards run: a Dask cluster if `cluster` is given, else the local pool (or, for
    ``workers == 0``, this process). The compiled core is built here, once."""
    if cluster is not None:
        return DaskCluster(cluster, workers, config, engine)
    core = CompiledCore.build(config) if engine == "verilator" else None
    return InProcess(core) if workers == 0 else LocalPool(workers, core)


# -- running a plan --------------------------------------------------------------------------


def crash_result(task: ShardTask, error: BaseException) -> dict:
    """A shard whose worker raised: a failure of this run, not recorded (a rerun retries it)."""
    lines = traceback.format_exception_only(type(error), error)
    message = f"the worker raised {lines[-1].strip()}"
    mismatch = {"kind": "crash", "edge": None, "beat": None, "message": message}
    mismatch.update(stream=None, reproduce=None, reproduce_shard=reproduce_shard(task))
    mismatch.update(shard=task.index, seed=task.seed)
    return {
        "index": task.index,
        "seed": task.seed,
        "edges": task.edges,
        "beats": 0,
        "clocks": 0,
        "dropped": 0,
        "timed_edges": 0,
        "sim_seconds": 0.0,
        "seconds": 0.0,
        "mismatches": [mismatch],
        "crashed": True,
    }


def run_plan(plan: Plan, runner, store: ShardStore, progress: Callable | None = None) -> dict:
    """Run the shards `store` has not finished; return the merged summary. `progress(done,
    total, stage)` is called with edges (finished ones included) after each shard; the stage
    is the count of mismatches once there are any (else None: the rate is the bar's)."""
    tasks = (task for task in plan.tasks() if task.index not in store.finished)
    resumed = len(store.finished)
    fresh: list[dict] = []  # this session's shards, crashed ones included
    done = sum(record["edges"] for record in store.finished.values())
    start = time.perf_counter()
    for task, result in runner.results(tasks):
        try:
            record = result()
        except Exception as error:
            record = crash_result(task, error)
        else:
            store.record(record)
        fresh.append(record)
        done += task.edges
        if progress is not None:
            progress(done, plan.edges, _failures(fresh, store))
    seconds = time.perf_counter() - start
    crashed = [record for record in fresh if record.get("crashed")]
    records = sorted([*store.finished.values(), *crashed], key=lambda r: r["index"])
    return summarize(plan, records, fresh, resumed, seconds)


def _failures(fresh: list[dict], store: ShardStore) -> str | None:
    """The progress bar's stage: the mismatches so far, if any."""
    failed = sum(len(r["mismatches"]) for r in store.finished.values())
    failed += sum(len(r["mismatches"]) for r in fresh if r.get("crashed"))
    return f"{failed} MISMATCHES" if failed else None


def summarize(plan: Plan, records: list[dict], fresh: list[dict], resumed: int, seconds: float):
    """The run's figures, merged over every finished shard (resumed ones included); rates and
    times are this session's (`fresh` shards)."""
    totals = {
        key: sum(record[key] for record in records)
        for key in ("edges", "beats", "clocks", "dropped", "timed_edges")
    }
    mismatches = [m for record in records for m in record["mismatches"]]
    edges_run = sum(record["edges"] for record in fresh)
    return {
        "passed": not mismatches and len(records) == plan.count,
        **plan.manifest(),
        "shards_done": len(records),
        "shards_resumed": resumed,
        "shards_run": len(fresh),
        **{f"{key}_checked": value for key, value in totals.items()},
        "edges_run": edges_run,
        "seconds": seconds,
        "edges_per_second": edges_run / seconds if seconds > 0 else 0.0,
        "worker_seconds": sum(record["seconds"] for record in fresh),
        "sim_seconds": sum(record["sim_seconds"] for record in fresh),
        "mismatches": mismatches,
    }


__all__ = [
    "ADDRESS_VARIABLE",
    "ClusterUnavailable",
    "DaskCluster",
    "InProcess",
    "LocalPool",
    "Plan",
    "RunMismatch",
    "ShardStore",
    "open_runner",
    "run_plan",
]
