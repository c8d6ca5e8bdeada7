"""The configuration shared by the model and the hardware: widths, estimate and accumulator.

Every register of the stepping loop has its width derived here (`register_widths`), so the
model can check each value it computes and the hardware can declare the same signals.
See docs/model.md for the reasoning behind each width.
"""

from __future__ import annotations

from dataclasses import dataclass, field

MODES = ("pw", "paper", "seg2", "seg4")
ACCUMULATORS = ("exact", "truncated")

# Segments of the add-only correction per mode (0: one pixel per column, no correction).
SEGMENTS = {"pw": 0, "paper": 1, "seg2": 2, "seg4": 4}

COORD_BITS_RANGE = (2, 16)
SUBPIXEL_BITS_RANGE = (0, 8)
INTENSITY_BITS_RANGE = (1, 16)

# Fixed-point units (2**-F of an intensity LSB) one edge adds to a pixel with the exact
# accumulator, at most (docs/algorithm.md 9.2 and 13.6: 81/32 on a line, at most 3.56 measured
# in a polygon's sums; docs/check_derivations.py [D7]). A power of two: it sets F.
UNITS_PER_EDGE = 4


class ConfigError(ValueError):
    """A configuration value outside what the model and the hardware support."""


@dataclass(frozen=True)
class RegisterWidth:
    bits: int
    signed: bool = False

    @property
    def min(self) -> int:
        return -(1 << (self.bits - 1)) if self.signed else 0

    @property
    def max(self) -> int:
        return (1 << (self.bits - 1)) - 1 if self.signed else (1 << self.bits) - 1

    def holds(self, value: int) -> bool:
        return self.min <= value <= self.max


def _check_int(name: str, value, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(f"{name} must be an integer in [{lo}, {hi}], not {value!r}")
    if not lo <= value <= hi:
        raise ConfigError(f"{name} must be in [{lo}, {hi}], not {value}")
    return value


@dataclass(frozen=True)
class EdgeConfig:
    """Widths and choices of one edge antialiaser.

    coord_bits:     integer bits of a vertex coordinate; vertices lie in [0, 2**coord_bits).
    subpixel_bits:  fractional bits of a vertex coordinate (vertex step 2**-subpixel_bits).
    intensity_bits: bits of an output intensity; full scale is 2**intensity_bits - 1.
    frac_bits:      fraction bits of the accumulator below one intensity LSB. None derives it
                    from the error budget (see `derived_frac_bits`).
    mode:           coverage estimate: pw, paper, seg2 or seg4.
    accumulator:    exact (quotient and remainder, no drift) or truncated (fixed-point slope).
    """

    coord_bits: int = 11
    subpixel_bits: int = 4
    intensity_bits: int = 8
    frac_bits: int | None = None
    mode: str = "paper"
    accumulator: str = "exact"
    _frac_bits: int = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        _check_int("coord_bits", self.coord_bits, *COORD_BITS_RANGE)
        _check_int("subpixel_bits", self.subpixel_bits, *SUBPIXEL_BITS_RANGE)
        _check_int("intensity_bits", self.intensity_bits, *INTENSITY_BITS_RANGE)
        if self.mode not in MODES:
            raise ConfigError(f"mode must be one of {', '.join(MODES)}, not {self.mode!r}")
        if self.accumulator not in ACCUMULATORS:
            raise ConfigError(
                f"accumulator must be one of {', '.join(ACCUMULATORS)}, not {self.accumulator!r}"
            )
        frac_bits = self.derived_frac_bits() if self.frac_bits is None else self.frac_bits
        # The initial value is scaled by 2**(F - s - 1), a left shift only for F >= s + 1. The
        # correction constants are K/2**(6 + 2 log2 N): F below that leaves them no resolution.
        _check_int("frac_bits", frac_bits, self.min_frac_bits, 48)
        object.__setattr__(self, "_frac_bits", frac_bits)

    # -- derived sizes ---------------------------------------------------------------------

    @property
    def F(self) -> int:
        """Fraction bits of the accumulator in use (derived or overridden)."""
        return self._frac_bits

    @property
    def segments(self) -> int:
        return SEGMENTS[self.mode]

    @property
    def subpixel_scale(self) -> int:
        return 1 << self.subpixel_bits

    @property
    def full_scale(self) -> int:
        return (1 << self.intensity_bits) - 1

    @property
    def max_vertex(self) -> int:
        """Largest vertex coordinate in sub-pixel units (2**coord_bits - 2**-s in pixels)."""
        return (1 << (self.coord_bits + self.subpixel_bits)) - 1

    @property
    def max_columns(self) -> int:
        """At most the columns one edge can step: pixel centres 0 .. 2**coord_bits inclusive."""
        return (1 << self.coord_bits) + 1

    @property
    def min_frac_bits(self) -> int:
        return max(self.subpixel_bits + 1, 6 + 2 * max(self.segments.bit_length() - 1, 0))

    def derived_frac_bits(self) -> int:
        """Fraction bits from the error budget of docs/model.md: the fixed-point error one
        edge adds to a pixel's coverage stays within 2**-(I + 1) even at the smallest
        intensity difference |I_d| = 1, where one unit of 2**-F LSB is 2**-F of coverage.

        exact:     no drift; an edge adds fewer than `UNITS_PER_EDGE` = 4 units to a pixel
                   (the estimate's floors, the quotient's, the end pieces'), so
                   4 * 2**-F <= 2**-(I + 1), F = I + 3.
        truncated: the dropped remainder of the slope drifts by less than one unit a column,
                   max_columns units over the longest edge: F = ceil(log2(max_columns)) + I + 1.
        """
        if self.accumulator == "exact":
            units_log2 = (UNITS_PER_EDGE - 1).bit_length()
        else:
            units_log2 = (self.max_columns - 1).bit_length()  # ceil(log2(max_columns))
        return max(units_log2 + self.intensity_bits + 1, self.min_frac_bits)

    def register_widths(self) -> dict[str, RegisterWidth]:
        """The width table of the stepping loop, shared with the hardware."""
        W, s = self.coord_bits, self.subpixel_bits
        acc = self.intensity_bits + self.F  # holds [0, |I_d| * 2**F] with |I_d| < 2**I
        return {
            # pixel coordinates of writes: columns 0 .. 2**W, rows one beyond on either side
            "x": RegisterWidth(W + 2, signed=True),
            "y": RegisterWidth(W + 2, signed=True),
            "remaining": RegisterWidth(W + 1),  # columns still to step after this one
            "du": RegisterWidth(W + s),  # major-axis length: the remainder modulus
            "ifix": RegisterWidth(acc),  # |I_d| << F: one row step of the accumulator
            "jq": RegisterWidth(acc),  # accumulator quotient, [0, ifix)
            "jr": RegisterWidth(W + s),  # accumulator remainder over du, [0, du)
            "kq": RegisterWidth(acc),  # per-column increment |I_d| k 2**F, quotient
            "kr": RegisterWidth(W + s),
            "khq": RegisterWidth(acc),  # half of it: the exit test threshold k/2
            "khr": RegisterWidth(W + s),
            "jsum": RegisterWidth(acc + 1),  # jq + kq + carry before the row step
            "dq": RegisterWidth(acc + 2, signed=True),  # exit depth d, quotient
            "dr": RegisterWidth(W + s),
            "t": RegisterWidth(acc + 1, signed=True),  # triangle estimate before clamping
            "area": RegisterWidth(acc + 1),  # a pixel's scaled area, [0, ifix]
            "seg_const": RegisterWidth(acc),  # per-edge thresholds and intercepts
            "value": RegisterWidth(self.intensity_bits),  # output intensity
            # accumulation (docs/algorithm.md s. 13): a piece's heights lie in
            # (-ifix, 2 ifix); a cell's delta in [-ifix, ifix]
            "height": RegisterWidth(acc + 2, signed=True),
            "delta": RegisterWidth(acc + 2, signed=True),
            "unit": RegisterWidth(2, signed=True),  # a unit step or a sign: -1, 0 or +1
            "flag": RegisterWidth(1),  # a per-edge condition: 0 or 1
        }

    def with_(self, **changes) -> EdgeConfig:
        """A copy with some fields changed (frac_bits re-derived unless given)."""
        fields = dict(
            coord_bits=self.coord_bits,
            subpixel_bits=self.subpixel_bits,
            intensity_bits=self.intensity_bits,
            frac_bits=self.frac_bits,
            mode=self.mode,
            accumulator=self.accumulator,
        )
        fields.update(changes)
        return EdgeConfig(**fields)
