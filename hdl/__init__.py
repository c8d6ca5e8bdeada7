"""Amaranth gateware of the edge antialiaser."""

from .core import (
    EdgeAntialiaser,
    EdgeStepper,
    clip_layout,
    edge_layout,
    pixel_layout,
    setup_layout,
    verilog,
    write_layout,
)

__all__ = [
    "EdgeAntialiaser",
    "EdgeStepper",
    "clip_layout",
    "edge_layout",
    "pixel_layout",
    "setup_layout",
    "verilog",
    "write_layout",
]
