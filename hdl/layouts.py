"""The core's payload layouts, each derived from the model's one declaration of its concept.

* `edge_layout`: one edge command (`edgeaa.model.Edge`), the ``edges`` stream's payload;
* `clip_layout`: the clip window (`edgeaa.model.Clip`), the ``clip`` port;
* `setup_layout`: the register bank from the setup to the stepper, one field per
  `edgeaa.model.bank.bank_fields` entry, sized by its register in the width table;
* `write_layout`: one output beat, the lanes and flags of `edgeaa.model.beat`;
* `delta_layout`: one beat of the polygon core's deltas, the cells of `edgeaa.model.beat`;
* `tile_op_layout`, `tile_cell_layout`, `tile_pixel_layout`: the tile stages' streams
  (`edgeaa.model.tile`: its ops, the resolve's cells, the tile's pixels).
"""

from __future__ import annotations

from amaranth.hdl import Cat, Const, signed, unsigned
from amaranth.lib import data

from ..model.bank import bank_fields
from ..model.beat import (
    CELL_FIELDS,
    CELLS,
    DELTA_FLAG_BITS,
    DELTA_PAYLOAD_PATHS,
    LANES,
    PAYLOAD_PATHS,
    PIXEL_FIELDS,
)
from ..model.config import EdgeConfig, RegisterWidth
from ..model.tile import OPS, PAINT, RESOLVE_OPS, TileConfig

__all__ = [
    "CELL_OP",
    "TILE_OP",
    "cell_sum_fields",
    "check_config",
    "clip_layout",
    "const_mul",
    "delta_layout",
    "edge_layout",
    "full_clip",
    "log2",
    "pixel_layout",
    "pixel_value_fields",
    "register_shape",
    "setup_layout",
    "signed_widened",
    "tile_cell_layout",
    "tile_op_layout",
    "tile_pixel_layout",
    "write_layout",
]


def check_config(config) -> EdgeConfig:
    if not isinstance(config, EdgeConfig):
        raise TypeError(f"config must be an EdgeConfig, not {config!r}")
    return config


def register_shape(width: RegisterWidth):
    """The Amaranth shape of a width-table entry."""
    return signed(width.bits) if width.signed else unsigned(width.bits)


def log2(n: int) -> int:
    return n.bit_length() - 1


def signed_widened(value):
    """A non-negative `value` made signed (a zero bit on top), so that ``~v`` is ``-v - 1``
    and ``~v + 1`` is ``-v`` (a negation or subtraction folded into an add's carry in)."""
    return Cat(value, Const(0, 1)).as_signed()


def const_mul(value, k: int):
    """``value * k`` for a small non-negative constant, as shifts and adds (no $mul cell)."""
    if k == 0:
        return Const(0, 1)
    terms = [value << i for i in range(k.bit_length()) if (k >> i) & 1]
    result = terms[0]
    for term in terms[1:]:
        result = result + term
    return result


def edge_layout(config: EdgeConfig) -> data.StructLayout:
    """One edge command: vertices in sub-pixel units, intensities and the inside side."""
    coord = unsigned(config.coord_bits + config.subpixel_bits)
    intensity = unsigned(config.intensity_bits)
    return data.StructLayout(
        {
            "x0": coord,
            "y0": coord,
            "x1": coord,
            "y1": coord,
            "i_in": intensity,
            "i_out": intensity,
            "inside": unsigned(1),
        }
    )


def clip_layout(config: EdgeConfig) -> data.StructLayout:
    """The clip window (`edgeaa.model.Clip`): whole pixels, bounds included, each bound in
    ``[0, 2**coord_bits]``; ``x_max = y_max = 2**coord_bits`` and zero minima clip nothing."""
    bound = unsigned(config.coord_bits + 1)
    return data.StructLayout({"x_min": bound, "y_min": bound, "x_max": bound, "y_max": bound})


def full_clip(config: EdgeConfig) -> dict[str, int]:
    """The ``clip`` value that clips nothing (`edgeaa.model.Clip.full`): the port's init."""
    top = 1 << config.coord_bits
    return {"x_min": 0, "y_min": 0, "x_max": top, "y_max": top}


def pixel_layout(config: EdgeConfig) -> data.StructLayout:
    """One lane of a beat: `PIXEL_FIELDS`, each sized by the register of the same name."""
    widths = config.register_widths()
    return data.StructLayout({name: register_shape(widths[name]) for name in PIXEL_FIELDS})


def write_layout(config: EdgeConfig) -> data.StructLayout:
    """One output beat: the writes of one column (one or two pixels) in `LANES`, then the
    one-bit flags of `PAYLOAD_PATHS` (``lane1_valid``, ``last``)."""
    pixel = pixel_layout(config)
    fields = {lane: pixel for lane in LANES}
    fields.update({path[0]: unsigned(1) for path in PAYLOAD_PATHS if len(path) == 1})
    return data.StructLayout(fields)


def delta_layout(config: EdgeConfig) -> data.StructLayout:
    """One beat of the deltas core: the `CELLS` (each `CELL_FIELDS`, sized by the register of
    the same name), then the flags of `DELTA_PAYLOAD_PATHS` (``nonzero``, a bit a cell, and
    ``last``: `DELTA_FLAG_BITS`)."""
    widths = config.register_widths()
    cell = data.StructLayout({name: register_shape(widths[name]) for name in CELL_FIELDS})
    fields = {name: cell for name in CELLS}
    flags = [path[0] for path in DELTA_PAYLOAD_PATHS if len(path) == 1]
    fields.update({name: unsigned(DELTA_FLAG_BITS[name]) for name in flags})
    return data.StructLayout(fields)


def setup_layout(config: EdgeConfig, pieces: bool = False) -> data.StructLayout:
    """The register bank handed from the setup to the stepper (the model's `EdgeSetup`): one
    field per `bank_fields` entry (the end pieces with `pieces`: the polygon core's),
    arrays of ``length`` registers."""
    fields = {}
    for field in bank_fields(config, pieces):
        shape = register_shape(field.width(config))
        fields[field.name] = data.ArrayLayout(shape, field.length(config)) if field.array else shape
    return data.StructLayout(fields)


def _code_bits(names) -> int:
    return max(1, (len(names) - 1).bit_length())


def _polygon_fields(tile: TileConfig) -> dict:
    """What a polygon's end carries: its intensity, I_out and fill rule (1: even-odd); and a
    tile's background. In colour (`TileConfig.channels` 3 or 4) the ``intensity`` field is
    the intensity and then the paint, red, green, blue and alpha (`PAINT`, I bits each: the
    accumulator passes it on whole), and the background is a value per channel, red in the
    low bits."""
    bits = tile.config.intensity_bits
    colour = tile.channels > 1
    return {
        "intensity": unsigned(bits * (1 + len(PAINT)) if colour else bits),
        "i_out": unsigned(bits),
        "evenodd": unsigned(1),
        "background": unsigned(bits * tile.channels),
    }


# The op codes of the tile stages' streams by name: `tile_op_layout`'s and `tile_cell_layout`'s.
TILE_OP = {name: code for code, name in enumerate(OPS)}
CELL_OP = {name: code for code, name in enumerate(RESOLVE_OPS)}


def tile_op_layout(tile: TileConfig) -> data.StructLayout:
    """The accumulator's input: ``op`` (an index of `edgeaa.model.tile.OPS`), the delta beat
    (``beat``), the polygon's fields (end) or the background (tile), and the tile's origin
    ``x0, y0`` in engine pixels (tile)."""
    origin = unsigned(tile.config.coord_bits + 1)
    return data.StructLayout(
        {
            "op": unsigned(_code_bits(OPS)),
            "beat": delta_layout(tile.config),
            **_polygon_fields(tile),
            "x0": origin,
            "y0": origin,
        }
    )


def tile_cell_layout(tile: TileConfig, lanes: int = 1) -> data.StructLayout:
    """The resolve's input: ``op`` (an index of `RESOLVE_OPS`), a beat of `lanes` cells: its
    first cell's tile pixel and the cells' sums side by side (`cell_sum_fields`; ``first``:
    the polygon's first beat; ``start``: its row's first, where the prefix sum restarts),
    and the polygon's fields or the background."""
    return data.StructLayout(
        {
            "op": unsigned(_code_bits(RESOLVE_OPS)),
            "x": unsigned(tile.x_bits),
            "y": unsigned(tile.y_bits),
            **{name: signed(tile.cell_bits) for name in cell_sum_fields(lanes)},
            "first": unsigned(1),
            "start": unsigned(1),
            **_polygon_fields(tile),
        }
    )


def tile_pixel_layout(tile: TileConfig, lanes: int = 1) -> data.StructLayout:
    """One beat of a flushed tile: its first pixel's place, the values of `lanes` pixels side
    by side (`pixel_value_fields`; a value per channel, red in the low bits), and ``last`` on
    the tile's last beat."""
    value = unsigned(tile.config.intensity_bits * tile.channels)
    return data.StructLayout(
        {
            "x": unsigned(tile.x_bits),
            "y": unsigned(tile.y_bits),
            **{name: value for name in pixel_value_fields(lanes)},
            "last": unsigned(1),
        }
    )


def cell_sum_fields(lanes: int) -> tuple[str, ...]:
    """The sum fields of a beat of `lanes` cells (`tile_cell_layout`): lane k, the cell at
    column ``x + k``, is ``sum`` for k = 0, else ``sum<k>``."""
    return ("sum", *(f"sum{k}" for k in range(1, lanes)))


def pixel_value_fields(lanes: int) -> tuple[str, ...]:
    """The value fields of a pixel beat of `lanes` pixels (`tile_pixel_layout`): lane k, the
    pixel at column ``x + k``, is ``value`` for k = 0, else ``value<k>``."""
    return ("value", *(f"value{k}" for k in range(1, lanes)))
