"""The radix experiment of issue 12 (benchmarks/lane_radix.py): both lanes divide exactly, and
the check catches a lane stopped one clock early."""

import importlib.util
from pathlib import Path

import pytest

from edgeaa.model.config import EdgeConfig

_PATH = Path(__file__).resolve().parent.parent / "benchmarks" / "lane_radix.py"
_SPEC = importlib.util.spec_from_file_location("lane_radix", _PATH)
lane_radix = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(lane_radix)


@pytest.mark.parametrize("lane", [lane_radix.Radix2Lane, lane_radix.Radix4Lane])
def test_lane_divides_exactly(lane, capsys):
    lane_radix.check(lane, EdgeConfig(), count=40, seed=3)
    assert "40 divisions equal divmod" in capsys.readouterr().out


def test_short_lane_is_caught():
    class Short(lane_radix.Radix4Lane):
        def __init__(self, config):
            super().__init__(config)
            self.clocks -= 1

    with pytest.raises(SystemExit, match="wrong of 40"):
        lane_radix.check(Short, EdgeConfig(), count=40, seed=3)
