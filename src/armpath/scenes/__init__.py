"""Scenes: obstacles, clearance rule and task data, read from TOML files.

The seed scene (SPEC sections 3-4) lives in ``seed.toml`` next to this module; it is the one place
for its numbers. Files are validated with pydantic and every problem is reported as a
:class:`~armpath.errors.SceneError` naming the field.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from armpath.errors import InvalidInputError, SceneError
from armpath.geometry import (
    CollisionWorld,
    HalfSpace,
    HollowFrustum,
    Obstacle,
    WallThickness,
    hollow_frustum,
)

Vec3 = tuple[float, float, float]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class _FiniteVec(_Strict):
    @field_validator("*", mode="after")
    @classmethod
    def _finite(cls, v: object) -> object:
        values = v if isinstance(v, tuple) else (v,)
        for x in values:
            if isinstance(x, float) and not np.isfinite(x):
                raise ValueError("must be a finite number")
        return v


class HalfSpaceSpec(_FiniteVec):
    type: Literal["half_space"]
    name: str
    point: Vec3
    normal: Vec3


class HollowFrustumSpec(_FiniteVec):
    type: Literal["hollow_frustum"]
    name: str
    base_center: Vec3
    height: float = Field(gt=0)
    r_bottom: float = Field(gt=0)
    r_top: float = Field(gt=0)
    wall: float = Field(gt=0)
    wall_thickness: WallThickness = WallThickness.NORMAL
    open_top: bool = True
    closed_bottom: bool = True
    axis: Vec3 = (0.0, 0.0, 1.0)


ObstacleSpec = Annotated[HalfSpaceSpec | HollowFrustumSpec, Field(discriminator="type")]


class ClearanceSpec(_FiniteVec):
    margin_mm: float = Field(default=1.0, ge=0)
    tool_tip_exempt_mm: float = Field(default=5.0, ge=0)


class ReachTaskSpec(_FiniteVec):
    target_mm: Vec3


class TasksSpec(_Strict):
    reach: ReachTaskSpec | None = None


class SceneFile(_Strict):
    """Schema of a scene file (TOML)."""

    name: str
    description: str = ""
    clearance: ClearanceSpec = ClearanceSpec()
    obstacles: list[ObstacleSpec] = []
    tasks: TasksSpec = TasksSpec()


@dataclass(frozen=True)
class Scene:
    """A validated scene: the collision world and the task data."""

    name: str
    description: str
    world: CollisionWorld
    reach_target_mm: tuple[float, float, float] | None
    source: str

    @property
    def workpieces(self) -> tuple[HollowFrustum, ...]:
        return tuple(o for o in self.world.obstacles if isinstance(o, HollowFrustum))

    @property
    def wall_thickness(self) -> WallThickness | None:
        """The wall-thickness convention of the scene's workpiece(s), if any."""
        conventions = {w.wall_thickness for w in self.workpieces}
        return conventions.pop() if len(conventions) == 1 else None

    def with_wall_thickness(self, convention: WallThickness | str) -> Scene:
        """The same scene with every hollow frustum's wall measured by ``convention``."""
        try:
            conv = WallThickness(convention)
        except ValueError:
            valid = ", ".join(w.value for w in WallThickness)
            raise InvalidInputError(
                f"wall thickness must be one of {valid}, got {convention!r}"
            ) from None
        obstacles = tuple(
            _rebuild_frustum(o, conv) if isinstance(o, HollowFrustum) else o
            for o in self.world.obstacles
        )
        return replace(self, world=replace(self.world, obstacles=obstacles))

    def describe(self) -> dict[str, object]:
        wall = self.wall_thickness
        return {
            "name": self.name,
            "source": self.source,
            "wall_thickness": wall.value if wall else None,
            **self.world.describe(),
        }


def _rebuild_frustum(f: HollowFrustum, conv: WallThickness) -> HollowFrustum:
    return hollow_frustum(
        f.name,
        f.origin,
        f.height,
        f.r_bottom,
        f.r_top,
        f.wall,
        conv,
        open_top=f.open_top,
        closed_bottom=f.closed_bottom,
        axis=f.axis,
    )


def _build_obstacle(spec: HalfSpaceSpec | HollowFrustumSpec) -> Obstacle:
    if isinstance(spec, HalfSpaceSpec):
        return HalfSpace(spec.name, np.array(spec.point), np.array(spec.normal))
    return hollow_frustum(
        spec.name,
        spec.base_center,
        spec.height,
        spec.r_bottom,
        spec.r_top,
        spec.wall,
        spec.wall_thickness,
        open_top=spec.open_top,
        closed_bottom=spec.closed_bottom,
        axis=spec.axis,
    )


def scene_from_dict(data: dict[str, object], source: str = "<dict>") -> Scene:
    """Validate a parsed scene file and build the scene."""
    try:
        spec = SceneFile.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        raise SceneError(f"scene {source}: {where}: {first['msg']}") from None
    try:
        obstacles = tuple(_build_obstacle(o) for o in spec.obstacles)
        world = CollisionWorld(
            obstacles, spec.clearance.margin_mm, spec.clearance.tool_tip_exempt_mm
        )
    except InvalidInputError as exc:
        raise SceneError(f"scene {source}: {exc}") from None
    reach = spec.tasks.reach.target_mm if spec.tasks.reach else None
    return Scene(spec.name, spec.description, world, reach, source)


def load_scene(path: str | Path | None = None) -> Scene:
    """Load a scene file (TOML); ``None`` loads the built-in seed scene."""
    if path is None:
        text = resources.files("armpath.scenes").joinpath("seed.toml").read_text("utf-8")
        source = "built-in seed.toml"
    else:
        p = Path(path)
        try:
            text = p.read_text("utf-8")
        except OSError as exc:
            raise SceneError(f"cannot read scene file {p}: {exc.strerror}") from None
        source = str(p)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"scene {source}: not valid TOML: {exc}") from None
    return scene_from_dict(data, source)


def seed_scene() -> Scene:
    """The built-in seed scene of SPEC section 3."""
    return load_scene(None)


__all__ = ["Scene", "SceneFile", "load_scene", "scene_from_dict", "seed_scene"]
