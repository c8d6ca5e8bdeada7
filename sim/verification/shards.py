"""One shard of a sharded regression (`edgeaa verify`): seeded random edges through the
simulated core against the model, checked in a worker process.

A shard is `ShardTask.edges` random edges drawn from its own seed, so any shard can be rerun
alone from the seed printed with a mismatch (`edgeaa verify --shard-seed SEED`). The edges are
those of the tests (`random_sim_edges`: every octant, sub-pixel vertices, random sides and
intensities, clip windows of every kind, bad commands) and run as two command streams:

* ``stalled``: the first half, with random source idles and sink back-pressure: every beat bit
  for bit and in order against the model, and the core's bad-command counter;
* ``ready``: the rest, offered back to back to an always-ready sink: the same checks, and every
  beat in the clock `edgeaa.model.timing.write_cycles` predicts.

The Amaranth runner has no stalls: with ``engine="amaranth"`` the whole shard is one ready
stream. The expected beats come from the vectorized model (`edgeaa.model.vector.run_edges`,
the same per-column arithmetic as the step model and tested equal to it), six to eight times
faster than the step model, which would otherwise take most of a shard's time.
"""

from __future__ import annotations

import hashlib
import math
import os
import shlex
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from itertools import islice
from pathlib import Path

import numpy as np

from ...command import config_arguments
from ...model import Edge, EdgeConfig, EdgeError, validate
from ...model.beat import BEAT_COLUMNS, COLUMN, LANES, PIXEL_FIELDS, beats_from_array
from ...model.timing import write_cycles
from ...model.vector import run_edges
from ..simulators import verilator_harness
from ..simulators.verilator_harness import FastRun
from .workloads import iter_sim_edges

ENGINES = ("verilator", "amaranth")

# The workload, as the tests draw it (tests/test_fastsim.py).
IDLE, STALL = 0.2, 0.3  # probability per clock of a source idle and of sink back-pressure
BAD_FRACTION = 0.02  # zero-length edges and I_in == I_out: the core drops and counts them
CLIP_FRACTION = 0.5  # edges with a random clip window (empty, start, end, both, loose)
# Longest major delta of a shard's edges, one per shard in turn: short edges keep the setup
# busy (setup-bound), long ones the stepper; 48 is the tests' default.
MAX_PIXELS = (16, 48, 200)
SHARD_EDGES = 2000  # default edges per shard: a few seconds of work, so progress is smooth
# Edges a shard draws, simulates and checks at a time: its memory is that of one chunk,
# whatever its edge count (one shard of 100,000 edges peaked at 326 MB RSS, 1.37 GB when it
# drew them all at once; tests/test_verify.py checks the peak allocation with tracemalloc).
# Each part of a stream after the first runs from reset with its own stall seed, so a stream
# of more edges than this simulates other clocks than one run would (the same edges and
# checks).
CHUNK_EDGES = 10_000

LANE1_FIELDS = [COLUMN[f"{LANES[1]}_{name}"] for name in PIXEL_FIELDS]


# -- the plan: shard seeds and sizes ---------------------------------------------------------


def shard_seed(run_seed: int, index: int) -> int:
    """The seed of shard `index` of a run: 48 bits of a hash, so neighbouring run seeds do not
    share shards and the seed fits the harness's unsigned stall seed."""
    digest = hashlib.sha256(f"edgeaa-verify/{run_seed}/{index}".encode()).digest()
    return int.from_bytes(digest[:6], "little")


def default_shards(edges: int) -> int:
    """Shards of about `SHARD_EDGES` edges: a function of the edge count only, so a rerun on
    another number of workers resumes the same shards."""
    return max(1, math.ceil(edges / SHARD_EDGES))


def shard_size(edges: int, shards: int, index: int) -> int:
    """Edges of shard `index` when `edges` are split into `shards` that differ by at most one."""
    base, extra = divmod(edges, shards)
    return base + (index < extra)


@dataclass(frozen=True)
class ShardTask:
    """What a worker needs to check one shard (the compiled core travels separately)."""

    index: int
    seed: int
    edges: int
    config: EdgeConfig
    engine: str = "verilator"

    @property
    def max_pixels(self) -> int:
        return MAX_PIXELS[self.seed % len(MAX_PIXELS)]

    def check(self, core: CompiledCore | None, report: Callable | None = None) -> dict:
        return check_shard(self, core, report=report)

    def blank_result(self) -> dict:
        """A record of nothing checked (a crashed shard's)."""
        result = {"index": self.index, "seed": self.seed, "edges": self.edges, "beats": 0}
        result.update(clocks=0, dropped=0, timed_edges=0, sim_seconds=0.0, seconds=0.0)
        return result | {"mismatches": []}

    def blank_mismatch(self) -> dict:
        return {"edge": None, "beat": None, "stream": None, "reproduce": None}

    def reproduce(self) -> str:
        return reproduce_shard(self)

    def draw(self) -> Iterator[Edge]:
        """The shard's edges one at a time (`iter_sim_edges` from its seed)."""
        return iter_sim_edges(
            self.config,
            self.seed,
            max_pixels=self.max_pixels,
            bad_fraction=BAD_FRACTION,
            clip_fraction=CLIP_FRACTION,
        )

    def draw_edges(self) -> list[Edge]:
        return list(islice(self.draw(), self.edges))

    def stream_bounds(self) -> list[tuple[str, int, int]]:
        """(name, first edge, end) of each command stream: the first half stalled, the rest
        ready; one ready stream on the Amaranth engine or for a one-edge shard."""
        if self.engine == "amaranth":
            return [("ready", 0, self.edges)]
        half = self.edges // 2
        bounds = [("stalled", 0, half), ("ready", half, self.edges)]
        return [bound for bound in bounds if bound[2] > bound[1]]

    def streams(self) -> list[tuple[str, int, list[Edge]]]:
        """(name, index of its first edge in the shard, edges) of each command stream."""
        edges = self.draw_edges()
        return [(name, lo, edges[lo:hi]) for name, lo, hi in self.stream_bounds()]

    def chunks(self, size: int | None = None) -> Iterator[tuple[str, int, int, list[Edge]]]:
        """(stream, part, index of its first edge in the shard, edges) of each piece of the
        streams, drawn as it is asked for: at most `size` (default `CHUNK_EDGES`) edges at a
        time, so a shard's memory does not grow with its edges. Part k of a stream is its
        edges from k * size on; a stream of `size` edges or fewer is one part."""
        size = CHUNK_EDGES if size is None else size
        draw = self.draw()
        for name, lo, hi in self.stream_bounds():
            for part, start in enumerate(range(lo, hi, size)):
                yield name, part, start, list(islice(draw, min(size, hi - start)))


# -- the compiled core, built once and shipped to the workers --------------------------------


@dataclass(frozen=True)
class CompiledCore:
    """The Verilated core and harness of one configuration, built once by the driver.

    Workers on this machine run the cached executable at `path`; a worker elsewhere (a
    cluster) writes `image`, the executable's bytes, to its own temporary directory once.
    Pass ``ship=True`` to `build` for that; a local pool needs only the path.
    """

    key: str  # the build's cache directory name: a hash of the Verilog, harness and flags
    path: str
    image: bytes = field(default=b"", repr=False)

    @classmethod
    def build(cls, config: EdgeConfig, *, ship: bool = False) -> CompiledCore:
        return cls.of(verilator_harness.build(config), ship=ship)

    @classmethod
    def of(cls, path: Path, *, ship: bool = False) -> CompiledCore:
        """The executable at `path` (a cached build), with its bytes if `ship`."""
        return cls(path.parent.name, str(path), path.read_bytes() if ship else b"")

    def executable(self) -> Path:
        path = Path(self.path)
        if path.is_file() and os.access(path, os.X_OK):
            return path
        if not self.image:
            raise RuntimeError(f"the compiled core {path} is not on this worker and was not sent")
        local = Path(tempfile.gettempdir()) / f"edgeaa-verify-{self.key}" / "harness"
        if not local.exists():  # one file per key; concurrent writers each rename a whole copy
            local.parent.mkdir(parents=True, exist_ok=True)
            partial = local.with_name(f"harness.{os.getpid()}")
            partial.write_bytes(self.image)
            partial.chmod(0o755)
            os.replace(partial, local)
        return local


def simulate(
    task: ShardTask, core: CompiledCore | None, stream: str, edges: list[Edge], part: int = 0
) -> FastRun:
    """The simulated core's view of part `part` of one command stream (`ShardTask.chunks`):
    its beats, clocks and error count. Each part runs from reset; its stalls come from the
    shard's seed plus the part."""
    if task.engine == "amaranth":
        from ..simulators import amaranth_sim

        return amaranth_sim.run(task.config, edges)
    idle, stall = (IDLE, STALL) if stream == "stalled" else (0.0, 0.0)
    seed = (task.seed + part) % (1 << 64)  # the harness reads an unsigned 64-bit seed
    return verilator_harness.run(
        task.config, edges, seed=seed, idle=idle, stall=stall, exe=core.executable()
    )


# -- the model's side ------------------------------------------------------------------------


@dataclass(frozen=True)
class ModelStream:
    """The model's beats of a command stream, as rows of `BEAT_COLUMNS` (lane 1 zero when not
    valid), the visible columns of each edge (0 for a bad command or an empty window) and how
    many commands are bad."""

    rows: np.ndarray
    columns: np.ndarray
    dropped: int


def model_stream(config: EdgeConfig, edges: list[Edge]) -> ModelStream:
    """Expected beats from the vectorized model: its writes grouped into columns (a column's
    writes are consecutive and share the major-axis pixel; the next column's differs by one)."""
    good = np.ones(len(edges), dtype=bool)
    for index, edge in enumerate(edges):
        try:
            validate(config, edge)  # what makes a command bad (setup runs once, in run_edges)
        except EdgeError:
            good[index] = False
    columns = np.zeros(len(edges), dtype=np.int64)
    dropped = len(edges) - int(good.sum())
    if not good.any():
        return ModelStream(np.zeros((0, len(BEAT_COLUMNS)), np.int64), columns, dropped)
    batch = run_edges(config, [edge for edge, ok in zip(edges, good, strict=True) if ok])
    columns[good] = [st.columns for st in batch.setups]
    x_major = np.array([st.x_major for st in batch.setups])
    rows = _beat_rows(batch.edge_index, batch.x, batch.y, batch.value, x_major)
    if len(rows) != columns.sum():
        raise AssertionError(f"the model's writes form {len(rows)} columns, not {columns.sum()}")
    return ModelStream(rows, columns, dropped)


def _beat_rows(edge_index, x, y, value, x_major) -> np.ndarray:
    """Writes (in the model's order) as beat rows: one per column, lane 0 then lane 1."""
    n = len(edge_index)
    major = np.where(x_major[edge_index], x, y)
    starts = np.ones(n, dtype=bool)
    starts[1:] = (edge_index[1:] != edge_index[:-1]) | (major[1:] != major[:-1])
    first = np.flatnonzero(starts)
    size = np.diff(np.append(first, n))
    if (size > 2).any():
        raise AssertionError("the model wrote more than two pixels in a column")
    pair = size == 2
    rows = np.zeros((len(first), len(BEAT_COLUMNS)), dtype=np.int64)
    for lane, index in ((LANES[0], first), (LANES[1], first[pair])):
        target = slice(None) if lane == LANES[0] else pair
        for name, values in zip(PIXEL_FIELDS, (x, y, value), strict=True):
            rows[target, COLUMN[f"{lane}_{name}"]] = values[index + (lane == LANES[1])]
    rows[:, COLUMN["lane1_valid"]] = pair
    column_edge = edge_index[first]
    rows[:-1, COLUMN["last"]] = column_edge[1:] != column_edge[:-1]
    rows[-1:, COLUMN["last"]] = 1
    return rows


# -- the checks ------------------------------------------------------------------------------


def core_rows(run: FastRun) -> np.ndarray:
    """The core's beats as rows of `BEAT_COLUMNS`, lane 1 zeroed where it is not valid (its
    values are then don't-cares)."""
    rows = run.beats[:, 1:].copy()
    rows[np.ix_(rows[:, COLUMN["lane1_valid"]] == 0, LANE1_FIELDS)] = 0
    return rows


def first_difference(got: np.ndarray, want: np.ndarray) -> int | None:
    """Index of the first row that differs, or where the shorter one ends; None if equal."""
    n = min(len(got), len(want))
    differ = np.flatnonzero((got[:n] != want[:n]).any(axis=1))
    if len(differ):
        return int(differ[0])
    return None if len(got) == len(want) else n


def describe(row: np.ndarray | None) -> str:
    return "no beat" if row is None else str(beats_from_array(row[None, :])[0])


def edge_of_beat(columns: np.ndarray, beat: int) -> tuple[int, int]:
    """(edge, column within the edge) of the stream's beat `beat` by the model's count; past the
    end, the last edge."""
    ends = np.cumsum(columns)
    edge = min(int(np.searchsorted(ends, beat, side="right")), len(columns) - 1)
    return edge, beat - int(ends[edge] - columns[edge])


KINDS = ("beat", "errors", "clock")  # a stream's disagreements, in the order they are listed


@dataclass
class StreamCheck:
    """A command stream checked part by part: where the next part starts (edges and model
    beats into the stream), bad commands counted by the core and by the model, and the first
    disagreement of each kind."""

    first_edge: int  # in the shard
    edges: int = 0
    beats: int = 0
    errors: int = 0
    dropped: int = 0
    found: dict = field(default_factory=dict)

    def check(self, config: EdgeConfig, stream: str, edges: list[Edge], run: FastRun) -> None:
        """Check the next part: its beats against the model's and, while every beat of the
        stream so far agrees, a ready stream's beat clocks against the timing model's."""
        model = model_stream(config, edges)
        got = core_rows(run)
        beat = first_difference(got, model.rows)
        if beat is not None and "beat" not in self.found:
            edge, column = edge_of_beat(model.columns, beat)
            core = describe(got[beat] if beat < len(got) else None)
            want = describe(model.rows[beat] if beat < len(model.rows) else None)
            what = f"is {core}, the model says {want}"
            self._add(config, edges, "beat", edge, beat, column, what)
        if stream == "ready" and beat is None and "beat" not in self.found:
            self._check_clocks(config, edges, run, model)
        self.edges += len(edges)
        self.beats += len(model.rows)
        self.errors += run.errors
        self.dropped += model.dropped

    def _check_clocks(self, config, edges, run: FastRun, model: ModelStream) -> None:
        if "clock" in self.found:
            return
        predicted = np.array([c for t in write_cycles(config, edges) for c in t.beats], np.int64)
        late = first_difference(run.beats[:, :1], predicted[:, None])
        if late is not None:
            edge, column = edge_of_beat(model.columns, late)
            text = (
                f"left in clock {int(run.beats[late, 0])}, the timing model says "
                f"{int(predicted[late])}"
            )
            self._add(config, edges, "clock", edge, late, column, text)

    def _add(self, config, edges, kind, edge, beat, column, what) -> None:
        """Record a disagreement at `edge` and `beat` of the part (numbered in the stream)."""
        text = f"beat {self.beats + beat} (column {column} of edge {self.edges + edge}) {what}"
        found = {"kind": kind, "edge": self.edges + edge, "beat": self.beats + beat}
        found["message"] = text
        found["reproduce"] = reproduce_edge(config, edges[edge])
        self.found[kind] = found

    def mismatches(self) -> list[dict]:
        """The stream's disagreements (edge indices within the stream), the bad-command
        counts once the whole stream is checked."""
        if self.errors != self.dropped:
            text = f"the core counted {self.errors} bad commands, the model {self.dropped}"
            found = {"kind": "errors", "edge": None, "beat": None, "message": text}
            self.found["errors"] = found | {"reproduce": None}
        return [self.found[kind] for kind in KINDS if kind in self.found]


def check_shard(
    task: ShardTask,
    core: CompiledCore | None = None,
    chunk: int | None = None,
    report: Callable[[int, int], None] | None = None,
) -> dict:
    """Run and check one shard, `chunk` edges at a time (`ShardTask.chunks`), calling
    `report(index, edges checked so far)` after each piece; the result is plain data (it is
    stored as a JSON line)."""
    start = time.perf_counter()
    result = {"index": task.index, "seed": task.seed, "edges": task.edges, "beats": 0}
    result.update(clocks=0, dropped=0, timed_edges=0, sim_seconds=0.0, mismatches=[])
    checks: dict[str, StreamCheck] = {}
    for stream, part, offset, edges in task.chunks(chunk):
        run = simulate(task, core, stream, edges, part)
        result["sim_seconds"] += run.seconds
        result["beats"] += len(run.beats)
        result["clocks"] += run.clocks
        result["dropped"] += run.errors
        result["timed_edges"] += len(edges) if stream == "ready" else 0
        checks.setdefault(stream, StreamCheck(offset)).check(task.config, stream, edges, run)
        if report is not None:
            report(task.index, offset + len(edges))
    for stream, check in checks.items():
        for found in check.mismatches():
            edge = None if found["edge"] is None else check.first_edge + found["edge"]
            found.update(stream=stream, edge=edge, reproduce=found.pop("reproduce"))
            found.update(reproduce_shard=reproduce_shard(task), shard=task.index, seed=task.seed)
            result["mismatches"].append(found)
    result["seconds"] = time.perf_counter() - start
    return result


# -- reproducers -----------------------------------------------------------------------------


def pixels(value: int, config: EdgeConfig) -> str:
    """A sub-pixel coordinate in pixels, exactly (a dyadic fraction: the float is exact)."""
    text = repr(value / config.subpixel_scale)
    return text[:-2] if text.endswith(".0") else text


def reproduce_edge(config: EdgeConfig, edge: Edge) -> str:
    """The `edgeaa edge` command that runs `edge` through the model: its writes as the core
    should give them (or, for a bad command, the model's one-line refusal)."""
    i_in, i_out = edge.intensities(config)
    argv = ["edgeaa", "edge"] + [pixels(v, config) for v in (edge.x0, edge.y0, edge.x1, edge.y1)]
    argv += ["--inside", edge.inside, "--i-in", str(i_in), "--i-out", str(i_out)]
    if edge.clip is not None:
        argv += ["--clip", *(str(v) for v in edge.clip)]
    return shlex.join(argv + config_arguments(config))


def reproduce_shard(task: ShardTask) -> str:
    """The `edgeaa verify` command that reruns this shard alone, on the same engine."""
    argv = ["edgeaa", "verify", "--shard-seed", str(task.seed), "--edges", str(task.edges)]
    argv += ["--engine", task.engine]
    return shlex.join(argv + config_arguments(task.config))
