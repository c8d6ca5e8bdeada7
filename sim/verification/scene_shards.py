"""One shard of scenes (`edgeaa verify --scenes`): seeded random scenes through the Verilated
polygon pipeline against the model's image, every pixel.

A shard is a range of scene seeds (`SceneTask.seeds`); each scene is `random_scene(config,
seed)`, planned as `edgeaa render` plans it, rendered by the pipeline as `edgeaa render
--engine verilator` renders it (`render_pipeline`: the scene's commands into
`edgeaa.sim.simulators.pipeline_harness`, the image from the pixels it sends) and compared
pixel for pixel with `render_scene`, the image `edgeaa render` (model engine) writes. A
mismatch names the scene seed and its first differing pixel, with the `edgeaa verify` command
that reruns that one scene.
"""

from __future__ import annotations

import hashlib
import shlex
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...command import config_arguments
from ...model import EdgeConfig
from ...model.tile import TileConfig
from ...render.pipeline import render_pipeline
from ...render.render import plan_scene, render_scene
from ..simulators import pipeline_harness
from .shards import CompiledCore
from .workloads import MARGIN, SCENE_HEIGHT, SCENE_POLYGONS, SCENE_WIDTH, random_scene

SHARD_SCENES = 50  # default scenes per shard: about 5 s of work (93 ms a scene measured)
MAX_LISTED_SCENES = 6  # mismatching scenes a shard's record lists (all are counted)
SCENE_KINDS = ("pixel", "hang")  # a scene's disagreements: a wrong pixel, or no image at all


def first_scene_seed(run_seed: int) -> int:
    """The seed of a run's first scene (scene k's is this + k): 48 bits of a hash, so runs of
    neighbouring seeds do not share scenes."""
    digest = hashlib.sha256(f"edgeaa-verify-scenes/{run_seed}".encode()).digest()
    return int.from_bytes(digest[:6], "little")


def scene_range(
    scenes: int, shards: int, seed: int, shard_seed: int | None, index: int
) -> tuple[int, int]:
    """(first scene seed, scenes) of shard `index` of a `ScenePlan` of these fields: the run's
    scene seeds are consecutive, split into shards that differ by at most one scene."""
    if shard_seed is not None:
        return shard_seed, scenes
    base, extra = divmod(scenes, shards)
    return first_scene_seed(seed) + index * base + min(index, extra), base + (index < extra)


def default_scene_shards(scenes: int) -> int:
    """Shards of about `SHARD_SCENES` scenes, a function of the scene count only (a rerun on
    other workers resumes the same shards)."""
    return max(1, -(-scenes // SHARD_SCENES))


def scene_tile(config: EdgeConfig) -> TileConfig:
    """The pipeline's tile: `edgeaa render --engine verilator`'s default."""
    return TileConfig(config)


def build_pipeline(config: EdgeConfig, *, ship: bool = False) -> CompiledCore:
    """The Verilated pipeline of `config`, built once by the driver for every worker."""
    return CompiledCore.of(pipeline_harness.build(scene_tile(config)), ship=ship)


@dataclass(frozen=True)
class SceneTask:
    """What a worker needs to check one shard of scenes: those of the seeds from `seed` on."""

    index: int
    seed: int  # the first scene's
    scenes: int
    config: EdgeConfig

    def seeds(self) -> range:
        return range(self.seed, self.seed + self.scenes)

    def check(self, core: CompiledCore | None, report: Callable | None = None) -> dict:
        return check_scenes(self, core, report)

    def blank_result(self) -> dict:
        """A record of nothing checked (a crashed shard's)."""
        result = {"index": self.index, "seed": self.seed, "scenes": self.scenes, "pixels": 0}
        result.update(clocks=0, failed_scenes=0, wrong_pixels=0, sim_seconds=0.0, seconds=0.0)
        return result | {"mismatches": []}

    def blank_mismatch(self) -> dict:
        return {"scene": None, "x": None, "y": None, "reproduce": None}

    def reproduce(self) -> str:
        """The `edgeaa verify` command that reruns this shard alone."""
        return reproduce_scenes(self.config, self.seed, self.scenes)


def reproduce_scenes(config: EdgeConfig, seed: int, scenes: int = 1) -> str:
    argv = ["edgeaa", "verify", "--scenes", str(scenes), "--shard-seed", str(seed)]
    return shlex.join(argv + config_arguments(config))


def scene_workload() -> dict:
    """What decides a run's scenes, for its record (run.json)."""
    return {
        "max_width": SCENE_WIDTH,
        "max_height": SCENE_HEIGHT,
        "max_polygons": SCENE_POLYGONS,
        "margin": MARGIN,
    }


def check_scene(config: EdgeConfig, seed: int) -> tuple[dict, dict | None]:
    """Render scene `seed` through the pipeline and the model: (its counts, the mismatch or
    None). A pipeline that hangs is a mismatch of the scene; any other error raises."""
    scene = random_scene(config, seed)
    plan = plan_scene(scene, config)
    counts = {"pixels": scene.width * scene.height, "clocks": 0, "sim_seconds": 0.0}
    found = {"scene": seed, "reproduce": reproduce_scenes(config, seed)}
    what = f"scene seed {seed} ({scene.width} x {scene.height}, {len(scene.polygons)} polygons)"
    try:
        hardware = render_pipeline(plan, "verilator", scene_tile(config))
    except pipeline_harness.PipelineHang as error:
        return counts, found | {"kind": "hang", "x": None, "y": None, "message": f"{what}: {error}"}
    counts["clocks"], counts["sim_seconds"] = hardware.pipeline.clocks, hardware.pipeline.seconds
    model = render_scene(plan).image
    wrong = np.argwhere(hardware.image != model)  # (y, x), in row order
    if not len(wrong):
        return counts, None
    y, x = (int(v) for v in wrong[0])
    message = (
        f"{what}: {len(wrong)} of {counts['pixels']} pixels differ; the first, ({x}, {y}), is "
        f"{int(hardware.image[y, x])}, the model says {int(model[y, x])}"
    )
    found |= {"kind": "pixel", "x": x, "y": y, "message": message, "wrong": len(wrong)}
    return counts, found


def check_scenes(task: SceneTask, core: CompiledCore | None, report: Callable | None = None):
    """Check the shard's scenes one by one, calling `report(index, scenes checked)` after
    each; the result is plain data (stored as a JSON line). The first `MAX_LISTED_SCENES`
    mismatching scenes are listed, all counted (`failed_scenes`, `wrong_pixels`)."""
    start = time.perf_counter()
    if core is not None:  # the driver's build: no Verilog generated again in this worker
        pipeline_harness.use_executable(scene_tile(task.config), core.executable())
    result = task.blank_result()
    for done, seed in enumerate(task.seeds(), 1):
        counts, found = check_scene(task.config, seed)
        for key, value in counts.items():
            result[key] += value
        if found is not None:
            result["failed_scenes"] += 1
            result["wrong_pixels"] += found.pop("wrong", 0)
            if len(result["mismatches"]) < MAX_LISTED_SCENES:
                found.update(reproduce_shard=task.reproduce(), shard=task.index, seed=task.seed)
                result["mismatches"].append(found)
        if report is not None:
            report(task.index, done)
    result["seconds"] = time.perf_counter() - start
    return result
