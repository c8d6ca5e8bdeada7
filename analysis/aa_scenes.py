"""The seeds' antialiasing methods on whole scenes (`edgeaa render --compare`, the TAA strip).

Each method draws a planned scene (`edgeaa.render.render.Plan`) as a GPU would:

- point sampling at pixel centres moved by (jx, jy): every polygon composited in order over
  the background at each sample, the renderer's exact scanline test (`sample_mask`) on
  coordinates scaled by UNITS (864 = 32 * 27 holds the MSAA patterns' 1/48 px grid and the
  first 26 Halton points of bases 2 and 3, so every sample position is exact);
- sample patterns (`sampling`, `msaa`): one point-sampled image per sample position, resolved
  with the pattern's weights (per sample, as MSAA resolves: overlapping polygons are composited
  per sample, not by coverage);
- image methods (`aa_methods.apply`): MLAA, FXAA, TAA on the point-sampled image scaled to
  [0, 1]; the geometry variant of FXAA gets the object that owns each pixel centre.

Objects: a polygon named "OBJECT/PART" belongs to object OBJECT (so the stripes of a hatch
drawn inside a shape are the shape's texture, not geometry); any other polygon is its own
object. The background is object 0.
"""

from __future__ import annotations

import numpy as np

from ..render.geometry import sample_mask
from . import aa_methods, msaa, sampling, temporal

UNITS = 864


def _sample_masks(plan, ux: int, uy: int):
    """Yield (polygon, window, mask) of the polygons' point samples moved by (ux, uy)/UNITS."""
    S, m = plan.config.subpixel_scale, UNITS
    ox, oy = plan.offset
    h, w = plan.scene.height, plan.scene.width
    for poly in plan.polygons:
        x0, y0, x1, y1 = poly.window
        x0, y0, x1, y1 = max(x0 - 1, 0), max(y0 - 1, 0), min(x1 + 1, w), min(y1 + 1, h)
        if x1 <= x0 or y1 <= y0:
            continue
        edges = plan.coords[poly.start : poly.stop] * m
        ys = (np.arange(y0, y1) + oy) * S * m + uy * S
        mask = sample_mask(edges, poly.rule, ys, (x0 + ox) * S * m + ux * S, S * m, x1 - x0)
        yield poly, (x0, y0, x1, y1), mask


def point_image(plan, ux: int = 0, uy: int = 0) -> np.ndarray:
    """The scene point sampled at pixel centres moved by (ux, uy) / UNITS px (float)."""
    image = np.full((plan.scene.height, plan.scene.width), float(plan.scene.background))
    for poly, (x0, y0, x1, y1), mask in _sample_masks(plan, ux, uy):
        image[y0:y1, x0:x1][mask] = poly.intensity
    return image


def object_ids(plan) -> np.ndarray:
    """The object owning each pixel centre (0: the background), by the OBJECT/PART names."""
    names: dict[str, int] = {}
    ids = np.zeros((plan.scene.height, plan.scene.width), dtype=np.int64)
    for poly, (x0, y0, x1, y1), mask in _sample_masks(plan, 0, 0):
        name = plan.scene.polygons[poly.index].name or f"#{poly.index}"
        obj = names.setdefault(name.split("/")[0], len(names) + 1)
        ids[y0:y1, x0:x1][mask] = obj
    return ids


def pattern_image(plan, name: str) -> np.ndarray:
    """Resolve of the pattern's per-sample images (`sampling` or `msaa` pattern name)."""
    if name in sampling.PATTERNS:
        units = np.round(sampling.PATTERNS[name] * UNITS).astype(np.int64)
        pattern = msaa.SamplePattern(units, np.full(len(units), 1 / len(units)), False, 0, "")
    else:
        p = msaa.PATTERNS[name]
        pattern = msaa.SamplePattern(p.units * (UNITS // msaa.UNITS), p.weights, p.mirrored, 0, "")
    out = 0.0
    mirrored = 0.0
    for (ux, uy), weight in zip(pattern.units, pattern.weights, strict=True):
        out = out + weight * point_image(plan, int(ux), int(uy))
        if pattern.mirrored:
            mirrored = mirrored + weight * point_image(plan, -int(ux), int(uy))
    if pattern.mirrored:
        ys, xs = np.indices(out.shape)
        odd = ((xs + plan.offset[0] + ys + plan.offset[1]) & 1).astype(bool)
        out = np.where(odd, mirrored, out)
    return out


def jittered(plan):
    """sample(jx, jy) for TAA: the point-sampled image in [0, 1], jitter on the UNITS grid."""
    full = float(plan.config.full_scale)

    def sample(jx: float, jy: float) -> np.ndarray:
        return point_image(plan, round(jx * UNITS), round(jy * UNITS)) / full

    return sample


def method_image(plan, name: str) -> np.ndarray:
    """A seed method's image of the planned scene, rounded to integer intensities."""
    full = float(plan.config.full_scale)
    if name in sampling.PATTERNS or name in msaa.PATTERNS:
        out = pattern_image(plan, name)
    else:
        ids = object_ids(plan) if name == "fxaa-geom" else None
        out = aa_methods.apply(name, jittered(plan), None if ids is None else lambda _: ids)
        out = out * full
    return np.floor(out + 0.5).astype(np.int64)


def taa_frames(plans, alpha: float = temporal.ALPHA, previous=None):
    """TAA over a sequence of planned frames (one jitter each): the resolved images.
    previous(frame) gives (ys, xs), where each pixel was in the frame before (reprojection);
    None: the history is read in place."""
    history = None
    for frame, plan in enumerate(plans):
        current = jittered(plan)(*temporal.jitter(frame))
        if history is not None and previous is not None:
            history = temporal.reproject(history, *previous(frame))
        history = temporal.blend(history, current, alpha)
        yield history * plan.config.full_scale
