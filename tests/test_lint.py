"""ruff, as configured in pyproject.toml (100 columns), is clean on the whole tree."""

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("command", [["check", "."], ["format", "--check", "."]])
def test_ruff_clean(command):
    ruff = shutil.which("ruff")
    assert ruff, "ruff is a dependency of edgeaa and must be installed"
    proc = subprocess.run([ruff, *command], cwd=ROOT, capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def sim_imports(package: str) -> set[str]:
    """The `edgeaa.sim` packages and modules (`simulators`, `verification`, `synthesis`) that
    the modules of `package` (a folder under sim/, or the module sim/synthesis.py) import."""
    import ast

    path = ROOT / "sim" / package
    files = sorted(path.rglob("*.py")) if path.is_dir() else [path.with_suffix(".py")]
    found = set()
    for file in files:
        parts = ["edgeaa", *file.relative_to(ROOT).with_suffix("").parts]
        for node in ast.walk(ast.parse(file.read_text())):
            if isinstance(node, ast.ImportFrom):
                base = parts[: len(parts) - node.level] if node.level else []
                module = ".".join([*base, *([node.module] if node.module else [])])
                names = [f"{module}.{alias.name}" for alias in node.names]
            elif isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            else:
                continue
            found |= {n.split(".")[2] for n in names if n.startswith("edgeaa.sim.")}
    return found


def test_the_sim_packages_import_each_other_one_way():
    """verification drives the simulators; the simulators, and the synthesis flow, do not
    reach back (the issue-25 split: no package imports another in both directions)."""
    assert sim_imports("simulators") <= {"simulators"}
    assert sim_imports("synthesis") == set()
    assert sim_imports("verification") <= {"simulators", "verification"}
