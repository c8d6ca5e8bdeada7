"""The PNG writer (`edgeaa.render.png`): Pillow reads back every pixel it wrote."""

from __future__ import annotations

import io

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from PIL import Image

from edgeaa.render.png import png_bytes, write_png_file

SHAPES = st.tuples(st.integers(1, 9), st.integers(1, 9), st.sampled_from([None, 3, 4]))


@st.composite
def images(draw):
    height, width, channels = draw(SHAPES)
    dtype = draw(st.sampled_from([np.uint8, np.uint16])) if channels is None else np.uint8
    shape = (height, width) if channels is None else (height, width, channels)
    return draw(arrays(dtype, shape))


@settings(max_examples=150, deadline=None)
@given(images())
def test_pillow_reads_back_every_sample(image):
    """Grey 8 and 16 bits, RGB and RGBA, of every small size and any samples."""
    read = np.asarray(Image.open(io.BytesIO(png_bytes(image))))
    assert read.shape == image.shape
    assert np.array_equal(read.astype(np.int64), image.astype(np.int64))


def test_a_large_image_reads_back_from_a_file_and_a_stream(tmp_path):
    """Every byte value in each row (the Up filter's wraps), by name and into a binary file."""
    rng = np.random.default_rng(7)
    image = rng.integers(0, 256, (300, 517), dtype=np.uint8)
    stream = io.BytesIO()
    write_png_file(image, stream)
    write_png_file(image, tmp_path / "a.png")
    assert stream.getvalue() == (tmp_path / "a.png").read_bytes() == png_bytes(image)
    assert np.array_equal(np.asarray(Image.open(tmp_path / "a.png")), image)


@pytest.mark.parametrize(
    "image, match",
    [
        (np.zeros((2, 2), dtype=np.int32), "uint8 or uint16"),
        (np.zeros((2, 2, 2), dtype=np.uint8), "not empty"),
        (np.zeros((0, 2), dtype=np.uint8), "not empty"),
    ],
)
def test_refuses_what_png_cannot_hold(image, match):
    with pytest.raises(ValueError, match=match):
        png_bytes(image)
