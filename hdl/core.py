# amaranth: UnusedElaboratable=no
"""The edge antialiaser cores: a multi-cycle per-edge setup and a one-column-per-clock stepper.

Two small tops compose the same parts: `LineCore` (the paper's method: `edgeaa.model.step.
run_edge`'s intensity writes, bit for bit) and `PolygonCore` (`run_edge_deltas`'s
accumulation deltas, the polygon pipeline's core). Each joins two components through a
one-edge bank stream:

* **Setup** (`edgeaa.hdl.setup.EdgeSetupUnit`, or `edgeaa.hdl.dispatch.SetupArray` of
  several; the polygon core's with the end pieces, `edgeaa.hdl.pieces.EndPieces`): a small
  state machine that folds the edge
  into the first octant, cuts its columns to the clip window and computes the `EdgeSetup`
  fields the loop needs with two lanes of a sequential multiply-divide unit. Its latency is
  fixed per configuration, and ``W + 1`` clocks longer for an edge whose start the clip
  window cuts. Its ``bank`` stream is the result, formed from its registers, which it holds
  until the stepper takes it (it accepts the next command in that clock).
* **Stepping** (`edgeaa.hdl.stepper.LineStepper` or `edgeaa.hdl.deltas.DeltaStepper`, both
  on the shared `edgeaa.hdl.column_loop.ColumnLoop`): one column per clock with an always-ready
  sink, using only adds, subtracts, compares, fixed shifts and shift-add multiplies by the
  small odd constants of the segment estimate; the column's writes are computed in a
  pipeline behind the loop (`edgeaa.model.timing.pipeline_depth` registers deep).

The next edge's setup runs while the current edge steps, and the stepper loads the bank in
the same clock as it steps its last column, so edges at least ``setup_interval`` columns long
leave back to back with no bubble. The polygon core's stepper keeps no copy of the bank: it
reads the per-edge constants from the bank the setup holds and takes it in the clock it
steps the edge's last column, so its setup and its stepping take turns (one edge of ``C``
columns per ``C + setup_interval`` clocks with one setup unit). `edgeaa.model.timing` is
the exact cycle model: the first beat of an edge accepted by an idle core is valid
``setup_latency`` clocks after it is accepted.

Ports (``W = coord_bits``, ``s = subpixel_bits``, ``I = intensity_bits``):

* ``edges`` (in stream): ``x0, y0, x1, y1`` unsigned ``W + s`` (sub-pixel units, as
  `edgeaa.model.Edge`), ``i_in, i_out`` unsigned ``I``, ``inside`` (0: left, 1: right).
* ``clip`` (in, `clip_layout`): ``x_min, y_min, x_max, y_max`` unsigned ``W + 1``, whole
  pixels, bounds included (`edgeaa.model.Clip`); sampled in the clock an edge is accepted,
  so it may change freely otherwise. Its init (an undriven port in Amaranth simulation) is
  the full window ``(0, 0, 2**W, 2**W)``, which clips nothing. In Verilog (``clip__x_min``
  etc.) an input has no default: it must be driven (docs/hardware.md, "Integration").
* ``writes`` (`LineCore`'s out stream, one beat per column): ``lane0`` and ``lane1``, each
  ``x, y`` signed ``W + 2`` and ``value`` unsigned ``I``; ``lane1_valid``; ``last`` (the
  edge's last column). Lane order is the model's write order: the primary pixel, then its
  neighbour. The fields of ``lane1`` are don't-care (but deterministic) when ``lane1_valid``
  is 0.
* ``deltas`` (`PolygonCore`'s out stream; one beat per column, `edgeaa.model.beat.DeltaBeat`):
  ``cell0`` .. ``cell3``, each ``x, y`` signed ``W + 2`` and ``delta`` signed ``I + F + 2``,
  ``nonzero`` (bit k: cell k's delta is not zero) and ``last``: the accumulation deltas of
  `edgeaa.model.step.run_edge_deltas`, zeros included, in its order. Same setup (with the
  end pieces, in the same clocks) and loop; the column pipeline is 4 registers deep
  (`edgeaa.hdl.deltas`: p3 cuts the cells' carry chains).
* ``errors`` (out, ``errors_bits`` = 16 bits by default): bad commands dropped so far,
  saturating at ``2**errors_bits - 1``.
* ``error`` (out): high for one clock when a bad command is dropped.

Bad commands, clipping and the setup arithmetic: `edgeaa.hdl.setup` and docs/hardware.md, "The
setup unit, clock by clock".
"""

from __future__ import annotations

import functools

from amaranth.hdl import Module, ResetSignal, Signal, unsigned
from amaranth.lib import data, stream, wiring
from amaranth.lib.wiring import In, Out

from ..model import timing
from ..model.beat import DELTAS, DELTAS_FAST, WRITES, BeatFormat
from ..model.config import EdgeConfig
from .deltas import DeltaStepper
from .dispatch import SetupArray, check_setup_units
from .layouts import check_config, clip_layout, edge_layout, full_clip
from .pieces import EndPieces
from .setup import ERRORS_BITS, EdgeSetupUnit
from .stepper import LineStepper

__all__ = ["ERRORS_BITS", "LineCore", "PolygonCore", "core_verilog", "flat_verilog", "verilog"]


class _Core(wiring.Component):
    """What both cores share: a setup (one unit, or a `SetupArray`) and a stepper joined by
    the bank stream, the command and window inputs, the output stream of the stepper's format
    (``out``), ``errors`` and ``error``. ``format`` (`edgeaa.model.beat.WRITES` or `DELTAS`)
    is the output's declaration; the timing properties are the timing model's for it
    (`edgeaa.model.timing`), which the tests check against simulated clocks."""

    format: BeatFormat  # each top's own (a class attribute)

    def __init__(self, config, stepper, pieces, errors_bits: int, setup_units: int):
        """`stepper`: the stepper's class; `pieces`: the setup's end-pieces part's class (each
        unit gets its own), or None."""
        self._config = check_config(config)
        self._setup_units = check_setup_units(setup_units)
        steps = self.format.lane_steps  # the setup lanes' steps a clock
        if setup_units == 1:
            part = None if pieces is None else pieces(config)
            self.setup = EdgeSetupUnit(
                config, errors_bits=errors_bits, pieces=part, lane_steps=steps
            )
        else:
            self.setup = SetupArray(
                config, setup_units, errors_bits=errors_bits, pieces=pieces, lane_steps=steps
            )
        self.stepper = stepper = stepper(config)
        for unit in getattr(self.setup, "units", [self.setup]):
            if unit.final_cycles != timing.final_cycles(config, self.format):
                raise ValueError("FINAL's clocks are not the timing model's")
        super().__init__(
            {
                "edges": In(stream.Signature(edge_layout(config))),
                "clip": In(clip_layout(config), init=full_clip(config)),
                self.format.stream: Out(stream.Signature(stepper.out.payload.shape())),
                "errors": Out(unsigned(errors_bits)),
                "error": Out(unsigned(1)),
            }
        )
        self.out = getattr(self, self.format.stream)  # the output stream
        # No edge in the setup, the bank or the stepper (not a port: for a parent's control).
        self.idle = Signal()

    @property
    def errors_bits(self) -> int:
        return self.setup.errors_bits

    @property
    def config(self) -> EdgeConfig:
        return self._config

    @property
    def setup_units(self) -> int:
        """Setup units (`edgeaa.hdl.dispatch.SetupArray` when more than one)."""
        return self._setup_units

    @property
    def run_cycles(self) -> int:
        """`edgeaa.model.timing.run_cycles`: clocks of RUN for an edge not clipped at its
        start."""
        return timing.run_cycles(self._config, fmt=self.format)

    @property
    def start_clip_cycles(self) -> int:
        """`edgeaa.model.timing.start_clip_cycles`: extra RUN clocks of a start-clipped edge."""
        return timing.start_clip_cycles(self._config, self.format)

    @property
    def setup_latency(self) -> int:
        """`edgeaa.model.timing.setup_latency`: clocks from accepting an edge (idle core, not
        clipped at its start) to its first beat."""
        return timing.setup_latency(self._config, self.format)

    @property
    def setup_interval(self) -> int:
        """`edgeaa.model.timing.setup_interval`: clocks per edge the setup sustains (edges of
        at least this many columns keep the stepper busy)."""
        return timing.setup_interval(self._config, self._setup_units, self.format)

    def elaborate(self, platform):
        m = Module()
        m.submodules.setup = setup = self.setup
        m.submodules.stepper = stepper = self.stepper
        # Nothing is accepted while rst is high: ready low, and the setup sees no command.
        rst = ResetSignal(allow_reset_less=True)
        m.d.comb += [
            setup.edges.valid.eq(self.edges.valid & ~rst),
            setup.edges.payload.eq(self.edges.payload),
            self.edges.ready.eq(setup.edges.ready & ~rst),
        ]
        wiring.connect(m, setup.bank, stepper.setup)
        wiring.connect(m, stepper.out, wiring.flipped(self.out))
        m.d.comb += [
            setup.clip.eq(self.clip),
            self.errors.eq(setup.errors),
            self.error.eq(setup.error),
            self.idle.eq(setup.in_idle & ~setup.bank.valid & stepper.idle),
        ]
        return m


class LineCore(_Core):
    """The line core, the paper's method: edge commands in, one beat of pixel writes per
    column out (``writes``, `edgeaa.model.beat.WRITES`), `run_edge` bit for bit. Ports and
    latency: the module docstring; ``setup`` (`EdgeSetupUnit` or `SetupArray`) and
    ``stepper`` (`LineStepper`) are its parts."""

    format = WRITES

    def __init__(
        self,
        config: EdgeConfig,
        *,
        errors_bits: int = ERRORS_BITS,
        setup_units: int = timing.DEFAULT_SETUP_UNITS,
    ):
        super().__init__(config, LineStepper, None, errors_bits, setup_units)


class PolygonCore(_Core):
    """The polygon core: edge commands in, one beat of accumulation deltas per column out
    (``deltas``, `edgeaa.model.beat.DELTAS`), `run_edge_deltas` bit for bit. Ports and
    latency: the module docstring; ``setup`` (`EdgeSetupUnit` with `EndPieces`, or a
    `SetupArray` of them) and ``stepper`` (`DeltaStepper`) are its parts."""

    format = DELTAS  # `fmt`: DELTAS, or DELTAS_FAST (the deeper stepper, the faster setup)

    def __init__(
        self,
        config: EdgeConfig,
        *,
        errors_bits: int = ERRORS_BITS,
        setup_units: int = timing.DEFAULT_SETUP_UNITS,
        fmt: BeatFormat = DELTAS,
    ):
        self.format = fmt
        stepper = functools.partial(DeltaStepper, fmt=fmt)
        # FINAL in two clocks: the y-major total0 product by a multiplier (`DELTAS_FAST`;
        # the format, not FINAL's clocks, says so: with s = 0 the serial product takes two)
        pieces = functools.partial(EndPieces, multiplier=fmt is DELTAS_FAST)
        super().__init__(config, stepper, pieces, errors_bits, setup_units)


# -- Verilog ---------------------------------------------------------------------------------


def _leaves(value, path):
    """(path, value) of each leaf field of a `data.View` payload (or the value itself)."""
    if isinstance(value, data.View):
        layout = data.Layout.cast(value.shape())
        for name, _field in layout:
            yield from _leaves(value[name], (*path, str(name)))
    else:
        yield path, value


def verilog(config: EdgeConfig, *, name: str = "edgeaa_core", flat: bool = True) -> str:
    """The line core of `config` as Verilog (`core_verilog` of `LineCore`)."""
    return core_verilog(LineCore(config), name=name, flat=flat)


def core_verilog(core: _Core, *, name: str = "edgeaa_core", flat: bool = True) -> str:
    """`core` (a `LineCore` or `PolygonCore`) as Verilog (`amaranth.back.verilog.convert`,
    ``emit_src=False``).

    Port names are the signature paths joined by ``__``. With `flat` (the default) every
    payload field is its own port, e.g. ``edges__payload__x0``,
    ``writes__payload__lane1__value``, ``writes__payload__last`` (``deltas__payload__...``
    for the polygon core); a thin wrapper module named `name` connects them to the core
    (instantiated as ``core``). Without `flat` the core is converted directly and each payload
    is one vector port (``edges__payload``), whose fields
    appear only as internal wires.

    The text starts with a comment for integrators (`edgeaa.hdl.integration.header`), and
    the signed outputs are declared ``signed``. Lint: ``verilator --lint-only -Wall`` is
    clean with the waiver file `edgeaa.hdl.integration.lint_waivers` makes of the text.
    """
    from amaranth.back import verilog as back_verilog

    if not flat:
        return back_verilog.convert(core, name=name, emit_src=False)
    return flat_verilog(core, name)


def flat_verilog(component: wiring.Component, name: str, *, annotated: bool = True) -> str:
    """`component` as Verilog under a wrapper module `name` whose ports are the leaves of its
    signature, named by their paths joined by ``__`` (the component instantiated as
    ``core``); `annotated`: with `edgeaa verilog`'s header and signed ports (a core, a
    pipeline or the peripheral; the board's simulated top has neither)."""
    from amaranth.back import verilog as back_verilog

    m = Module()
    m.submodules.core = component
    ports = []  # (name, signal, None): the direction follows from what drives the signal
    for path, member, value in component.signature.flatten(component):
        for leaf_path, leaf in _leaves(value, tuple(map(str, path))):
            port = Signal(leaf.shape(), name="__".join(leaf_path))
            m.d.comb += leaf.eq(port) if member.flow == In else port.eq(leaf)
            ports.append((port.name, port, None))
    from .integration import annotate

    source = back_verilog.convert(m, name=name, ports=ports, emit_src=False)
    if not annotated:
        return source
    signed = [(port.name, len(port)) for _, port, _ in ports if port.shape().signed]
    return annotate(source, component, name, signed)
