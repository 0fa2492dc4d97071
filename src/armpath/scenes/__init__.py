"""Scenes: obstacles, clearance rule and task data, read from TOML or YAML files.

The seed scene (SPEC sections 3-4) lives in ``seed.toml`` next to this module; it is the one place
for its numbers. Files are validated with pydantic and every problem is reported as a
:class:`~armpath.errors.SceneError` naming the field.
"""

from __future__ import annotations

import copy
import tomllib
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

from armpath.budget import MAX_COORDINATE_MM
from armpath.errors import InvalidInputError, SceneError
from armpath.geometry import (
    Box,
    Capsule,
    CollisionWorld,
    HalfSpace,
    HollowFrustum,
    Obstacle,
    SolidOfRevolution,
    Sphere,
    WallThickness,
    cone_frustum,
    cylinder,
    hollow_frustum,
)
from armpath.geometry.curves import Curve, ParametricCurve, Polyline, plane_section

Vec3 = tuple[float, float, float]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


def _check_number(x: float) -> None:
    if not np.isfinite(x):
        raise ValueError("must be a finite number")
    if abs(x) > MAX_COORDINATE_MM:
        raise ValueError(
            f"{x:g} is beyond the largest coordinate or size a scene may use "
            f"({MAX_COORDINATE_MM:g} mm)"
        )


class _FiniteVec(_Strict):
    @field_validator("*", mode="after")
    @classmethod
    def _finite(cls, v: object) -> object:
        values = v if isinstance(v, tuple | list) else (v,)
        for x in values:
            for y in x if isinstance(x, tuple | list) else (x,):
                if isinstance(y, float | int) and not isinstance(y, bool):
                    _check_number(float(y))
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


class SphereSpec(_FiniteVec):
    type: Literal["sphere"]
    name: str
    center: Vec3
    radius: float = Field(gt=0)


class CapsuleSpec(_FiniteVec):
    type: Literal["capsule"]
    name: str
    start: Vec3
    end: Vec3
    radius: float = Field(gt=0)


class BoxSpec(_FiniteVec):
    type: Literal["box"]
    name: str
    center: Vec3
    size: Vec3 = Field(description="edge lengths along the box axes")
    rotation_deg: Vec3 = Field(
        default=(0.0, 0.0, 0.0), description="rotation vector of the box axes, degrees"
    )

    @field_validator("size", mode="after")
    @classmethod
    def _positive(cls, v: Vec3) -> Vec3:
        if any(x <= 0 for x in v):
            raise ValueError("box size must be positive")
        return v


class CylinderSpec(_FiniteVec):
    type: Literal["cylinder"]
    name: str
    base_center: Vec3
    axis: Vec3 = (0.0, 0.0, 1.0)
    radius: float = Field(gt=0)
    height: float = Field(gt=0)


class ConeFrustumSpec(_FiniteVec):
    type: Literal["cone_frustum"]
    name: str
    base_center: Vec3
    axis: Vec3 = (0.0, 0.0, 1.0)
    r_bottom: float = Field(ge=0)
    r_top: float = Field(ge=0)
    height: float = Field(gt=0)


class MeshSpec(_FiniteVec):
    type: Literal["mesh"]
    name: str
    file: str = Field(description="STL/OBJ path, relative to the scene file")
    scale: float = Field(default=1.0, gt=0)
    translation: Vec3 = (0.0, 0.0, 0.0)
    rotation_deg: Vec3 = (0.0, 0.0, 0.0)


ObstacleSpec = Annotated[
    HalfSpaceSpec
    | HollowFrustumSpec
    | SphereSpec
    | CapsuleSpec
    | BoxSpec
    | CylinderSpec
    | ConeFrustumSpec
    | MeshSpec,
    Field(discriminator="type"),
]


class ClearanceSpec(_FiniteVec):
    margin_mm: float = Field(default=1.0, ge=0)
    tool_tip_exempt_mm: float = Field(default=5.0, ge=0)
    self_margin_mm: float = Field(default=1.0, ge=0)


class ReachTaskSpec(_FiniteVec):
    target_mm: Vec3


class SpotweldTaskSpec(_FiniteVec):
    """Points on the inner wall of a hollow obstacle, given by their projections on xy."""

    workpiece: str = Field(description="name of the hollow_frustum obstacle")
    points_xy_mm: list[tuple[float, float]] = Field(min_length=1)
    surface: Literal["inner"] = "inner"


class PlaneSectionCurveSpec(_FiniteVec):
    """Where a plane cuts a side face of a solid of revolution obstacle (hollow_frustum,
    cylinder, cone_frustum): its outer face (the seed crack) or a hollow solid's inner face."""

    type: Literal["plane_section"]
    name: str = "curve"
    solid: str = Field(description="name of the hollow_frustum, cylinder or cone_frustum")
    face: Literal["outer", "inner"] = "outer"
    plane_point: Vec3
    plane_normal: Vec3


class ParametricCurveSpec(_FiniteVec):
    """``x(t), y(t), z(t)`` (mm) as expressions in ``t`` (numbers, + - * / ^ **, sin, cos, ...)."""

    type: Literal["parametric"]
    name: str = "curve"
    x: str
    y: str
    z: str
    t: tuple[float, float] = (0.0, 1.0)


class PolylineCurveSpec(_FiniteVec):
    type: Literal["polyline"]
    name: str = "curve"
    points_mm: list[Vec3] = Field(min_length=2)
    closed: bool = False


CurveSpec = Annotated[
    PlaneSectionCurveSpec | ParametricCurveSpec | PolylineCurveSpec, Field(discriminator="type")
]


class TraceTaskSpec(_Strict):
    """Task 2: the curve the fingertip follows."""

    curve: CurveSpec


class TasksSpec(_Strict):
    reach: ReachTaskSpec | None = None
    trace: TraceTaskSpec | None = None
    spotweld: SpotweldTaskSpec | None = None


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
    spotweld: SpotweldTaskSpec | None = None
    trace: TraceTaskSpec | None = None
    #: The validated scene file as plain JSON types (mesh paths made absolute): results carry
    #: it, so a result replays in its scene from any folder (:func:`scene_from_dict`).
    definition: dict[str, Any] = field(default_factory=dict)

    def spotweld_targets_mm(self) -> NDArray[np.float64]:
        """Task 3's points ``(N, 3)`` mm: each xy projection lifted onto the inner wall of the
        named workpiece (its height from the inner surface under the scene's wall convention).
        """
        if self.spotweld is None:
            raise SceneError(f"scene {self.source} defines no [tasks.spotweld]")
        spec = self.spotweld
        found = [o for o in self.world.obstacles if o.name == spec.workpiece]
        if not found:
            names = ", ".join(repr(o.name) for o in self.world.obstacles) or "none"
            raise SceneError(
                f"scene {self.source}: tasks.spotweld.workpiece {spec.workpiece!r} is not an "
                f"obstacle of the scene (obstacles: {names})"
            )
        if not isinstance(found[0], HollowFrustum):
            raise SceneError(
                f"scene {self.source}: tasks.spotweld.workpiece {spec.workpiece!r} is not a "
                "hollow_frustum obstacle"
            )
        w = found[0]
        return np.array([w.inner_wall_point(x, y) for x, y in spec.points_xy_mm])

    def trace_curve(self) -> Curve:
        """Task 2's curve, built against the scene's obstacles (mm)."""
        if self.trace is None:
            raise SceneError(f"scene {self.source} defines no [tasks.trace]")
        spec = self.trace.curve
        try:
            if isinstance(spec, PlaneSectionCurveSpec):
                found = [o for o in self.world.obstacles if o.name == spec.solid]
                if not found:
                    names = ", ".join(repr(o.name) for o in self.world.obstacles) or "none"
                    raise SceneError(
                        f"scene {self.source}: tasks.trace.curve.solid {spec.solid!r} is not an "
                        f"obstacle of the scene (obstacles: {names})"
                    )
                if not isinstance(found[0], SolidOfRevolution):
                    raise SceneError(
                        f"scene {self.source}: tasks.trace.curve.solid {spec.solid!r} is not a "
                        "hollow_frustum, cylinder or cone_frustum"
                    )
                return plane_section(
                    spec.name, found[0], spec.plane_point, spec.plane_normal, spec.face
                )
            if isinstance(spec, ParametricCurveSpec):
                return ParametricCurve(spec.name, spec.x, spec.y, spec.z, spec.t[0], spec.t[1])
            return Polyline(spec.name, np.array(spec.points_mm), spec.closed)
        except SceneError:
            raise
        except InvalidInputError as exc:
            raise SceneError(f"scene {self.source}: tasks.trace.curve: {exc}") from None

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
        definition = copy.deepcopy(self.definition)
        for spec in definition.get("obstacles", []):
            if spec.get("type") == "hollow_frustum":
                spec["wall_thickness"] = conv.value
        return replace(self, world=replace(self.world, obstacles=obstacles), definition=definition)

    def describe(self) -> dict[str, object]:
        """The scene for result files: name, source, wall convention, the obstacles and the
        clearance rule, and ``definition`` (what :func:`scene_from_dict` rebuilds it from)."""
        wall = self.wall_thickness
        return {
            "name": self.name,
            "source": self.source,
            "wall_thickness": wall.value if wall else None,
            **self.world.describe(),
            "definition": self.definition,
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


def _rotation(rotvec_deg: Vec3) -> NDArray[np.float64]:
    from scipy.spatial.transform import Rotation

    return np.asarray(Rotation.from_rotvec(np.radians(rotvec_deg)).as_matrix())


def _build_obstacle(spec: BaseModel, base_dir: Path | None) -> Obstacle:
    if isinstance(spec, HalfSpaceSpec):
        return HalfSpace(spec.name, np.array(spec.point), np.array(spec.normal))
    if isinstance(spec, SphereSpec):
        return Sphere(spec.name, np.array(spec.center), spec.radius)
    if isinstance(spec, CapsuleSpec):
        return Capsule(spec.name, np.array(spec.start), np.array(spec.end), spec.radius)
    if isinstance(spec, BoxSpec):
        return Box(
            spec.name, np.array(spec.center), np.array(spec.size) / 2, _rotation(spec.rotation_deg)
        )
    if isinstance(spec, CylinderSpec):
        return cylinder(spec.name, spec.base_center, spec.axis, spec.radius, spec.height)
    if isinstance(spec, ConeFrustumSpec):
        return cone_frustum(
            spec.name, spec.base_center, spec.axis, spec.r_bottom, spec.r_top, spec.height
        )
    if isinstance(spec, MeshSpec):
        try:
            from armpath.geometry.mesh import load_mesh
        except ImportError as exc:
            raise InvalidInputError(f"obstacle {spec.name!r}: {exc}") from None

        path = Path(spec.file)
        if not path.is_absolute() and base_dir is not None:
            path = base_dir / path
        T = np.eye(4)
        T[:3, :3] = _rotation(spec.rotation_deg)
        T[:3, 3] = spec.translation
        return load_mesh(path, spec.name, spec.scale, T)
    assert isinstance(spec, HollowFrustumSpec)
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


def scene_from_dict(
    data: dict[str, object], source: str = "<dict>", base_dir: Path | None = None
) -> Scene:
    """Validate a parsed scene file and build the scene (relative mesh paths from
    ``base_dir``)."""
    if not isinstance(data, dict):
        raise SceneError(f"scene {source}: the top level must be a table of keys")
    try:
        spec = SceneFile.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        msg = str(first["msg"]).removeprefix("Value error, ")
        raise SceneError(f"scene {source}: {where}: {msg}") from None
    try:
        obstacles = tuple(_build_obstacle(o, base_dir) for o in spec.obstacles)
        world = CollisionWorld(
            obstacles,
            spec.clearance.margin_mm,
            spec.clearance.tool_tip_exempt_mm,
            spec.clearance.self_margin_mm,
        )
    except InvalidInputError as exc:
        raise SceneError(f"scene {source}: {exc}") from None
    reach = spec.tasks.reach.target_mm if spec.tasks.reach else None
    definition = spec.model_dump(mode="json")
    for o_spec, o in zip(definition["obstacles"], obstacles, strict=True):
        if o_spec["type"] == "mesh":
            o_spec["file"] = str(Path(getattr(o, "source", None) or o_spec["file"]).resolve())
    scene = Scene(
        spec.name,
        spec.description,
        world,
        reach,
        source,
        spec.tasks.spotweld,
        spec.tasks.trace,
        definition,
    )
    if scene.spotweld is not None:
        scene.spotweld_targets_mm()  # validates the workpiece name and the points
    if scene.trace is not None:
        scene.trace_curve()  # validates the curve against the obstacles
    return scene


def _one_line(exc: Exception) -> str:
    """A parser's message on one line (YAML's point at the error over several)."""
    return " ".join(str(exc).split())


def load_scene(path: str | Path | None = None) -> Scene:
    """Load a scene file (``.toml``, or ``.yaml``/``.yml``); ``None`` loads the seed scene."""
    base_dir = None
    suffix = ".toml"
    if path is None:
        text = resources.files("armpath.scenes").joinpath("seed.toml").read_text("utf-8")
        source = "built-in seed.toml"
    else:
        p = Path(path)
        suffix = p.suffix.lower()
        if suffix not in (".toml", ".yaml", ".yml"):
            raise SceneError(f"scene file {p} must end in .toml, .yaml or .yml")
        try:
            text = p.read_text("utf-8")
        except OSError as exc:
            raise SceneError(f"cannot read scene file {p}: {exc.strerror}") from None
        except UnicodeDecodeError as exc:
            raise SceneError(
                f"scene file {p} is not UTF-8 text (byte {exc.start}: {exc.reason})"
            ) from None
        source = str(p)
        base_dir = p.parent
    data: object
    if suffix == ".toml":
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise SceneError(f"scene {source}: not valid TOML: {_one_line(exc)}") from None
    else:
        import yaml

        try:
            data = yaml.safe_load(text)
        except yaml.YAMLError as exc:
            raise SceneError(f"scene {source}: not valid YAML: {_one_line(exc)}") from None
    return scene_from_dict(data, source, base_dir)  # type: ignore[arg-type]


def seed_scene() -> Scene:
    """The built-in seed scene of SPEC section 3."""
    return load_scene(None)


__all__ = ["Scene", "SceneFile", "load_scene", "scene_from_dict", "seed_scene"]
