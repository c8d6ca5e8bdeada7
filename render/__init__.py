"""Scene rendering: polygons and text through the model or the cycle-accurate core."""

from .builtin import BUILTINS, builtin
from .render import Plan, Render, plan_scene, render_scene
from .scene import Polygon, Scene, SceneError, load_scene, parse_path, parse_scene

__all__ = [
    "BUILTINS",
    "Plan",
    "Polygon",
    "Render",
    "Scene",
    "SceneError",
    "builtin",
    "load_scene",
    "parse_path",
    "parse_scene",
    "plan_scene",
    "render_scene",
]
