"""The error budget of the bound tests (test_bounds.py): slope, bound and coverages of a write.

`fixed_point_term` is the model's fixed-point allowance of one write (docs/algorithm.md).
"""

from __future__ import annotations

from fractions import Fraction

from edgeaa.model import Edge, EdgeConfig, EdgeResult, EdgeSetup, Write, error_bound, reference


def fixed_point_term(config: EdgeConfig, setup: EdgeSetup, column: int) -> Fraction:
    """The model's fixed-point allowance of a write in `column` (derived in docs/algorithm.md)."""
    return reference.fixed_point_term(config.mode, config.accumulator, setup.ifix, column)


def write_column(setup: EdgeSetup, write: Write) -> int:
    """Index (0 = first) of the column a write belongs to."""
    return (write.x - setup.x) * setup.col_dx + (write.y - setup.y) * setup.col_dy


def slope(setup: EdgeSetup) -> Fraction:
    """k = |minor delta| / |major delta| of the folded edge."""
    return Fraction(setup.dv, setup.du)


def bound(config: EdgeConfig, setup: EdgeSetup) -> Fraction:
    """The estimate's own bound k/8, k/64, k/256 or k/1024 as an exact rational."""
    per_k = {"pw": 8, "paper": 64, "seg2": 256, "seg4": 1024}[config.mode]
    value = slope(setup) / per_k
    assert abs(float(value) - error_bound(config.mode, float(slope(setup)))) < 1e-15
    return value


def model_coverage(result: EdgeResult, write: Write) -> Fraction:
    """EdgeResult.coverage as an exact rational (the float it returns is this, rounded)."""
    area_a = Fraction(write.area, result.setup.ifix)
    cov = area_a if result.setup.inside_is_a else 1 - area_a
    assert abs(float(cov) - result.coverage(write)) <= 1e-15
    return cov


def output_coverage(config: EdgeConfig, edge: Edge, write: Write) -> Fraction:
    """(value - I_out) / (I_in - I_out): the coverage the rounded output intensity stands for."""
    i_in, i_out = edge.intensities(config)
    return Fraction(write.value - i_out, i_in - i_out)


def column_pixels(setup: EdgeSetup, column: int, x: int, y: int, reach: int = 2):
    """The pixels of a column around its primary pixel (x, y), rows -reach .. +reach."""
    return [(x + r * setup.row_dx, y + r * setup.row_dy) for r in range(-reach, reach + 1)]
