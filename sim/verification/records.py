"""The record of a sharded run (`edgeaa verify --out DIR`): ``run.json`` (the plan) and
``shards.jsonl`` (one JSON line per finished shard), their one schema (`record_error`,
`manifest_error`) and the store that reads and appends them (`ShardStore`).

A file that fails the schema is refused, never rewritten; only a last line an interrupted
write left without its newline is cut off (with a note), and that shard runs again.
"""

from __future__ import annotations

import json
import math
import os
import stat
from dataclasses import dataclass, field
from pathlib import Path

from ...model.numbers import shown
from .scene_shards import MAX_LISTED_SCENES, scene_range
from .shards import KINDS, shard_seed, shard_size

MANIFEST = "run.json"
RECORDS = "shards.jsonl"
FORMAT = 2  # of run.json and shards.jsonl (2: the workload names its chunk_edges)


class RunMismatch(ValueError):
    """The output directory holds a different run (one line saying how it differs)."""


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
