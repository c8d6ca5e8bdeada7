"""One edge command as the core's input ports see it: the ``edges`` payload and the ``clip``
window the driver presents while offering it (sampled in the clock the edge is accepted).

Every driver (the compiled harness's command file, the Amaranth runner and the core's unit
tests) builds its port values here, so they cannot drift apart. `COMMAND_FORMAT` is the same
row for the harness generator (`edgeaa.sim.simulators.harness`).
"""

from __future__ import annotations

from typing import NamedTuple

from ...hdl.layouts import edge_layout
from ...model import Clip, Edge, EdgeConfig
from ...model.edge import validate_clip
from .harness import StreamFormat

# The ``edges`` payload's fields in port order (the core's `edge_layout`; widths aside, the
# same in every configuration).
EDGE_FIELDS = tuple(str(name) for name, _ in edge_layout(EdgeConfig()))
CLIP_FIELDS = Clip._fields  # clip: x_min, y_min, x_max, y_max
COMMAND_FIELDS = EDGE_FIELDS + CLIP_FIELDS  # a command file row
COMMAND_FORMAT = StreamFormat(
    "edges", tuple((name,) for name in EDGE_FIELDS), tuple(("clip", name) for name in CLIP_FIELDS)
)


class Command(NamedTuple):
    """Port values of one edge command: ``edges.payload`` and ``clip`` field by field."""

    payload: dict[str, int]
    clip: dict[str, int]

    def row(self) -> tuple[int, ...]:
        """The values in `COMMAND_FIELDS` order."""
        return tuple(self.payload[name] for name in EDGE_FIELDS) + tuple(
            self.clip[name] for name in CLIP_FIELDS
        )


def edge_payload(config: EdgeConfig, edge: Edge) -> dict[str, int]:
    """The ``edges.payload`` fields of `edge` (i_in None as full scale, inside as 1 = right)."""
    i_in, i_out = edge.intensities(config)
    return {
        "x0": edge.x0,
        "y0": edge.y0,
        "x1": edge.x1,
        "y1": edge.y1,
        "i_in": i_in,
        "i_out": i_out,
        "inside": int(edge.inside == "right"),
    }


def edge_clip(config: EdgeConfig, edge: Edge) -> dict[str, int]:
    """The ``clip`` port fields of `edge`: its window (`Clip.full` when edge.clip is None).

    Raises `EdgeError` for a window the port cannot carry (a bound outside [0, 2**coord_bits]):
    the model would drop such an edge as bad, but the core never sees it as bad.
    """
    if edge.clip is not None:
        validate_clip(config, tuple(edge.clip))
    return edge.window(config)._asdict()


def edge_command(config: EdgeConfig, edge: Edge) -> Command:
    """The port values of `edge`: payload and clip fields."""
    return Command(edge_payload(config, edge), edge_clip(config, edge))
