"""The docs' numerical checks run with the tests, so a derivation that stops holding fails CI."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_derivations_in_docs_check_out():
    proc = subprocess.run(
        [sys.executable, str(ROOT / "docs" / "check_derivations.py")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-4000:]
