"""The formal specification is the model: `formal.spec` on Amaranth values equals the model on
Python ints.

`edgeaa.sim.verification.formal.spec` runs the model's own per-column arithmetic and setup
fold (`edgeaa.model.column`, `edgeaa.model.edge.fold` / `window`) on Amaranth values through
`HdlArith`. Here its expressions are evaluated by Amaranth's simulator on the states of real
edges (the loop registers of every column of a short edge, and of a long one's ends and a
seeded sample between, from `run_edge`'s trace, and each command with its clip window) and
compared with what the model computes for the same state, so a wrong select, negation or
segment pick in the Amaranth arithmetic shows up as a mismatch.
"""

from __future__ import annotations

import random
import types

import numpy as np
import pytest
from amaranth.hdl import Module, Signal, Value, signed, unsigned
from amaranth.sim import Simulator

from edgeaa.model import Clip, Edge, EdgeConfig, EdgeError, run_edge, setup
from edgeaa.model.accumulate import FILL_RULES, fill, fill_coverage, intensity_offset
from edgeaa.model.beat import DELTAS, WRITES, BeatFormat
from edgeaa.model.column import IntArith, advance, column_areas, output_value, piece_end
from edgeaa.model.step import run_edge_deltas
from edgeaa.model.tile import TileConfig
from edgeaa.sim.verification.formal import spec
from edgeaa.sim.verification.formal.tile_common import SMALL_TILE

CONFIGS = {
    "paper": EdgeConfig(),
    "seg4": EdgeConfig(mode="seg4"),
    "pw-truncated": EdgeConfig(mode="pw", accumulator="truncated"),
    "seg2-small": EdgeConfig(coord_bits=6, subpixel_bits=2, intensity_bits=5, mode="seg2"),
}


def _shape(width):
    return signed(width.bits) if width.signed else unsigned(width.bits)


def _bank_signals(config: EdgeConfig, fmt: BeatFormat = WRITES) -> types.SimpleNamespace:
    """A bank-like record of free signals, one per bank field of `fmt` (arrays as lists)."""
    record = {}
    for field in fmt.bank_fields(config):
        shape = _shape(field.width(config))
        if field.array:
            record[field.name] = [Signal(shape) for _ in range(field.length(config))]
        else:
            record[field.name] = Signal(shape, name=field.name)
    return types.SimpleNamespace(**record)


def _command_signals(config: EdgeConfig):
    coord = unsigned(config.coord_bits + config.subpixel_bits)
    cmd = types.SimpleNamespace(
        **{name: Signal(coord, name=name) for name in ("x0", "y0", "x1", "y1")},
        i_in=Signal(unsigned(config.intensity_bits)),
        i_out=Signal(unsigned(config.intensity_bits)),
        inside=Signal(),
    )
    bound = unsigned(config.coord_bits + 1)
    clip = types.SimpleNamespace(**{name: Signal(bound, name=name) for name in Clip._fields})
    return cmd, clip


def _random_edges(config: EdgeConfig, rng: random.Random, count: int) -> list[Edge]:
    top, hi = 1 << config.coord_bits, config.max_vertex
    edges = []
    while len(edges) < count:
        p = [rng.randrange(hi + 1) for _ in range(4)]
        if rng.random() < 0.7:  # short edges: many columns of every kind in few steps
            p[2] = min(max(p[0] + rng.randrange(-40, 41), 0), hi)
            p[3] = min(max(p[1] + rng.randrange(-40, 41), 0), hi)
        clip = Clip(*(rng.randrange(top + 1) for _ in range(4))) if rng.random() < 0.4 else None
        full = config.full_scale
        edge = Edge(
            *p,
            inside=rng.choice(("left", "right")),
            i_in=rng.randrange(full + 1),
            i_out=rng.randrange(full + 1),
            clip=clip,
        )
        try:
            if setup(config, edge).columns:
                edges.append(edge)
        except EdgeError:
            continue
    return edges


ENDS = 16  # columns compared at each end of a long edge, and drawn at random between


def _compared_columns(rng: random.Random, columns: int) -> set[int]:
    """The columns of an edge whose state the simulator evaluates: every column of a short
    edge; of a long one the first and last `ENDS` and `ENDS` drawn from between (each is a
    settle of the simulator; a long edge's middle columns repeat the same arithmetic)."""
    if columns <= 3 * ENDS:
        return set(range(columns))
    between = rng.sample(range(ENDS, columns - ENDS), ENDS)
    return {*range(ENDS), *range(columns - ENDS, columns), *between}


def _model_column(config: EdgeConfig, st, state) -> dict[str, int]:
    """What the spec's column must give for one of the model's loop states."""
    a = IntArith(config)
    areas = column_areas(a, config, st, state.jq, state.jr)
    step = advance(a, st, state.x, state.y, state.jq, state.jr)
    out = {
        "area0": areas.area0,
        "value0": output_value(a, config, st, areas.area0),
        "two": int(bool(areas.two)),
        "below": int(bool(areas.below)),
        "jsum": step.jsum,
        "row_step": int(step.row_step),
    }
    if areas.two:
        out["area1"] = areas.area1
        out["value1"] = output_value(a, config, st, areas.area1)
    return out


def _drive_bank(ctx, config: EdgeConfig, bank, st, fmt: BeatFormat = WRITES) -> None:
    for field in fmt.bank_fields(config):
        value, target = field.value(st), getattr(bank, field.name)
        if field.array:
            for element, item in zip(target, value, strict=True):
                ctx.set(element, item)
        else:
            ctx.set(target, value)


def _drive_command(ctx, config: EdgeConfig, cmd, clip, edge: Edge) -> None:
    i_in, i_out = edge.intensities(config)
    values = {"x0": edge.x0, "y0": edge.y0, "x1": edge.x1, "y1": edge.y1}
    values |= {"i_in": i_in, "i_out": i_out, "inside": int(edge.inside == "right")}
    for key, value in values.items():
        ctx.set(getattr(cmd, key), value)
    for key, value in edge.window(config)._asdict().items():
        ctx.set(getattr(clip, key), value)


@pytest.mark.parametrize("name", list(CONFIGS))
def test_spec_column_and_fold_are_the_model(name):
    config = CONFIGS[name]
    seed = 20261124 + len(name)
    rng = random.Random(seed)
    bank = _bank_signals(config)
    cmd, clip = _command_signals(config)
    column = spec.column(config, bank, spec.axes(bank))
    folded = spec.fold(config, cmd)
    cut = spec.window(config, folded, clip)
    probes = {
        **{key: getattr(column, key) for key in ("area0", "area1", "value0", "value1")},
        **{key: getattr(column, key) for key in ("two", "below", "jsum", "row_step")},
        **{f"fold_{key}": getattr(folded, key) for key in ("du", "dv", "value_base", "bad")},
        "first": cut.first,
        "last": cut.last,
        "start_clip": cut.start_clip,
        "fits": spec.all_(column.fits.values()),
    }
    m = Module()
    wires = {}
    for key, value in probes.items():
        value = Value.cast(value)
        wires[key] = Signal(value.shape(), name=f"probe_{key}")
        m.d.comb += wires[key].eq(value)
    mismatches = []

    async def bench(ctx):
        for edge in _random_edges(config, rng, 25):
            result = run_edge(config, edge)
            st = result.setup
            _drive_bank(ctx, config, bank, st)
            _drive_command(ctx, config, cmd, clip, edge)
            checks = {"fold_du": st.du, "fold_dv": st.dv, "fold_value_base": st.value_base}
            checks |= {"fold_bad": 0, "start_clip": int(st.clipped_start)}
            checks |= {"columns": st.columns}
            got = {key: ctx.get(wires[key]) for key in checks if key in wires}
            got["columns"] = ctx.get(wires["last"]) - ctx.get(wires["first"]) + 1
            mismatches.extend((edge, k, got[k], v) for k, v in checks.items() if got[k] != v)
            compared = _compared_columns(rng, st.columns)
            for state in (state for state in result.trace if state.column in compared):
                for name in ("x", "y", "jq", "jr"):
                    ctx.set(getattr(bank, name), getattr(state, name))
                ctx.set(bank.remaining, st.columns - 1 - state.column)
                want = _model_column(config, st, state) | {"fits": 1}
                got = {key: ctx.get(wires[key]) for key in want}
                mismatches.extend(
                    (edge, state, k, got[k], v) for k, v in want.items() if got[k] != v
                )

    sim = Simulator(m)
    sim.add_testbench(bench)
    sim.run()
    assert not mismatches, f"seed {seed}: {len(mismatches)} mismatches, first {mismatches[:3]}"


EDGES = 25


def _deltas_states(config: EdgeConfig, edge: Edge):
    """The deltas loop's state of each column (`run_edge_deltas`' loop: x, y, jq, jr, the
    folded row, the piece start hs, the column index) with the model's cells."""
    st = setup(config, edge)
    a = IntArith(config)
    x, y, jq, jr, row, hs = st.x, st.y, st.jq, st.jr, st.pieces.row0, st.pieces.hs0
    for column, cells in enumerate(run_edge_deltas(config, edge)):
        last = column == st.columns - 1 and st.pieces.last_partial
        he, _ = piece_end(a, st, last, jq, jr, row)
        yield types.SimpleNamespace(
            column=column, x=x, y=y, jq=jq, jr=jr, row=row, hs=hs, he=he, cells=cells
        )
        step = advance(a, st, x, y, jq, jr)
        hs = he - (st.ifix if step.row_step else 0)
        row += 1 if step.row_step else 0
        x, y, jq, jr = step.x, step.y, step.jq, step.jr


@pytest.mark.parametrize("name", list(CONFIGS))
def test_spec_deltas_column_is_the_model(name):
    """`spec.deltas_column` (the model's `piece_end`, `column_deltas`, `delta_cells` on
    Amaranth values) gives `run_edge_deltas`' cells for every column of random edges."""
    config = CONFIGS[name]
    seed = 20261125 + len(name)
    rng = random.Random(seed)
    widths = config.register_widths()
    bank = _bank_signals(config, DELTAS)
    bank.hs = Signal(_shape(widths["height"]), name="hs")
    row, first_col = Signal(_shape(widths["y"]), name="row"), Signal(name="first_col")
    m = Module()
    column = spec.deltas_column(config, bank, row, first_col, m)
    probes = {"he": column.he, "fits": spec.all_(column.fits.values())}
    for k, cell in enumerate(column.cells):
        probes.update({f"cell{k}_{name}": value for name, value in zip("xyd", cell, strict=True)})
    wires = {}
    for key, value in probes.items():
        value = Value.cast(value)
        wires[key] = Signal(value.shape(), name=f"probe_{key}")
        m.d.comb += wires[key].eq(value)
    mismatches, compared = [], [0]

    async def bench(ctx):
        for edge in _random_edges(config, rng, EDGES):
            st = setup(config, edge)
            _drive_bank(ctx, config, bank, st, DELTAS)
            columns = _compared_columns(rng, st.columns)
            for state in (s for s in _deltas_states(config, edge) if s.column in columns):
                for key in ("x", "y", "jq", "jr", "hs"):
                    ctx.set(getattr(bank, key), getattr(state, key))
                ctx.set(bank.remaining, st.columns - 1 - state.column)
                ctx.set(row, state.row)
                ctx.set(first_col, state.column == 0)
                want = {"he": state.he, "fits": 1}
                for k, cell in enumerate(state.cells):
                    want.update({f"cell{k}_{n}": v for n, v in zip("xyd", cell, strict=True)})
                got = {key: ctx.get(wires[key]) for key in want}
                compared[0] += 1
                mismatches.extend(
                    (edge, state.column, k, got[k], v) for k, v in want.items() if got[k] != v
                )

    sim = Simulator(m)
    sim.add_testbench(bench)
    sim.run()
    assert compared[0] > 100
    assert not mismatches, f"seed {seed}: {len(mismatches)} mismatches, first {mismatches[:3]}"


@pytest.mark.parametrize("name", ["small-tile", "default-tile"])
def test_fill_on_amaranth_values_is_the_model(name):
    """The resolve proof's pixel, `intensity_offset` of the model's `fill_coverage` on
    Amaranth values (`spec.HdlArith`) in the width `formal.resolve` gives the exact prefix
    sum, equals `fill` on arrays and `fill_coverage` on ints (`IntArith`) for both rules,
    every |I_d| and sums at and around each multiple of ifix across the documented range and
    twice it (fault ``wide_range``), plus a seeded sample."""
    tile = SMALL_TILE if name == "small-tile" else TileConfig()
    config, n = tile.config, tile.cell_bits
    seed = 20261128 + len(name)
    rng = random.Random(seed)
    exact, evenodd = Signal(signed(n + 4), name="exact"), Signal(name="evenodd")
    d = Signal(config.intensity_bits, name="d")
    ifix = d << config.F
    coverage = fill_coverage(spec.HdlArith(config), exact, evenodd, ifix)
    m = Module()
    wires = {"coverage": Signal(Value.cast(coverage).shape())}
    wires["q"] = Signal(Value.cast(intensity_offset(coverage, config.F)).shape())
    m.d.comb += [
        wires["coverage"].eq(coverage),
        wires["q"].eq(intensity_offset(coverage, config.F)),
    ]
    top = (1 << (n + 3)) - 1
    mismatches, compared = [], [0]

    def samples(step):
        limit = 2 * tile.winding_limit * step
        for k in range(-limit // step - 1, limit // step + 2):
            yield from (k * step + j for j in (-1, 0, 1, step // 2))
        yield from (rng.randrange(-top - 1, top + 1) for _ in range(64))

    async def bench(ctx):
        for magnitude in range(1, config.full_scale + 1):
            step = magnitude << config.F
            ctx.set(d, magnitude)
            for rule in FILL_RULES:
                ctx.set(evenodd, rule == "evenodd")
                for value in (v for v in samples(step) if -top - 1 <= v <= top):
                    ctx.set(exact, value)
                    want = int(fill(np.array([value]), rule, step)[0])
                    ints = fill_coverage(IntArith(), value, rule == "evenodd", step)
                    got = ctx.get(wires["coverage"]), ctx.get(wires["q"])
                    compared[0] += 1
                    if got != (want, intensity_offset(want, config.F)) or ints != want:
                        mismatches.append((magnitude, rule, value, got, want, ints))

    sim = Simulator(m)
    sim.add_testbench(bench)
    sim.run()
    assert compared[0] > 1000
    assert not mismatches, f"seed {seed}: {len(mismatches)} mismatches, first {mismatches[:3]}"
