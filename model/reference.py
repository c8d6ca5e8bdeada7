"""The exact reference: the area of a pixel on the inside of an edge's supporting line.

The same closed form serves floats (numpy arrays) and exact rationals (Fraction): with the
line written as a height h(t) = a + b t over the pixel's span along the major axis
(t in [0, 1], heights measured from the pixel's near boundary along the minor axis), the
area below the line inside the pixel is the integral of clamp(h, 0, 1), which is

    (G(a + b) - G(a)) / b,   G(z) = 0 (z <= 0), z^2 / 2 (0 <= z <= 1), z - 1/2 (z >= 1),

and clamp(a, 0, 1) when b = 0. Derivation and checks: docs/algorithm.md.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from .config import EdgeConfig
from .edge import Edge


def _ramp_integral(z):
    """G(z), the antiderivative of clamp(z, 0, 1) with G(0) = 0."""
    if z <= 0:
        return 0 * z
    if z >= 1:
        return z - Fraction(1, 2) if isinstance(z, Fraction) else z - 0.5
    return z * z / 2


def _clamped_mean(a, b):
    """Mean of clamp(a + b t, 0, 1) over t in [0, 1]."""
    if b == 0:
        return min(max(a, 0 * a), 0 * a + 1)
    return (_ramp_integral(a + b) - _ramp_integral(a)) / b


def _edge_frame(config: EdgeConfig, edge: Edge, number):
    """Pixel-unit endpoints, the major axis, and whether inside lies toward larger minor."""
    scale = config.subpixel_scale
    x0, y0, x1, y1 = (number(v) / scale for v in (edge.x0, edge.y0, edge.x1, edge.y1))
    dx, dy = x1 - x0, y1 - y0
    x_major = abs(dx) >= abs(dy)
    # The left of travel (dx, dy) on the image (y down) is the normal (dy, -dx). Inside lies
    # toward larger minor coordinate when that normal, or its opposite for 'right', points so.
    normal_minor = -dx if x_major else dy
    if edge.inside == "right":
        normal_minor = -normal_minor
    return x0, y0, x1, y1, x_major, normal_minor > 0


def exact_coverage(config: EdgeConfig, edge: Edge, x: int, y: int) -> Fraction:
    """Inside area of pixel (x, y) for the edge's supporting line, as an exact rational."""
    x0, y0, x1, y1, x_major, inside_high = _edge_frame(config, edge, Fraction)
    if x_major:
        p0, q0, dp, dq, p, q = x0, y0, x1 - x0, y1 - y0, x, y
    else:
        p0, q0, dp, dq, p, q = y0, x0, y1 - y0, x1 - x0, y, x
    k = dq / dp
    # Height of the line above the pixel's low boundary (q - 1/2) at the span's start p - 1/2.
    a = q0 + k * (p - Fraction(1, 2) - p0) - (q - Fraction(1, 2))
    below = 1 - _clamped_mean(a, k)  # area on the side of larger minor coordinate
    return below if inside_high else 1 - below


def exact_coverage_array(config: EdgeConfig, edge: Edge, xs, ys) -> np.ndarray:
    """Inside area of pixels (xs[i], ys[i]) as float64, vectorized."""
    x0, y0, x1, y1, x_major, inside_high = _edge_frame(config, edge, float)
    xs, ys = np.asarray(xs, dtype=np.float64), np.asarray(ys, dtype=np.float64)
    if x_major:
        p0, q0, dp, dq, p, q = x0, y0, x1 - x0, y1 - y0, xs, ys
    else:
        p0, q0, dp, dq, p, q = y0, x0, y1 - y0, x1 - x0, ys, xs
    k = dq / dp
    a = q0 + k * (p - 0.5 - p0) - (q - 0.5)
    below = 1.0 - _clamped_mean_array(a, k)
    return below if inside_high else 1.0 - below


def _clamped_mean_array(a: np.ndarray, k: float) -> np.ndarray:
    """Mean of clamp(a + k t, 0, 1) over t in [0, 1] for |k| <= 1, without cancellation.

    (G(a + k) - G(a)) / k subtracts two numbers near 1/2 and divides by a small k when one end
    is clamped; each case below is the same integral written so that nothing cancels.
    """
    if k == 0:
        return np.clip(a, 0.0, 1.0)
    if k < 0:  # run t backwards: the same mean from a + k rising with slope -k
        a, k = a + k, -k
    b = a + k
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.select(
            [b <= 0, a >= 1, (a >= 0) & (b <= 1), a < 0, True],
            [
                0.0,
                1.0,
                a + 0.5 * k,  # no clamping
                np.where(b <= 1, b * b / (2 * k), (b - 0.5) / k),  # the near end clamped at 0
                1.0 - (1.0 - a) ** 2 / (2 * k),  # the far end clamped at 1
            ],
        )


# Fixed-point allowance of one write with the exact accumulator, in units of 2**-F intensity
# LSB: the floors of the loop (docs/algorithm.md, section 9.2), U_N = 1 + the largest floor
# error of the triangle estimate. Strict bounds.
FIXED_POINT_UNITS = {
    "pw": Fraction(1),
    "paper": Fraction(2),
    "seg2": Fraction(5, 2),
    "seg4": Fraction(81, 32),
}


def fixed_point_term(mode: str, accumulator: str, ifix: int, column: int) -> Fraction:
    """The fixed-point part of a write's error bound, as a coverage fraction.

    U / ifix with U = FIXED_POINT_UNITS[mode]; the truncated accumulator adds its drift, less
    than column + 1 units in column `column` (0 = first) of which one is already in U
    (docs/algorithm.md, section 9.3), so U + column. ifix = |I_d| << F units make a pixel.
    """
    units = FIXED_POINT_UNITS[mode] + (column if accumulator == "truncated" else 0)
    return units / ifix


def error_bound(mode: str, k: float) -> float:
    """The estimate's own error bound as a coverage fraction: k/8, k/64, k/256, k/1024."""
    return {"pw": 1 / 8, "paper": 1 / 64, "seg2": 1 / 256, "seg4": 1 / 1024}[mode] * k
