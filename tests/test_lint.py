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
