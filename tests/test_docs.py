"""The docs' numerical checks: docs/check_derivations.py with `-m slow` (about 50 s), so a
derivation that stops holding fails that run."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow  # about 50 s: every derivation's numerical check (docs/check_derivations.py)
def test_derivations_in_docs_check_out():
    proc = subprocess.run(
        [sys.executable, str(ROOT / "docs" / "check_derivations.py")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-4000:]
