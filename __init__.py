"""edgeaa: a hardware-oriented, fixed-point, antialiased edge rasterizer.

- `edgeaa.model`: the bit-accurate integer model (the golden reference).
- `edgeaa.hdl`: the Amaranth hardware of the same pipeline.
- `edgeaa.sim`: the harnesses that run the hardware and compare it with the model.
"""

__version__ = "0.1.0"
