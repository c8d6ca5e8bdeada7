"""The emitted Verilog as a block in someone else's design (docs/hardware.md, "Integration").

`edgeaa verilog` writes what this module makes of Amaranth's Verilog:

* `sign_ports`: the signed output ports (the beat's ``x``, ``y``, ``delta``) declared
  ``signed``; Amaranth's Verilog back end declares every port unsigned.
* `header`: a comment at the top of the file naming the signed ports, the inputs that must be
  driven (with the clip window's tie-off values), the reset behaviour and the lint command.
* `must_drive`: the inputs that have no safe meaning when left undriven, for the header and
  the command's note on standard error.
* `name_error`: why a module name cannot be used (not a plain Verilog identifier, or one of
  the Verilog-2005 and SystemVerilog-2017 keywords, `KEYWORDS`), for `edgeaa verilog --name`.
* `lint_waivers`: the Verilator configuration file (``.vlt``) that makes ``verilator
  --lint-only -Wall`` clean. Every waiver is one rule on the lines of one file (``-file``,
  ``-lines``), chosen by the shape of the line Yosys wrote (`WAIVERS`), and explained. A
  warning on a line of any other shape stays a warning: lint fails and a person looks.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = [
    "KEYWORDS",
    "MAX_NAME",
    "WAIVERS",
    "WAIVER_FILENAME",
    "Waiver",
    "annotate",
    "header",
    "lint_waivers",
    "must_drive",
    "name_error",
    "sign_ports",
]

# -- module names -------------------------------------------------------------------------------

# The reserved words of IEEE 1800-2017 (SystemVerilog) Annex B, which include every one of IEEE
# 1364-2005 (Verilog) Annex B: a module named `always`, `wire` or `logic` cannot be written
# plainly (Yosys escapes it, `\always `), and a user's tools may read either language.
KEYWORDS = frozenset(
    """
    accept_on alias always always_comb always_ff always_latch and assert assign assume
    automatic before begin bind bins binsof bit break buf bufif0 bufif1 byte case casex casez
    cell chandle checker class clocking cmos config const constraint context continue cover
    covergroup coverpoint cross deassign default defparam design disable dist do edge else end
    endcase endchecker endclass endclocking endconfig endfunction endgenerate endgroup
    endinterface endmodule endpackage endprimitive endprogram endproperty endspecify
    endsequence endtable endtask enum event eventually expect export extends extern final
    first_match for force foreach forever fork forkjoin function generate genvar global highz0
    highz1 if iff ifnone ignore_bins illegal_bins implements implies import incdir include
    initial inout input inside instance int integer interconnect interface intersect join
    join_any join_none large let liblist library local localparam logic longint macromodule
    matches medium modport module nand negedge nettype new nexttime nmos nor noshowcancelled
    not notif0 notif1 null or output package packed parameter pmos posedge primitive priority
    program property protected pull0 pull1 pulldown pullup pulsestyle_ondetect
    pulsestyle_onevent pure rand randc randcase randsequence rcmos real realtime ref reg
    reject_on release repeat restrict return rnmos rpmos rtran rtranif0 rtranif1 s_always
    s_eventually s_nexttime s_until s_until_with scalared sequence shortint shortreal
    showcancelled signed small soft solve specify specparam static string strong strong0
    strong1 struct super supply0 supply1 sync_accept_on sync_reject_on table tagged task this
    throughout time timeprecision timeunit tran tranif0 tranif1 tri tri0 tri1 triand trior
    trireg type typedef union unique unique0 unsigned until until_with untyped use uwire var
    vectored virtual void wait wait_order wand weak weak0 weak1 while wildcard wire with within
    wor xnor xor
    """.split()  # noqa: SIM905 (the standard's table, as it reads)
)
MAX_NAME = 64  # characters of a module name (the standards allow 1,024; tools often fewer)
# A simple identifier that Yosys writes as it is: a letter or _, then letters, digits and _.
# The standards also allow $ after the first character, but Yosys escapes such a name
# (`\a$b `), so the module would not be found under the name asked for.
_PLAIN_NAME = re.compile(rf"[A-Za-z_][A-Za-z0-9_]{{0,{MAX_NAME - 1}}}", re.ASCII)


def name_error(name: str) -> str | None:
    """Why `name` cannot name the top module, or None when it can."""
    if name in KEYWORDS:
        return f"{name} is a Verilog/SystemVerilog keyword; choose another name"
    if not _PLAIN_NAME.fullmatch(name):
        return (
            f"must be a plain Verilog identifier (a letter or _, then letters, digits or _; "
            f"at most {MAX_NAME} characters; no $, which Yosys would escape)"
        )
    return None


# -- the shapes of the lines Yosys's write_verilog emits --------------------------------------

_NAME = r"(?:\\\S+ |[A-Za-z_][\w$]*)"  # plain or escaped (ends with a space) identifier
_SLICE = r"(?: ?\[\d+(?::\d+)?\])?"
_CONST = r"\d+'s?[bodh][0-9a-fA-FxXzZ_]+"
_PART = rf"(?:{_NAME}{_SLICE}|{_CONST})"
_CONCAT = rf"\{{ (?:{_PART}, )*{_PART} \}}"
_OPERAND = rf"(?:\$signed\((?:{_CONCAT}|{_PART})\)|{_CONCAT}|{_PART})"
_ASSIGN = rf"^\s*assign (?P<lhs>{_NAME}){_SLICE} ?= "

_CELL = re.compile(rf"{_ASSIGN}{_OPERAND} (?:\+|-|<|<=|>|>=|==|!=) {_OPERAND};$")
_ZERO_TEST = re.compile(rf"{_ASSIGN}! {_OPERAND};$")
_SHIFT_RIGHT = re.compile(rf"{_ASSIGN}{_OPERAND} >> {_OPERAND};$")
_DECLARATION = re.compile(rf"^\s*(?:wire|reg)(?: signed)?(?: \[\d+:\d+\])? (?P<name>{_NAME})")
_INPUT = re.compile(rf"^\s*input(?: signed)?(?: \[\d+:\d+\])? (?P<name>{_NAME})")
_PORT = re.compile(rf"^\s*(?:input|output)(?: signed)?(?: \[\d+:\d+\])? (?P<name>{_NAME})")
_REG_INIT = re.compile(rf"^\s*reg(?: signed)?(?: \[\d+:\d+\])? {_NAME} ?= {_CONST};$")
_CASEZ = re.compile(r"^\s*casez \(")
_MODULE = re.compile(rf"^module (?P<name>{_NAME})")


@dataclass(frozen=True)
class Waiver:
    """One kind of waived warning: a Verilator rule on the lines of one shape."""

    rule: str
    shape: str  # what the lines look like (the .vlt comment)
    reason: str  # why the warning says nothing about the design

    def matches(self, line: str, scope: _Scope) -> bool:
        return _MATCHERS[self.shape](line, scope)


@dataclass
class _Scope:
    """The module a line is in: its name, whether it is the top, its 1-bit wires."""

    name: str = ""
    top: bool = False
    one_bit: set[str] | None = None
    ports: set[str] | None = None  # the top's ports declared so far


WAIVERS = (
    Waiver(
        "WIDTHEXPAND",
        "assign w = a OP b; (one Yosys cell: + - < <= > >= == !=)",
        "the operands are extended to the cell's width, by sign when written $signed(...) "
        "and by zeros otherwise: the cell's semantics, which Amaranth's arithmetic rules "
        "define (a + b is one bit wider than the wider operand; a compare extends both)",
    ),
    Waiver(
        "WIDTHTRUNC",
        "assign w = ! v; (a zero test of a vector)",
        "! of a vector is 1 exactly when every bit is 0 (Amaranth's v == 0, which Yosys "
        "writes as a logical not): no bit is lost",
    ),
    Waiver(
        "WIDTHTRUNC",
        "assign w = a >> b; into a 1-bit w (a bit select)",
        "Amaranth's a.bit_select(b, 1): bit b of a, written by Yosys as a shift whose result "
        "keeps its lowest bit",
    ),
    Waiver(
        "UNUSEDSIGNAL",
        "wire/reg declarations, and inputs of the submodules (never the top's ports)",
        "Amaranth names a wire for every payload field, intermediate and observed signal "
        "(formal checks and parents read some); an unused one, or its unused high bits "
        "(an intermediate one bit wider than the register it feeds), drives nothing. An "
        "input of the top that nothing reads would still be reported",
    ),
    Waiver(
        "PROCASSINIT",
        "reg r = CONST; (a register's declaration)",
        "the register's initial value is its reset value; the always block assigns it again "
        "under rst (Amaranth's reset semantics, the same in synthesis and simulation)",
    ),
    Waiver(
        "CASEINCOMPLETE",
        "casez (...) (a switch of a process)",
        "each process assigns its default value before the casez, so an unlisted value "
        "(an unreachable state encoding, an unmatched switch) keeps it: no latch, no X",
    ),
    Waiver(
        "DECLFILENAME",
        "module ... (a module header)",
        "one file holds the top and its submodules (named top.child), and the file's name "
        "is the user's choice",
    ),
)


def _is_bit_select(line: str, scope: _Scope) -> bool:
    match = _SHIFT_RIGHT.match(line)
    return bool(match) and match["lhs"].strip() in (scope.one_bit or ())


def _is_unused_candidate(line: str, scope: _Scope) -> bool:
    declared = _DECLARATION.match(line)
    if declared:  # not the wire Yosys declares again for each of the top's ports
        return declared["name"].strip() not in (scope.ports or ())
    return not scope.top and bool(_INPUT.match(line))


_MATCHERS = {
    WAIVERS[0].shape: lambda line, scope: bool(_CELL.match(line)),
    WAIVERS[1].shape: lambda line, scope: bool(_ZERO_TEST.match(line)),
    WAIVERS[2].shape: _is_bit_select,
    WAIVERS[3].shape: _is_unused_candidate,
    WAIVERS[4].shape: lambda line, scope: bool(_REG_INIT.match(line)),
    WAIVERS[5].shape: lambda line, scope: bool(_CASEZ.match(line)),
    WAIVERS[6].shape: lambda line, scope: bool(_MODULE.match(line)),
}


def _scopes(lines: list[str]) -> list[_Scope]:
    """The module of each line (the top: the module after ``(* top = 1 *)``)."""
    scopes, scope, top_next = [], _Scope(), False
    for line in lines:
        if re.match(r"^\(\* top = +1 +\*\)", line):
            top_next = True
        match = _MODULE.match(line)
        if match:
            scope = _Scope(match["name"].strip(), top_next, set(), set())
            top_next = False
        port = _PORT.match(line)
        if port and scope.top:
            scope.ports.add(port["name"].strip())
        declared = _DECLARATION.match(line)
        if declared and scope.one_bit is not None and not re.search(r"\[\d+:\d+\]", line):
            scope.one_bit.add(declared["name"].strip())
        scopes.append(scope)
    return scopes


def _runs(numbers: list[int]) -> list[tuple[int, int]]:
    """Consecutive line numbers as (first, last) runs."""
    runs: list[tuple[int, int]] = []
    for n in numbers:
        if runs and runs[-1][1] == n - 1:
            runs[-1] = (runs[-1][0], n)
        else:
            runs.append((n, n))
    return runs


# The Verilog file names a waiver file can point at (`-file "*name"`, no quoting needed).
WAIVER_FILENAME = re.compile(r"[\w.+-]+")
WAIVER_HEADER = "// Lint waivers for {filename}, written with it by `edgeaa verilog`"


def lint_waivers(source: str, filename: str) -> str:
    """The Verilator configuration file that waives, in the Verilog `source` written to a
    file named `filename` (its base name), exactly the `WAIVERS` lines: one ``lint_off
    -rule R -file "*filename" -lines A-B`` per run of lines of one shape. Pass it before
    the Verilog: ``verilator --lint-only -Wall core.vlt core.v``."""
    if not WAIVER_FILENAME.fullmatch(filename):
        raise ValueError(f"filename must be a plain file name, not {filename!r}")
    lines = source.splitlines()
    scopes = _scopes(lines)
    out = [
        "`verilator_config",
        WAIVER_HEADER.format(filename=filename) + ": valid only for",
        "// that exact text (line numbers). Use: verilator --lint-only -Wall <this file> "
        f"{filename}",
        "// Each waiver is one rule on lines of one shape; why that warning says nothing",
        "// about the design is above its lines. Any other warning is reported.",
    ]
    for waiver in WAIVERS:
        numbers = [i + 1 for i, line in enumerate(lines) if waiver.matches(line, scopes[i])]
        if not numbers:
            continue
        out += ["", f"// {waiver.rule} on {waiver.shape}: {len(numbers)} lines.", "//"]
        out += [f"//   {part}" for part in _wrap(waiver.reason, 84)]
        for first, last in _runs(numbers):
            span = str(first) if first == last else f"{first}-{last}"
            out.append(f'lint_off -rule {waiver.rule} -file "*{filename}" -lines {span}')
    return "\n".join(out) + "\n"


def _wrap(text: str, width: int) -> list[str]:
    """`text` in lines of at most `width` characters (longer words alone), its leading
    spaces kept on the first."""
    lines, line = [], text[: len(text) - len(text.lstrip())]
    for word in text.split():
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = word
        else:
            line = f"{line} {word}" if line.strip() else line + word
    return [*lines, line] if line else lines


# -- ports ------------------------------------------------------------------------------------


def sign_ports(source: str, top: str, names: list[str]) -> str:
    """`source` with the output ports `names` of module `top` declared ``signed``. Only a
    port that the top module drives by one plain assignment (``assign port = ...;``) is
    changed, where the declaration cannot change any value; anything else raises."""
    lines = source.splitlines(keepends=True)
    opening = re.compile(rf"^module {re.escape(top)}\(")
    start = next(i for i, line in enumerate(lines) if opening.match(line))
    start = next(i for i in range(start, len(lines)) if lines[i].rstrip().endswith(");"))
    end = next(i for i in range(start, len(lines)) if lines[i].startswith("endmodule"))
    for name in names:
        declaration = re.compile(rf"^(\s*)(output|wire)( \[\d+:0\] {name};\n)$")
        uses = [i for i in range(start + 1, end) if re.search(rf"(?<![\w$.]){name}\b", lines[i])]
        shapes = [
            "decl" if declaration.match(lines[i]) else "assign" if _assigns(lines[i], name) else i
            for i in uses
        ]
        if sorted(shapes, key=str) != ["assign", "decl", "decl"]:
            raise ValueError(f"cannot declare {name} signed: it is used as {shapes}")
        for i in uses:
            lines[i] = declaration.sub(r"\1\2 signed\3", lines[i])
    return "".join(lines)


def _assigns(line: str, name: str) -> bool:
    return bool(re.match(rf"^\s*assign {name} = [^;]*;$", line))


# -- what a user must drive, and the header -----------------------------------------------------


# The peripherals' register windows by top kind: what must be driven, and the header's lines.
WINDOWS = {
    "peripheral": (
        "bus__cyc, bus__stb (0 when idle) and the other bus__* inputs",
        ["bus__* (the register window, a target) is Wishbone B4 pipelined, 32-bit data, word",
         "  addresses, byte lanes."],
    ),
    "axi-lite peripheral": (
        "axi__awvalid, axi__wvalid, axi__arvalid (0 when idle), axi__bready, axi__rready and "
        "the other axi__* inputs",
        ["axi__* (the register window, a subordinate) is AXI4-Lite, 32-bit data, byte",
         "  addresses (4 times the word offset), write strobes; one transaction at a time."],
    ),
}  # fmt: skip


def must_drive(top_kind: str, config, stream: str = "") -> list[str]:
    """The inputs that must be driven, one line each (`top_kind`: "core", "pipeline" or a
    peripheral's, `WINDOWS`;
    `stream`: the core's output stream, `edgeaa.model.beat.BeatFormat.stream`)."""
    if top_kind == "core":
        full = 1 << config.coord_bits
        return [
            f"clk, rst (synchronous, active high), edges__valid and {stream}__ready",
            f"clip__x_min, clip__y_min, clip__x_max, clip__y_max: no default; tie them to "
            f"0, 0, {full}, {full} to clip nothing (undriven, Verilator reads 0: the window "
            "(0, 0, 0, 0) steps only column 0 or row 0, most edges give no beat; a 4-state "
            "simulator reads X and the core's state goes X)",
        ]
    if top_kind in WINDOWS:
        return [
            f"clk, rst (synchronous, active high); {WINDOWS[top_kind][0]}; fb__ack, fb__stall, "
            "fb__err and dl__ack, dl__stall, dl__err (0 when unused)"
        ]
    return ["clk, rst (synchronous, active high), commands__valid and pixels__ready"]


def header(
    *, name: str, what: str, config, top_kind: str, stream: str, signed: list[tuple[str, int]]
) -> str:
    """The comment `edgeaa verilog` puts at the top of the file."""
    lines = [
        f"module {name}: {what}, {config}",
        "Written by `edgeaa verilog`; docs/hardware.md, 'Ports' and 'Integration'.",
        "Connect by name (.port(signal)): the port order below is Yosys's, not the table's.",
    ]
    if signed:
        lines.append("Signed ports (two's complement, declared signed): " + ", ".join(
            f"{port} [{bits - 1}:0]" for port, bits in signed
        ) + "; every other port is unsigned.")  # fmt: skip
    else:
        lines.append("Every port is unsigned.")
    lines.append("Must be driven (a Verilog input has no default):")
    lines += [f"  {item}" for item in must_drive(top_kind, config, stream)]
    if top_kind in WINDOWS:
        lines += [
            *WINDOWS[top_kind][1],
            "fb__* (the framebuffer writes, an initiator) and dl__* (the display-list reads, an",
            "  initiator) are Wishbone B4 pipelined, 32-bit data, word addresses, byte lanes;",
            "  docs/hardware.md, 'Integrating edgeaa', has the register map.",
            "Reset: one clock of rst clears every register, the FIFO, the pipeline and the",
            "  counters; the pipeline then clears its tile (one clock a pixel) before pixels.",
        ]
    else:
        lines += [
            "Payload inputs are sampled only in the clock a command is accepted (valid & ready).",
            "Reset: while rst is high the input stream's ready is low (nothing is accepted);",
            "  one clock of rst clears every edge in flight, the counters and the output's valid.",
        ]
    lines += [
        "Lint: verilator --lint-only -Wall FILE.vlt FILE.v, with the waiver file written",
        "  beside this one (for this exact text).",
    ]
    out = []
    for line in lines:
        indent = "  " if line.startswith("  ") else ""
        wrapped = _wrap(line, 92)
        out += [wrapped[0]] + [f"{indent}  {rest}" for rest in wrapped[1:]]
    return "".join(f"// {line}\n" for line in out)


def annotate(source: str, component, name: str, signed: list[tuple[str, int]]) -> str:
    """`flat_verilog`'s text as `edgeaa verilog` writes it: the `signed` (port, width) outputs
    declared signed and the `header` on top. `component` is the core or the pipeline."""
    tile = getattr(component, "tile", None)
    if tile is not None:
        kind, config, stream = getattr(component, "top_kind", "pipeline"), tile.config, ""
        what = f"the edgeaa polygon {kind}, tile {tile.width}x{tile.height}"
        what += f", {tile.channels} channels" * (tile.channels > 1)  # grey: as it was
    else:
        kind, config, stream = "core", component.config, component.format.stream
        what = f"the edgeaa {stream} core"
    source = sign_ports(source, name, [port for port, _ in signed])
    text = header(name=name, what=what, config=config, top_kind=kind, stream=stream, signed=signed)
    return text + source
