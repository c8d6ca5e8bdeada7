# amaranth: UnusedElaboratable=no
"""Several setup units feeding the stepper in command order (`SetupArray`).

One `edgeaa.hdl.setup.EdgeSetupUnit` accepts an edge every ``P = R + 3 + Phi`` clocks
(`edgeaa.model.timing.setup_interval`: 24 by default, 26 in the deltas core, whose FINAL
takes ``Phi = ceil((s + 2) / 2)`` clocks); short edges leave the stepper idle. `SetupArray`
holds ``N`` units and hands the edge commands to them in turn (round robin, every command,
bad ones included) and takes their banks in the same turn, so the stepper sees the banks in
command order.

* **Dispatch**: a pointer ``d`` names the unit the next command goes to; ``edges.ready`` is
  high when that unit is free (``busy[d]`` low). Accepting a command sets ``busy[d]`` and
  moves ``d`` on. The window on ``clip`` goes to every unit (the one accepting samples it).
* **Collect**: a pointer ``c`` names the unit holding the oldest command. The ``bank``
  stream shows that unit's bank (a multiplexer); when the stepper takes it, ``busy[c]``
  clears and ``c`` moves on. A unit that is busy, back in IDLE and holds no bank dropped its
  command (a bad command, or an edge with no column in its window): ``busy[c]`` clears and
  ``c`` moves on, one clock per dropped command.
* A unit holds at most one command (``busy``), so its FINAL never waits: its bank is valid
  ``R + 3 + Phi`` clocks after it accepted the command (``W + 1`` more when start-clipped).
* The ``bank`` stream holds its payload while it is valid and not taken (``collect`` moves
  only on a retirement, and the unit holds its bank in HOLD): the deltas stepper reads the
  per-edge constants from it while it steps the edge and takes it (the unit retires) when
  it steps the edge's last column.

``errors`` and ``error`` are the units' own counts, joined: a bad command is counted in the
clock its unit's FOLD ends (as the single unit does) and ``error`` pulses in the next clock.
The exact clocks are `edgeaa.model.timing.schedule` with ``setup_units = N``.
"""

from __future__ import annotations

from amaranth.hdl import Array, Module, Mux, Signal, Value, unsigned
from amaranth.lib import stream, wiring
from amaranth.lib.wiring import In, Out

from ..model.config import EdgeConfig
from ..model.timing import MAX_SETUP_UNITS
from .layouts import check_config, clip_layout, edge_layout, full_clip
from .setup import ERRORS_BITS, EdgeSetupUnit

__all__ = ["SetupArray", "check_setup_units"]


def check_setup_units(setup_units) -> int:
    """`setup_units` if it is an integer in [1, `MAX_SETUP_UNITS`], else TypeError."""
    if (
        isinstance(setup_units, bool)
        or not isinstance(setup_units, int)
        or not 1 <= setup_units <= MAX_SETUP_UNITS
    ):
        raise TypeError(
            f"setup_units must be an integer in [1, {MAX_SETUP_UNITS}], not {setup_units!r}"
        )
    return setup_units


class SetupArray(wiring.Component):
    """`units` setup units behind one command stream and one bank stream, in command order.

    Ports as `EdgeSetupUnit`'s: ``edges``, ``clip``, ``bank``, ``errors``, ``error``.
    ``units`` (the `EdgeSetupUnit` list), ``busy`` (one bit per unit), ``dispatch`` and
    ``collect`` (the two pointers) and ``in_idle`` (no command anywhere in the array) are
    attributes for tests and the core. `pieces`: the class of each unit's end-pieces part
    (`edgeaa.hdl.pieces.EndPieces`, called with `config`), None for the line core;
    `lane_steps`: each unit's lane steps a clock (`EdgeSetupUnit`).
    """

    def __init__(
        self,
        config: EdgeConfig,
        units: int,
        *,
        errors_bits: int = ERRORS_BITS,
        pieces=None,
        lane_steps: int = 1,
    ):
        self._config = check_config(config)
        count = check_setup_units(units)
        self.units = [
            EdgeSetupUnit(
                config,
                errors_bits=errors_bits,
                pieces=None if pieces is None else pieces(config),
                accept_in_hold=False,  # offered a command only when free (`busy`)
                lane_steps=lane_steps,
            )
            for _ in range(count)
        ]
        self._errors_bits = errors_bits
        super().__init__(
            {
                "edges": In(stream.Signature(edge_layout(config))),
                "clip": In(clip_layout(config), init=full_clip(config)),
                "bank": Out(stream.Signature(self.units[0].bank.payload.shape())),
                "errors": Out(unsigned(errors_bits)),
                "error": Out(unsigned(1)),
            }
        )
        self.busy = Signal(count, name="busy")
        self.dispatch = Signal(range(count), name="dispatch")
        self.collect = Signal(range(count), name="collect")
        self.in_idle = Signal(name="in_idle")

    @property
    def config(self) -> EdgeConfig:
        return self._config

    @property
    def errors_bits(self) -> int:
        return self._errors_bits

    def elaborate(self, platform):
        m = Module()
        for index, unit in enumerate(self.units):
            m.submodules[f"unit{index}"] = unit
            m.d.comb += unit.clip.eq(self.clip)
        self._dispatch(m)
        self._collect(m)
        self._errors(m)
        m.d.comb += self.in_idle.eq(self.busy == 0)
        return m

    def _next(self, pointer):
        """``pointer + 1`` modulo the number of units."""
        return Mux(pointer == len(self.units) - 1, 0, pointer + 1)

    def _dispatch(self, m) -> None:
        """The command goes to unit ``dispatch`` when it is free."""
        d, busy = self.dispatch, self.busy
        m.d.comb += self.edges.ready.eq(~busy.bit_select(d, 1))
        for index, unit in enumerate(self.units):
            m.d.comb += [
                unit.edges.payload.eq(self.edges.payload),
                # A busy unit must not see the command: back in IDLE after a dropped command
                # it would accept it.
                unit.edges.valid.eq(self.edges.valid & self.edges.ready & (d == index)),
            ]
        with m.If(self.edges.valid & self.edges.ready):
            m.d.sync += d.eq(self._next(d))

    def _collect(self, m) -> None:
        """The bank of unit ``collect`` goes to the stepper; a dropped command is passed."""
        c, busy = self.collect, self.busy
        units = self.units
        valids = Array(unit.bank.valid for unit in units)
        payloads = Array(Value.cast(unit.bank.payload) for unit in units)
        idles = Array(unit.in_idle for unit in units)
        m.d.comb += [
            self.bank.valid.eq(valids[c]),
            Value.cast(self.bank.payload).eq(payloads[c]),
        ]
        for index, unit in enumerate(units):
            m.d.comb += unit.bank.ready.eq(self.bank.ready & (c == index))
        dropped = busy.bit_select(c, 1) & idles[c] & ~valids[c]
        retire = Signal(name="retire")
        m.d.comb += retire.eq((self.bank.valid & self.bank.ready) | dropped)
        accepted = Signal(len(units))
        with m.If(self.edges.valid & self.edges.ready):
            m.d.comb += accepted.eq(1 << self.dispatch)
        retired = Signal(len(units))
        with m.If(retire):
            m.d.comb += retired.eq(1 << c)
            m.d.sync += c.eq(self._next(c))
        m.d.sync += busy.eq((busy | accepted) & ~retired)

    def _errors(self, m) -> None:
        """One saturating count and one pulse for all units (each unit's FOLD detects)."""
        counting = Signal()
        for unit in self.units:
            with m.If(unit.in_fold & unit.accepted["bad"]):
                m.d.comb += counting.eq(1)
        m.d.sync += self.error.eq(counting)
        with m.If(counting & (self.errors != (1 << self._errors_bits) - 1)):
            m.d.sync += self.errors.eq(self.errors + 1)
