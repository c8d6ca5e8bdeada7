"""Numbers from text, read without unbounded work, and values quoted in messages.

`Fraction('0e1000000000')` builds a billion-digit power before anything can check its range,
and an integer of thousands of digits makes a message thousands of characters long: every
entry point that reads a number from text (the command line, scene files, `Edge.from_pixels`)
reads it here.
"""

from __future__ import annotations

import re
from fractions import Fraction

__all__ = ["DECIMAL", "MAX_EXPONENT", "MAX_NUMBER_TEXT", "MAX_SHOWN", "decimal", "shown"]

MAX_SHOWN = 40  # characters of a bad value quoted in a message
MAX_NUMBER_TEXT = 60  # characters of a number on the command line
# [0-9], not \d: \d and Fraction() also read Arabic-Indic and full-width digits ('٣', '４').
DECIMAL = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?", re.ASCII)
MAX_EXPONENT = 60  # |exponent| of a decimal: far past any coordinate, cheap to evaluate


def shown(value) -> str:
    """A value for a message: its repr, cut short (a number may have thousands of digits)."""
    text = repr(value)
    if len(text) > MAX_SHOWN:
        text = f"{text[: MAX_SHOWN - 12]}... ({len(text)} characters)"
    return text


def decimal(text: str) -> Fraction:
    """A decimal number exactly, without the unbounded work of `Fraction('0e1000000000')`.

    Raises ValueError (the message says what is allowed) for anything that is not a plain
    decimal (`inf`, `nan`, `1/3`, `0x10`), longer than MAX_NUMBER_TEXT characters, or with an
    exponent beyond +-MAX_EXPONENT (zero excepted: `0e1000000000` is 0).
    """
    text = text.strip()
    match = DECIMAL.fullmatch(text) if len(text) <= MAX_NUMBER_TEXT else None
    if match is None:
        raise ValueError(
            f"must be a decimal number such as 10.25 (at most {MAX_NUMBER_TEXT} characters), "
            f"not {shown(text)}"
        )
    mantissa, exponent = match.group(1), match.group(2)
    if not exponent:
        return Fraction(text)
    if not mantissa.strip("0."):
        return Fraction(0)
    power = int(exponent[1:])
    if abs(power) > MAX_EXPONENT:
        raise ValueError(f"= {shown(text)} is out of range (exponents up to +-{MAX_EXPONENT})")
    return Fraction(text)
