"""PNG files from numpy arrays, with the standard library's zlib.

Written here rather than with Pillow: Pillow's import alone is 2.7 MB of a model render's
peak resident memory, whose target is twice AGG's (docs/results.md section 7), and a PNG
writer is a header, one filtered and deflated image and a checksum per chunk (the PNG
specification, sections 5, 9 and 11). Pillow still reads them back in the tests.
"""

from __future__ import annotations

import struct
import zlib

import numpy as np

SIGNATURE = b"\x89PNG\r\n\x1a\n"
COLOUR_TYPES = {1: 0, 3: 2, 4: 6}  # channels -> PNG colour type: grey, RGB, RGBA
UP = 2  # PNG filter type: each byte less the byte above (one numpy pass; the files within
# 0.995 to 1.10 times Pillow's adaptive filters' size on a page, a map and a font, 2026-12-07)
LEVEL = 6  # zlib's compression level, as Pillow's PNG writer uses


def _chunk(kind: bytes, body: bytes) -> bytes:
    """A PNG chunk: length, type, data and the CRC-32 of type and data."""
    return (
        struct.pack(">I", len(body))
        + kind
        + body
        + struct.pack(">I", zlib.crc32(body, zlib.crc32(kind)))
    )


def png_bytes(array: np.ndarray) -> bytes:
    """The PNG of `array`: (height, width) grey or (height, width, 3 or 4) RGB or RGBA, uint8
    or uint16 samples (uint16 stored big-endian, as PNG's 16-bit samples are)."""
    if array.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"PNG samples are uint8 or uint16, not {array.dtype}")
    channels = 1 if array.ndim == 2 else array.shape[2]
    if array.ndim not in (2, 3) or channels not in COLOUR_TYPES or 0 in array.shape[:2]:
        raise ValueError(
            f"a PNG image is (height, width[, 3 or 4]) and not empty, not {array.shape}"
        )
    height, width = array.shape[:2]
    bits = 8 * array.dtype.itemsize
    rows = np.ascontiguousarray(array, dtype=array.dtype.newbyteorder(">"))
    rows = rows.view(np.uint8).reshape(height, -1)
    filtered = np.empty((height, rows.shape[1] + 1), dtype=np.uint8)
    filtered[:, 0] = UP
    filtered[0, 1:] = rows[0]  # the row above the first is zeros
    np.subtract(rows[1:], rows[:-1], out=filtered[1:, 1:])  # modulo 256, as PNG's Up is
    header = struct.pack(">IIBBBBB", width, height, bits, COLOUR_TYPES[channels], 0, 0, 0)
    return b"".join(
        [
            SIGNATURE,
            _chunk(b"IHDR", header),
            _chunk(b"IDAT", zlib.compress(filtered.data, LEVEL)),
            _chunk(b"IEND", b""),
        ]
    )


def write_png_file(array: np.ndarray, path) -> None:
    """`png_bytes` of `array` written to `path`: a file name, or a binary file to write to."""
    data = png_bytes(array)
    if hasattr(path, "write"):
        path.write(data)
        return
    with open(path, "wb") as file:
        file.write(data)
