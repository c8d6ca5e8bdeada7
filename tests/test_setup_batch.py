"""`edge.setup_batch` (numpy, many edges at once) equals `edge.setup` field by field, and
`vector.run_deltas_arrays` gives `vector.run_edges_deltas`'s deltas; bad edges raise the same
EdgeError as `validate`, naming the first bad edge."""

from __future__ import annotations

import itertools
import random
from dataclasses import fields, replace

import numpy as np
import pytest
from fixtures import (
    edge_configs,
    random_any_length_edge,
    random_edge_commands,
    random_span_edge,
    window_near,
)
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from edgeaa.model.config import ACCUMULATORS, MODES, EdgeConfig
from edgeaa.model.edge import (
    Clip,
    Edge,
    EdgeError,
    EdgeSetup,
    SetupBatch,
    setup,
    setup_batch,
    setup_int64_bits,
    validate,
)
from edgeaa.model.vector import run_deltas_arrays, run_edges_deltas, run_setup_deltas

HYPOTHESIS = settings(
    max_examples=120,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
SUBPIXEL_BITS = (0, 2, 4, 8)
INTENSITY_BITS = (1, 8, 16)


def arrays(config: EdgeConfig, edges: list[Edge]) -> dict:
    """setup_batch's arguments for `edges` (clip as four arrays; None is the full window)."""

    def column(name):
        return np.array([getattr(e, name) for e in edges], dtype=np.int64)

    windows = [e.window(config) for e in edges]
    return dict(
        x0=column("x0"),
        y0=column("y0"),
        x1=column("x1"),
        y1=column("y1"),
        inside_left=np.array([e.inside == "left" for e in edges], dtype=bool),
        i_in=np.array([e.intensities(config)[0] for e in edges], dtype=np.int64),
        i_out=column("i_out"),
        clip=tuple(np.array([w[m] for w in windows], dtype=np.int64) for m in range(4)),
    )


def typed(value):
    """A setup value with the type of every scalar in it (True and 1 differ)."""
    if isinstance(value, tuple):
        return tuple(typed(v) for v in value)
    if hasattr(value, "__dataclass_fields__"):
        return tuple((f.name, typed(getattr(value, f.name))) for f in fields(value))
    return type(value).__name__, value


def assert_batch_equals_setup(config: EdgeConfig, edges: list[Edge], context: str = ""):
    """setup_batch, on the int64 path (when it fits) and on Python ints, equals setup."""
    expected = [typed(setup(config, e)) for e in edges]
    for force_object in (False, True):
        batch = setup_batch(config, **arrays(config, edges), force_object=force_object)
        assert len(batch) == len(edges)
        for k, edge in enumerate(edges):
            got = typed(batch[k])
            assert got == expected[k], (
                f"{context} {config} force_object={force_object} edge {k} {edge}:\n"
                f"{[(a, b) for a, b in zip(got, expected[k], strict=True) if a != b]}"
            )
    return batch


def random_config(rng: random.Random, **fixed) -> EdgeConfig:
    values = dict(
        coord_bits=rng.randint(2, 16),
        subpixel_bits=rng.choice(SUBPIXEL_BITS),
        intensity_bits=rng.choice(INTENSITY_BITS),
        mode=rng.choice(MODES),
        accumulator=rng.choice(ACCUMULATORS),
    )
    values.update(fixed)
    return EdgeConfig(**values)


def random_edges(rng: random.Random, config: EdgeConfig, count: int) -> list[Edge]:
    """Short, long and any-length edges, most with a clip window near them (often one that
    cuts the start or the end, or empties the edge)."""
    edges = []
    for _ in range(count):
        kind = rng.random()
        if kind < 0.4:
            edge = random_span_edge(rng, config, rng.choice([1, 3, 40]))
        elif kind < 0.7:
            edge = random_span_edge(rng, config)
        else:
            edge = random_any_length_edge(rng, config)
        edges.append(replace(edge, clip=window_near(config, edge, rng.randint)))
    return edges


def test_the_batch_has_the_fields_of_edge_setup():
    assert [f.name for f in fields(SetupBatch)] == [f.name for f in fields(EdgeSetup)]


@pytest.mark.parametrize(
    "mode, subpixel_bits, intensity_bits, accumulator",
    list(itertools.product(MODES, SUBPIXEL_BITS, INTENSITY_BITS, ACCUMULATORS)),
)
def test_setup_batch_equals_setup_seeded(mode, subpixel_bits, intensity_bits, accumulator):
    seed = MODES.index(mode) * 1000 + subpixel_bits * 100 + intensity_bits * 2
    seed += ACCUMULATORS.index(accumulator)
    rng = random.Random(seed)
    for coord_bits in (2, rng.randint(3, 15), 16):
        config = EdgeConfig(
            coord_bits=coord_bits,
            subpixel_bits=subpixel_bits,
            intensity_bits=intensity_bits,
            mode=mode,
            accumulator=accumulator,
        )
        assert_batch_equals_setup(config, random_edges(rng, config, 60), f"seed {seed}:")


def configs():
    """`edge_configs` at the sub-pixel and intensity widths these tests sample."""
    return edge_configs(st.sampled_from(SUBPIXEL_BITS), st.sampled_from(INTENSITY_BITS))


@HYPOTHESIS
@given(data=st.data())
def test_setup_batch_equals_setup(data):
    config = data.draw(configs())
    rng = random.Random(data.draw(st.integers(0, 2**32)))
    assert_batch_equals_setup(config, random_edges(rng, config, data.draw(st.integers(1, 12))))


def test_setup_batch_at_the_int64_limit():
    """With frac_bits chosen so that `setup_int64_bits` is exactly 63, the int64 path gives
    setup's values on the extreme edges (corners, full intensity, start-cutting windows)."""
    for W, s, intensity_bits, mode in itertools.product(
        (2, 11, 16), (0, 4, 8), (1, 16), ("pw", "seg4")
    ):
        base = EdgeConfig(coord_bits=W, subpixel_bits=s, intensity_bits=intensity_bits, mode=mode)
        F = 62 - base.full_scale.bit_length() - max(W + s, W + 3, 2 * s + 2, s + 3, 7)
        if not base.min_frac_bits <= F <= 48:
            continue
        config = base.with_(frac_bits=F)
        assert setup_int64_bits(config, config.full_scale) == 63
        hi, top, fs = config.max_vertex, 1 << W, config.full_scale
        corners = [(0, 0), (hi, hi), (0, hi), (hi, 0), (1, 0), (hi, hi - 1), (hi // 2, 0)]
        points = list(dict.fromkeys(corners))  # distinct: no zero-length edge
        clips = [
            Clip(0, 0, top, top),
            Clip(top, top, top, top),
            Clip(0, 0, 0, 0),
            Clip(top, 0, 0, top),
        ]
        edges = [
            Edge(*p, *q, side, i_in, i_out, clip)
            for p, q in itertools.permutations(points, 2)
            for side in ("left", "right")
            for i_in, i_out in ((fs, 0), (0, fs))
            for clip in clips
        ]
        assert_batch_equals_setup(config, edges)
        int64 = setup_batch(config, **arrays(config, edges))
        assert int64.jq.dtype == np.int64 and int64.pieces.total0.dtype == np.int64
        wider = config.with_(frac_bits=F + 1)  # one bit over: Python ints
        assert setup_batch(wider, **arrays(wider, edges)).jq.dtype == object


def test_inputs_broadcast_and_string_sides():
    config = EdgeConfig()
    edges = [Edge(0, 0, 50, 7, "left", None, 0), Edge(90, 3, 10, 40, "right", None, 0)]
    expected = [setup(config, e) for e in edges]
    x0, y0, x1, y1 = (np.array([getattr(e, n) for e in edges]) for n in ("x0", "y0", "x1", "y1"))
    sides = np.array(["left", "right"])
    batch = setup_batch(config, x0, y0, x1, y1, sides, None, 0)
    assert list(batch) == expected
    clipped = [replace(e, clip=Clip(1, 0, 4, 2)) for e in edges]
    batch = setup_batch(config, x0, y0, x1, y1, sides, config.full_scale, 0, Clip(1, 0, 4, 2))
    assert list(batch) == [setup(config, e) for e in clipped]
    empty = setup_batch(config, *(np.zeros(0, dtype=np.int64) for _ in range(4)), [], 1, 0)
    assert len(empty) == 0 and list(empty) == []


def test_from_setups_round_trips():
    rng = random.Random(5)
    config = EdgeConfig(mode="seg4", intensity_bits=16, frac_bits=48)  # object-array fields
    setups = [setup(config, e) for e in random_edges(rng, config, 30)]
    assert list(SetupBatch.from_setups(config, setups)) == setups


# -- deltas from arrays ----------------------------------------------------------------------


def assert_same_deltas(config: EdgeConfig, edges: list[Edge], context: str = ""):
    expected = run_edges_deltas(config, edges)
    for force_object in (False, True):
        got = run_deltas_arrays(config, **arrays(config, edges), force_object=force_object)
        for name in ("edge_index", "x", "y", "delta"):
            a, b = getattr(got, name), getattr(expected, name)
            assert a.dtype == b.dtype, f"{context} {config} {name}"
            assert a.tolist() == b.tolist(), f"{context} {config} {name} force={force_object}"
        assert isinstance(got.setups, SetupBatch)
        assert list(got.setups) == list(expected.setups), f"{context} {config}"


@pytest.mark.parametrize("mode, accumulator", list(itertools.product(MODES, ACCUMULATORS)))
def test_array_deltas_equal_edge_deltas_seeded(mode, accumulator):
    seed = MODES.index(mode) * 2 + ACCUMULATORS.index(accumulator)
    rng = random.Random(seed)
    for _ in range(4):
        config = random_config(rng, mode=mode, accumulator=accumulator)
        spans = [random_span_edge(rng, config, rng.choice([2, 30])) for _ in range(40)]
        edges = [replace(e, clip=window_near(config, e, rng.randint)) for e in spans]
        assert_same_deltas(config, edges, f"seed {seed}:")


def test_array_deltas_of_a_batch_in_int64_and_python_ints():
    """coord_bits 16, intensity_bits 16: long steep edges leave int64 in the column loop."""
    config = EdgeConfig(coord_bits=16, intensity_bits=16, mode="seg2")
    hi, rng = config.max_vertex, random.Random(11)
    edges = [
        random_span_edge(rng, config, 8),
        Edge(0, 0, 3000 * 16, 3000 * 16 - 3, "left", None, 0),
        random_span_edge(rng, config, 8),
        Edge(hi, 0, hi - 2500 * 16 - 5, 2500 * 16, "right", 0, config.full_scale),
    ]
    assert_same_deltas(config, edges)


def test_array_deltas_of_the_builtin_text():
    from edgeaa.render import builtin
    from edgeaa.render.render import edges_to_send, plan_scene

    config = EdgeConfig()
    plan = plan_scene(builtin("text"), config)
    edges = [plan.edge(int(e), clip=True) for e in edges_to_send(plan, True)["sent"]]
    assert_same_deltas(config, edges)
    batch = run_setup_deltas(config, setup_batch(config, **arrays(config, edges)))
    assert batch.delta.tolist() == run_edges_deltas(config, edges).delta.tolist()


def test_empty_array_batch():
    config = EdgeConfig()
    empty = np.zeros(0, dtype=np.int64)
    batch = run_deltas_arrays(config, empty, empty, empty, empty, empty.astype(bool), 1, 0)
    assert len(batch) == 0 and batch.delta.dtype == np.int64


# -- bad edges ---------------------------------------------------------------------------------


def first_error(config: EdgeConfig, edges: list[Edge]) -> str | None:
    for k, edge in enumerate(edges):
        try:
            validate(config, edge)
        except EdgeError as error:
            return f"edge {k}: {error}"
    return None


def batch_error(config: EdgeConfig, **kwargs) -> str | None:
    try:
        setup_batch(config, **kwargs)
    except EdgeError as error:
        return str(error)
    return None


def spoil(rng: random.Random, config: EdgeConfig, edge: Edge) -> Edge:
    """The edge with one thing validate rejects (or, sometimes, unchanged)."""
    hi, fs, top = config.max_vertex, config.full_scale, 1 << config.coord_bits
    kind = rng.randrange(7)
    if kind == 0:
        name = rng.choice(["x0", "y0", "x1", "y1"])
        return replace(edge, **{name: rng.choice([-1, hi + 1, -(2**40)])})
    if kind == 1:
        return replace(edge, x1=edge.x0, y1=edge.y0)
    if kind == 2:
        return replace(edge, i_in=rng.choice([-1, fs + 1]))
    if kind == 3:
        return replace(edge, i_out=rng.choice([-1, fs + 1]))
    if kind == 4:
        return replace(edge, i_out=edge.intensities(config)[0])
    if kind == 5:
        bounds = list(edge.window(config))
        bounds[rng.randrange(4)] = rng.choice([-1, top + 1])
        return replace(edge, clip=Clip(*bounds))
    return edge


def error_arrays(config: EdgeConfig, edges: list[Edge]) -> dict:
    """`arrays` that keep bad values (i_in as given; clip None when no edge has one)."""
    kwargs = arrays(config, edges)
    kwargs["i_in"] = np.array([e.intensities(config)[0] for e in edges], dtype=np.int64)
    if all(e.clip is None for e in edges):
        kwargs["clip"] = None
    return kwargs


@pytest.mark.parametrize("seed", range(6))
def test_bad_edges_raise_validates_error_for_the_first(seed):
    rng = random.Random(seed)
    for _ in range(40):
        config = random_config(rng)
        edges = random_edge_commands(config, rng, rng.randint(1, 8), 20, clip=rng.random() < 0.5)
        edges = [spoil(rng, config, e) if rng.random() < 0.3 else e for e in edges]
        expected = first_error(config, edges)
        assert batch_error(config, **error_arrays(config, edges)) == expected, f"seed {seed}"


def test_bad_sides_and_types():
    config = EdgeConfig()
    good = [Edge(0, 0, 5, 2), Edge(3, 3, 9, 1, "right")]
    kwargs = error_arrays(config, good)
    assert batch_error(config, **kwargs) is None
    sides = np.array(["left", "up"])
    message = batch_error(config, **dict(kwargs, inside_left=sides))
    assert message == "edge 1: inside must be 'left' or 'right', not 'up'"
    floats = kwargs["x1"].astype(float) + 0.5
    assert batch_error(config, **dict(kwargs, x1=floats)) == (
        "edge 0: X1 must be an integer in sub-pixel units, not 5.5"
    )
    flags = np.array([True, False])
    assert batch_error(config, **dict(kwargs, y0=flags)) == (
        "edge 0: Y0 must be an integer in sub-pixel units, not True"
    )
    python_ints = kwargs["x0"].astype(object)  # Python ints are integers too
    assert batch_error(config, **dict(kwargs, x0=python_ints)) is None
    with pytest.raises(EdgeError, match="clip must be"):
        setup_batch(config, **dict(kwargs, clip=(1, 2, 3)))
