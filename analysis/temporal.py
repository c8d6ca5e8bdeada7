"""Temporal antialiasing (TAA) as the textbook chapter describes it (seeds/003, 5.4.2).

Each frame is rendered with one sample per pixel, moved by a sub-pixel jitter that changes
every frame: the Halton sequence in bases 2 and 3 (Karis found it better than the GPUs'
MSAA patterns, the chapter notes), points 1 .. JITTER_CYCLE, then repeating. The history is
blended exponentially, history <- history + ALPHA (current - history), after clamping it to
the minimum and maximum of the current frame's 3 x 3 neighbourhood (neighbourhood clamping,
which keeps a moved edge from leaving a ghost behind). When the scene moves, the history is
first reprojected (`reproject`): each pixel reads it, bilinearly, where its surface was in the
previous frame (the motion vectors the chapter's velocity buffer holds; here the scene's
motion is known exactly).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator

import numpy as np

ALPHA = 0.1  # weight of the new frame
JITTER_CYCLE = 16
STATIC_FRAMES = 32  # frames run on a still image before it is measured


def radical_inverse(index: int, base: int) -> float:
    """The index-th Halton value in `base`: its digits mirrored about the point."""
    out, scale = 0.0, 1.0 / base
    while index > 0:
        index, digit = divmod(index, base)
        out += digit * scale
        scale /= base
    return out


def jitter(frame: int) -> tuple[float, float]:
    """The sample's offset from the pixel centre in frame `frame` (px, in [-1/2, 1/2))."""
    i = frame % JITTER_CYCLE + 1
    return radical_inverse(i, 2) - 0.5, radical_inverse(i, 3) - 0.5


def neighbourhood(image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Minimum and maximum over each pixel's 3 x 3 neighbourhood (clamped at the border)."""
    pad = [(0, 0)] * (image.ndim - 2) + [(1, 1), (1, 1)]
    padded = np.pad(image, pad, mode="edge")
    out = []
    for op in (np.minimum, np.maximum):  # separable: rows of three, then columns of three
        rows = op(op(padded[..., :-2], padded[..., 1:-1]), padded[..., 2:])
        out.append(op(op(rows[..., :-2, :], rows[..., 1:-1, :]), rows[..., 2:, :]))
    return out[0], out[1]


def blend(history: np.ndarray | None, current: np.ndarray, alpha: float = ALPHA) -> np.ndarray:
    if history is None:
        return current.astype(np.float64)
    lo, hi = neighbourhood(current)
    clamped = np.clip(history, lo, hi)
    return clamped + alpha * (current - clamped)


def reproject(history: np.ndarray, ys: np.ndarray, xs: np.ndarray) -> np.ndarray:
    """The history read bilinearly at (ys, xs) (each pixel's position in the previous frame),
    clamped at the border."""
    h, w = history.shape[-2:]
    ys, xs = np.clip(ys, 0, h - 1), np.clip(xs, 0, w - 1)
    y0, x0 = (
        np.minimum(np.floor(ys).astype(np.int64), h - 2),
        np.minimum(np.floor(xs).astype(np.int64), w - 2),
    )
    fy, fx = ys - y0, xs - x0
    top = history[..., y0, x0] * (1 - fx) + history[..., y0, x0 + 1] * fx
    bottom = history[..., y0 + 1, x0] * (1 - fx) + history[..., y0 + 1, x0 + 1] * fx
    return top * (1 - fy) + bottom * fy


def resolve(frames: Iterable[np.ndarray], alpha: float = ALPHA) -> Iterator[np.ndarray]:
    """The TAA output after each frame."""
    history = None
    for frame in frames:
        history = blend(history, frame, alpha)
        yield history


def still(sample: Callable[[float, float], np.ndarray], frames: int = STATIC_FRAMES):
    """TAA of a still image after `frames` frames; sample(jx, jy) renders one frame."""
    history = None
    for f in range(frames):
        history = blend(history, sample(*jitter(f)))
    return history
