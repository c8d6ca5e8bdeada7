"""Amaranth gateware of the edge antialiaser: the top (`core`), its setup (`setup`) and
stepper (`stepper`), and the payload layouts (`layouts`)."""

from .core import EdgeAntialiaser, verilog
from .layouts import (
    clip_layout,
    delta_layout,
    edge_layout,
    pixel_layout,
    setup_layout,
    write_layout,
)
from .setup import EdgeSetupUnit
from .stepper import EdgeStepper

__all__ = [
    "EdgeAntialiaser",
    "EdgeSetupUnit",
    "EdgeStepper",
    "clip_layout",
    "delta_layout",
    "edge_layout",
    "pixel_layout",
    "setup_layout",
    "verilog",
    "write_layout",
]
