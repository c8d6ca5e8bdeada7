"""Error bounds of the step-by-step model against the exact half-plane reference.

Every write of every column is judged against the exact area of its pixel on the inside of
the edge's supporting line (the endpoint rule: columns are whole, whatever the endpoints):

    |coverage - exact| <= error_bound(mode, k) + fixed_point_term(config, setup, column)

and after output rounding, with half an output LSB more. See tests/error_budget.py for the
derivation of the fixed-point term.
"""

from __future__ import annotations

import dataclasses
import math
import random
from fractions import Fraction

import pytest
from error_budget import (
    bound,
    column_pixels,
    fixed_point_term,
    model_coverage,
    output_coverage,
    slope,
    write_column,
)
from fixtures import GEOMETRY_CONFIGS, random_any_length_edge, slope_edges
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import edgeaa.model.column as column_module
import edgeaa.model.step as step_module
from edgeaa.model import (
    ACCUMULATORS,
    MODES,
    Edge,
    EdgeConfig,
    EdgeResult,
    exact_coverage,
    run_edge,
)
from edgeaa.model.reference import FIXED_POINT_UNITS

HYPOTHESIS = settings(deadline=None, max_examples=80, suppress_health_check=[HealthCheck.too_slow])
SLOW_HYPOTHESIS = settings(HYPOTHESIS, max_examples=200)
# Longest major delta drawn by hypothesis; long edges are the stability tests' business.
MAX_PIXELS = 96
HALF = Fraction(1, 2)
# The bounds per unit of k, and the segments of each mode (the spec's N; 0 = one pixel).
PER_K = {
    "pw": Fraction(1, 8),
    "paper": Fraction(1, 64),
    "seg2": Fraction(1, 256),
    "seg4": Fraction(1, 1024),
}
SEGMENTS = {"pw": 0, "paper": 1, "seg2": 2, "seg4": 4}


# -- the exact side ---------------------------------------------------------------------------


class ExactCache:
    """Exact coverages of one edge, shared by all modes and accumulators."""

    def __init__(self, config: EdgeConfig, edge: Edge):
        self.config, self.edge, self.values = config, edge, {}

    def __call__(self, x: int, y: int) -> Fraction:
        key = (x, y)
        if key not in self.values:
            self.values[key] = exact_coverage(self.config, self.edge, x, y)
        return self.values[key]


def line_position(config: EdgeConfig, edge: Edge, result: EdgeResult, column: int):
    """f of a column from the geometry, as integers (num, den) with f = num / den, den > 0.

    f is the line's distance at the column centre from the near boundary (towards smaller
    folded minor coordinate) of the row the trace is in: the state J of the loop is f * ifix.
    """
    st_ = result.setup
    trace = result.trace[column]
    s = config.subpixel_scale
    if st_.x_major:
        p0, q0, dp, dq = edge.x0, edge.y0, edge.x1 - edge.x0, edge.y1 - edge.y0
        p, q, row_step = trace.x, trace.y, st_.row_dy
    else:
        p0, q0, dp, dq = edge.y0, edge.x0, edge.y1 - edge.y0, edge.x1 - edge.x0
        p, q, row_step = trace.y, trace.x, st_.row_dx
    # q_line - q = (q0 dp + dq (p s - p0) - q s dp) / (s dp) pixels; f = that * row_step + 1/2
    num = (q0 * dp + dq * (p * s - p0) - q * s * dp) * row_step
    den = s * dp
    if den < 0:
        num, den = -num, -den
    return 2 * num + den, 2 * den


def line_fraction(config: EdgeConfig, edge: Edge, result: EdgeResult, column: int) -> Fraction:
    return Fraction(*line_position(config, edge, result, column))


def state_is_line(config: EdgeConfig, edge: Edge, result: EdgeResult, column: int) -> bool:
    """Zero drift: jq + jr/du == f * ifix exactly, 0 <= f < 1 (in integers, for speed)."""
    st_ = result.setup
    state = result.trace[column]
    num, den = line_position(config, edge, result, column)
    return 0 <= num < den and (state.jq * st_.du + state.jr) * den == num * st_.ifix * st_.du


def triangle(mode: str, k: Fraction, d: Fraction) -> Fraction:
    """The spec's N-segment add-only estimate of d^2/(2k), exact, clamped at 0."""
    n = SEGMENTS[mode]
    j = min(math.floor(2 * n * d / k), n - 1)
    return max(Fraction(2 * j + 1, 4 * n) * d - (8 * j * (j + 1) + 1) * k / (64 * n * n), 0)


def ideal_areas(mode: str, k: Fraction, f: Fraction) -> dict[int, Fraction]:
    """The estimate in exact arithmetic (the spec's sections 3 and 6): A-side area by row
    offset from the primary pixel, for the line at height f in it and slope k."""
    if SEGMENTS[mode] == 0:
        return {0: f}
    d_up, d_dn = f + k / 2 - 1, k / 2 - f
    if d_up > 0:
        t = triangle(mode, k, d_up)
        return {0: f - t, 1: t}
    if d_dn > 0:
        t = triangle(mode, k, d_dn)
        return {0: f + t, -1: 1 - t}
    return {0: f}


# -- the checks ----------------------------------------------------------------------------


def bound_violations(config: EdgeConfig, edge: Edge, cov: ExactCache, result=None, columns=None):
    """Writes beyond the bound, before and after output rounding (empty: all within).

    columns: the column indices to check (default all).
    """
    result = run_edge(config, edge) if result is None else result
    st_ = result.setup
    b = bound(config, st_)
    i_in, i_out = edge.intensities(config)
    half_lsb = Fraction(1, 2 * abs(i_in - i_out))
    bad = []
    for column in range(len(result.columns)) if columns is None else columns:
        for w in result.columns[column]:
            assert write_column(st_, w) == column
            exact = cov(w.x, w.y)
            limit = b + fixed_point_term(config, st_, column)
            err = abs(model_coverage(result, w) - exact)
            out_err = abs(output_coverage(config, edge, w) - exact)
            if err > limit or out_err > limit + half_lsb:
                bad.append(
                    f"{config.mode}/{config.accumulator} write {w} column {column}: exact "
                    f"{float(exact):.6f} error {float(err):.3g} (output {float(out_err):.3g})"
                    f" > bound {float(b):.3g} + fixed point {float(limit - b):.3g}"
                )
    return bad


def completeness_violations(config: EdgeConfig, edge: Edge, cov: ExactCache, result=None):
    """Pixels of the stepped columns that should have a write and have none, or vice versa.

    Two-pixel modes: every pixel the line passes through (0 < exact < 1) is written -- the
    exit tests are exact, so this holds without the margin of the bound, and implies that
    every pixel with bound < exact < 1 - bound is written. A pixel the line does not touch
    (exact 0 or 1) is not written, except the primary pixel of a k = 0 edge lying exactly on
    a row boundary: the line at the column centre is then on the row's near boundary (f = 0,
    rows are [y - 1/2, y + 1/2)), and the write is area 0, which is exactly right.
    pw: one write per column, and every pixel with k/8 + eps < exact < 1 - k/8 - eps written
    (the pixel beyond the column's exit holds at most k/8 and is never written).
    """
    result = run_edge(config, edge) if result is None else result
    st_ = result.setup
    k = slope(st_)
    written = {(w.x, w.y) for w in result.writes}
    bad = []
    if len(written) != len(result.writes):
        bad.append("a pixel written twice")
    margin = bound(config, st_) + fixed_point_term(config, st_, 0)
    if config.mode == "pw" and any(len(column) != 1 for column in result.columns):
        bad.append("pw: not one write per column")
    for state in result.trace:
        for x, y in column_pixels(st_, state.column, state.x, state.y):
            exact = cov(x, y)
            is_written = (x, y) in written
            if config.mode == "pw":
                if margin < exact < 1 - margin and not is_written:
                    bad.append(f"pw: pixel {(x, y)} exact {exact} not written")
            elif 0 < exact < 1 and not is_written:
                bad.append(f"{config.mode}: pixel {(x, y)} exact {exact} not written")
            if is_written and exact in (0, 1):
                on_boundary = k == 0 and (x, y) == (state.x, state.y)
                if not on_boundary:
                    bad.append(f"{config.mode}: pixel {(x, y)} exact {exact} written")
    return bad


def estimate_violations(config: EdgeConfig, edge: Edge, result: EdgeResult, columns=None):
    """The exact accumulator against the estimate computed in exact arithmetic.

    Its state is the line's exact position (zero drift) in every column, it takes the same
    exit decisions, and each write is within FIXED_POINT_UNITS of the exact estimate.
    """
    trace = result.trace if columns is None else [result.trace[n] for n in columns]
    st_ = result.setup
    k = slope(st_)
    units = FIXED_POINT_UNITS[config.mode]
    bad = []
    for state in trace:
        f = line_fraction(config, edge, result, state.column)
        if not state_is_line(config, edge, result, state.column):
            bad.append(f"column {state.column}: state {state} is not f = {f}")
            continue
        ideal = ideal_areas(config.mode, k, f)
        areas = {
            (w.x - state.x) * st_.row_dx + (w.y - state.y) * st_.row_dy: w.area
            for w in result.columns[state.column]
        }
        if set(areas) != set(ideal):
            bad.append(f"column {state.column}: rows {sorted(areas)} != {sorted(ideal)}")
            continue
        for offset, area in areas.items():
            if abs(area - ideal[offset] * st_.ifix) >= units:
                bad.append(
                    f"column {state.column} row {offset:+d}: area {area} vs "
                    f"{float(ideal[offset] * st_.ifix):.3f} (>= {units} units)"
                )
        if config.mode != "pw":
            # The column's total is exact: only the split between the two rows is estimated.
            total = sum(areas.values()) - (st_.ifix if -1 in areas else 0)
            if not 0 <= f * st_.ifix - total < 1:
                bad.append(f"column {state.column}: total {total} vs {f * st_.ifix}")
    return bad


def drift_violations(edge: Edge, config: EdgeConfig, result: EdgeResult, columns):
    """The truncated accumulator's premise: jq = J - delta, delta in [0, column + 1)."""
    bad = []
    for n in columns:
        state = result.trace[n]
        delta = line_fraction(config, edge, result, n) * result.setup.ifix - state.jq
        if not 0 <= delta < n + 1:
            bad.append(f"column {n}: drift {float(delta)} outside [0, {n + 1})")
    return bad


# -- hypothesis: bounds, completeness, the estimate ---------------------------------------


def check_bounds(config_name: str, accumulator: str, edge: Edge) -> None:
    """All modes on one edge: the bound, and the exact estimate (exact) or the drift premise
    of fixed_point_term (truncated)."""
    base = GEOMETRY_CONFIGS[config_name].with_(accumulator=accumulator)
    cov = ExactCache(base, edge)
    for mode in MODES:
        config = base.with_(mode=mode)
        result = run_edge(config, edge)
        bad = bound_violations(config, edge, cov, result)
        assert not bad, f"{config_name} {edge}: {len(bad)} violations, first: {bad[0]}"
        if accumulator == "exact":
            bad = estimate_violations(config, edge, result)
        else:
            bad = drift_violations(edge, config, result, range(len(result.trace)))
        assert not bad, f"{config_name} {edge}: {bad[:3]}"


def check_completeness(config_name: str, edge: Edge) -> None:
    base = GEOMETRY_CONFIGS[config_name]
    cov = ExactCache(base, edge)
    for mode in MODES:
        config = base.with_(mode=mode)
        result = run_edge(config, edge)
        bad = completeness_violations(config, edge, cov, result)
        assert not bad, f"{config_name} {edge}: {bad[:3]}"
        assert columns_overlapped(config, edge) == [
            state.x if result.setup.x_major else state.y for state in result.trace
        ]


@pytest.mark.parametrize("accumulator", ACCUMULATORS)
@pytest.mark.parametrize("config_name", sorted(GEOMETRY_CONFIGS))
@HYPOTHESIS
@given(data=st.data())
def test_error_bound(config_name, accumulator, data):
    edge = data.draw(
        slope_edges(GEOMETRY_CONFIGS[config_name], max_pixels=MAX_PIXELS), label="edge"
    )
    check_bounds(config_name, accumulator, edge)


@pytest.mark.parametrize("config_name", sorted(GEOMETRY_CONFIGS))
@HYPOTHESIS
@given(data=st.data())
def test_completeness(config_name, data):
    edge = data.draw(
        slope_edges(GEOMETRY_CONFIGS[config_name], max_pixels=MAX_PIXELS), label="edge"
    )
    check_completeness(config_name, edge)


@pytest.mark.slow
@pytest.mark.parametrize("accumulator", ACCUMULATORS)
@pytest.mark.parametrize("config_name", ["default", "tiny"])
@SLOW_HYPOTHESIS
@given(data=st.data())
def test_error_bound_and_completeness_slow(config_name, accumulator, data):
    """More examples and edges of any length (up to 2049 columns)."""
    edge = data.draw(slope_edges(GEOMETRY_CONFIGS[config_name]), label="edge")
    check_bounds(config_name, accumulator, edge)
    if accumulator == "exact":
        check_completeness(config_name, edge)


def columns_overlapped(config: EdgeConfig, edge: Edge) -> list[int]:
    """The endpoint rule from the geometry: the columns (major-axis pixel coordinates, in
    the order of travel) whose open interior the edge's major-axis projection overlaps."""
    s = config.subpixel_scale
    x_major = abs(edge.x1 - edge.x0) >= abs(edge.y1 - edge.y0)
    p0, p1 = (edge.x0, edge.x1) if x_major else (edge.y0, edge.y1)
    lo, hi = Fraction(min(p0, p1), s), Fraction(max(p0, p1), s)
    # c - 1/2 < hi and c + 1/2 > lo
    columns = list(range(math.floor(lo - HALF) + 1, math.ceil(hi + HALF)))
    return columns if p1 > p0 else columns[::-1]


@pytest.mark.parametrize("config_name", sorted(GEOMETRY_CONFIGS))
@HYPOTHESIS
@given(data=st.data())
def test_inside_left_and_right_are_complementary(config_name, data):
    """Same pixels, same areas: coverage_left + coverage_right == 1 and the two values add up
    to I_in + I_out, per pixel, in every mode and accumulator."""
    base = GEOMETRY_CONFIGS[config_name]
    edge = data.draw(slope_edges(base, max_pixels=32), label="edge")
    left = dataclasses.replace(edge, inside="left")
    right = dataclasses.replace(edge, inside="right")
    i_in, i_out = edge.intensities(base)
    for mode in MODES:
        for accumulator in ACCUMULATORS:
            config = base.with_(mode=mode, accumulator=accumulator)
            res_l, res_r = run_edge(config, left), run_edge(config, right)
            assert [(w.x, w.y, w.area) for w in res_l.writes] == [
                (w.x, w.y, w.area) for w in res_r.writes
            ]
            for wl, wr in zip(res_l.writes, res_r.writes, strict=True):
                assert model_coverage(res_l, wl) + model_coverage(res_r, wr) == 1
                assert wl.value + wr.value == i_in + i_out


@pytest.mark.parametrize("config_name", sorted(GEOMETRY_CONFIGS))
@HYPOTHESIS
@given(data=st.data())
def test_reversed_edge_is_the_same_half_plane(config_name, data):
    """P1 -> P0 with the other inside side is the same half-plane: the folded frame is
    mirrored (f -> 1 - f, an exit through the far boundary becomes one through the near
    boundary with the same depth d), and the exact estimate is symmetric under it. So the
    two runs write the same pixels with coverages that differ only by the fixed-point terms
    of the two runs -- except where the line crosses a column centre exactly on a row
    boundary (f = 0): rows are [y - 1/2, y + 1/2) in each folded frame, so the primary pixel
    is the row on the near side in each. Two-pixel modes write both rows anyway (for k > 0);
    pw writes the other one, and a k = 0 line writes an area-0 (coverage 0 or 1) pixel."""
    base = GEOMETRY_CONFIGS[config_name]
    edge = data.draw(slope_edges(base, max_pixels=32), label="edge")
    other = "right" if edge.inside == "left" else "left"
    reverse = Edge(edge.x1, edge.y1, edge.x0, edge.y0, other, edge.i_in, edge.i_out)
    for mode in MODES:
        config = base.with_(mode=mode)
        fwd, rev = run_edge(config, edge), run_edge(config, reverse)
        st_ = fwd.setup
        tolerance = 2 * fixed_point_term(config, st_, 0)
        assert len(fwd.columns) == len(rev.columns)
        on_boundary = {
            state.x if st_.x_major else state.y
            for state in fwd.trace
            if line_fraction(config, edge, fwd, state.column) == 0
        }
        cov_r = {(w.x, w.y): model_coverage(rev, w) for w in rev.writes}
        for w in fwd.writes:
            key = (w.x, w.y)
            major = w.x if st_.x_major else w.y
            if key in cov_r:
                assert abs(model_coverage(fwd, w) - cov_r.pop(key)) < tolerance, (mode, edge)
            else:
                assert major in on_boundary and (mode == "pw" or slope(st_) == 0), (mode, edge)
        for x, y in cov_r:
            assert (x if st_.x_major else y) in on_boundary, (mode, edge)


# -- seeded random edges of any length ----------------------------------------------------


RANDOM_SEEDS = [
    *(pytest.param(seed, ("tiny", "default"), id=f"seed{seed}") for seed in range(4)),
    *(
        pytest.param(seed, ("tiny", "default", "wide"), id=f"seed{seed}", marks=pytest.mark.slow)
        for seed in range(4, 44)
    ),
]


@pytest.mark.parametrize("seed, names", RANDOM_SEEDS)
def test_random_edges_of_any_length(seed, names):
    """Seeded random edges over the whole range: every column of the default and tiny
    configurations; the first and last 200 columns and the whole trace at coord_bits=15
    (slow run only)."""
    rng = random.Random(seed)
    for name in names:
        base = GEOMETRY_CONFIGS[name]
        edge = random_any_length_edge(rng, base)
        cov = ExactCache(base, edge)
        for mode in MODES:
            for accumulator in ACCUMULATORS:
                config = base.with_(mode=mode, accumulator=accumulator)
                result = run_edge(config, edge)
                columns = range(len(result.trace))
                checked = columns if name != "wide" else [*columns[:200], *columns[-200:]]
                checked = sorted(set(checked))
                bad = bound_violations(config, edge, cov, result, checked)
                if accumulator == "exact":
                    bad += estimate_violations(config, edge, result, checked)
                    if mode == "paper":
                        bad += [
                            f"column {n}: drift"
                            for n in columns
                            if not state_is_line(config, edge, result, n)
                        ]
                else:
                    bad += drift_violations(edge, config, result, checked)
                context = f"seed {seed} {name} {mode}/{accumulator} {edge}"
                assert not bad, f"{context}: {bad[:3]}"


# -- tightness ---------------------------------------------------------------------------

SWEEP_CONFIG = EdgeConfig(coord_bits=11, subpixel_bits=8)
SWEEP_PIXELS = 32  # major length of each swept edge


def sweep_edges():
    """Slopes k = i/16 and two off-grid ones; sub-pixel start offsets across the pixel in y,
    on a pixel centre and on a pixel boundary in x."""
    s = SWEEP_CONFIG.subpixel_scale
    du = SWEEP_PIXELS * s
    minors = [du * i // 16 for i in range(17)] + [du * 5 // 7 + 1, du * 13 // 17 + 3]
    for dv in minors:
        for x_offset in (0, s // 2):
            for y_offset in range(0, s, 43):
                x0, y0 = 100 * s + x_offset, 300 * s + y_offset
                yield Edge(x0, y0, x0 + du, y0 + dv, i_in=255, i_out=0)


def sweep_maxima(modes=MODES, check=True):
    """Max |coverage - exact| / k and absolute per mode over the sweep; checks the bound."""
    ratio = dict.fromkeys(modes, Fraction(0))
    absolute = dict.fromkeys(modes, Fraction(0))
    for edge in sweep_edges():
        cov = ExactCache(SWEEP_CONFIG, edge)
        for mode in modes:
            config = SWEEP_CONFIG.with_(mode=mode)
            result = run_edge(config, edge)
            if check:
                bad = bound_violations(config, edge, cov, result)
                assert not bad, f"{edge}: {bad[0]}"
            k = slope(result.setup)
            for w in result.writes:
                err = abs(model_coverage(result, w) - cov(w.x, w.y))
                absolute[mode] = max(absolute[mode], err)
                if k:
                    ratio[mode] = max(ratio[mode], err / k)
    return ratio, absolute


def test_sweep_reaches_each_bound():
    """The bounds are tight: a sweep of slopes and offsets reaches >= 90 % of k/8, k/64,
    k/256 and k/1024 (and never exceeds them beyond the fixed-point term)."""
    ratio, absolute = sweep_maxima()
    for mode in MODES:
        assert ratio[mode] >= Fraction(9, 10) * PER_K[mode], (mode, float(ratio[mode]))
        # The absolute worst case is at 45 degrees: 1/8, 1/64, 1/256, 1/1024.
        assert absolute[mode] >= Fraction(9, 10) * PER_K[mode], (mode, float(absolute[mode]))


def test_paper_figure_for_formula_1():
    """Formula (1) alone (pw) errs by up to k/8: 1/16 = 0.0625 at k = 1/2 (the paper's 0.062
    matches this, or the mean of k/8 over k uniform in [0, 1]), 0.125 at 45 degrees."""
    config = SWEEP_CONFIG.with_(mode="pw")
    s = config.subpixel_scale
    worst = {}
    for dv_over_du in (Fraction(1, 2), Fraction(1)):
        worst[dv_over_du] = Fraction(0)
        for offset in range(0, s, 16):
            du = 16 * s
            edge = Edge(s, s + offset, s + du, s + offset + int(du * dv_over_du))
            cov = ExactCache(config, edge)
            result = run_edge(config, edge)
            for w in result.writes:
                err = abs(model_coverage(result, w) - cov(w.x, w.y))
                worst[dv_over_du] = max(worst[dv_over_du], err)
    assert worst[Fraction(1, 2)] == Fraction(1, 16)
    assert worst[Fraction(1)] == Fraction(1, 8)


# -- mutations: the checks can fail ----------------------------------------------------------

MUTATION_EDGES = [Edge(0, 3, 40 * 256, 3 + 33 * 256), Edge(50, 7000, 9000, 100, inside="right")]


def zero_intercepts(monkeypatch):
    """setup() with the estimate's intercepts dropped: t = d/4 instead of d/4 - k/64."""
    original = step_module.setup

    def mutated(config, edge):
        st_ = original(config, edge)
        return dataclasses.replace(st_, seg_intercepts=tuple(0 for _ in st_.seg_intercepts))

    monkeypatch.setattr(step_module, "setup", mutated)


def single_slope(monkeypatch):
    """triangle_estimate with slope 1/4 on every segment and no intercept."""

    def mutated(a, config, st_, dq, where=True):
        return a.check("t", dq >> 2, where)

    monkeypatch.setattr(column_module, "triangle_estimate", mutated)


def no_bottom_exit(monkeypatch):
    """The neighbour below is never written (one pixel per column when entering from below)."""
    monkeypatch.setattr(column_module, "exit_depths", never_below(column_module.exit_depths))


def never_below(exit_depths):
    """`exit_depths` with the test "the edge enters from the row below" always false."""

    def mutated(a, st_, jq, jr):
        depths = exit_depths(a, st_, jq, jr)
        return {**depths, "below": depths["below"] & False}

    return mutated


@pytest.mark.parametrize(
    "mutation, modes",
    [
        (zero_intercepts, ("paper", "seg2", "seg4")),
        (single_slope, ("seg2", "seg4")),
    ],
)
def test_bound_check_catches_a_wrong_estimate(monkeypatch, mutation, modes):
    mutation(monkeypatch)
    config = SWEEP_CONFIG
    for mode in modes:
        caught = []
        for edge in MUTATION_EDGES:
            cov = ExactCache(config, edge)
            caught += bound_violations(config.with_(mode=mode), edge, cov)
        assert caught, f"{mutation.__name__} in {mode} passed the bound check"


def test_completeness_check_catches_a_missing_neighbour(monkeypatch):
    no_bottom_exit(monkeypatch)
    for edge in MUTATION_EDGES:
        cov = ExactCache(SWEEP_CONFIG, edge)
        config = SWEEP_CONFIG.with_(mode="paper")
        assert completeness_violations(config, edge, cov), edge


# -- stability: the longest edges ---------------------------------------------------------

LONG_CONFIG = EdgeConfig(coord_bits=15, subpixel_bits=8)
BLOCK = 400  # columns checked exactly at each end of a long edge


def long_edges(config: EdgeConfig):
    """Full-span edges at slopes 1/L and (L-1)/L, sub-pixel offsets 0 and the largest."""
    s = config.subpixel_scale
    span = (1 << config.coord_bits) - 1  # L pixels: from pixel 0 to pixel 2**W - 1
    for offset in (0, s - 1):
        for dv in (s, span * s - s):
            yield Edge(offset, offset, offset + span * s, offset + dv, i_in=None, i_out=0)


def edge_id(edge: Edge) -> str:
    return f"{edge.x0},{edge.y0}-{edge.x1},{edge.y1}"


def ends(result: EdgeResult, block: int = BLOCK):
    columns = len(result.trace)
    return range(block), range(columns - block, columns)


def block_errors(config, edge, cov, result, columns):
    """Max |coverage - exact| over the writes of some columns, and any bound violations."""
    worst = max(
        abs(model_coverage(result, w) - cov(w.x, w.y)) for n in columns for w in result.columns[n]
    )
    return worst, bound_violations(config, edge, cov, result, columns)


LONGEST_CONFIG = EdgeConfig(coord_bits=16, subpixel_bits=8)
LONG_CASES = [
    *(
        pytest.param(LONG_CONFIG, edge, modes, id=f"{edge_id(edge)}-{'+'.join(modes)}", marks=m)
        for edge in long_edges(LONG_CONFIG)
        for modes, m in ((("paper",), ()), (("pw", "seg2", "seg4"), pytest.mark.slow))
    ),
    *(
        pytest.param(LONGEST_CONFIG, edge, MODES, id=f"W16-{edge_id(edge)}", marks=pytest.mark.slow)
        for edge in long_edges(LONGEST_CONFIG)
    ),
]


@pytest.mark.parametrize("long_config, edge, modes", LONG_CASES)
def test_long_edges_exact_accumulator_has_no_drift(long_config, edge, modes):
    """At the largest coordinates the exact accumulator's state is the line's exact position
    in every column (zero drift), and the last columns are within the same column-independent
    bound as the first. (The loop state is the same in every mode; the other modes' writes
    are checked in the slow run.)"""
    cov = ExactCache(long_config, edge)
    for mode in modes:
        config = long_config.with_(mode=mode)
        result = run_edge(config, edge)
        st_ = result.setup
        assert len(result.trace) == 1 << config.coord_bits
        if mode == modes[0]:
            for state in result.trace:
                assert state_is_line(config, edge, result, state.column), (edge, state)
        first, last = ends(result)
        limit = bound(config, st_) + fixed_point_term(config, st_, 0)
        worst = {}
        for name, columns in (("first", first), ("last", last)):
            worst[name], bad = block_errors(config, edge, cov, result, columns)
            assert not bad, f"{edge}: {bad[0]}"
            bad = estimate_violations(config, edge, result, columns)
            assert not bad, f"{edge}: {bad[:3]}"
        assert worst["last"] <= limit and worst["first"] <= limit, (mode, edge, worst)


TRUNCATED = LONG_CONFIG.with_(accumulator="truncated")


@pytest.mark.parametrize("edge", list(long_edges(TRUNCATED)), ids=edge_id)
def test_long_edges_truncated_accumulator_at_derived_frac_bits(edge):
    """With the derived F the truncated drift over the longest edge stays within the budget
    of EdgeConfig.derived_frac_bits -- max_columns * 2**-F <= 2**-(I+1) LSB, so at |I_d| = 1
    (where the drift weighs most) the coverage is off by at most 2**-(I+1), half an output
    LSB at full scale -- and the bound holds with it."""
    edge = dataclasses.replace(edge, i_in=1, i_out=0)
    config = TRUNCATED.with_(mode="seg4")
    cov = ExactCache(config, edge)
    result = run_edge(config, edge)
    st_ = result.setup
    first, last = ends(result)
    assert not drift_violations(edge, config, result, [*first, *last])
    end = result.trace[-1]
    drift = line_fraction(config, edge, result, end.column) * st_.ifix - end.jq
    assert drift <= 1 << (config.F - config.intensity_bits - 1), float(drift)
    for columns in (first, last):
        _, bad = block_errors(config, edge, cov, result, columns)
        assert not bad, f"{edge}: {bad[0]}"


@pytest.mark.parametrize("edge", list(long_edges(TRUNCATED)), ids=edge_id)
def test_long_edges_truncated_accumulator_with_too_few_bits_breaks(edge):
    """With F = subpixel_bits + 1 the truncated slope drifts visibly on a long edge: the
    output is off by more than the bound, the exact accumulator's fixed-point term and half
    an LSB together, while the same F with the exact accumulator still holds.

    The intensity difference is chosen so that K = |I_d| k 2**F loses much per column: at
    k = 1/L, |I_d| = 255 gives K = 3.98 (kq = 3, a quarter pixel lost over the edge; with
    |I_d| = 1, kq = 0 loses a whole row but the error, 1/2, hides below half an LSB); at
    k = (L-1)/L, |I_d| = 1 gives K = 511.98 (kq = 511, 63 rows lost; at 255 only 0.016 a
    column is lost).
    """
    shallow = abs(edge.y1 - edge.y0) < abs(edge.x1 - edge.x0) // 2
    edge = dataclasses.replace(edge, i_in=255 if shallow else 1, i_out=0)
    half_lsb = Fraction(1, 2 * edge.i_in)
    few = TRUNCATED.subpixel_bits + 1
    config = TRUNCATED.with_(mode="paper", frac_bits=few)
    assert config.F == few < TRUNCATED.F
    cov = ExactCache(config, edge)
    result = run_edge(config, edge)
    st_ = result.setup
    first, last = ends(result)
    budget = bound(config, st_) + FIXED_POINT_UNITS["paper"] / st_.ifix + half_lsb
    for columns in (first, last):
        # The truncated term of fixed_point_term (one unit per column) still bounds it...
        _, bad = block_errors(config, edge, cov, result, columns)
        assert not bad, f"{edge}: {bad[0]}"
    # ... but that term is now visible: beyond the drift-free budget, even after rounding.
    worst_last, _ = block_errors(config, edge, cov, result, last)
    assert worst_last > budget, (edge, float(worst_last), float(budget))
    assert (
        max(
            abs(output_coverage(config, edge, w) - cov(w.x, w.y))
            for n in last
            for w in result.columns[n]
        )
        > budget
    )
    exact_acc = config.with_(accumulator="exact")
    for columns in (first, last):
        _, bad = block_errors(exact_acc, edge, cov, run_edge(exact_acc, edge), columns)
        assert not bad, f"{edge}: {bad[0]}"


# -- named cases -----------------------------------------------------------------------------


def check_every_way(base: EdgeConfig, edge: Edge) -> dict[tuple[str, str], EdgeResult]:
    """All modes and accumulators: bounds; completeness and the exact estimate (exact acc.)."""
    cov = ExactCache(base, edge)
    results = {}
    for mode in MODES:
        for accumulator in ACCUMULATORS:
            config = base.with_(mode=mode, accumulator=accumulator)
            result = run_edge(config, edge)
            bad = bound_violations(config, edge, cov, result)
            if accumulator == "exact":
                bad += completeness_violations(config, edge, cov, result)
                bad += estimate_violations(config, edge, result)
            assert not bad, f"{edge} {mode}/{accumulator}: {bad[:3]}"
            results[mode, accumulator] = result
    return results


DEFAULT = GEOMETRY_CONFIGS["default"]


def px(config: EdgeConfig, *coords, **kwargs) -> Edge:
    return Edge.from_pixels(config, *coords, **kwargs)


@pytest.mark.parametrize("level", ["5", "5.5", "5.25", "4.9375"])
@pytest.mark.parametrize("direction", [1, -1])
@pytest.mark.parametrize("transpose", [False, True], ids=["horizontal", "vertical"])
@pytest.mark.parametrize("inside", ["left", "right"])
def test_axis_aligned_edges_are_exact(level, direction, transpose, inside):
    """k = 0: one write per column, coverage equal to the exact area (the bound is 0 and the
    area |I_d| f 2**F is an integer); on a pixel boundary (5.5) the primary pixel is the row
    above/left of the line with area 0 -- the documented exception of test_completeness."""
    a, b = ("2.25", "9.75") if direction == 1 else ("9.75", "2.25")
    coords = (level, a, level, b) if transpose else (a, level, b, level)
    edge = px(DEFAULT, *coords, inside=inside, i_in=200, i_out=17)
    cov = ExactCache(DEFAULT, edge)
    for (mode, accumulator), result in check_every_way(DEFAULT, edge).items():
        assert all(len(column) == 1 for column in result.columns), (mode, accumulator)
        for w in result.writes:
            assert model_coverage(result, w) == cov(w.x, w.y), (mode, accumulator, w)


DIAGONALS = [(1, 1), (1, -1), (-1, 1), (-1, -1)]


@pytest.mark.parametrize("sx, sy", DIAGONALS)
def test_diagonals_through_pixel_centres(sx, sy):
    """45 degrees through pixel centres: the line passes through corners of the neighbours
    only, so every mode writes exactly one pixel per column, with coverage 1/2."""
    x0, y0 = 10, 10
    edge = px(DEFAULT, x0, y0, x0 + 8 * sx, y0 + 8 * sy)
    for (mode, accumulator), result in check_every_way(DEFAULT, edge).items():
        assert all(len(column) == 1 for column in result.columns), (mode, accumulator)
        assert {model_coverage(result, w) for w in result.writes} == {HALF}


@pytest.mark.parametrize("sx, sy", DIAGONALS)
def test_diagonals_through_pixel_corners_reach_the_bound(sx, sy):
    """45 degrees through pixel corners: the cut-off triangles are the largest, d = k/2, where
    every estimate errs by exactly its bound: pw k/8 (the triangle is not written), paper
    1/8 - (1/8 - 1/64), seg2 1/8 - 31/256, seg4 1/8 - 127/1024."""
    x0, y0 = 10, Fraction(21, 2)
    edge = px(DEFAULT, x0, y0, x0 + 8 * sx, y0 + 8 * sy)
    cov = ExactCache(DEFAULT, edge)
    for (mode, accumulator), result in check_every_way(DEFAULT, edge).items():
        config = DEFAULT.with_(mode=mode, accumulator=accumulator)
        st_ = result.setup
        worst = max(abs(model_coverage(result, w) - cov(w.x, w.y)) for w in result.writes)
        assert abs(worst - PER_K[mode]) <= fixed_point_term(config, st_, len(result.trace))
        assert all(len(column) == (1 if mode == "pw" else 2) for column in result.columns)


@pytest.mark.parametrize(
    "coords",
    [
        ("5.25", "3", "5.4375", "3.125"),  # x-major, inside column 5
        ("5.4375", "3.125", "5.25", "3"),
        ("7", "4.5625", "7.0625", "4.9375"),  # y-major, inside row 5
        ("4.5", "2", "5.4375", "2.9375"),  # from a column boundary: column 5 only
        ("3.5625", "1", "4.5", "1.5"),  # to a column boundary: column 4 only
    ],
)
def test_single_column_edges(coords):
    edge = px(DEFAULT, *coords, i_in=3, i_out=250)
    for result in check_every_way(DEFAULT, edge).values():
        assert len(result.trace) == 1


@pytest.mark.parametrize("dx, dy", [(1, 0), (0, 1), (1, 1), (1, -1), (-1, 0), (0, -1), (-1, 1)])
@pytest.mark.parametrize("start", [(72, 40), (71, 39), (64, 64)])
def test_one_subpixel_long_edges(dx, dy, start):
    """The shortest edges, from pixel centres (64), boundaries (72 = 4.5 px) and in between:
    one column, judged against the supporting line like any other."""
    x0, y0 = start
    edge = Edge(x0, y0, x0 + dx, y0 + dy, inside="right")
    for result in check_every_way(DEFAULT, edge).values():
        assert len(result.trace) == 1


def border_edges(config: EdgeConfig):
    """Edges from coordinate 0 and from the largest coordinate, along and across the borders
    (at most 24 px long), and the full-range diagonals of the tiny configuration."""
    hi = config.max_vertex
    r = min(hi, 24 * config.subpixel_scale)
    coords = [
        (0, 0, r, 0),  # along the top border
        (0, r, 0, 0),  # along the left border, upwards
        (hi, hi, hi - r, hi),  # along the bottom border at the largest coordinate
        (hi, hi - r, hi, hi),  # along the right border
        (0, 0, r, r),  # out of the origin corner
        (hi, hi, hi - r, hi - r // 3),  # out of the far corner
        (0, hi, r // 2, hi - r),
        (hi, 0, hi - r, r // 5),
    ]
    if config.coord_bits <= 5:
        coords += [(0, 0, hi, hi), (0, hi, hi, 0), (hi, hi, 0, hi // 3)]
    return coords


@pytest.mark.parametrize(
    "config, coords",
    [
        pytest.param(GEOMETRY_CONFIGS[name], c, id=f"{name}-{'-'.join(map(str, c))}")
        for name in ("tiny", "default")
        for c in border_edges(GEOMETRY_CONFIGS[name])
    ],
)
def test_edges_at_the_coordinate_limits(config, coords):
    """Edges at coordinate 0 and at the largest coordinate: the neighbour rows outside the
    range (-1 and 2**W) are written and judged like any other; the columns stepped are those
    whose interior the edge's projection overlaps (the endpoint rule)."""
    for inside in ("left", "right"):
        edge = Edge(*coords, inside=inside, i_in=1, i_out=config.full_scale)
        result = check_every_way(config, edge)["paper", "exact"]
        columns = columns_overlapped(config, edge)
        assert len(columns) <= config.max_columns
        major = [state.x if result.setup.x_major else state.y for state in result.trace]
        assert major == columns


def test_inside_darker_than_outside():
    """I_in < I_out: the value goes from I_out towards I_in with the coverage. A horizontal
    edge at y = 5.25 going right, inside left (up): row 5 is 3/4 inside, I = 200 - 3/4 * 190
    = 57.5, which rounds to 57 or 58."""
    edge = px(DEFAULT, "1", "5.25", "9", "5.25", inside="left", i_in=10, i_out=200)
    for result in check_every_way(DEFAULT, edge).values():
        values = {(w.x, w.y): w.value for w in result.writes}
        assert set(values) == {(x, 5) for x in range(1, 10)}
        assert all(abs(v - Fraction(115, 2)) <= HALF for v in values.values())
