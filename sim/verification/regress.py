"""Sharded regressions (`edgeaa verify`): plan the shards, run them in this process, on a local
process pool or on a Dask distributed cluster, record each finished shard in a directory so a
rerun resumes, and merge the results.

A plan is of edges (`Plan`: shards of `edgeaa.sim.verification.shards`) or of scenes
(`ScenePlan`: shards of `edgeaa.sim.verification.scene_shards`); the store, the runners and the
summary serve both, the records' schema chosen by the plan (`schema_of`).

The directory holds ``run.json`` (the plan: configuration, edge or scene count, shards, seed,
engine and workload; a rerun with other options is refused rather than mixed in) and
``shards.jsonl``, one JSON line per finished shard written as it finishes. Both are checked
against one schema when a run resumes (`manifest_error`, `record_error`), and a file that
fails it is refused, never rewritten; only a last line an interrupted write left without its
newline is cut off (with a note), and that shard runs again. A shard whose worker raised
(rather than found a mismatch) is reported but not recorded, so a rerun tries it again.

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
import math
import os
import queue
import signal
import stat
import time
import traceback
from collections.abc import Callable, Iterable, Iterator
from concurrent import futures
from dataclasses import dataclass, field, fields
from multiprocessing import get_context
from pathlib import Path
from typing import ClassVar

from ...model import EdgeConfig
from ...model.numbers import shown
from .scene_shards import (
    MAX_LISTED_SCENES,
    SceneTask,
    build_pipeline,
    first_scene_seed,
    scene_workload,
)
from .shards import (
    BAD_FRACTION,
    CHUNK_EDGES,
    CLIP_FRACTION,
    IDLE,
    KINDS,
    MAX_PIXELS,
    STALL,
    CompiledCore,
    ShardTask,
    shard_seed,
    shard_size,
)

MANIFEST = "run.json"
RECORDS = "shards.jsonl"
FORMAT = 2  # of run.json and shards.jsonl (2: the workload names its chunk_edges)
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


def scene_range(
    scenes: int, shards: int, seed: int, shard_seed: int | None, index: int
) -> tuple[int, int]:
    """(first scene seed, scenes) of shard `index` of a `ScenePlan` of these fields: the run's
    scene seeds are consecutive, split into shards that differ by at most one scene."""
    if shard_seed is not None:
        return shard_seed, scenes
    base, extra = divmod(scenes, shards)
    return first_scene_seed(seed) + index * base + min(index, extra), base + (index < extra)


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


# -- the record of finished shards -----------------------------------------------------------


class DamagedRecord(RunMismatch):
    """A file of the output directory is not what `ShardStore` writes (one line naming it)."""


MAX_MANIFEST = 1 << 16  # bytes of run.json (it takes about 600)
MAX_LINE = 1 << 16  # bytes of a line of shards.jsonl (at most six mismatches: about 5 KB)
COUNTS = ("beats", "clocks", "dropped", "timed_edges")  # a record's whole counts, >= 0
TIMES = ("sim_seconds", "seconds")
MISMATCH_FIELDS = {  # a recorded mismatch's fields and their JSON types
    "kind": (str,),
    "edge": (int, type(None)),
    "beat": (int, type(None)),
    "message": (str,),
    "stream": (str, type(None)),
    "reproduce": (str, type(None)),
    "reproduce_shard": (str,),
    "shard": (int,),
    "seed": (int,),
}
RECORD_FIELDS = ("index", "seed", "edges", *COUNTS, *TIMES, "mismatches")
# A shard of scenes' record (`edgeaa.sim.verification.scene_shards.check_scenes`).
SCENE_COUNTS = ("pixels", "clocks", "failed_scenes", "wrong_pixels")
SCENE_MISMATCH_FIELDS = {
    "kind": (str,),
    "scene": (int,),
    "x": (int, type(None)),
    "y": (int, type(None)),
    "message": (str,),
    "reproduce": (str, type(None)),
    "reproduce_shard": (str,),
    "shard": (int,),
    "seed": (int,),
}
SCENE_RECORD_FIELDS = ("index", "seed", "scenes", *SCENE_COUNTS, *TIMES, "mismatches")


@dataclass(frozen=True)
class Schema:
    """What a run's shard records hold: their fields, counts, mismatches' fields and how
    many mismatches a record lists at most."""

    unit: str
    fields: tuple
    counts: tuple
    mismatch: dict
    most: int


EDGE_SCHEMA = Schema("edges", RECORD_FIELDS, COUNTS, MISMATCH_FIELDS, 2 * len(KINDS))
SCENE_SCHEMA = Schema(
    "scenes", SCENE_RECORD_FIELDS, SCENE_COUNTS, SCENE_MISMATCH_FIELDS, MAX_LISTED_SCENES
)


def schema_of(manifest: dict) -> Schema:
    """The records' schema of the run of `manifest` (a run of scenes counts scenes)."""
    return SCENE_SCHEMA if "scenes" in manifest else EDGE_SCHEMA


def expected_shard(manifest: dict, index: int) -> tuple[int, int]:
    """(seed, size) of shard `index` of the run of `manifest`, as its plan makes them."""
    if "scenes" in manifest:
        keys = ("scenes", "shards", "seed", "shard_seed")
        return scene_range(*(manifest[key] for key in keys), index)
    if manifest["shard_seed"] is not None:
        return manifest["shard_seed"], manifest["edges"]
    seed = shard_seed(manifest["seed"], index)
    return seed, shard_size(manifest["edges"], manifest["shards"], index)


def _shown(value) -> str:
    """A recorded value for a message: a plain one cut short, a structure by its type only (its
    repr could be deep)."""
    if isinstance(value, dict | list):
        return f"a JSON {'object' if isinstance(value, dict) else 'array'}"
    return shown(value)


def _is(value, types: tuple) -> bool:
    """`value` is of one of the JSON `types` (a bool is not an int here)."""
    return isinstance(value, types) and (bool in types or not isinstance(value, bool))


def record_error(record, manifest: dict) -> str | None:
    """What is wrong with a shard's record (a parsed line of shards.jsonl) for the run of
    `manifest`, or None: the one schema of a record (`schema_of`), its fields' types and
    ranges, and the shard's seed and size as the plan makes them. Looks no deeper than the
    schema does."""
    schema = schema_of(manifest)
    if not isinstance(record, dict) or record.keys() != set(schema.fields):
        return f"is not a shard record (an object of the fields {', '.join(schema.fields)})"
    count = 1 if manifest["shard_seed"] is not None else manifest["shards"]
    index = record["index"]
    if not _is(index, (int,)) or not 0 <= index < count:
        return f"index {_shown(index)} is not a shard of this run (0 to {count - 1})"
    seed, size = expected_shard(manifest, index)
    for name, want in (("seed", seed), (schema.unit, size)):
        if not _is(record[name], (int,)) or record[name] != want:
            return f"shard {index}'s {name} is {_shown(record[name])}, the plan's {want}"
    for name in schema.counts:
        if not _is(record[name], (int,)) or record[name] < 0:
            return f"{name} {_shown(record[name])} is not a count (a whole number >= 0)"
    for name in TIMES:
        value = record[name]
        if not _is(value, (int, float)) or not 0 <= value < math.inf:
            return f"{name} {_shown(value)} is not a time (a number of seconds >= 0)"
    mismatches = record["mismatches"]
    if not isinstance(mismatches, list) or len(mismatches) > schema.most:
        return f"mismatches is not a list of at most {schema.most} mismatches"
    for mismatch in mismatches:
        if not isinstance(mismatch, dict) or mismatch.keys() != schema.mismatch.keys():
            return "a mismatch is not an object of the fields " + ", ".join(schema.mismatch)
        for name, types in schema.mismatch.items():
            if not _is(mismatch[name], types):
                return f"a mismatch's {name} {_shown(mismatch[name])} is of the wrong type"
    return None


def manifest_error(recorded, manifest: dict) -> str | None:
    """What makes `recorded` (a parsed run.json) not a run record of the shape `manifest` has,
    or None: an object of the same fields, each a plain value, an object of plain values or a
    list of plain values where `manifest` has one. Different values are another run's."""
    if isinstance(recorded, dict) and recorded.get("format") != manifest["format"]:
        return f"is of format {_shown(recorded.get('format'))}, this edgeaa reads {FORMAT}"
    if not isinstance(recorded, dict) or recorded.keys() != manifest.keys():
        return "is not a run record (an object of the fields " + ", ".join(manifest) + ")"
    for name, want in manifest.items():
        if isinstance(want, dict):
            if not isinstance(recorded[name], dict) or recorded[name].keys() != want.keys():
                return f"field {name} is not an object of the fields " + ", ".join(want)
            values = list(recorded[name].values())
        else:
            values = [recorded[name]]
        for value in values:
            if isinstance(value, list):
                value = None if all(_is(v, PLAIN) for v in value) else value
            if not _is(value, PLAIN):
                return f"field {name} holds {_shown(value)}, not a plain value"
    return None


PLAIN = (str, int, float, bool, type(None))  # JSON values without structure


class Finished:
    """The indices of finished shards, in memory bounded by the shards out of order: all
    below `low`, and the others in a set (a run finishes shards about in index order)."""

    def __init__(self):
        self.low, self.above, self.count = 0, set(), 0

    def add(self, index: int) -> None:
        self.above.add(index)
        self.count += 1
        while self.low in self.above:
            self.above.remove(self.low)
            self.low += 1

    def __contains__(self, index: int) -> bool:
        return index < self.low or index in self.above

    def __len__(self) -> int:
        return self.count


MAX_LISTED = 100  # mismatches a summary lists (the count is of all of them)


@dataclass
class Totals:
    """Figures summed over shards' records (`summed`: the keys of a plan's records, `summed`
    below), and the first `MAX_LISTED` of their mismatches: a run of millions of shards keeps
    these, not its records."""

    summed: tuple
    shards: int = 0
    sums: dict = field(default_factory=dict)
    mismatches: list = field(default_factory=list)
    mismatch_count: int = 0

    def __post_init__(self):
        self.sums = dict.fromkeys(self.summed, 0) | self.sums

    def add(self, record: dict) -> None:
        self.shards += 1
        for key in self.summed:
            self.sums[key] += record[key]
        self.mismatch_count += len(record["mismatches"])
        self.mismatches += record["mismatches"][: MAX_LISTED - len(self.mismatches)]


class ShardStore:
    """Finished shards by index: in memory, and in `directory` when one is given. Holds their
    indices (`finished`) and totals (`totals`), not the records.

    A file there that is not what this class writes (another program's, or damaged) is
    refused (`DamagedRecord`, naming the file and line), never repaired or overwritten. The
    one exception is what an interrupted write leaves: a last line without its newline,
    which is cut off (the note in `notes` says so) and its shard runs again."""

    def __init__(self, directory: str | os.PathLike | None, manifest: dict):
        self.directory = None if directory is None else Path(directory)
        self.finished = Finished()
        self.totals = Totals(summed(manifest))
        self.notes: list[str] = []
        if self.directory is not None:
            self._open(manifest)

    def _damaged(self, path: Path, what: str, line: int | None = None) -> DamagedRecord:
        where = f"{_path(path)}" + ("" if line is None else f" line {line}")
        return DamagedRecord(
            f"{where} {what}; use a fresh --out folder or delete {_path(self.directory)}"
        )

    def _open(self, manifest: dict) -> None:
        self.directory.mkdir(parents=True, exist_ok=True)
        path = self.directory / MANIFEST
        if path.exists() or path.is_symlink():
            recorded = self._parse(path, _read_small(path, MAX_MANIFEST))
            _check_unit(self.directory, recorded, manifest)
            error = manifest_error(recorded, manifest)
            if error is not None:
                raise self._damaged(path, error)
            if recorded != manifest:
                differences = _differences(recorded, manifest)
                raise RunMismatch(
                    f"{_path(self.directory)} holds another run ({differences}): rerun with its "
                    "options or give another --out"
                )
        else:
            partial = path.with_name(f".{MANIFEST}.{os.getpid()}")
            partial.write_text(json.dumps(manifest, indent=1) + "\n")
            os.replace(partial, path)
        self._load(manifest)

    def _parse(self, path: Path, data: bytes | str, line: int | None = None):
        """The JSON value of `data`; a file or line that is not one is refused."""
        if isinstance(data, str):  # what _read_small says is wrong with the file
            raise self._damaged(path, data)
        try:
            return json.loads(data.decode("utf-8"))
        except UnicodeDecodeError:
            raise self._damaged(path, "is not UTF-8 text", line) from None
        except RecursionError:
            raise self._damaged(path, "nests too deeply", line) from None
        except ValueError as error:
            raise self._damaged(path, f"is not JSON ({error})", line) from None

    def _load(self, manifest: dict) -> None:
        """The recorded shards, each line checked (`record_error`)."""
        path = self.directory / RECORDS
        if not (path.exists() or path.is_symlink()):
            return
        problem = _not_a_file(path)
        try:
            file = open(path, "rb") if problem is None else None  # noqa: SIM115 (closed below)
        except OSError as error:
            problem = f"cannot be read ({error.strerror})"
        if problem is not None:
            raise self._damaged(path, problem)
        with file:
            end, number = 0, 0
            while line := self._line(file, path, number + 1):
                number += 1
                if not line.endswith(b"\n"):
                    self._cut(path, number, end)
                    break
                end += len(line)
                record = self._parse(path, line, number)
                error = record_error(record, manifest)
                if error is None and record["index"] in self.finished:
                    error = f"records shard {record['index']} again"
                if error is not None:
                    raise self._damaged(path, error, number)
                self._add(record)

    def _add(self, record: dict) -> None:
        self.finished.add(record["index"])
        self.totals.add(record)

    def _line(self, file, path: Path, number: int) -> bytes:
        """Line `number` of shards.jsonl, newline included; b"" at the end."""
        try:
            line = file.readline(MAX_LINE + 1)
        except OSError as error:
            raise self._damaged(path, f"cannot be read ({error.strerror})", number) from None
        if len(line) > MAX_LINE:
            raise self._damaged(path, f"is longer than {MAX_LINE:,} bytes", number)
        return line

    def _cut(self, path: Path, number: int, end: int) -> None:
        """Cut off the last line, which lacks its newline: a write an interrupt stopped."""
        os.truncate(path, end)
        self.notes.append(
            f"{_path(path)} line {number} was cut short (an interrupted write): dropped, "
            "its shard runs again"
        )

    def record(self, result: dict) -> None:
        self._add(result)
        if self.directory is not None:
            # The line in one write (more only if the disk fills): an interrupt lands before
            # or after it, not inside.
            line = memoryview((json.dumps(result) + "\n").encode())
            fd = os.open(self.directory / RECORDS, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
            try:
                while line:
                    line = line[os.write(fd, line) :]
            finally:
                os.close(fd)


def _check_unit(directory: Path, recorded, manifest: dict) -> None:
    """Refuse a run of edges recorded where one of scenes is asked for, or the other way."""
    if not isinstance(recorded, dict) or not {"edges", "scenes"} & recorded.keys():
        return  # not a run record at all: `manifest_error` says so
    there, here = schema_of(recorded).unit, schema_of(manifest).unit
    if there != here:
        raise RunMismatch(
            f"{_path(directory)} holds a run of {there}, not of {here}: give another --out"
        )


def summed(manifest: dict) -> tuple:
    """The figures `Totals` sums over the records of the run of `manifest`."""
    schema = schema_of(manifest)
    return (schema.unit, *schema.counts, *TIMES)


def _path(path: Path) -> str:
    """A path for a one-line message: as it is, or quoted if it holds a newline or the like."""
    text = str(path)
    return text if text.isprintable() else repr(text)


def _not_a_file(path: Path) -> str | None:
    """What keeps `path` from being read as a record file (a directory, a pipe that would
    block the read, a dangling link), or None."""
    try:
        mode = path.stat().st_mode
    except OSError as error:
        return f"cannot be read ({error.strerror})"
    if stat.S_ISDIR(mode):
        return "is a directory"
    return None if stat.S_ISREG(mode) else "is not a regular file"


def _read_small(path: Path, limit: int) -> bytes | str:
    """The bytes of the file at `path`, or what is wrong with it: too large, not a file."""
    problem = _not_a_file(path)
    if problem is not None:
        return problem
    try:
        with open(path, "rb") as file:
            data = file.read(limit + 1)
    except OSError as error:
        return f"cannot be read ({error.strerror})"
    return data if len(data) <= limit else f"is larger than {limit:,} bytes"


def _differences(recorded: dict, wanted: dict) -> str:
    keys = [key for key in wanted if recorded.get(key) != wanted[key]]
    return ", ".join(
        f"{key} {_shown(recorded.get(key))} there, {wanted[key]!r} here" for key in keys
    )


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
    "RunMismatch",
    "ScenePlan",
    "ShardStore",
    "open_runner",
    "run_plan",
]
