"""Colour: paints composited per channel with the model's integer composite (docs/scenes.md,
"Colour").

A colour scene is planned and accumulated once, as its outlines' coverage: every polygon at
full scale over 0 (`coverage_scene`), so each pixel's coverage q is in [0, full] steps
(`edgeaa.render.render`, the same edges, deltas and fill rule as a grey scene). A `Canvas`
holds the image as premultiplied red, green, blue and alpha, `intensity_bits` each, and
composites each polygon source-over in order: with the paint's alpha A (in steps of full),
q' = round(q A / full) half up, and every channel c (alpha's paint value is full) becomes

    c + round(q' (paint_c - c) / full)        (`edgeaa.model.accumulate.composite`)

which is premultiplied source-over: P_out = paint alpha' + P (1 - alpha'), alpha' = q' / full.
Grey scenes do not come here: they keep their own path, bit for bit.

Group opacity (SVG's `opacity` on a group, `Scene.layers`): the polygons inside a layer are
composited as above onto a transparent image, and when the layer ends (at the first polygon
outside it, or at `Canvas.finish`) that image L is composited onto the one below B with the
opacity o (in steps of full, rounded half up), every channel c of premultiplied RGBA:

    c' = round(L_c o / full),   out_c = c' + round(B_c (full - a') / full)

with a' the alpha channel's c' (`composite_layer`): source-over of the layer scaled by the
opacity. Each of the two roundings is within 1/2 step, so a layer adds at most 1 step to
each channel's error against the same composite in real numbers (`exact_colour`). Scenes
without layers never come here: their images are unchanged bit for bit.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..model.accumulate import composite
from .scene import Scene

CHANNELS = 4  # red, green, blue, alpha


def coverage_scene(scene: Scene) -> Scene:
    """The scene's outlines, every polygon at full scale over 0: the plan of a colour scene
    (each pixel's composite needs the polygon's coverage in steps of full scale)."""
    polygons = tuple(replace(p, intensity=None, paint=None) for p in scene.polygons)
    return replace(scene, polygons=polygons, background=0, background_paint=None)


def quantized(paint, full: int) -> np.ndarray:
    """A paint (floats in [0, 1]) in steps of `full`, rounded half up."""
    return np.floor(np.asarray(paint, dtype=np.float64) * full + 0.5).astype(np.int64)


def layer_steps(current: list[int], path: tuple[int, ...]) -> tuple[int, tuple[int, ...]]:
    """How many open layers (outermost first) to end, and which to open, to draw inside
    `path`."""
    keep = 0
    while keep < min(len(current), len(path)) and current[keep] == path[keep]:
        keep += 1
    return len(current) - keep, path[keep:]


def composite_layer(below: np.ndarray, layer: np.ndarray, opacity: int, full: int) -> None:
    """Source-over, in place, of a premultiplied layer scaled by opacity / full onto below."""
    scaled = (2 * layer * opacity + full) // (2 * full)
    below[...] = scaled + (2 * below * (full - scaled[..., 3:4]) + full) // (2 * full)


class Canvas:
    """The colour image being composited, premultiplied, (height, width, 4) int64; `image`
    is final after `finish` (the layers still open composited)."""

    def __init__(self, scene: Scene, full: int):
        self.full = full
        if scene.background_paint is not None:
            background = quantized(scene.background_paint, full)
        else:  # a grey background, opaque
            background = np.array([scene.background] * 3 + [full], dtype=np.int64)
        background[:3] = (2 * background[:3] * background[3] + full) // (2 * full)
        self.background = background  # premultiplied, as the image holds it
        self.image = np.empty((scene.height, scene.width, CHANNELS), dtype=np.int64)
        self.image[:] = background
        paints = []
        for p in scene.polygons:
            if p.paint is not None:
                paints.append(quantized(p.paint, full))
            else:  # an intensity polygon: grey, opaque
                value = full if p.intensity is None else p.intensity
                paints.append(np.array([value] * 3 + [full], dtype=np.int64))
        self.paints = np.array(paints, dtype=np.int64).reshape(-1, CHANNELS)
        self.paints[:, 3] = np.clip(self.paints[:, 3], 0, full)
        self.opacities = np.clip(quantized(scene.layers, full), 0, full).reshape(-1)
        self.paths = [p.layers for p in scene.polygons]
        self.target = self.image  # where polygons are drawn: the innermost open layer's image
        self.open: list[tuple[int, np.ndarray]] = []  # (layer, the image below it)

    @property
    def layered(self) -> bool:
        return bool(len(self.opacities))

    def enter(self, path: tuple[int, ...]) -> None:
        """End and open layers so that drawing goes into `path`'s innermost."""
        ends, opens = layer_steps([layer for layer, _ in self.open], path)
        for _ in range(ends):
            layer, below = self.open.pop()
            composite_layer(below, self.target, int(self.opacities[layer]), self.full)
            self.target = below
        for layer in opens:
            self.open.append((layer, self.target))
            self.target = np.zeros_like(self.image)

    def finish(self) -> np.ndarray:
        """Composite the layers still open; the final image."""
        self.enter(())
        return self.image

    def draw(self, index: int, rows: np.ndarray, cols: np.ndarray, q: np.ndarray, d: int):
        """Composite polygon `index` where its coverage is q / d (d is full scale here)."""
        if d != self.full:
            raise ValueError(f"a colour scene's coverage is in steps of {self.full}, not {d}")
        self.enter(self.paths[index])
        red, green, blue, alpha = (int(v) for v in self.paints[index])
        q = (2 * q * alpha + self.full) // (2 * self.full)
        live = q != 0
        rows, cols, q = rows[live], cols[live], q[live]
        for channel, value in enumerate((red, green, blue, self.full)):
            below = self.target[rows, cols, channel]
            self.target[rows, cols, channel] = composite(below, q, value, self.full)


def exact_colour(plan, scene: Scene) -> np.ndarray:
    """The colour reference (float64, premultiplied, (height, width, 4)): each polygon's
    exact coverage (`edgeaa.render.exact`, of the plan's quantized outlines) times its
    alpha, composited source-over per channel in floating point, with the canvas's
    quantized paints and opacities: the error then measures the coverage and the integer
    composite. Layers are composited as the canvas does, in floating point."""
    from .exact import exact_coverage

    canvas = Canvas(scene, plan.config.full_scale)
    full = canvas.full
    image = canvas.image.astype(np.float64)
    open_: list[tuple[int, np.ndarray]] = []
    for i in range(len(plan.polygons) + 1):
        path = canvas.paths[i] if i < len(plan.polygons) else ()
        ends, opens = layer_steps([layer for layer, _ in open_], path)
        for _ in range(ends):
            layer, below = open_.pop()
            scaled = image * (canvas.opacities[layer] / full)
            image = scaled + below * (1 - scaled[..., 3:4] / full)
        for layer in opens:
            open_.append((layer, image))
            image = np.zeros_like(image)
        if i == len(plan.polygons):
            break
        (x0, y0, x1, y1), cover = exact_coverage(plan, i)
        if cover.size:
            paint = canvas.paints[i].astype(np.float64)
            weight = cover * (paint[3] / full)
            paint[3] = full
            view = image[y0:y1, x0:x1]
            view += weight[..., None] * (paint - view)
    return image


def straight(image: np.ndarray, full: int) -> tuple[np.ndarray, bool]:
    """Premultiplied RGBA to straight (the PNG's), rounded half up; and whether every pixel
    is opaque (then RGB is enough)."""
    alpha = image[..., 3]
    out = image.copy()
    shown = alpha > 0
    for channel in range(3):
        values = out[..., channel]
        values[shown] = np.minimum(
            full, (2 * values[shown] * full + alpha[shown]) // (2 * alpha[shown])
        )
        values[~shown] = 0
    return out, bool((alpha == full).all())
