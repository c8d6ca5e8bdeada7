"""The word length F on content the project did not write: images through the tiles
(`edgeaa.render.pipeline.render_tiles`, the hardware pipeline's model) at the exact
accumulator's derived F and at the truncated one's (21 at the defaults), and each against
the exact coverage (`edgeaa.render.exact.exact_image`).

Scenes: the built-ins, four fonts at 9 and 24 px, four icons at 16 and 48 px and the
adversarial scenes (`edgeaa.render.corpus`). Per scene: how many pixels differ between the
two F, by how much at most, and the maximum error against the exact coverage at each F, in
intensity LSB. Prints a markdown table (docs/hardware.md, "The word length in the
hardware").

    python benchmarks/word_length.py
"""

from __future__ import annotations

import sys

import numpy as np

from edgeaa.model import EdgeConfig
from edgeaa.model.tile import TileConfig
from edgeaa.render import plan_scene
from edgeaa.render.builtin import BUILTINS, builtin
from edgeaa.render.corpus import ICONS, adversarial_scenes, font_scene, icon_scene
from edgeaa.render.exact import exact_image
from edgeaa.render.pipeline import render_tiles

FONTS = ("DejaVuSans", "DejaVuSerif", "STIXGeneral", "cmr10")
WIDE = 21  # the truncated accumulator's derived F at the defaults


def scenes() -> list:
    out = [builtin(name) for name in BUILTINS]
    out += [font_scene(name, size)[0] for name in FONTS for size in (9, 24)]
    out += [icon_scene(name, size) for name in ICONS[:4] for size in (16, 48)]
    return out + adversarial_scenes()


def image(scene, config: EdgeConfig) -> tuple[np.ndarray, object]:
    plan = plan_scene(scene, config)
    return render_tiles(plan, TileConfig(config)).astype(np.int64), plan


def main() -> int:
    derived = EdgeConfig()
    wide = derived.with_(frac_bits=WIDE)
    print(f"F = {derived.F} (derived, exact) against F = {WIDE}; errors in LSB of 255")
    print()
    columns = f"max err, F = {WIDE} | max err, F = {derived.F}"
    print(f"| scene | pixels | differ | max diff | {columns} |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    worst = [0, 0.0, 0.0]
    for k, scene in enumerate(scenes()):
        print(f"  scene {k + 1}: {scene.name}", file=sys.stderr)
        narrow, plan = image(scene, derived)
        broad, _ = image(scene, wide)
        exact = exact_image(plan)
        differ = int(np.count_nonzero(narrow != broad))
        diff = int(np.abs(narrow - broad).max())
        err_wide, err_narrow = np.abs(broad - exact).max(), np.abs(narrow - exact).max()
        worst = [max(worst[0], differ), max(worst[1], err_wide), max(worst[2], err_narrow)]
        print(
            f"| {scene.name} | {narrow.size} | {differ} | {diff} | {err_wide:.2f} |"
            f" {err_narrow:.2f} |"
        )
    print(f"| worst | | {worst[0]} | | {worst[1]:.2f} | {worst[2]:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
