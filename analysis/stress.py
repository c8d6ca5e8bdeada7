"""Numerical stability: `edgeaa stress`.

Part 1, the bound on extreme edges. For each coordinate width W the stress edges are
(`stress_edges`): the longest edges, corner to corner of the coordinate square, with
slopes 0, 1/L, (L - 1)/L and 1 (L = 2**(W+s) - 1 sub-pixel units, the longest major
delta) in all eight symmetries of the square; sub-pixel extremes (every vertex coordinate
at phase 0 or S - 1, shallow and steep); and edges starting and ending on every sub-pixel
phase (all S x S start/end phase pairs of the major coordinate, x- and y-major, for
W <= 10; S pairs (i, S - 1 - i) above that, to bound the run time). Each edge runs at
|I_d| = 1 (the largest fixed-point error in coverage) and at full scale, in every mode and
both accumulators, and every write is checked against the bound of docs/algorithm.md 9.1
(before output rounding):

    |coverage - exact| <= c_N k + u / (|I_d| 2**F),  u = u_N (exact), u_N + n (truncated)

with u_N = 1, 2, 5/2, 81/32 for pw, paper, seg2, seg4 and n the column (0 = first). The
"excess" of a write is (|coverage - exact| - c_N k) |I_d| 2**F, in accumulator units.
For the exact accumulator the excess must stay below u_N however long the edge: the
table shows its maximum over the first and the second half of every edge's columns.

Part 2, the word length of the truncated accumulator. docs/model.md derives
F = ceil(log2(max_columns)) + I + 1 from the budget max_columns 2**-F <= 2**-(I+1) in
coverage, a budget for the truncated accumulator's drift. For each (W, I) and F from the
derived value + 1 downwards, the paper-mode model runs the drift edges (`drift_edges`: the
worst-case slope for that F, whose increment K = dv 2**F / du has the fractional part
1 - 1/du so that the drift grows by almost one unit per column, plus the longest edges and
the phase edges, all at |I_d| = 1) with both accumulators. F is *safe* by either criterion
when, at F and every F above it,

    drift: max |coverage truncated - coverage exact accumulator| <= 2**-(I+1) + u_N 2**-F
    error: max |coverage truncated - exact area| - c_N k          <= 2**-(I+1) + u_N 2**-F

(the budget, plus the fixed-point units the exact accumulator has anyway: "the bound plus
rounding"). The measured smallest safe F of each criterion is printed beside the derived F.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from ..model import Edge, EdgeConfig
from ..model.step import WidthError
from ..model.vector import chunked, run_edges
from ..progress import ProgressBar
from .evaluate import BOUND_PER_K
from .geometry import column_index, exact_coverage_pixels, pixel_keys
from .report import fmt_float, pyplot, save, table

UNITS = {"pw": 1.0, "paper": 2.0, "seg2": 2.5, "seg4": 81 / 32}  # u_N, docs/algorithm.md 9.1
FULL_WIDTHS = (2, 4, 6, 8, 10, 11, 12, 14, 16)
QUICK_WIDTHS = (2, 4, 6, 8, 11)
FULL_INTENSITIES = (4, 8, 12, 16)
QUICK_INTENSITIES = (4, 8)
MAX_STATES = 1 << 21  # column states per model run (memory)
ALL_PHASES_UP_TO = 10  # W at most this: every start/end phase pair


def symmetries(m: int, x0: int, y0: int, x1: int, y1: int) -> list[tuple[int, int, int, int]]:
    """The edge under the 8 symmetries of the square [0, m]^2 (mirrors and the swap)."""
    out = []
    for swap, fx, fy in itertools.product((False, True), repeat=3):

        def f(x, y, swap=swap, fx=fx, fy=fy):
            if swap:
                x, y = y, x
            return (m - x if fx else x), (m - y if fy else y)

        out.append((*f(x0, y0), *f(x1, y1)))
    return out


def _with_intensities(coords, i_ds: tuple[int, ...]) -> list[Edge]:
    return [Edge(*c, inside="left", i_in=i_d, i_out=0) for i_d in i_ds for c in coords]


def stress_edges(config: EdgeConfig, i_ds: tuple[int, ...] | None = None) -> list[Edge]:
    """The stress edges of part 1 (module docstring), at |I_d| = 1 and full scale."""
    m, s = config.max_vertex, config.subpixel_scale
    i_ds = i_ds or tuple(sorted({1, config.full_scale}))
    coords: list[tuple[int, int, int, int]] = []
    for dv in sorted({0, 1, m - 1, m}):
        coords += symmetries(m, 0, 0, m, dv)
    for a, b, c, d in itertools.product((0, s - 1), repeat=4):
        coords.append((a, b, m - c, m - d))  # steep (k close to 1)
        coords.append((a, b, m - c, d))  # shallow
    coords += phase_edges(config)
    unique = list(dict.fromkeys(c for c in coords if c[:2] != c[2:]))
    return _with_intensities(unique, i_ds)


def phase_edges(config: EdgeConfig) -> list[tuple[int, int, int, int]]:
    """Edges starting and ending on every sub-pixel phase of the major coordinate."""
    m, s = config.max_vertex, config.subpixel_scale
    top = m - (s - 1)  # the last whole-pixel multiple of S: phases top .. top + s - 1
    if config.coord_bits <= ALL_PHASES_UP_TO:
        pairs = list(itertools.product(range(s), repeat=2))
    else:
        pairs = [(i, s - 1 - i) for i in range(s)]
    out = []
    half = (m // 2) - ((m // 2) % s)
    for i, j in pairs:
        out.append((i, j, top + j, half + i))  # x-major, k about 1/2
        out.append((j, i, half + i, top + j))  # y-major
    return out


def worst_drift_dv(du: int, frac_bits: int) -> int:
    """dv with frac(dv 2**F / du) = 1 - 1/du: the truncated drift grows fastest (du odd)."""
    return (-pow(2, -frac_bits, du)) % du


def drift_edges(config: EdgeConfig) -> list[Edge]:
    """The edges of part 2 at |I_d| = 1: worst-case slope for config.F, longest, phases."""
    m = config.max_vertex
    coords = symmetries(m, 0, 0, m, worst_drift_dv(m, config.F))
    for dv in (1, m - 1):
        coords += symmetries(m, 0, 0, m, dv)
    s = config.subpixel_scale
    top, half = m - (s - 1), (m // 2) - ((m // 2) % s)
    coords += [(i, s - 1 - i, top + s - 1 - i, half + i) for i in range(s)]
    unique = list(dict.fromkeys(coords))
    return _with_intensities(unique, (1,))


@dataclass
class WriteCheck:
    """Per-write errors of one model run over a list of edges."""

    writes: int = 0
    ratio: float = 0.0  # max |err| / bound
    excess_first: float = -np.inf  # max excess units, first half of the columns
    excess_second: float = -np.inf  # second half
    excess_minus_n: float = -np.inf  # max (excess units - n)
    excess_coverage: float = -np.inf  # max |err| - c_N k, in coverage
    width_errors: int = 0
    violations: int = 0  # writes beyond the bound (relative tolerance 1e-9 for float noise)


def _chunks(config: EdgeConfig, edges: list[Edge]) -> list[list[Edge]]:
    """Batches of about MAX_STATES column states (an edge steps at most du / S + 2)."""
    scale = config.subpixel_scale

    def states(edge: Edge) -> int:
        return max(abs(edge.x1 - edge.x0), abs(edge.y1 - edge.y0)) // scale + 2

    return chunked(edges, states, MAX_STATES)


def check_writes(config: EdgeConfig, edges: list[Edge]) -> WriteCheck:
    """Run the model on the edges and measure every write against the bound."""
    out = WriteCheck()
    c_n, u_n = BOUND_PER_K[config.mode], UNITS[config.mode]
    for chunk in _chunks(config, edges):
        try:
            batch = run_edges(config, chunk)
        except WidthError:
            out.width_errors += 1
            continue
        e = batch.edge_index
        cov = batch.coverage()
        exact = exact_coverage_pixels(config, chunk, e, batch.x, batch.y)
        err = np.abs(cov - exact)
        k = np.array([st.dv / st.du for st in batch.setups])[e]
        i_d = np.array([st.ifix >> config.F for st in batch.setups], dtype=np.float64)[e]
        columns = np.array([st.columns for st in batch.setups])[e]
        n = column_index(batch)
        unit = 1.0 / (i_d * 2.0**config.F)  # one accumulator unit, in coverage
        u = u_n + (n if config.accumulator == "truncated" else 0)
        bound = c_n * k + u * unit
        excess = (err - c_n * k) / unit
        first = 2 * n < columns
        out.writes += len(batch)
        out.violations += int(np.count_nonzero(err > bound * (1 + 1e-9)))
        out.ratio = max(out.ratio, float((err / bound).max()))
        if first.any():
            out.excess_first = max(out.excess_first, float(excess[first].max()))
        if (~first).any():
            out.excess_second = max(out.excess_second, float(excess[~first].max()))
        out.excess_minus_n = max(out.excess_minus_n, float((excess - n).max()))
        out.excess_coverage = max(out.excess_coverage, float((err - c_n * k).max()))
    return out


# -- part 1 -----------------------------------------------------------------------------------


@dataclass
class BoundRow:
    coord_bits: int
    accumulator: str
    edges: int
    checks: dict[str, WriteCheck]


def bound_sweep(
    widths: tuple[int, ...], subpixel_bits: int, intensity_bits: int, progress: bool = True
) -> list[BoundRow]:
    rows = []
    bar = ProgressBar("stress bounds", len(widths) * 8, enabled=progress)
    for w in widths:
        base = EdgeConfig(coord_bits=w, subpixel_bits=subpixel_bits, intensity_bits=intensity_bits)
        edges = stress_edges(base)
        for accumulator in ("exact", "truncated"):
            checks = {}
            for mode in BOUND_PER_K:
                with bar.doing(f"W={w} {accumulator} {mode}"):
                    config = base.with_(mode=mode, accumulator=accumulator)
                    checks[mode] = check_writes(config, edges)
            rows.append(BoundRow(w, accumulator, len(edges), checks))
    return rows


def bound_table(rows: list[BoundRow]) -> str:
    out = []
    for row in rows:
        checks = row.checks.values()
        worst_mode = max(row.checks, key=lambda m: row.checks[m].ratio)
        exact = row.accumulator == "exact"
        out.append(
            [
                str(row.coord_bits),
                row.accumulator,
                str(row.edges),
                str(sum(c.writes for c in checks)),
                f"{row.checks[worst_mode].ratio:.6f} ({worst_mode})",
                str(sum(c.violations for c in checks)),
                " / ".join(f"{row.checks[m].excess_first:.2f}" for m in row.checks)
                if exact
                else "-",
                " / ".join(f"{row.checks[m].excess_second:.2f}" for m in row.checks)
                if exact
                else "-",
                " / ".join(f"{row.checks[m].excess_minus_n:.2f}" for m in row.checks)
                if not exact
                else "-",
                str(sum(c.width_errors for c in checks)),
            ]
        )
    headers = [
        "W",
        "accumulator",
        "edges",
        "writes",
        "max err/bound",
        "beyond bound",
        "excess, 1st half",
        "excess, 2nd half",
        "max(excess - n)",
        "width errors",
    ]
    note = (
        "excess = (|err| - c_N k) |I_d| 2^F accumulator units, per mode pw / paper / seg2 / "
        "seg4; the bound allows u_N = 1 / 2 / 2.5 / 2.53 (exact) and u_N + n (truncated, "
        "column n)."
    )
    return table(headers, out, align="rlrrrrrrrr") + "\n" + note


# -- part 2 -----------------------------------------------------------------------------------


@dataclass
class SafeRow:
    coord_bits: int
    intensity_bits: int
    derived: int
    floor: int  # min_frac_bits: F cannot go lower
    measured_error: int | None = None  # smallest safe F by the error criterion
    measured_drift: int | None = None  # smallest safe F by the drift criterion
    excess: dict[int, float] = field(default_factory=dict)  # F -> worst error excess / budget
    drift: dict[int, float] = field(default_factory=dict)  # F -> worst drift / budget


def allowance(config: EdgeConfig) -> float:
    """The bound plus rounding of part 2: 2**-(I+1) + u_N 2**-F (coverage at |I_d| = 1)."""
    return 2.0 ** -(config.intensity_bits + 1) + UNITS[config.mode] * 2.0**-config.F


def error_and_drift(config: EdgeConfig, edges: list[Edge]) -> tuple[float, float, int]:
    """For the truncated config: the worst |err| - c_N k, the worst drift |coverage truncated
    - coverage exact accumulator| over the pixels both write, and the width errors."""
    c_n = BOUND_PER_K[config.mode]
    excess, drift, width_errors = -np.inf, 0.0, 0
    exact_config = config.with_(accumulator="exact")
    for chunk in _chunks(config, edges):
        try:
            truncated = run_edges(config, chunk)
            exact_acc = run_edges(exact_config, chunk)
        except WidthError:
            width_errors += 1
            continue
        e = truncated.edge_index
        exact = exact_coverage_pixels(config, chunk, e, truncated.x, truncated.y)
        k = np.array([st.dv / st.du for st in truncated.setups])[e]
        cov = truncated.coverage()
        excess = max(excess, float((np.abs(cov - exact) - c_n * k).max()))
        keys_t = pixel_keys(e, truncated.x, truncated.y)
        keys_e = pixel_keys(exact_acc.edge_index, exact_acc.x, exact_acc.y)
        _, it, ie = np.intersect1d(keys_t, keys_e, return_indices=True)
        if len(it):
            drift = max(drift, float(np.abs(cov[it] - exact_acc.coverage()[ie]).max()))
    return excess, drift, width_errors


def safe_frac_bits(
    widths: tuple[int, ...],
    intensities: tuple[int, ...],
    subpixel_bits: int,
    *,
    span: int = 4,
    full_span_intensity: int | None = 8,
    progress: bool = True,
) -> list[SafeRow]:
    """Smallest safe F per (W, I) by two criteria, over the drift edges (truncated, paper,
    |I_d| = 1), from derived F + 1 downwards until both fail (for full_span_intensity, at
    least down to derived F - span, for the plot), never below min_frac_bits:

    - error: max |err| - k/64 <= 2**-(I+1) + u_N 2**-F (the bound plus rounding);
    - drift: max |coverage truncated - coverage exact accumulator| <= 2**-(I+1) + u_N 2**-F
      (the budget of docs/model.md is a budget for exactly this drift).
    """
    rows = []
    bar = ProgressBar("stress word length", len(widths) * len(intensities), enabled=progress)
    for w, i in itertools.product(widths, intensities):
        base = EdgeConfig(
            coord_bits=w,
            subpixel_bits=subpixel_bits,
            intensity_bits=i,
            mode="paper",
            accumulator="truncated",
        )
        with bar.doing(f"W={w} I={i}"):
            rows.append(_safe_row(base, span if i == full_span_intensity else None))
    return rows


def _safe_row(base: EdgeConfig, span: int | None) -> SafeRow:
    """One (W, I) row of `safe_frac_bits`; `span`: go at least that far below derived F."""
    row = SafeRow(base.coord_bits, base.intensity_bits, base.F, base.min_frac_bits)
    budget = 2.0 ** -(base.intensity_bits + 1)
    error_ok = drift_ok = True
    for f in range(base.F + 1, base.min_frac_bits - 1, -1):
        config = base.with_(frac_bits=f)
        excess, drift, width_errors = error_and_drift(config, drift_edges(config))
        row.excess[f], row.drift[f] = excess / budget, drift / budget
        error_ok = error_ok and width_errors == 0 and excess <= allowance(config)
        drift_ok = drift_ok and width_errors == 0 and drift <= allowance(config)
        if error_ok:
            row.measured_error = f
        if drift_ok:
            row.measured_drift = f
        if not (error_ok or drift_ok) and (span is None or f <= base.F - span):
            break
    return row


def safe_table(rows: list[SafeRow]) -> str:
    def measured(row: SafeRow, f: int | None) -> str:
        if f is None:
            return "-"
        return f"<= {f} (floor)" if f == row.floor else str(f)

    def ratio(values: dict[int, float], f: int) -> str:
        return fmt_float(values[f], 3) if f in values else "-"

    out = []
    for row in rows:
        d = row.derived
        out.append(
            [
                str(row.coord_bits),
                str(row.intensity_bits),
                str(d),
                measured(row, row.measured_drift),
                measured(row, row.measured_error),
                ratio(row.drift, d),
                ratio(row.drift, d - 1),
                ratio(row.drift, d - 2),
                ratio(row.excess, d - 1),
            ]
        )
    headers = [
        "W",
        "I",
        "derived F",
        "measured F (drift)",
        "measured F (error)",
        "drift/budget at derived F",
        "at derived F-1",
        "at derived F-2",
        "error excess/budget at derived F-1",
    ]
    note = (
        "truncated accumulator, paper, |I_d| = 1, drift edges; budget = 2^-(I+1). drift = "
        "max |coverage truncated - coverage exact accumulator|; error excess = max "
        "|err| - k/64. Safe: the quantity <= budget + u_N 2^-F at that F and every F above it. "
        "(floor): F cannot go below min_frac_bits."
    )
    return table(headers, out, align="rrrrrrrrr") + "\n" + note


# -- the drift plot ---------------------------------------------------------------------------


@dataclass
class DriftCurve:
    """Running maxima along the worst-case drift edge (index = column n)."""

    accumulator: str
    frac_bits: int
    derived: bool
    drift: np.ndarray | None  # max |truncated - exact accumulator| coverage so far
    excess_units: np.ndarray  # max (|err| - c_N k) |I_d| 2**F so far

    @property
    def label(self) -> str:
        return f"{self.accumulator}, F = {self.frac_bits}" + (" (derived)" if self.derived else "")


def _running_max(n: np.ndarray, values: np.ndarray) -> np.ndarray:
    per_column = np.full(int(n.max()) + 1, -np.inf)
    np.maximum.at(per_column, n, values)
    return np.maximum.accumulate(per_column)


def drift_curves(
    coord_bits: int, subpixel_bits: int, intensity_bits: int, span: int = 6
) -> list[DriftCurve]:
    """The worst-case drift edge for each F from derived - span to derived + 1: the
    truncated accumulator's drift from the exact accumulator (same F, same pixels), and the
    error excess of both accumulators in units."""
    base = EdgeConfig(
        coord_bits=coord_bits,
        subpixel_bits=subpixel_bits,
        intensity_bits=intensity_bits,
        mode="paper",
    )
    curves = []
    derived = base.F
    for f in range(max(base.min_frac_bits, derived - span), derived + 2):
        m = base.max_vertex
        edge = Edge(0, 0, m, worst_drift_dv(m, f), inside="left", i_in=1, i_out=0)
        k = edge.y1 / edge.x1
        runs = {}
        for accumulator in ("exact", "truncated"):
            config = base.with_(accumulator=accumulator, frac_bits=f)
            batch = run_edges(config, [edge])
            exact = exact_coverage_pixels(config, [edge], batch.edge_index, batch.x, batch.y)
            excess = (np.abs(batch.coverage() - exact) - BOUND_PER_K["paper"] * k) * 2.0**f
            runs[accumulator] = (batch, column_index(batch), excess)
        (tb, tn, t_excess), (eb, _, _) = runs["truncated"], runs["exact"]
        keys_t, keys_e = tb.x * (1 << 20) + tb.y, eb.x * (1 << 20) + eb.y
        common, it, ie = np.intersect1d(keys_t, keys_e, return_indices=True)
        drift = np.abs(tb.coverage()[it] - eb.coverage()[ie])
        curves.append(
            DriftCurve(
                "truncated",
                f,
                f == derived,
                _running_max(tn[it], drift),
                _running_max(tn, t_excess),
            )
        )
    return curves


def length_curves(coord_bits: int, subpixel_bits: int, intensity_bits: int) -> list[DriftCurve]:
    """|err| in accumulator units along the longest shallow edge (0, 0) -> (L, 1), k = 1/L
    (k/64 is then about one unit: the error is mostly the fixed-point part), |I_d| = 1,
    derived F, both accumulators."""
    base = EdgeConfig(
        coord_bits=coord_bits,
        subpixel_bits=subpixel_bits,
        intensity_bits=intensity_bits,
        mode="paper",
    )
    m = base.max_vertex
    edge = Edge(0, 0, m, 1, inside="left", i_in=1, i_out=0)  # stays in row 0
    curves = []
    for accumulator in ("exact", "truncated"):
        config = base.with_(accumulator=accumulator)
        batch = run_edges(config, [edge])
        exact = exact_coverage_pixels(config, [edge], batch.edge_index, batch.x, batch.y)
        units = np.abs(batch.coverage() - exact) * 2.0**config.F
        n = column_index(batch)
        curves.append(DriftCurve(accumulator, config.F, True, None, _running_max(n, units)))
    return curves


def plot_stress(
    curves: list[DriftCurve],
    shallow: list[DriftCurve],
    safe_rows: list[SafeRow],
    config: EdgeConfig,
    path: str,
) -> None:
    plt = pyplot()
    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(19, 6.2))
    budget = 2.0 ** -(config.intensity_bits + 1)
    cmap = plt.get_cmap("viridis")
    truncated = [c for c in curves if c.accumulator == "truncated"]
    for idx, curve in enumerate(truncated):
        colour = cmap(idx / max(len(truncated) - 1, 1))
        n = np.arange(1, len(curve.drift) + 1)
        ax1.loglog(
            n,
            np.maximum(curve.drift, 1e-12),
            color=colour,
            label=curve.label,
            linewidth=1.8 if curve.derived else 1.2,
        )
        ax1.loglog(n, n * 2.0**-curve.frac_bits, ":", color=colour, linewidth=0.9)
    ax1.axhline(
        budget,
        color="black",
        linestyle="--",
        linewidth=1.2,
        label=f"budget 2^-(I+1) = {budget:.3g}",
    )
    ax1.axvline(
        config.max_columns,
        color="gray",
        linestyle="-.",
        linewidth=1.0,
        label=f"max_columns = 2^W + 1 = {config.max_columns}",
    )
    ax1.set_xlabel("edge length so far (columns, n + 1)")
    ax1.set_ylabel("max |coverage truncated - coverage exact accumulator| so far")
    ax1.set_title(
        f"(a) Truncated drift against length and F (W={config.coord_bits}, "
        f"s={config.subpixel_bits}, I={config.intensity_bits},\npaper, |I_d| = 1, "
        "worst-case slope per F); dotted: (n + 1) 2^-F",
        fontsize=10,
    )
    ax1.grid(True, which="both", alpha=0.3)
    ax1.set_ylim(1e-8, 1)
    ax1.legend(fontsize=7, loc="upper left")

    floor = 1e-2
    for curve in sorted(shallow, key=lambda c: c.accumulator == "exact"):
        n = np.arange(1, len(curve.excess_units) + 1)
        exact = curve.accumulator == "exact"
        ax2.loglog(
            n,
            np.maximum(curve.excess_units, floor),
            color="tab:red" if exact else "tab:blue",
            linestyle=(0, (3, 3)) if exact else "-",
            label=curve.label,
            linewidth=2.6 if exact else 1.4,
            zorder=3 if exact else 2,
        )
    n = np.arange(1, config.max_columns + 1)
    k_units = BOUND_PER_K["paper"] / config.max_vertex * 2.0**config.F
    kr = (1 << config.F) % config.max_vertex  # the remainder step of K on that edge
    wrap = -(-config.max_vertex // kr) if kr else "never"
    ax2.loglog(
        n,
        k_units + n - 1 + UNITS["paper"],
        ":",
        color="tab:blue",
        label="bound k/64 + (u_N + n) units (truncated)",
    )
    ax2.axhline(
        k_units + UNITS["paper"],
        color="tab:red",
        linestyle=":",
        label="bound k/64 + u_N units (exact)",
    )
    ax2.set_xlabel("edge length so far (columns, n + 1)")
    ax2.set_ylabel("max |err| |I_d| 2^F so far (accumulator units)")
    ax2.set_title(
        "(b) Error in accumulator units, longest edge of slope 1/L (one row, no estimate\n"
        f"error), derived F, |I_d| = 1: the same until the exact remainder wraps (n = {wrap}),\n"
        f"then exact stays under 1 unit, truncated keeps growing (<= {floor:g} drawn at "
        f"{floor:g})",
        fontsize=10,
    )
    ax2.grid(True, which="both", alpha=0.3)
    ax2.legend(fontsize=7, loc="upper left")

    intensity = config.intensity_bits
    colours = plt.get_cmap("tab10")
    shown = [r for r in safe_rows if r.intensity_bits == intensity and r.drift]
    for idx, row in enumerate(shown):
        fs = sorted(row.drift)
        xs = [f - row.derived for f in fs]
        colour = colours(idx % 10)
        ax3.semilogy(
            xs,
            [max(row.drift[f], 1e-6) for f in fs],
            "o-",
            color=colour,
            label=f"W = {row.coord_bits} (derived F = {row.derived})",
        )
        ax3.semilogy(xs, [max(row.excess[f], 0.05) for f in fs], "x:", color=colour, alpha=0.7)
    ax3.axhline(1.0, color="black", linestyle="--", label="budget 2^-(I+1)")
    ax3.axvline(0, color="gray", linestyle="-.", label="derived F = ceil(log2(2^W+1)) + I + 1")
    ax3.set_xlabel("F - derived F (bits)")
    ax3.set_ylabel(
        "worst drift (o, solid) and |err| - k/64 (x, dotted) / 2^-(I+1)\n"
        "(values below 0.05 drawn at 0.05)"
    )
    ax3.set_ylim(0.04, 20)
    ax3.set_title(
        f"(c) Truncated accumulator against fraction bits\n(I = {intensity}, paper, "
        "|I_d| = 1, drift edges of every W)",
        fontsize=10,
    )
    ax3.grid(True, which="both", alpha=0.3)
    ax3.legend(fontsize=7)
    fig.tight_layout()
    save(fig, path)
    plt.close(fig)
