"""Amaranth gateware of the edge antialiaser: the two cores (`core`: `LineCore`, `PolygonCore`),
their setup (`setup`) and steppers (`stepper`, `deltas`), and the payload layouts (`layouts`)."""

from .core import LineCore, PolygonCore, core_verilog, verilog
from .deltas import DeltaStepper
from .layouts import (
    clip_layout,
    delta_layout,
    edge_layout,
    pixel_layout,
    setup_layout,
    write_layout,
)
from .setup import EdgeSetupUnit
from .stepper import LineStepper

__all__ = [
    "DeltaStepper",
    "EdgeSetupUnit",
    "LineCore",
    "LineStepper",
    "PolygonCore",
    "clip_layout",
    "delta_layout",
    "edge_layout",
    "pixel_layout",
    "setup_layout",
    "core_verilog",
    "verilog",
    "write_layout",
]
