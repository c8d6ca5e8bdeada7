"""Every method's coverage on one common set of pixels, against the exact area.

The pixel set of a list of edges is the pixels edgeaa's two-pixel modes write (exactly the
pixels the edge's line crosses, docs/algorithm.md section 12) in the columns strictly
between each edge's endpoints (`geometry.inner_columns`). Every method is evaluated on
exactly these pixels:

- ``edgeaa-<mode>``: the model (`model.vector.run_edges`). ``coverage="model"`` takes the
  coverage before output rounding (what the error bounds are about); ``coverage="output"``
  the written intensity as a fraction, (value - I_out) / (I_in - I_out), what a consumer
  sees. pw writes one pixel per column; the crossed neighbour it leaves to the fill is
  taken as pixel-centre sampled (0 or 1), as a fill would draw it.
- the sample patterns of `sampling`, and the peers of `peers` (their masks).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..model import MODES, Edge, EdgeConfig
from ..model.vector import WriteBatch, run_edges
from . import peers, sampling
from .geometry import exact_coverage_pixels, inner_columns, pixel_keys, slope_k

EDGEAA_METHODS = tuple(f"edgeaa-{mode}" for mode in MODES)
SAMPLE_METHODS = tuple(sampling.PATTERNS)
BOUND_PER_K = {"pw": 1 / 8, "paper": 1 / 64, "seg2": 1 / 256, "seg4": 1 / 1024}


def mode_of(method: str) -> str | None:
    return method.removeprefix("edgeaa-") if method in EDGEAA_METHODS else None


@dataclass(frozen=True)
class PixelSet:
    edges: list[Edge]
    edge_index: np.ndarray
    x: np.ndarray
    y: np.ndarray
    exact: np.ndarray  # exact inside area
    k: np.ndarray  # the folded slope of the pixel's edge

    def __len__(self) -> int:
        return len(self.edge_index)


def pixel_set(config: EdgeConfig, edges: list[Edge]) -> tuple[PixelSet, WriteBatch]:
    """The common pixel set, and the paper-mode batch it came from."""
    batch = run_edges(config.with_(mode="paper"), edges)
    keep = inner_columns(batch)
    e, x, y = batch.edge_index[keep], batch.x[keep], batch.y[keep]
    exact = exact_coverage_pixels(config, edges, e, x, y)
    k = np.array([slope_k(config, edge) for edge in edges], dtype=np.float64)[e]
    return PixelSet(edges, e, x, y, exact, k), batch


def output_fraction(config: EdgeConfig, edges: list[Edge], batch: WriteBatch) -> np.ndarray:
    """(value - I_out) / (I_in - I_out) of every write: the written inside fraction."""
    i_in = np.array([e.intensities(config)[0] for e in edges], dtype=np.float64)
    i_out = np.array([e.intensities(config)[1] for e in edges], dtype=np.float64)
    e = batch.edge_index
    return (batch.value - i_out[e]) / (i_in[e] - i_out[e])


def edgeaa_on_pixels(
    config: EdgeConfig, pixels: PixelSet, batch: WriteBatch, coverage: str = "model"
) -> np.ndarray:
    """The model's coverage of each pixel of the set (see the module docstring for pw)."""
    if coverage == "model":
        values = batch.coverage()
    else:
        values = output_fraction(config, pixels.edges, batch)
    keys = pixel_keys(batch.edge_index, batch.x, batch.y)
    order = np.argsort(keys, kind="stable")
    sorted_keys = keys[order]
    want = pixel_keys(pixels.edge_index, pixels.x, pixels.y)
    pos = np.clip(np.searchsorted(sorted_keys, want), 0, max(len(keys) - 1, 0))
    found = sorted_keys[pos] == want
    out = np.empty(len(pixels), dtype=np.float64)
    out[found] = values[order[pos[found]]]
    if not found.all():
        missing = ~found
        out[missing] = sampling.sample_coverage(
            config,
            pixels.edges,
            pixels.edge_index[missing],
            pixels.x[missing],
            pixels.y[missing],
            "point",
        )
    return out


def timed(fn: Callable[[], object]) -> tuple[float, object]:
    start = time.perf_counter()
    result = fn()
    return time.perf_counter() - start, result


@dataclass
class MethodRun:
    """One method's coverage on the pixel set and its run time (seconds, min of repeats)."""

    name: str
    coverage: np.ndarray
    seconds: float
    outputs: int  # pixels the method produced (writes, samples pixels, mask pixels)


def run_method(
    config: EdgeConfig,
    edges: list[Edge],
    pixels: PixelSet,
    name: str,
    *,
    coverage: str = "model",
    jobs: list[peers.MaskJob] | None = None,
) -> MethodRun:
    """Run one method once (timed) and take its coverage on the pixel set."""
    mode = mode_of(name)
    if mode is not None:
        mode_config = config.with_(mode=mode)
        seconds, batch = timed(lambda: run_edges(mode_config, edges))
        cov = edgeaa_on_pixels(config, pixels, batch, coverage)
        return MethodRun(name, cov, seconds, len(batch))
    if name in sampling.PATTERNS:
        seconds, cov = timed(
            lambda: sampling.sample_coverage(
                config, edges, pixels.edge_index, pixels.x, pixels.y, name
            )
        )
        return MethodRun(name, cov, seconds, len(pixels))
    if name in peers.FILL_PEERS:
        if jobs is None:
            raise ValueError("peer methods need their mask jobs")
        seconds, masks = timed(lambda: peers.render(name, jobs))
        cov = peers.gather(name, jobs, masks, pixels.edge_index, pixels.x, pixels.y)
        return MethodRun(name, cov, seconds, sum(w * h for w, h in (j.size for j in jobs)))
    raise ValueError(f"unknown method {name!r}")
