"""Content the project did not write (`edgeaa.render.corpus`) through the hardware pipeline:
serif, italic and mono fonts at 9 and 24 px, matplotlib's SVG toolbar icons at 16 and 48 px,
and the adversarial scenes, rendered by the Verilated `EdgePipeline`, every pixel equal to
the model's; a sample again under seeded idle clocks and back-pressure (`render_pipeline`).

One harness run per font family, for the icons and for the adversarial scenes: the scenes'
command streams one after another (each tile starts with its own tile command), the frames
cut back into scenes, each scene's image compared with the model's and named if it differs.
"""

from __future__ import annotations

import random

import numpy as np
import pytest

from edgeaa.model import EdgeConfig
from edgeaa.model.pipeline import CODE
from edgeaa.model.tile import TileConfig
from edgeaa.render import plan_scene, render_scene
from edgeaa.render.corpus import ICONS, adversarial_scenes, font_scene, icon_scene
from edgeaa.render.pipeline import image_from_frames, render_pipeline, scene_commands
from edgeaa.sim.simulators import pipeline_harness

CONFIG = EdgeConfig()
TILE = TileConfig(CONFIG)
FONT_CASES = [(name, size) for name in ("DejaVuSerif", "STIXGeneral", "cmr10") for size in (9, 24)]
FONT_CASES += [("STIXGeneralItalic", 12), ("DejaVuSansMono", 16)]
ADVERSARIAL = {scene.name: scene for scene in adversarial_scenes()}


def _same_image(scene, **run) -> None:
    result = render_pipeline(plan_scene(scene, CONFIG), "verilator", TILE, **run)
    assert result.mismatches == 0, f"{scene.name}: {result.mismatches} pixels differ ({run})"


def _same_images(scenes: dict) -> None:
    """`scenes` (by label) in one harness run, each scene's image equal to the model's."""
    plans = {label: plan_scene(scene, CONFIG) for label, scene in scenes.items()}
    commands = {label: scene_commands(plan, TILE) for label, plan in plans.items()}
    run = pipeline_harness.run(TILE, [c for stream in commands.values() for c in stream])
    assert run.errors == run.edge_errors == 0, f"{run.errors} commands, {run.edge_errors} edges"
    frames, differ = run.frames(TILE), {}
    for label, plan in plans.items():
        tiles = sum(c.op == CODE["flush"] for c in commands[label])
        image = image_from_frames(plan, TILE, frames[:tiles])
        frames = frames[tiles:]
        mismatches = int(np.count_nonzero(image != render_scene(plan, skip=True).image))
        if mismatches:
            differ[label] = mismatches
    assert not frames, f"{len(frames)} frames more than the scenes' flushes"
    assert not differ, f"pixels that differ from the model's, by scene: {differ}"


@pytest.mark.parametrize("name", sorted({name for name, _ in FONT_CASES}))
def test_fonts_through_the_pipeline_give_the_models_image(name):
    scenes = {}
    for size in (size for font, size in FONT_CASES if font == name):
        scenes[f"{name} {size} px"], missing = font_scene(name, size)
        assert not missing, f"{name} lacks {missing}"
    _same_images(scenes)


def test_svg_icons_through_the_pipeline_give_the_models_image():
    _same_images(
        {f"{name} {size} px": icon_scene(name, size) for name in ICONS for size in (16, 48)}
    )


def test_adversarial_scenes_through_the_pipeline_give_the_models_image():
    _same_images(ADVERSARIAL)


def test_back_pressure_on_content_we_did_not_write():
    seed = random.randrange(1 << 32)
    rng = random.Random(seed)
    scenes = [font_scene("cmr10", 9)[0], icon_scene(rng.choice(ICONS), 24)]
    scenes.append(ADVERSARIAL[rng.choice(sorted(ADVERSARIAL))])
    for scene in scenes:
        try:
            _same_image(scene, seed=rng.randrange(1 << 16), idle=0.3, stall=0.4)
        except AssertionError as error:
            raise AssertionError(f"seed {seed}: {error}") from None


def test_icons_are_filled_paths_inside_their_scene():
    for name in ICONS:
        scene = icon_scene(name, 24)
        points = [p for polygon in scene.polygons for contour in polygon.contours for p in contour]
        assert scene.polygons and len(points) > 30, name
        assert all(0 <= x <= scene.width and 0 <= y <= scene.height for x, y in points), name
    with pytest.raises(ValueError, match="icon must be one of"):
        icon_scene("hand", 24)  # a gradient-filled, transformed drawing: not in the corpus
