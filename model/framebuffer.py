"""The framebuffer's pixel formats: how the peripheral's framebuffer writer
(`edgeaa.hdl.peripheral.FramebufferWriter`, its ``fb_format`` register) lays a pixel of
I-bit channels out as bytes in memory (docs/hardware.md, "Integrating edgeaa").

* ``grey8``: one byte, the grey value (the one format of a grey pipeline);
* ``rgb565``: a 16-bit little-endian word, red 15:11, green 10:5, blue 4:0, each channel
  rounded from I bits to 5 or 6 (`scale_channel`);
* ``rgb888``: three bytes, red, green, blue in memory order;
* ``rgba8888``: four bytes, red, green, blue, alpha (premultiplied, as the pixel is; full
  scale for an opaque 3-channel or grey pixel).

The others are a colour pipeline's (3 or 4 channels). The 8-bit fields hold the channel's
value as it is (I <= 8 bits: a framebuffer byte).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .accumulate import alpha_coverage
from .tile import alpha_steps

__all__ = [
    "FORMATS",
    "PixelFormat",
    "default_format",
    "format_codes",
    "framebuffer_bytes",
    "scale_channel",
    "scale_steps",
]


class PixelFormat(NamedTuple):
    name: str
    code: int  # the value in the ``fb_format`` register
    bytes: int  # bytes per pixel in memory


FORMATS = {
    f.name: f
    for f in (
        PixelFormat("grey8", 0, 1),
        PixelFormat("rgb565", 1, 2),
        PixelFormat("rgb888", 2, 3),
        PixelFormat("rgba8888", 3, 4),
    )
}
FORMAT_BITS = 2  # the register's format field


def format_codes(channels: int) -> tuple[PixelFormat, ...]:
    """The formats a pipeline of `channels` writes: grey8 from grey (the writer stays the
    grey one), the colour formats from colour (no luminance)."""
    return tuple(f for f in FORMATS.values() if (channels == 1) == (f.name == "grey8"))


def default_format(channels: int) -> PixelFormat:
    """The format after reset (and for a code the pipeline does not write): grey8 for grey,
    rgb888 for 3 channels, rgba8888 for 4."""
    return FORMATS[{1: "grey8", 3: "rgb888", 4: "rgba8888"}[channels]]


def scale_channel(c, bits: int, n: int):
    """round(c (2**n - 1) / (2**bits - 1)) half up: an I-bit channel as an n-bit field, exact
    (ints or numpy arrays)."""
    return alpha_coverage(c, (1 << n) - 1, (1 << bits) - 1)  # the same rounding as alpha


def scale_steps(c, bits: int, n: int):
    """`scale_channel` without a divider, for n <= bits (any arithmetic: ints, numpy,
    Amaranth values): the alpha stage's rounding with the alpha 2**n - 1 <= full
    (`edgeaa.model.tile.alpha_steps`; docs/hardware.md derives it)."""
    if n > bits:
        raise ValueError(f"scale_steps narrows: {n} field bits from {bits} intensity bits")
    return alpha_steps(c, (1 << n) - 1, bits)


def framebuffer_bytes(image: np.ndarray, fmt: PixelFormat, bits: int) -> np.ndarray:
    """The model's image (height, width) grey or (height, width, channels) as the bytes the
    framebuffer holds in `fmt`: (height, width, fmt.bytes), byte 0 the lowest address."""
    image = np.asarray(image, dtype=np.int64)
    channels = image.shape[2] if image.ndim == 3 else 1
    if fmt not in format_codes(channels):
        raise ValueError(f"a {channels}-channel image has no {fmt.name} pixels")
    if bits > 8:
        raise ValueError(f"the framebuffer's bytes hold at most 8 intensity bits, not {bits}")
    if fmt.name == "grey8":
        return image[..., None]
    rgb = [image[..., k] for k in range(3)]
    alpha = image[..., 3] if channels == 4 else np.full(image.shape[:2], (1 << bits) - 1)
    if fmt.name == "rgb565":
        r, g, b = (scale_channel(c, bits, n) for c, n in zip(rgb, (5, 6, 5), strict=True))
        word = r << 11 | g << 5 | b
        planes = [word & 0xFF, word >> 8]
    else:
        planes = rgb + [alpha] * (fmt.name == "rgba8888")
    return np.stack(planes, axis=-1)
