"""The vectorized model: the step model's writes for whole batches of edges at once, in numpy.

`run_edges` gives bit-identical writes to `step.run_edge` (same pixels, values, areas and
order) without a Python loop over columns. Given Edge objects, the per-edge setup
(`edge.setup`, which also validates the edge and raises the same EdgeError) runs in a Python
loop; `run_deltas_arrays` takes the edges as arrays and sets them up with `edge.setup_batch`
(numpy, the same values), and `run_setup_deltas` takes a `SetupBatch`. The column loop reads
the setup as a `SetupBatch` (one array per field) either way.

Closed form of the stepping loop. Column i = 0 .. columns - 1 of an edge starts with

    R_i    = jr0 + i kr                carries_i = R_i // du       jr_i = R_i % du
    U_i    = jq0 + i kq + carries_i    rows_i    = U_i // ifix     jq_i = U_i - rows_i ifix
    pixel  = (x0 + i col_dx + rows_i row_dx,  y0 + i col_dy + rows_i row_dy)

which is what the loop's add / compare / subtract steps compute, provided each step carries at
most once and steps at most one row: jr0 < du and kr < du (divmod remainders), jq0 < ifix
(mf < 2 S du in setup), and kq + carry <= ifix (kq <= ifix since dv <= du; kq = ifix only
when dv = du, and then kr = 0, so no carry). `_check_invariants` asserts these per edge. The
exit tests, triangle estimate, segment choice and output rounding are the step model's
formulas applied to arrays; in truncated mode setup already zeroes jr, kr and khr.
`_check_invariants` asserts the same on a whole `SetupBatch`.

Overflow bound (why int64 is enough, and when it is not). Let n = columns. The loop's last
advance (after column n - 1) is width-checked in the step model, so states i = 0 .. n are
computed here and every value is bounded by:

* R_i <= (du - 1)(n + 1) < 2**(W + s) (2**W + 2) <= 2**24 (2**16 + 2) < 2**41: always fits.
* 0 <= U_i <= U_n = jq0 + n kq + carries_n (U is nondecreasing in i); i kq <= U_n.
* rows_i ifix <= U_i; jsum_i = U_(i+1) - rows_i ifix < 2 ifix.
* exit depths |dq| <= ifix + khq + 1 <= 2 ifix + 1; the slope term (2j + 1) dq with
  j <= 3 is at most 7 |dq| < 16 ifix; areas are in [-16 ifix, 16 ifix]; the rounding add
  area + 2**(F - 1) < 32 ifix since 2**F <= ifix.

So an edge is computed in int64 when U_n <= 2**62 and ifix <= 2**58 (everything then stays
below 2**63). Neither holds for every allowed configuration: with intensity_bits = 16 and a
frac_bits override of 48, ifix = |I_in - I_out| 2**48 reaches 2**64 - 2**48; with
coord_bits = 16, intensity_bits = 16 (derived F = 34) a long steep edge has U_n near
2**16 * 2**50 = 2**66. Such edges are computed with numpy object arrays of Python ints
(same formulas, exact, slower): the check is per edge, in exact Python integers, so a result
is never silently wrapped. The output arrays x, y, value always fit int64 (W + 2 and
intensity_bits bits); `area` is int64 when its register (intensity_bits + F + 1 bits) fits
int64, and an object array of Python ints otherwise.

Register widths are checked on the arrays as in the step model (the same registers, the same
values), raising WidthError; with a batch the first failing register reported may differ
from the one the step model would report first (the per-edge constants are checked register
by register over the whole batch), and every edge's setup (so any EdgeError) runs before any
column.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from .column import (
    ArrayArith,
    column_areas,
    column_deltas,
    delta_cells,
    neighbour_offset,
    output_value,
    piece_end,
)
from .config import EdgeConfig
from .edge import Edge, EdgeSetup, SetupBatch, setup, setup_batch
from .step import Write

INT64_U_LIMIT = 1 << 62  # largest U_n an edge may reach on the int64 path
INT64_IFIX_LIMIT = 1 << 58  # largest ifix on the int64 path (intermediates < 32 ifix)
_FLOAT_EXACT = 1 << 53  # integers up to this convert to float64 exactly
CHUNK_STATES = 1 << 13  # column states per numpy pass: some 500 bytes a state of temporaries
# (1 << 15 held up to 7 MB more at a page's peak; 1 << 13 costs about 5 % of its render time)


class VectorInvariantError(AssertionError):
    """A setup value breaks an assumption of the closed form (a bug in setup, not an input)."""


@dataclass(frozen=True, eq=False)
class WriteBatch:
    """The writes of a batch of edges, one row per write, in the step model's order.

    edge_index: index of the edge in the batch; x, y: pixel; value: output intensity;
    area: scaled A-side area (units of 2**-F intensity LSB). All int64 except `area`, which is
    an object array of Python ints when the config's area register is wider than int64.
    """

    edge_index: np.ndarray
    x: np.ndarray
    y: np.ndarray
    value: np.ndarray
    area: np.ndarray
    setups: tuple[EdgeSetup, ...]

    def __len__(self) -> int:
        return len(self.edge_index)

    def edge_slice(self, k: int) -> slice:
        """The rows of edge k (its writes are contiguous)."""
        lo, hi = np.searchsorted(self.edge_index, [k, k + 1])
        return slice(int(lo), int(hi))

    def writes(self, k: int | None = None) -> list[Write]:
        """The writes of edge k (all edges if None) as the step model's Write tuples."""
        rows = slice(None) if k is None else self.edge_slice(k)
        return [
            Write(int(x), int(y), int(v), int(a))
            for x, y, v, a in zip(
                self.x[rows], self.y[rows], self.value[rows], self.area[rows], strict=True
            )
        ]

    def coverage(self) -> np.ndarray:
        """Inside coverage per write, float64, equal to EdgeResult.coverage of each write."""
        return coverage(self)


def coverage(batch: WriteBatch) -> np.ndarray:
    """area / ifix, or 1 - that when the inside is the B side: EdgeResult.coverage per write.

    Python's int / int is correctly rounded; so is float64 division of exactly converted
    operands, which is used when area and ifix are below 2**53. Larger values divide as
    Python ints (object arrays) to give the same float.
    """
    if len(batch) == 0:
        return np.zeros(0, dtype=np.float64)
    ifix_list = [st.ifix for st in batch.setups]
    inside_a = np.array([st.inside_is_a for st in batch.setups], dtype=bool)[batch.edge_index]
    area = batch.area
    small = max(ifix_list) <= _FLOAT_EXACT and max(abs(int(area.min())), int(area.max())) <= (
        _FLOAT_EXACT
    )
    if small:
        ifix = np.array(ifix_list, dtype=np.int64)[batch.edge_index]
        area_a = area.astype(np.int64) / ifix
    else:
        ifix = np.array(ifix_list, dtype=object)[batch.edge_index]
        area_a = (area.astype(object) / ifix).astype(np.float64)
    return np.where(inside_a, area_a, 1.0 - area_a)


def run_edge_vector(config: EdgeConfig, edge: Edge) -> WriteBatch:
    """One edge through the vectorized model (edge_index all 0)."""
    return run_edges(config, [edge])


def run_edges(
    config: EdgeConfig, edges: Iterable[Edge], *, force_object: bool = False
) -> WriteBatch:
    """The writes of all edges, in order, bit-identical to `run_edge` on each edge.

    force_object computes every edge with Python-int object arrays (the overflow fallback),
    for testing that path against the int64 one.
    """
    setups = tuple(setup(config, edge) for edge in edges)  # validates: raises EdgeError
    batch = SetupBatch.from_setups(config, setups)
    area_dtype = np.int64 if config.register_widths()["area"].bits <= 63 else object
    chunks, mixed = _groups(config, batch, force_object)
    parts = [_run_group(config, batch, chunk, dtype) for chunk, dtype in chunks]
    if not parts:
        empty = np.zeros(0, dtype=np.int64)
        return WriteBatch(empty, empty, empty, empty, empty.astype(area_dtype), setups)
    edge_index, x, y, value, area = _merge(parts, 5, mixed)
    return WriteBatch(
        edge_index.astype(np.int64),
        x.astype(np.int64),
        y.astype(np.int64),
        value.astype(np.int64),
        area.astype(area_dtype),
        setups,
    )


# -- per-edge checks ---------------------------------------------------------------------------


def _groups(config: EdgeConfig, batch: SetupBatch, force_object: bool):
    """Check the batch's constants and split it into chunks (ascending edge indices) computed
    in int64 and in object arrays: a list of (chunk, dtype), and whether both kinds occur."""
    _check_constants(config, batch)
    _check_invariants(batch)
    fits = np.zeros(len(batch), dtype=bool) if force_object else _fits_int64_batch(batch)
    fast, slow = np.flatnonzero(fits), np.flatnonzero(~fits)
    weights = batch.columns.astype(np.int64) + 1  # column states per edge
    chunks = [
        (chunk, dtype)
        for group, dtype in ((fast, np.int64), (slow, object))
        for chunk in _chunks(weights, group)
    ]
    return chunks, bool(len(fast) and len(slow))


def _merge(parts: list[list[np.ndarray]], count: int, mixed: bool) -> list[np.ndarray]:
    """The chunks' output columns joined in edge order."""
    columns = [np.concatenate([part[name] for part in parts]) for name in range(count)]
    if mixed:  # each group is in order; a stable sort on the edge interleaves them
        order = np.argsort(columns[0], kind="stable")
        columns = [column[order] for column in columns]
    return columns


def _check_constants(config: EdgeConfig, b: SetupBatch) -> None:
    """The per-edge registers run_edge checks before its loop, over the whole batch."""
    a = ArrayArith(config, None)
    for name in ("du", "ifix", "kq", "kr", "khq", "khr"):
        a.check(name, getattr(b, name))
    for values in b.seg_thresholds + b.seg_intercepts:
        a.check("seg_const", values)
    for name in ("x", "y", "jq", "jr"):
        a.check(name, getattr(b, name))
    a.check("remaining", b.columns - 1, b.columns > 0)  # the largest value the loop assigns


def _check_invariants(b: SetupBatch) -> None:
    """What the closed form assumes of setup (see the module docstring)."""
    ok = (
        (b.columns >= 0)
        & (b.du >= 1)
        & (b.ifix >= 1)
        & (b.jr >= 0)
        & (b.jr < b.du)
        & (b.kr >= 0)
        & (b.kr < b.du)
        & (b.khr >= 0)
        & (b.khr < b.du)
        & (b.jq >= 0)
        & (b.jq < b.ifix)
        & (b.kq >= 0)
        & (b.kq + np.where(b.kr != 0, 1, 0) <= b.ifix)
    )
    if not ok.all():
        k = int(np.argmin(ok))
        raise VectorInvariantError(f"setup breaks the closed form's assumptions: {b[k]}")


def _fits_int64(st: EdgeSetup) -> bool:
    """Whether every intermediate of the edge stays below 2**63 (bound in the docstring)."""
    n = st.columns
    u_last = st.jq + n * st.kq + (st.jr + n * st.kr) // st.du
    return u_last <= INT64_U_LIMIT and st.ifix <= INT64_IFIX_LIMIT


def _fits_int64_batch(b: SetupBatch) -> np.ndarray:
    """`_fits_int64` of every edge (a bool array), in exact integers."""
    fits = np.asarray(b.ifix <= INT64_IFIX_LIMIT, dtype=bool)
    n, top = b.columns, lambda values: int(np.max(values, initial=0))  # all nonnegative
    if top(b.jq) + top(n) * top(b.kq) + top(b.jr) + top(n) * top(b.kr) <= INT64_U_LIMIT:
        return fits  # a bound on every U_n already fits
    jq, jr, kq, kr, du, n = (v.astype(object) for v in (b.jq, b.jr, b.kq, b.kr, b.du, n))
    u_last = jq + n * kq + (jr + n * kr) // du  # Python ints: exact
    return fits & np.asarray(u_last <= INT64_U_LIMIT, dtype=bool)


def chunked(items: Sequence, weight, limit: int) -> list[list]:
    """Split `items` into runs whose `weight` adds up to about `limit` each (each run closes
    once it reaches the limit)."""
    chunks, chunk, total = [], [], 0
    for item in items:
        chunk.append(item)
        total += weight(item)
        if total >= limit:
            chunks.append(chunk)
            chunk, total = [], 0
    if chunk:
        chunks.append(chunk)
    return chunks


def weighted_runs(weights: np.ndarray, limit: int) -> list[slice]:
    """Consecutive runs (slices) of items whose `weights` (each at least 1) add up to about
    `limit`: `chunked` in numpy, one searchsorted per run (the item that brings a run to the
    limit closes it)."""
    total = np.cumsum(weights)
    runs, start, base = [], 0, 0
    while start < len(total):
        stop = min(int(np.searchsorted(total, base + limit)) + 1, len(total))
        runs.append(slice(start, stop))
        start, base = stop, int(total[stop - 1])
    return runs


def _chunks(weights: np.ndarray, group: np.ndarray) -> list[np.ndarray]:
    """Split a group of edges into runs of about CHUNK_STATES column states (cache-sized
    arrays: several times faster than one huge batch), weights[k] per edge k."""
    return [group[run] for run in weighted_runs(weights[group], CHUNK_STATES)]


def _divmod(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Floor quotient and remainder (np.divmod has no object-array loop)."""
    if a.dtype == object:
        q = a // b
        return q, a - q * b
    return np.divmod(a, b)


class _PerEdge:
    """`SetupBatch` fields (or its pieces') gathered by an index (one element per column or per
    write) in `dtype`: what the shared column arithmetic reads as ``st``."""

    def __init__(self, fields, dtype, index: np.ndarray):
        self._fields, self._dtype, self._index = fields, dtype, index

    def _column(self, values: np.ndarray) -> np.ndarray:
        picked = values[self._index]
        if picked.dtype == bool:
            return picked
        # astype(object) of int64 gives Python ints, so nothing wraps on the object path.
        return picked.astype(self._dtype, copy=False)

    def __getattr__(self, name: str):
        if name.startswith("_"):
            raise AttributeError(name)
        if name == "pieces":
            value = _PerEdge(self._fields.pieces, self._dtype, self._index)
        elif name in ("seg_thresholds", "seg_intercepts"):
            value = tuple(self._column(v) for v in getattr(self._fields, name))
        else:
            value = self._column(getattr(self._fields, name))
        setattr(self, name, value)  # gathered once
        return value


# -- the vectorized loop -----------------------------------------------------------------------


def _column_states(
    a: ArrayArith, batch: SetupBatch, group: np.ndarray, dtype
) -> dict[str, np.ndarray]:
    """The loop registers of every column of the edges `group` in closed form (module
    docstring), width-checked like the step model's, including the advance after each edge's
    last column."""
    columns = batch.columns[group].astype(np.int64)
    # States i = 0 .. columns: the last one is the advance after the last column, which the
    # step model also computes and width-checks.
    states = columns + 1
    e = np.repeat(np.arange(len(group)), states)  # edge (within the group) of each state
    starts = np.cumsum(states) - states
    i = np.arange(int(states.sum()), dtype=np.int64) - np.repeat(starts, states)
    if dtype is object:
        i = i.astype(object)
    st = _PerEdge(batch, dtype, group[e])
    carries, jr = _divmod(st.jr + i * st.kr, st.du)
    unreduced = st.jq + i * st.kq + carries
    rows, jq = _divmod(unreduced, st.ifix)
    x = st.x + i * st.col_dx + rows * st.row_dx
    y = st.y + i * st.col_dy + rows * st.row_dy
    for name, values in (("x", x), ("y", y), ("jq", jq), ("jr", jr)):
        a.check(name, values)
    # jsum of the advance out of state i (into i + 1): U_(i+1) - rows_i ifix.
    is_col = i < columns[e]
    nxt = np.flatnonzero(is_col) + 1
    a.check("jsum", unreduced[nxt] - rows[is_col] * st.ifix[is_col])
    return {
        "e": e[is_col],
        "jq": jq[is_col],
        "jr": jr[is_col],
        "x": x[is_col],
        "y": y[is_col],
        "i": i[is_col],
        "rows": rows[is_col],
    }


def _interleave(count: np.ndarray, has: np.ndarray, pairs, dtype) -> list[np.ndarray]:
    """Each column's primary value, then its neighbour's where it has one."""
    first = np.cumsum(count) - count
    second = first[has] + 1
    out = []
    for primary, neighbour in pairs:
        column = np.empty(int(count.sum()), dtype=dtype)
        column[first] = primary
        column[second] = neighbour
        out.append(column)
    return out


def _run_group(config: EdgeConfig, batch: SetupBatch, group: np.ndarray, dtype) -> list[np.ndarray]:
    """Writes of the edges `group` (ascending), computed in `dtype` (int64 or object)."""
    a = ArrayArith(config, dtype)
    s = _column_states(a, batch, group, dtype)
    e, x, y = s["e"], s["x"], s["y"]
    st = _PerEdge(batch, dtype, group[e])
    areas = column_areas(a, config, st, s["jq"], s["jr"])
    has = np.broadcast_to(np.asarray(areas.two, dtype=bool), e.shape)
    offset = np.asarray(neighbour_offset(a, areas)) if config.segments else 1
    area1 = np.broadcast_to(np.asarray(areas.area1, dtype=dtype), e.shape)
    e_out, x_out, y_out, area_out = _interleave(
        1 + has.astype(np.int64),
        has,
        (
            (e, e[has]),
            (x, (x + offset * st.row_dx)[has]),
            (y, (y + offset * st.row_dy)[has]),
            (areas.area0, area1[has]),
        ),
        dtype,
    )
    e_out = e_out.astype(np.int64)
    a.check("x", x_out)
    a.check("y", y_out)
    value = output_value(a, config, _PerEdge(batch, dtype, group[e_out]), area_out)
    edge_index = group[e_out]
    return [edge_index, x_out, y_out, value, area_out]


# -- accumulation deltas -----------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class DeltaBatch:
    """The accumulation deltas of a batch of edges: four cells per column, in the order of
    `step.run_edge_deltas` (zeros included). delta is int64, or an object array of Python
    ints when the delta register is wider than int64. setups: `run_edges_deltas` gives the
    EdgeSetup of each edge, `run_deltas_arrays` and `run_setup_deltas` the `SetupBatch`
    (``setups[k]`` is edge k's EdgeSetup either way)."""

    edge_index: np.ndarray
    x: np.ndarray
    y: np.ndarray
    delta: np.ndarray
    setups: tuple[EdgeSetup, ...] | SetupBatch

    def __len__(self) -> int:
        return len(self.edge_index)


def run_edges_deltas(
    config: EdgeConfig, edges: Iterable[Edge], *, force_object: bool = False
) -> DeltaBatch:
    """The deltas of all edges, bit-identical to `run_edge_deltas` on each edge."""
    setups = tuple(setup(config, edge) for edge in edges)  # validates: raises EdgeError
    batch = SetupBatch.from_setups(config, setups)
    return DeltaBatch(*_batch_deltas(config, batch, force_object), setups)


def run_deltas_arrays(
    config: EdgeConfig, x0, y0, x1, y1, inside_left, i_in, i_out, clip=None, *,
    force_object: bool = False,
) -> DeltaBatch:  # fmt: skip
    """`run_edges_deltas` of edges given as arrays (`edge.setup_batch`'s arguments: sub-pixel
    coordinates, inside_left bools, intensities, clip None, one Clip or four arrays): the same
    deltas as for the Edge list, with the setups as a `SetupBatch`. Bad edges raise EdgeError
    naming the first one's index."""
    batch = setup_batch(
        config, x0, y0, x1, y1, inside_left, i_in, i_out, clip, force_object=force_object
    )
    return run_setup_deltas(config, batch, force_object=force_object)


def run_setup_deltas(
    config: EdgeConfig, batch: SetupBatch, *, force_object: bool = False
) -> DeltaBatch:
    """The deltas of the edges whose setup is `batch` (`edge.setup_batch`)."""
    return DeltaBatch(*_batch_deltas(config, batch, force_object), batch)


def _batch_deltas(config: EdgeConfig, batch: SetupBatch, force_object: bool) -> list[np.ndarray]:
    """edge_index, x, y (int64) and delta of every column of the batch, in edge order."""
    delta_dtype = np.int64 if config.register_widths()["delta"].bits <= 63 else object
    chunks, mixed = _groups(config, batch, force_object)
    parts = [_deltas_group(config, batch, chunk, dtype) for chunk, dtype in chunks]
    if not parts:
        empty = np.zeros(0, dtype=np.int64)
        return [empty, empty, empty, empty.astype(delta_dtype)]
    edge_index, x, y, delta = _merge(parts, 4, mixed)
    # copy=False: the columns are new arrays already (a copy each was the deltas again)
    return [
        edge_index.astype(np.int64, copy=False),
        x.astype(np.int64, copy=False),
        y.astype(np.int64, copy=False),
        delta.astype(delta_dtype, copy=False),
    ]


def _deltas_group(
    config: EdgeConfig, batch: SetupBatch, group: np.ndarray, dtype
) -> list[np.ndarray]:
    """Deltas of the edges `group` (ascending), computed in `dtype` (int64 or object)."""
    a = ArrayArith(config, dtype)
    s = _column_states(a, batch, group, dtype)
    e, i = s["e"], s["i"]
    st = _PerEdge(batch, dtype, group[e])
    p = st.pieces
    first = (i == 0) & p.first_partial
    last = (i == st.columns - 1) & p.last_partial
    he, adj = piece_end(a, st, last, s["jq"], s["jr"], p.row0 + s["rows"])
    # hs: the first column's from setup, then where the previous column's piece ended.
    hs = np.array(he, copy=True)
    later = np.flatnonzero(i > 0)
    hs[later] = he[later - 1] - (s["rows"][later] - s["rows"][later - 1]) * st.ifix[later]
    start = i == 0
    hs[start] = p.hs0[start]
    a.check("height", hs)
    d = column_deltas(a, config, st, first, last, hs, he, adj, s["jq"])
    cells = delta_cells(a, st, s["x"], s["y"], d)
    count = len(e)
    out = [np.empty(4 * count, dtype=dtype) for _ in range(3)]
    for k, cell in enumerate(cells):
        for column, values in zip(out, cell, strict=True):
            column[k::4] = np.broadcast_to(np.asarray(values, dtype=dtype), (count,))
    edge_index = np.repeat(group[e], 4)
    return [edge_index, *out]
