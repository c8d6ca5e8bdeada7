"""The vectorized model gives the step model's writes, bit for bit and in the same order."""

from __future__ import annotations

import random

import numpy as np
import pytest
from fixtures import VECTOR_CONFIG_FIELDS, random_span_edge, span_edges, vector_config
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from edgeaa.model.config import ACCUMULATORS, MODES, EdgeConfig, RegisterWidth
from edgeaa.model.edge import Edge, EdgeError, setup
from edgeaa.model.step import WidthError, run_edge
from edgeaa.model.vector import WriteBatch, _fits_int64, run_edge_vector, run_edges

COMBOS = [(mode, acc) for mode in MODES for acc in ACCUMULATORS]


HYPOTHESIS = settings(
    max_examples=150,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


def step_batch(config: EdgeConfig, edges: list[Edge]):
    """The step model's writes of a batch as rows (edge, x, y, value, area) and coverages."""
    rows, coverages = [], []
    for k, edge in enumerate(edges):
        result = run_edge(config, edge)
        rows += [(k, w.x, w.y, w.value, w.area) for w in result.writes]
        coverages += [result.coverage(w) for w in result.writes]
    return rows, coverages


def batch_rows(batch: WriteBatch):
    for name in ("edge_index", "x", "y", "value"):
        assert getattr(batch, name).dtype == np.int64, name
    return list(
        zip(
            batch.edge_index.tolist(),
            batch.x.tolist(),
            batch.y.tolist(),
            batch.value.tolist(),
            batch.area.tolist(),
            strict=True,
        )
    )


def assert_identical(config: EdgeConfig, edges: list[Edge], context: str = ""):
    """Compare the vectorized batch with the step model; return the batch and the step rows."""
    expected, coverages = step_batch(config, edges)
    batch = run_edges(config, edges)
    got = batch_rows(batch)
    if got != expected:
        first = next(
            (n for n, (a, b) in enumerate(zip(got, expected, strict=False)) if a != b),
            min(len(got), len(expected)),
        )
        k = (got + expected)[first][0] if first < max(len(got), len(expected)) else None
        raise AssertionError(
            f"{context} {config}: writes differ at row {first} (edge {k}: "
            f"{edges[k] if k is not None else None}); {len(got)} vs {len(expected)} writes; "
            f"vector {got[first : first + 2]} step {expected[first : first + 2]}"
        )
    assert batch.coverage().tolist() == coverages, f"{context} {config}: coverage differs"
    area_bits = config.register_widths()["area"].bits
    assert batch.area.dtype == (np.int64 if area_bits <= 63 else object)
    return batch, expected


# -- edge generation ---------------------------------------------------------------------------


# -- hypothesis: single edges and batches, every config x mode x accumulator ------------------


@pytest.mark.parametrize("name", list(VECTOR_CONFIG_FIELDS))
@HYPOTHESIS
@given(data=st.data())
def test_batches_identical(name, data):
    """Every mode and both accumulators on the same drawn batch (1 to 4 edges)."""
    mode = data.draw(st.sampled_from(MODES), label="mode")
    base = vector_config(name, mode)
    batch = data.draw(st.lists(span_edges(base), min_size=1, max_size=4), label="edges")
    for accumulator in ACCUMULATORS:
        config = vector_config(name, mode, accumulator)
        assert_identical(config, batch, "batch")


@HYPOTHESIS
@given(data=st.data())
def test_object_fallback_matches_int64(data):
    """The Python-int path gives the int64 path's writes (longer edges: no step model here)."""
    mode = data.draw(st.sampled_from(MODES), label="mode")
    config = vector_config("default", mode)
    batch = data.draw(st.lists(span_edges(config, span_px=2048), min_size=1, max_size=3))
    for accumulator in ACCUMULATORS:
        config = vector_config("default", mode, accumulator)
        fast, slow = run_edges(config, batch), run_edges(config, batch, force_object=True)
        assert batch_rows(fast) == batch_rows(slow)
        assert fast.coverage().tolist() == slow.coverage().tolist()


# -- the corner corpus -------------------------------------------------------------------------


def corner_geometries(config: EdgeConfig) -> dict[str, tuple[int, int, int, int]]:
    hi, scale = config.max_vertex, config.subpixel_scale
    c = hi // 2
    n = max(1, min(hi // 4, 5 * scale + scale // 3))  # a few pixels, off the pixel grid
    geometries = {
        "horizontal_right": (c - n, c, c + n, c),
        "horizontal_left": (c + n, c + 1, c - n, c + 1),
        "vertical_down": (c, c - n, c, c + n),
        "vertical_up": (c + 1, c + n, c + 1, c - n),
        "diag45_se": (c, c, c + n, c + n),
        "diag45_sw": (c, c, c - n, c + n),
        "diag45_nw": (c, c, c - n, c - n),
        "diag45_ne": (c, c, c + n, c - n),
        "longest_diag": (0, 0, hi, hi),
        "longest_bottom_leftward": (hi, hi, 0, hi),
        "longest_shallow_to_corner": (0, hi - hi // 3, hi, hi),
        "longest_steep_up": (hi, hi, hi - hi // 5, 0),
        "corner_tiny": (hi - 1, hi, hi, hi - 1),
        "origin_tiny": (0, 1, 1, 0),
    }
    # All 8 octants, with an odd minor delta so the slope is off the grid.
    for octant, (sx, sy, swap) in enumerate(
        [(1, 1, 0), (1, 1, 1), (-1, 1, 1), (-1, 1, 0), (-1, -1, 0), (-1, -1, 1), (1, -1, 1)]
        + [(1, -1, 0)]
    ):
        major, minor = 2 * n + 1, n | 1
        dx, dy = (minor, major) if swap else (major, minor)
        geometries[f"octant{octant}"] = (c, c, c + sx * dx, c + sy * dy)
    if scale > 1:  # a single column (impossible without sub-pixels: du >= 1 pixel spans 2)
        p = c - c % scale  # a pixel centre: its column spans p -+ scale / 2
        geometries["single_column_shallow"] = (p - 1, c, p + 1, c + 1)
        geometries["single_column_steep"] = (c, p - 1, c + 1, p + 1)
        geometries["single_column_vertical"] = (c, p, c, p + 1)
    return geometries


def corner_corpus(config: EdgeConfig) -> list[tuple[str, Edge]]:
    fs = config.full_scale
    long_wide = (config.mode, config.accumulator) in (("seg4", "exact"), ("paper", "truncated"))
    long_overrides = ("longest_diag", "longest_shallow_to_corner")
    variants = [
        ("left_full", "left", None, 0),
        ("right_full", "right", None, 0),
        ("left_in_below_out", "left", 0, fs),
        ("right_in_below_out", "right", 1, fs - 1),
        ("right_small_diff", "right", fs // 2, fs // 2 + 1),
    ]
    corpus = []
    for g, (name, coords) in enumerate(corner_geometries(config).items()):
        if name.startswith("longest"):
            # full-length edges are slow in the step model: one variant each, rotating
            chosen = [variants[g % len(variants)]]
            if config.coord_bits > 12 and (name != "longest_diag" or not long_wide):
                continue  # 2**15 columns: the longest diagonal only, in two combos
            if config.frac_bits is not None and name not in long_overrides:
                continue  # frac_bits overrides: two of the four
        else:
            chosen = variants
        for vname, inside, i_in, i_out in chosen:
            corpus.append((f"{name}/{vname}", Edge(*coords, inside, i_in, i_out)))
    return corpus


@pytest.mark.parametrize("mode, accumulator", COMBOS)
@pytest.mark.parametrize("name", list(VECTOR_CONFIG_FIELDS))
def test_corner_corpus(name, mode, accumulator):
    config = vector_config(name, mode, accumulator)
    corpus = corner_corpus(config)
    names = [n for n, _ in corpus]
    batch, expected = assert_identical(config, [e for _, e in corpus], "corner corpus")
    for k, (label, _edge) in enumerate(corpus):
        st_ = batch.setups[k]
        if label.startswith("single_column"):
            assert st_.columns == 1, label
        if label.startswith("longest_diag"):  # column 2**W is reachable with sub-pixels only
            assert st_.columns == config.max_columns - (config.subpixel_bits == 0), label
        assert [tuple(w) for w in batch.writes(k)] == [r[1:] for r in expected if r[0] == k]
    assert len(set(names)) == len(names)


def test_corner_corpus_covers_what_it_names():
    config = vector_config("default")
    for _name, edge in corner_corpus(config):
        setup(config, edge)  # all valid
    kinds = {n.split("/")[0] for n, _ in corner_corpus(config)}
    assert {f"octant{o}" for o in range(8)} <= kinds
    assert {"single_column_shallow", "single_column_steep", "longest_diag"} <= kinds
    assert {f"diag45_{d}" for d in ("ne", "nw", "se", "sw")} <= kinds
    wide = [vector_config("wide", m, a) for m, a in COMBOS]
    assert sum("longest_diag/" in n for c in wide for n, _ in corner_corpus(c)) == 2
    octants = set()
    for o in range(8):
        st_ = setup(config, Edge(*corner_geometries(config)[f"octant{o}"]))
        octants.add((st_.x_major, st_.col_dx + st_.col_dy, st_.row_dx + st_.row_dy))
    assert len(octants) == 8


# -- seeded mixed batches, overflow fallback ---------------------------------------------------


@pytest.mark.parametrize("mode, accumulator", COMBOS)
def test_seeded_mixed_batch(mode, accumulator):
    seed = 20240 + COMBOS.index((mode, accumulator))
    rng = random.Random(seed)
    config = vector_config("default", mode, accumulator)
    batch = [random_span_edge(rng, config, rng.choice([2, 16, 128, None])) for _ in range(40)]
    _, expected = assert_identical(config, batch, f"seed {seed}:")
    for k in range(0, len(batch), 7):  # single edges through the one-edge entry point
        alone = [(0, *row[1:]) for row in expected if row[0] == k]
        assert batch_rows(run_edge_vector(config, batch[k])) == alone, f"seed {seed}: edge {k}"


@pytest.mark.parametrize("mode", MODES)
def test_int64_overflow_fallback(mode):
    """coord_bits 16 and intensity_bits 16 at F = 34 (the truncated accumulator's derived F
    there): long steep edges need U beyond 2**63."""
    config = EdgeConfig(coord_bits=16, intensity_bits=16, mode=mode, frac_bits=34)
    hi = config.max_vertex
    seed = 7 + MODES.index(mode)
    rng = random.Random(seed)
    batch = [
        random_span_edge(rng, config, 8),
        Edge(0, 0, 5000 * 16, 5000 * 16 - 3, "left", None, 0),  # ~5000 rows of 2**50
        random_span_edge(rng, config, 8),
        Edge(hi, 0, hi - 4500 * 16 - 5, 4500 * 16, "right", 0, config.full_scale),
        random_span_edge(rng, config, 8),
    ]
    fits = [_fits_int64(setup(config, e)) for e in batch]
    assert fits == [True, False, True, False, True], f"seed {seed}: {fits}"
    assert_identical(config, batch, f"seed {seed}:")


def test_empty_batch():
    batch = run_edges(EdgeConfig(), [])
    assert len(batch) == 0 and batch.x.dtype == np.int64 and batch.coverage().shape == (0,)


# -- errors ------------------------------------------------------------------------------------


@st.composite
def maybe_invalid_edges(draw, config: EdgeConfig):
    hi, fs = config.max_vertex, config.full_scale
    # near either end of the range: short edges keep the step model fast
    coord = st.integers(-2, 40) | st.integers(hi - 40, hi + 2) | st.sampled_from([0.5, True, "3"])
    return Edge(
        draw(coord),
        draw(coord),
        draw(coord),
        draw(coord),
        draw(st.sampled_from(["left", "right", "up"])),
        draw(st.none() | st.integers(-1, fs + 1)),
        draw(st.integers(-1, fs + 1)),
    )


def _outcome(fn):
    try:
        fn()
    except (EdgeError, WidthError) as error:
        return type(error).__name__, str(error)
    return None


@HYPOTHESIS
@given(data=st.data())
def test_invalid_edges_raise_the_same_error(data):
    config = vector_config(data.draw(st.sampled_from(["default", "tiny"])))
    edge = data.draw(maybe_invalid_edges(config))
    step = _outcome(lambda: run_edge(config, edge))
    vector = _outcome(lambda: run_edges(config, [edge]))
    assert step == vector
    if step is not None:  # in a batch, after a valid edge
        valid = Edge(0, 0, 3, 1)
        assert _outcome(lambda: run_edges(config, [valid, edge])) == step


WIDTH_REGISTERS = [
    "x",
    "y",
    "remaining",
    "du",
    "ifix",
    "jq",
    "jr",
    "kq",
    "kr",
    "khq",
    "khr",
    "jsum",
    "dq",
    "dr",
    "t",
    "area",
    "seg_const",
    "value",
]


# Bits to take off each register so that the narrowed width fails on some tiny-config edge
# (the declared widths keep a bit or more of margin on area, dq, t, khq and seg_const; the
# remainders are below du <= 15 in the tiny config).
NARROW_BY = dict(area=2, dq=2, t=4, khq=2, seg_const=2, remaining=2, jr=2, kr=2, khr=2, dr=2)
WIDTH_COMBOS = [("pw", "exact"), ("paper", "truncated"), ("seg2", "exact"), ("seg4", "exact")]


@pytest.mark.parametrize("register", WIDTH_REGISTERS)
def test_width_checks_agree(monkeypatch, register):
    """With one register narrowed, both models raise WidthError on exactly the same edges."""
    original = EdgeConfig.register_widths
    drop = NARROW_BY.get(register, 1)

    def narrowed(self):
        widths = original(self)
        width = widths[register]
        widths[register] = RegisterWidth(width.bits - drop, width.signed)
        return widths

    seed = 99 + WIDTH_REGISTERS.index(register)
    rng = random.Random(seed)
    outcomes = []
    for mode, accumulator in WIDTH_COMBOS:
        config = vector_config("tiny", mode, accumulator)
        batch = [e for n, e in corner_corpus(config) if n.endswith(("left_full", "in_below_out"))]
        batch += [random_span_edge(rng, config) for _ in range(10)]
        monkeypatch.setattr(EdgeConfig, "register_widths", narrowed)
        for edge in batch:
            step = _outcome(lambda e=edge, c=config: run_edge(c, e))
            vector = _outcome(lambda e=edge, c=config: run_edges(c, [e]))
            step_kind = step and step[0]
            vector_kind = vector and vector[0]
            assert step_kind == vector_kind, f"seed {seed}: {register} {config} {edge}"
            outcomes.append(step_kind)
        monkeypatch.setattr(EdgeConfig, "register_widths", original)
    assert "WidthError" in outcomes, f"seed {seed}: narrowing {register} never failed"
    assert None in outcomes or register in ("du", "ifix", "x", "y"), f"seed {seed}: {register}"
