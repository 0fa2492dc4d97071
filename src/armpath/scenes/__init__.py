"""Scenes: obstacles, the clearance rule, the arm that works in the cell and its tasks, read from
TOML or YAML files.

The seed scene (SPEC sections 3-4) lives in ``seed.toml`` next to this module; it is the one place
for its numbers. Files are validated with pydantic (:mod:`armpath.scenes.schema`) and every
problem is reported as a :class:`~armpath.errors.SceneError` naming the field; the solids are
built by :mod:`armpath.scenes.build`, the arm by :mod:`armpath.scenes.arm`.
"""

from typing import TYPE_CHECKING

from armpath.lazy import lazy_exports

if TYPE_CHECKING:
    from armpath.scenes.load import load_scene, scene_from_dict, seed_scene
    from armpath.scenes.scene import Scene
    from armpath.scenes.schema import SceneFile

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "load": (
            "load_scene",
            "scene_from_dict",
            "seed_scene",
        ),
        "scene": ("Scene",),
        "schema": ("SceneFile",),
    },
)

__all__ = ["Scene", "SceneFile", "load_scene", "scene_from_dict", "seed_scene"]
