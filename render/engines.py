"""The engines a scene's edges can run through.

Line mode (`run_engine`'s writes) and the polygon renderer's accumulation deltas
(`run_deltas`) each run through three engines giving the same ordered output: the model,
and the core (`edgeaa.hdl.LineCore` for the writes, `PolygonCore` for the deltas) in
Verilator or in Amaranth's simulator.

- ``model``: `edgeaa.model.vector.run_edges`, the vectorized bit-accurate model, in chunks
  of edges (for the progress bar; the writes do not depend on the chunking).
- ``verilator``: `edgeaa.sim.simulators.verilator_harness.run`, the core's Verilog compiled by
  Verilator with a C++ harness (cycle-accurate; the build is cached).
- ``amaranth``: `edgeaa.sim.simulators.amaranth_sim.run`, the core in Amaranth's Python simulator
  (cycle-accurate, slow: small scenes only).

The simulators return beats (one per column: lane 0, then lane 1 when the column has a
second write; ``last`` on an edge's final column; no beat at all for an edge whose clip
window holds none of its columns); `beats_to_writes` turns them into the model's write
order. Cycles come from the timing model (`edgeaa.model.timing`) for every engine, and the
simulators' measured clocks are kept beside them.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

import numpy as np

from ..model import Edge, EdgeConfig
from ..model.beat import (
    CELLS,
    DELTA_RUN_COLUMNS,
    LANES,
    PIXEL_FIELDS,
    RUN_COLUMNS,
    WRITES,
    BeatFormat,
    edge_columns,
)
from ..model.timing import beat_cycles, stream_cycles
from .bands import narrow

ENGINES = ("model", "amaranth", "verilator")
MODEL_CHUNK = 512  # edges per run_edges call
AMARANTH_CLOCKS_PER_SECOND = 1000.0  # rough rate of the Python simulator, for the warning
AMARANTH_WARN_SECONDS = 60.0


@dataclass(frozen=True)
class EngineRun:
    """Writes of the edges sent, in order: edge (index into the list sent), x, y, value."""

    engine: str
    edge_index: np.ndarray
    x: np.ndarray
    y: np.ndarray
    value: np.ndarray
    seconds: float  # engine wall time (the Verilator build excluded)
    clocks: int | None = None  # simulated clocks, including the drain (simulators only)
    beat_clocks: np.ndarray | None = None  # clock of every beat (simulators only)

    def __len__(self) -> int:
        return len(self.edge_index)


def cycles(config: EdgeConfig, edges: list[Edge], fmt: BeatFormat = WRITES) -> int:
    """Clocks from the first command to the last beat, inclusive, by the timing model
    (back-to-back source, always-ready sink) of the core whose output is `fmt`: the last
    beat's clock + 1; 0 for no edges."""
    return max(beat_cycles(config, edges, fmt=fmt), default=-1) + 1


def beat_clocks(config: EdgeConfig, edges: list[Edge], fmt: BeatFormat = WRITES) -> np.ndarray:
    """The timing model's clock of every beat (`edgeaa.model.timing.beat_cycles`), as int64."""
    return np.array(beat_cycles(config, edges, fmt=fmt), dtype=np.int64)


def beats_to_writes(beats: np.ndarray, columns) -> tuple[np.ndarray, ...]:
    """Beat rows of `edgeaa.model.beat.RUN_COLUMNS` (the clock, then the beat) to the model's
    write order (edge index, x, y, value): lane 0 then lane 1 of each beat.

    `columns` holds each sent edge's visible columns
    (`edgeaa.model.beat.edge_columns`):
    the core emits that many beats per edge, the last one with `last`, and none for an edge
    with 0 (no column in its clip window). Edge indices count every edge sent. Raises unless
    the beats and their `last` flags fit the counts exactly."""
    beats = np.asarray(beats, dtype=np.int64).reshape(-1, len(RUN_COLUMNS))
    field = {name: beats[:, index] for index, name in enumerate(RUN_COLUMNS)}
    columns = np.asarray(columns, dtype=np.int64).reshape(-1)
    _check_lasts(field["last"].astype(bool), columns)
    edge_of_beat = np.repeat(np.arange(len(columns), dtype=np.int64), columns)
    two = field["lane1_valid"].astype(bool)
    count = 1 + two.astype(np.int64)
    first = np.cumsum(count) - count
    total = int(count.sum())
    out = [np.empty(total, dtype=np.int64) for _ in range(4)]
    pixel = [tuple(field[f"{lane}_{name}"] for lane in LANES) for name in PIXEL_FIELDS]
    for column, (lane0, lane1) in zip(out, [(edge_of_beat, edge_of_beat), *pixel], strict=True):
        column[first] = lane0
        column[first[two] + 1] = lane1[two]
    return tuple(out)


@dataclass(frozen=True)
class DeltaRun:
    """Accumulation deltas: edge (index into the edges sent, or a scene edge after
    `in_image`), cell x, y and the signed delta; zeros left out after `in_image`."""

    engine: str
    edge: np.ndarray
    x: np.ndarray
    y: np.ndarray
    delta: np.ndarray
    seconds: float  # engine wall time (the Verilator build excluded)
    clocks: int | None = None  # simulated clocks, including the drain (simulators only)
    beat_clocks: np.ndarray | None = None  # clock of every beat (simulators only)

    def __len__(self) -> int:
        return len(self.edge)

    def take(self, rows) -> DeltaRun:
        return DeltaRun(
            self.engine, self.edge[rows], self.x[rows], self.y[rows], self.delta[rows],
            self.seconds, self.clocks, self.beat_clocks,
        )  # fmt: skip

    @staticmethod
    def joined(runs: list[DeltaRun]) -> DeltaRun:
        """One run of the deltas of `runs`, in order (engine seconds summed; the simulators'
        figures are one stream's and are not joined)."""
        columns = (
            np.concatenate([getattr(r, n) for r in runs]) for n in ("edge", "x", "y", "delta")
        )
        return DeltaRun(runs[0].engine, *columns, sum(r.seconds for r in runs))

    def in_image(self, sent: np.ndarray, offset: tuple[int, int], rows=None, bounds=None):
        """The nonzero deltas, with scene edge ids and image pixel coordinates; with `rows`
        (y0, y1) only those in image rows y0 .. y1 - 1; with `bounds` (x and y's least and
        greatest, the delta's) in the narrowest integer types that hold them
        (`render.bands.narrow`)."""
        x, y = self.x - offset[0], self.y - offset[1]
        keep = self.delta != 0
        if rows is not None:
            keep &= (y >= rows[0]) & (y < rows[1])
        keep = np.flatnonzero(keep)
        edge = np.asarray(sent, dtype=np.int64)[self.edge[keep]]
        x, y, delta = x[keep], y[keep], self.delta[keep]
        if bounds is not None:
            lo, hi, delta_lo, delta_hi = bounds
            edge = narrow(edge, 0, int(edge.max(initial=0)))
            x, y = narrow(x, lo, hi), narrow(y, lo, hi)
            delta = narrow(delta, delta_lo, delta_hi)
        return DeltaRun(self.engine, edge, x, y, delta, self.seconds, self.clocks, self.beat_clocks)


def run_deltas(config: EdgeConfig, arrays, engine: str, progress=None, setups=None):
    """The accumulation deltas of the edges `arrays` (a `render.render.EdgeArrays`, all
    valid) through an engine, in order: four cells per stepped column. Returns the run and
    the edges' (columns, clipped_start) arrays from their setup, for the timing model.
    progress(done, total) is called as edges complete. `setups`: the edges' `SetupBatch`
    when the caller has it already (`edgeaa.model.edge.setup_batch` of `arrays`)."""
    from ..model.edge import setup_batch

    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {', '.join(ENGINES)}, not {engine!r}")
    if setups is None:
        setups = setup_batch(config, *arrays.args(), arrays.clip)
    if engine == "model":
        return _model_deltas(config, arrays, progress, setups)
    from ..hdl.core import PolygonCore  # a simulator's render only: a model render loads no hdl

    batch = setups
    shapes = (batch.columns, batch.clipped_start)
    if not len(arrays):
        empty = np.zeros(0, dtype=np.int64)
        return DeltaRun(engine, empty, empty, empty, empty, 0.0, 0, empty), shapes
    edges = arrays.edges()
    run = _simulate(config, edges, engine, progress, PolygonCore)
    if run.errors:
        raise RuntimeError(f"the core dropped {run.errors} edge commands as bad")
    beats = np.asarray(run.beats, dtype=np.int64).reshape(-1, len(DELTA_RUN_COLUMNS))
    columns = batch.columns.astype(np.int64)
    _check_lasts(beats[:, DELTA_RUN_COLUMNS.index("last")].astype(bool), columns)
    edge = np.repeat(np.repeat(np.arange(len(columns), dtype=np.int64), columns), len(CELLS))
    x, y, delta = (
        beats[:, [DELTA_RUN_COLUMNS.index(f"{cell}_{name}") for cell in CELLS]].reshape(-1)
        for name in ("x", "y", "delta")
    )
    run = DeltaRun(engine, edge, x, y, delta, run.seconds, run.clocks, beats[:, 0])
    return run, shapes


def cycles_of(config: EdgeConfig, shapes, fmt: BeatFormat = WRITES) -> int:
    """`cycles` from the edges' (columns, clipped_start) arrays, all good commands
    (`edgeaa.model.timing.stream_cycles`: `schedule`'s clocks in numpy)."""
    return stream_cycles(config, *shapes, fmt=fmt)


def _model_deltas(config: EdgeConfig, arrays, progress, setups):
    from ..model.vector import run_setup_deltas

    start = time.perf_counter()
    if progress is not None:
        progress(0, len(arrays))
    batch = run_setup_deltas(config, setups)
    if progress is not None:
        progress(len(arrays), len(arrays))
    run = DeltaRun(
        "model", batch.edge_index, batch.x, batch.y, batch.delta, time.perf_counter() - start
    )
    return run, (batch.setups.columns, batch.setups.clipped_start)


def _simulate(config: EdgeConfig, edges: list[Edge], engine: str, progress, top):
    """Run the core `top` (`LineCore` or `PolygonCore`) in a simulator (the Verilator build is
    cached and not timed)."""
    if engine == "verilator":
        from ..sim.simulators import verilator_harness

        if progress is not None:
            progress(0, len(edges))
        run = verilator_harness.run(config, edges, top=top)
        if progress is not None:
            progress(len(edges), len(edges))
        return run
    from ..sim.simulators import amaranth_sim

    expected = cycles(config, edges, top.format)
    if expected / AMARANTH_CLOCKS_PER_SECOND > AMARANTH_WARN_SECONDS:
        minutes = expected / AMARANTH_CLOCKS_PER_SECOND / 60
        print(
            f"edgeaa render: warning: the amaranth engine simulates about "
            f"{AMARANTH_CLOCKS_PER_SECOND:,.0f} clocks/s and this scene needs "
            f"{expected:,} clocks (about {minutes:.0f} min); --engine verilator gives "
            "the same image",
            file=sys.stderr,
            flush=True,
        )
    return amaranth_sim.run(config, edges, progress=progress, top=top)


def _check_lasts(last: np.ndarray, columns: np.ndarray) -> None:
    """Raise unless the beats and their `last` flags fit the edges' column counts exactly."""
    visible = int(np.count_nonzero(columns))
    if int(last.sum()) != visible or len(last) != int(columns.sum()):
        raise RuntimeError(
            f"the core ended {int(last.sum())} edges in {len(last)} beats; {len(columns)} were "
            f"sent, {visible} with columns in their window ({int(columns.sum())} columns)"
        )
    ends = np.cumsum(columns[columns > 0]) - 1
    if not np.array_equal(np.flatnonzero(last), ends):
        raise RuntimeError("the core's `last` beats do not end the edges after their columns")


class EngineUnavailable(RuntimeError):
    """An engine that cannot do what was asked (one line for the user)."""


def run_engine(config: EdgeConfig, edges: list[Edge], engine: str, progress=None) -> EngineRun:
    """Run `edges` (all valid: the core would drop bad ones) through an engine.
    progress(done, total) is called as edges complete."""
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {', '.join(ENGINES)}, not {engine!r}")
    if engine == "model":
        return _run_model(config, edges, progress)
    if not edges:
        empty = np.zeros(0, dtype=np.int64)
        return EngineRun(engine, empty, empty, empty, empty, 0.0, 0, empty)
    from ..hdl.core import LineCore

    run = _simulate(config, edges, engine, progress, LineCore)
    if run.errors:
        raise RuntimeError(f"the core dropped {run.errors} edge commands as bad")
    edge_index, x, y, value = beats_to_writes(run.beats, edge_columns(config, edges))
    return EngineRun(engine, edge_index, x, y, value, run.seconds, run.clocks, run.beats[:, 0])


def _run_model(config: EdgeConfig, edges: list[Edge], progress) -> EngineRun:
    from ..model.vector import run_edges

    start = time.perf_counter()
    parts = []
    for lo in range(0, len(edges), MODEL_CHUNK):
        batch = run_edges(config, edges[lo : lo + MODEL_CHUNK])
        parts.append((batch.edge_index + lo, batch.x, batch.y, batch.value))
        if progress is not None:
            progress(min(lo + MODEL_CHUNK, len(edges)), len(edges))
    if parts:
        columns = [np.concatenate([part[i] for part in parts]) for i in range(4)]
    else:
        columns = [np.zeros(0, dtype=np.int64) for _ in range(4)]
    return EngineRun("model", *columns, seconds=time.perf_counter() - start)
