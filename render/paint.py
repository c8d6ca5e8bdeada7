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

Linear light (`Scene.linear_light`, `edgeaa render --linear-light`): the same composites on
the paints decoded to linear light at 16 bits, the image encoded to sRGB at `finish`
(docs/scenes.md section 9).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..model.accumulate import alpha_coverage, composite
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


def composite_layer(below, layer, opacity: int, full: int, scale: int | None = None) -> None:
    """Source-over, in place, of a premultiplied layer scaled by opacity / full onto below
    (their channels in steps of `scale`, default full)."""
    scale = full if scale is None else scale
    scaled = (2 * layer * opacity + full) // (2 * full)
    below[...] = scaled + (2 * below * (scale - scaled[..., 3:4]) + scale) // (2 * scale)


def srgb_decode(c):
    """sRGB values in [0, 1] to linear light (IEC 61966-2-1)."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def srgb_encode(x):
    """Linear light in [0, 1] to sRGB values."""
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


LINEAR_FULL = (1 << 16) - 1  # linear light's full scale while compositing: 16 bits


def encoded(linear: np.ndarray, scale: int, full: int, rounded: bool) -> np.ndarray:
    """A premultiplied linear image (steps of `scale`) as premultiplied sRGB in steps of full:
    alpha a = A full / scale, each channel round(encode(C / A) a) (floats when not
    `rounded`)."""
    alpha = linear[..., 3] * (full / scale)
    if rounded:
        alpha = np.floor(alpha + 0.5)
    shown = linear[..., 3] > 0
    out = np.zeros(linear.shape, dtype=np.float64)
    straight = linear[..., :3][shown] / linear[..., 3][shown][:, None]
    out[..., :3][shown] = srgb_encode(straight) * alpha[shown][:, None]
    out[..., 3] = alpha
    return np.floor(out + 0.5).astype(np.int64) if rounded else out


class Canvas:
    """The colour image being composited, premultiplied, (height, width, 4) int64; `image`
    is final after `finish` (the layers still open composited). With the scene's
    `linear_light` the composites are on a premultiplied linear-light image in steps of
    LINEAR_FULL (`work`), encoded to sRGB into `image` at `finish`."""

    def __init__(self, scene: Scene, full: int):
        self.full = full
        self.linear = scene.linear_light
        self.scale = LINEAR_FULL if self.linear else full  # the composites' channel scale
        if scene.background_paint is not None:
            background = quantized(scene.background_paint, full)
        else:  # a grey background, opaque
            background = np.array([scene.background] * 3 + [full], dtype=np.int64)
        unmixed = background.copy()  # straight
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
        # the values composited: the paints' colours (decoded when linear), alpha full
        self.values = self._values(self.paints)
        self.work = self.image
        if self.linear:  # the background decoded, premultiplied at the linear scale
            self.work = np.empty_like(self.image)
            self.work[:] = (2 * self._values(unmixed[None])[0] * unmixed[3] + full) // (2 * full)
        self.opacities = np.clip(quantized(scene.layers, full), 0, full).reshape(-1)
        self.paths = [p.layers for p in scene.polygons]
        self.target = self.work  # where polygons are drawn: the innermost open layer's image
        self.open: list[tuple[int, np.ndarray]] = []  # (layer, the image below it)

    @property
    def layered(self) -> bool:
        return bool(len(self.opacities))

    def enter(self, path: tuple[int, ...]) -> None:
        """End and open layers so that drawing goes into `path`'s innermost."""
        ends, opens = layer_steps([layer for layer, _ in self.open], path)
        for _ in range(ends):
            layer, below = self.open.pop()
            opacity = int(self.opacities[layer])
            composite_layer(below, self.target, opacity, self.full, self.scale)
            self.target = below
        for layer in opens:
            self.open.append((layer, self.target))
            self.target = np.zeros_like(self.image)

    def _values(self, paints: np.ndarray) -> np.ndarray:
        """Paints (straight, steps of full) as the channel values composited: alpha at the
        composites' full scale, colours decoded to linear light when linear."""
        values = paints.copy()
        values[:, 3] = self.scale
        if self.linear:
            linear = srgb_decode(paints[:, :3] / self.full) * self.scale
            values[:, :3] = np.floor(linear + 0.5).astype(np.int64)
        return values

    def finish(self) -> np.ndarray:
        """Composite the layers still open; the final image (encoded from linear light)."""
        self.enter(())
        if self.linear:
            self.image[...] = encoded(self.work, self.scale, self.full, rounded=True)
        return self.image

    def draw(self, index: int, rows: np.ndarray, cols: np.ndarray, q: np.ndarray, d: int):
        """Composite polygon `index` where its coverage is q / d (d is full scale here)."""
        if d != self.full:
            raise ValueError(f"a colour scene's coverage is in steps of {self.full}, not {d}")
        self.enter(self.paths[index])
        q = alpha_coverage(q, int(self.paints[index, 3]), self.full)
        live = q != 0
        rows, cols, q = rows[live], cols[live], q[live]
        for channel, value in enumerate(self.values[index]):
            below = self.target[rows, cols, channel]
            self.target[rows, cols, channel] = composite(below, q, int(value), self.full)


def exact_colour(plan, scene: Scene) -> np.ndarray:
    """The colour reference (float64, premultiplied, (height, width, 4)): each polygon's
    exact coverage (`edgeaa.render.exact`, of the plan's quantized outlines) times its
    alpha, composited source-over per channel in floating point, with the canvas's
    quantized paints and opacities: the error then measures the coverage and the integer
    composite. Layers are composited as the canvas does, in floating point; in linear light
    on the canvas's decoded paints, then encoded without rounding."""
    from .exact import exact_coverage

    canvas = Canvas(scene, plan.config.full_scale)
    full, scale = canvas.full, canvas.scale
    image = canvas.work.astype(np.float64)
    open_: list[tuple[int, np.ndarray]] = []
    for i in range(len(plan.polygons) + 1):
        path = canvas.paths[i] if i < len(plan.polygons) else ()
        ends, opens = layer_steps([layer for layer, _ in open_], path)
        for _ in range(ends):
            layer, below = open_.pop()
            scaled = image * (canvas.opacities[layer] / full)
            image = scaled + below * (1 - scaled[..., 3:4] / scale)
        for layer in opens:
            open_.append((layer, image))
            image = np.zeros_like(image)
        if i == len(plan.polygons):
            break
        (x0, y0, x1, y1), cover = exact_coverage(plan, i)
        if cover.size:
            value = canvas.values[i].astype(np.float64)
            weight = cover * (canvas.paints[i, 3] / full)
            view = image[y0:y1, x0:x1]
            view += weight[..., None] * (value - view)
    return encoded(image, scale, full, rounded=False) if canvas.linear else image


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
