"""A plain aliased Bresenham line core: the cost baseline for the antialiased edge core.

It takes the same line commands as edgeaa (endpoints in sub-pixel units, `coord_bits +
subpixel_bits` bits each) and writes one pixel per clock, without coverage or intensity.
Its synthesis figures (see `edgeaa.sim.synthesis`) are the price of "just drawing the line".

Endpoints. Pixel (x, y) is centred on the integer point (x, y), as in `edgeaa.model`, so a
vertex X (in pixels) lies in pixel floor(X + 1/2). With ``rounding="nearest"`` (the default)
each endpoint is rounded to that pixel: ``(X + 2**(s-1)) >> s`` in sub-pixel units, halves
up. Vertices span [0, 2**W) pixels, so the pixels span 0 .. 2**W inclusive and need W + 1
bits. With ``rounding="floor"`` the integer part ``X >> s`` is used instead (pixels
0 .. 2**W - 1, W bits): cheaper by one bit, but off by up to one pixel from the geometry.

Algorithm. The all-octant error-term form of Bresenham's algorithm (no octant folding, no
swap of the axes), as in most FPGA line drawers::

    dx = |x1 - x0|, sx = sign(x1 - x0);  dy = -|y1 - y0|, sy = sign(y1 - y0)
    err = dx + dy
    loop: plot (x, y); stop after (x1, y1)
          e2 = 2 err
          if e2 >= dy: err += dy; x += sx
          if e2 <= dx: err += dx; y += sy

|err| stays below 3/2 * 2**W, so err fits W + 2 signed bits. The step keeps err + dx,
err + dy and err + (dx + dy) side by side and muxes, so the loop's critical path is one
comparison plus a mux. Nothing multiplies or divides.

Timing. A command is accepted in one cycle (``i.ready`` is high whenever the core is idle)
and set up in ``SETUP_CYCLES`` = 2 cycles (absolute differences, then dx + dy); then one pixel
leaves per clock while ``o.ready`` is high. A line of n pixels therefore occupies the core for
n + ``OVERHEAD_CYCLES`` cycles; the next command is accepted while the last pixel of the line
still waits in the output register. The output is registered: ``o.valid`` and ``o.payload``
come from flip-flops and hold still until taken, and no ready signal reaches a valid signal
through logic. The last pixel of each line has ``last`` set.
"""

from __future__ import annotations

from amaranth import Cat, Module, Mux, Signal, signed, unsigned
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from ..model import EdgeConfig

__all__ = ["ROUNDINGS", "BresenhamLine"]

ROUNDINGS = ("nearest", "floor")


class BresenhamLine(wiring.Component):
    """One-pixel-per-clock aliased line drawer.

    Parameters (keyword-only)
    -------------------------
    config:   the `EdgeConfig` whose coord_bits (W) and subpixel_bits (s) set the widths.
    rounding: "nearest" (endpoint to the pixel whose centre is nearest, W + 1 bit pixels) or
              "floor" (integer part of the endpoint, W bit pixels).

    Members
    -------
    i: In(stream.Signature(command_layout)):  x0, y0, x1, y1, each unsigned(W + s), sub-pixel
       units.
    o: Out(stream.Signature(pixel_layout)):   x, y unsigned(pixel_bits); last (1 bit).
    """

    SETUP_CYCLES = 2
    OVERHEAD_CYCLES = 1 + SETUP_CYCLES  # the accept cycle plus the set-up

    def __init__(self, *, config: EdgeConfig | None = None, rounding: str = "nearest"):
        if config is None:
            config = EdgeConfig()
        if not isinstance(config, EdgeConfig):
            raise TypeError(f"config must be an edgeaa.model.EdgeConfig, not {config!r}")
        if rounding not in ROUNDINGS:
            raise ValueError(f"rounding must be one of {', '.join(ROUNDINGS)}, not {rounding!r}")
        self._config = config
        self._rounding = rounding
        W, s = config.coord_bits, config.subpixel_bits
        self._pixel_bits = W + 1 if rounding == "nearest" and s > 0 else W
        self._command_layout = data.StructLayout(
            {name: unsigned(W + s) for name in ("x0", "y0", "x1", "y1")}
        )
        self._pixel_layout = data.StructLayout(
            {"x": unsigned(self._pixel_bits), "y": unsigned(self._pixel_bits), "last": 1}
        )
        super().__init__(
            {
                "i": In(stream.Signature(self._command_layout)),
                "o": Out(stream.Signature(self._pixel_layout)),
            }
        )

    @property
    def config(self) -> EdgeConfig:
        return self._config

    @property
    def rounding(self) -> str:
        return self._rounding

    @property
    def pixel_bits(self) -> int:
        return self._pixel_bits

    @property
    def command_layout(self) -> data.StructLayout:
        return self._command_layout

    @property
    def pixel_layout(self) -> data.StructLayout:
        return self._pixel_layout

    def elaborate(self, platform):
        m = Module()
        W, s = self._config.coord_bits, self._config.subpixel_bits
        P = self._pixel_bits

        def to_pixel(value):
            if s == 0:
                return value
            if self._rounding == "nearest":
                return (value + (1 << (s - 1)))[s:]  # the sum keeps its carry: W + 1 bits
            return value[s:]

        # Current pixel and end point (pixel units).
        x = Signal(unsigned(P))
        y = Signal(unsigned(P))
        x1 = Signal(unsigned(P))
        y1 = Signal(unsigned(P))
        # Step directions (1: decrement) and the error-term constants.
        sx = Signal()
        sy = Signal()
        dx = Signal(unsigned(P))  # |x1 - x0|
        dy = Signal(signed(P + 1))  # -|y1 - y0|
        dxy = Signal(signed(W + 2))  # dx + dy, also the initial error
        err = Signal(signed(W + 2))

        # Set-up 1: the absolute differences, both subtractions side by side and a mux.
        ddx = Signal(signed(P + 1))
        ddy = Signal(signed(P + 1))
        m.d.comb += [ddx.eq(x1 - x), ddy.eq(y1 - y)]

        # The step: which axes move, and the new error term (a comparison, then a mux).
        e2 = Signal(signed(W + 3))
        step_x = Signal()
        step_y = Signal()
        at_end = Signal()
        advance = Signal()
        m.d.comb += [
            e2.eq(Cat(0, err).as_signed()),
            step_x.eq(e2 >= dy),
            step_y.eq(e2 <= dx),
            at_end.eq((x == x1) & (y == y1)),
        ]
        err_next = Mux(step_x, Mux(step_y, err + dxy, err + dy), Mux(step_y, err + dx, err))

        with m.If(self.o.ready):
            m.d.sync += self.o.valid.eq(0)

        with m.FSM():
            with m.State("IDLE"):
                m.d.comb += self.i.ready.eq(1)
                with m.If(self.i.valid):
                    m.d.sync += [
                        x.eq(to_pixel(self.i.payload.x0)),
                        y.eq(to_pixel(self.i.payload.y0)),
                        x1.eq(to_pixel(self.i.payload.x1)),
                        y1.eq(to_pixel(self.i.payload.y1)),
                    ]
                    m.next = "SETUP1"
            with m.State("SETUP1"):
                m.d.sync += [
                    sx.eq(ddx < 0),
                    sy.eq(ddy < 0),
                    dx.eq(Mux(ddx < 0, x - x1, ddx)),
                    dy.eq(Mux(ddy < 0, ddy, y - y1)),
                ]
                m.next = "SETUP2"
            with m.State("SETUP2"):
                m.d.sync += [dxy.eq(dx + dy), err.eq(dx + dy)]
                m.next = "RUN"
            with m.State("RUN"):
                m.d.comb += advance.eq(~self.o.valid | self.o.ready)  # the output is free
                with m.If(advance):
                    m.d.sync += [
                        self.o.valid.eq(1),
                        self.o.payload.x.eq(x),
                        self.o.payload.y.eq(y),
                        self.o.payload.last.eq(at_end),
                        err.eq(err_next),
                    ]
                    with m.If(step_x):
                        m.d.sync += x.eq(x + Mux(sx, -1, 1))
                    with m.If(step_y):
                        m.d.sync += y.eq(y + Mux(sy, -1, 1))
                    with m.If(at_end):
                        m.next = "IDLE"

        return m
