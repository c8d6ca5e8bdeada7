# amaranth: UnusedElaboratable=no
"""`FormalHarness`: the core with free inputs and the check groups, covers and faults asked
for (docs/hardware.md, "The harness, its check groups and faults", describes them)."""

from __future__ import annotations

import types

from amaranth.asserts import AnySeq
from amaranth.hdl import Assert, Assume, ClockDomain, Elaboratable, Fragment, Module, Signal, Value

from ....hdl.core import LineCore, PolygonCore
from ....model.config import EdgeConfig
from .bounds import check as check_bounds
from .count import capacity
from .count import check as check_count
from .covers import add as add_covers
from .deltas import DELTA_CHECKS
from .deltas import check as check_deltas
from .pipeline import check as check_pipeline
from .stream import check as check_stream
from .stream import held as hold_flag

__all__ = [
    "ClockedHarness",
    "CHECKS",
    "COVERS",
    "DELTA_CHECKS",
    "FAULTS",
    "LINE_CHECKS",
    "FormalHarness",
    "capacity",
]

LINE_CHECKS = ("pipe", "beat", "minor")  # the writes core's pipeline
CHECKS = ("stream", "count", "bounds", *LINE_CHECKS, *DELTA_CHECKS)
COVERS = ("drop", "stepper", "deltas")
# Each core's stepper pipeline: its check groups, its cover and the family that checks it (the
# proofs move with the parts: the harness builds the core it proves).
_PIPELINES = {
    LineCore: (LINE_CHECKS, "stepper", check_pipeline),
    PolygonCore: (DELTA_CHECKS, "deltas", check_deltas),
}
FAULTS = ("stall_payload", "stall_bank", "silent_drop", "tight_jq", "tight_hs")


def _choose(name: str, value, allowed) -> tuple[str, ...]:
    value = tuple(value)
    unknown = [item for item in value if item not in allowed]
    if unknown:
        raise ValueError(f"{name} must be among {', '.join(allowed)}, not {unknown}")
    return value


def _check_pipeline_groups(top, groups, covers) -> None:
    """The pipeline groups and covers of the other core do not apply."""
    other = set()
    for core, (checks, cover, _) in _PIPELINES.items():
        if core is not top:
            other |= {*checks, cover}
    wrong = sorted(other & (set(groups) | set(covers)))
    if wrong:
        raise ValueError(f"{', '.join(wrong)} do not apply to {top.__name__}")


class ClockedHarness(Elaboratable):
    """A formal harness's clock domain ``sync``, its clock a port (``clk``, what
    `harness_rtlil` lists): Amaranth ties an undriven clock to 0 (a frozen design).
    ``reset``: the domain's reset is the harness's to drive (else it has none)."""

    def __init__(self, reset: bool):
        self.reset = reset
        self.domain = ClockDomain("sync", reset_less=not reset)

    @property
    def clk(self) -> Signal:
        return self.domain.clk


class FormalHarness(ClockedHarness):
    """The core with free inputs and the properties of `checks` (docs/hardware.md, "The
    harness, its check groups and faults").

    ``reset``: the reset is a free input (else the domain has no reset). ``covers``: add the
    Cover statements. ``assumes``: check groups proven elsewhere, assumed here. ``fault``: one
    of `FAULTS`, a deliberate error the checks must catch. ``top``: the core proven,
    `LineCore` (its pipeline groups `LINE_CHECKS`, its cover ``stepper``) or `PolygonCore`
    (`DELTA_CHECKS`, its cover ``deltas``); the other core's groups do not apply. ``fmt``:
    the polygon core's output, if not its default (`edgeaa.model.beat.DELTAS_FAST`: the
    fast pipeline's core, its stepper with p3 and its setup multiplying in FINAL).
    """

    def __init__(
        self,
        config: EdgeConfig | None = None,
        checks=("stream", "count", "bounds"),
        *,
        covers=(),
        assumes=(),
        reset: bool = True,
        fault: str | None = None,
        top=LineCore,
        fmt=None,
    ):
        self.config = EdgeConfig() if config is None else config
        if not isinstance(self.config, EdgeConfig):
            raise TypeError(f"config must be an EdgeConfig, not {config!r}")
        self.checks = _choose("checks", checks, CHECKS)
        if fault is not None and fault not in FAULTS:
            raise ValueError(f"fault must be one of {', '.join(FAULTS)} or None, not {fault!r}")
        covers = COVERS if covers is True else () if covers is False else covers
        self.covers = _choose("covers", covers, COVERS)
        self.assumes = _choose("assumes", assumes, CHECKS)
        super().__init__(reset)
        self.fault = fault
        if top not in _PIPELINES:
            raise TypeError(f"top must be LineCore or PolygonCore, not {top!r}")
        self.top = top
        _check_pipeline_groups(top, self.checks + self.assumes, self.covers)
        # One setup unit: the properties observe its internals (`SetupArray` is checked in
        # simulation, tests/test_setup_array.py).
        if fmt is not None and top is not PolygonCore:
            raise TypeError(f"fmt applies to PolygonCore, not {top.__name__}")
        output = {} if fmt is None else {"fmt": fmt}
        self.core = top(self.config, setup_units=1, **output)

    def elaborate(self, platform):
        m = Module()
        core = self.core
        # Elaborated here: the deltas stepper makes its observation points as it elaborates.
        m.submodules.dut = Fragment.get(core, platform)
        m.domains.sync = self.domain
        if self.reset:
            m.d.comb += self.domain.rst.eq(AnySeq(1))
        edges = core.edges
        m.d.comb += [
            edges.valid.eq(AnySeq(1)),
            edges.payload.eq(AnySeq(len(Value.cast(edges.payload)))),
            # The window is free in every clock: the core must sample it with the command.
            Value.cast(core.clip).eq(AnySeq(len(Value.cast(core.clip)))),
            core.out.ready.eq(AnySeq(1)),
        ]
        ctx = self._context(m)
        check_pipeline_of = _PIPELINES[self.top][2]
        stepper_covers = bool({"stepper", "deltas"} & set(self.covers))
        if "stream" in self.checks or stepper_covers:
            check_stream(ctx)
        wanted = set(self.checks) | set(self.assumes)
        if "count" in wanted or self.covers:
            check_count(ctx)
        if wanted & {"bounds", *LINE_CHECKS, *DELTA_CHECKS} or stepper_covers:
            check_bounds(ctx)
            check_pipeline_of(ctx)
        add_covers(ctx)
        return m

    def _context(self, m) -> types.SimpleNamespace:
        """What the check families share: the module, the core and its two parts, what they
        observe of the outputs (faults act here), and `emit`."""
        core = self.core
        out = core.out
        stepper = core.stepper
        ctx = types.SimpleNamespace(
            m=m,
            config=self.config,
            format=core.format,  # the output's declaration (`edgeaa.model.beat`)
            core=core,
            setup=core.setup,
            stepper=stepper,
            out=out,  # the output stream: writes or deltas
            layout=out.payload.shape(),
            # The stages before the output register, each with valid and last.
            stages=stepper.stages,
            checks=self.checks,
            assumes=self.assumes,
            covers=self.covers,
            fault=self.fault,
            emit=self._emit(m),
        )
        ctx.payload = Value.cast(out.payload)
        ctx.error = core.error
        held = hold_flag(m, out)  # a beat was valid and not taken in the previous clock
        if self.fault == "stall_payload":
            ctx.payload = ctx.payload ^ held
        if self.fault == "silent_drop":
            ctx.error = Value.cast(0)
        ctx.held = held
        return ctx

    def _emit(self, m):
        def emit(group, condition, message):
            """An Assert if `group` is checked, an Assume if it is assumed (proven
            elsewhere)."""
            if group in self.checks:
                m.d.comb += Assert(condition, message)
            elif group in self.assumes:
                m.d.comb += Assume(condition, message)

        return emit
