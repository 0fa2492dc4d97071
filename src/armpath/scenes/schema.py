"""The schema of scene files (TOML or YAML), validated with pydantic: obstacles, the clearance
rule, the arm that works in the cell and its tasks. Lengths mm, angles deg; every number finite
and within :data:`~armpath.budget.MAX_COORDINATE_MM`."""

from __future__ import annotations

from collections.abc import Callable
from typing import Annotated, ClassVar, Literal, get_args

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationInfo,
    field_validator,
    model_validator,
)

from armpath.budget import MAX_COORDINATE_MM
from armpath.errors import InvalidInputError
from armpath.geometry import WallThickness
from armpath.tolerances import check_point_tolerance, check_trace_tolerance

Vec3 = tuple[float, float, float]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


def _check_number(x: float, parameter: bool = False) -> None:
    """A finite number within what a scene may hold: a coordinate or a size (mm), or with
    ``parameter`` a curve's parameter (no unit, the same largest value)."""
    if not np.isfinite(x):
        raise ValueError("must be a finite number")
    if abs(x) > MAX_COORDINATE_MM:
        raise ValueError(
            f"{x:g} is beyond the largest curve parameter a scene may use ({MAX_COORDINATE_MM:g})"
            if parameter
            else f"{x:g} is beyond the largest coordinate or size a scene may use "
            f"({MAX_COORDINATE_MM:g} mm)"
        )


def _takes(annotation: object, kinds: tuple[type, ...]) -> bool:
    """Whether a field's type admits a value of one of ``kinds`` (itself, or in a union or a
    container of them)."""
    return annotation in kinds or any(_takes(a, kinds) for a in get_args(annotation))


def _takes_bool(annotation: object) -> bool:
    """Whether a field's type admits true/false."""
    return _takes(annotation, (bool,))


class _FiniteVec(_Strict):
    #: fields that count (ticks, steps) rather than measure: checked with their own limits
    #: where they are used, not as coordinates or sizes
    _counts: ClassVar[frozenset[str]] = frozenset()

    @model_validator(mode="before")
    @classmethod
    def _no_truth_values(cls, data: object) -> object:
        """true or false where a number goes is a mistake (pydantic would read 1 or 0: a
        sphere of ``radius = true`` was 1 mm)."""
        if not isinstance(data, dict):
            return data
        for name, v in data.items():
            field = cls.model_fields.get(name)
            if (
                field is None
                or _takes_bool(field.annotation)
                or not _takes(field.annotation, (int, float))
            ):
                continue
            values = v if isinstance(v, tuple | list) else (v,)
            for x in values:
                for y in x if isinstance(x, tuple | list) else (x,):
                    if isinstance(y, bool):
                        raise ValueError(f"{name}: must be a number, not {str(y).lower()}")
        return data

    @field_validator("*", mode="after")
    @classmethod
    def _finite(cls, v: object, info: ValidationInfo) -> object:
        if info.field_name in cls._counts:
            return v
        values = v if isinstance(v, tuple | list) else (v,)
        for x in values:
            for y in x if isinstance(x, tuple | list) else (x,):
                if isinstance(y, float | int) and not isinstance(y, bool):
                    _check_number(float(y), parameter=info.field_name == "t")
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


def _checked_tolerance(v: float | None, check: Callable[[float], float]) -> float | None:
    """A task's tolerance (mm), None or within :mod:`armpath.tolerances`' range."""
    if v is not None:
        try:
            check(v)
        except InvalidInputError as exc:
            raise ValueError(str(exc)) from None
    return v


def _point_tolerance(v: float | None) -> float | None:
    return _checked_tolerance(v, check_point_tolerance)


def _trace_tolerance(v: float | None) -> float | None:
    return _checked_tolerance(v, check_trace_tolerance)


class ReachTaskSpec(_FiniteVec):
    """Task 1: the point the tool reaches and the largest error accepted there (``tolerance_mm``;
    None: :data:`~armpath.tolerances.POINT_TOLERANCE_MM`)."""

    target_mm: Vec3
    tolerance_mm: float | None = None

    _tolerance = field_validator("tolerance_mm")(_point_tolerance)


class SpotweldTaskSpec(_FiniteVec):
    """The welds: points ``points_mm`` (3-D), or projections ``points_xy_mm`` lifted onto the
    inner (default) or outer face of a hollow_frustum obstacle (``workpiece``); the largest tool
    point error accepted at each (``tolerance_mm``; None:
    :data:`~armpath.tolerances.POINT_TOLERANCE_MM`)."""

    workpiece: str | None = Field(default=None, description="name of the hollow_frustum")
    points_xy_mm: list[tuple[float, float]] | None = None
    points_mm: list[Vec3] | None = None
    surface: Literal["inner", "outer"] = "inner"
    tolerance_mm: float | None = None

    _tolerance = field_validator("tolerance_mm")(_point_tolerance)

    @model_validator(mode="after")
    def _one_kind(self) -> SpotweldTaskSpec:
        if (self.points_xy_mm is None) == (self.points_mm is None):
            raise ValueError("give either points_mm (3-D points) or points_xy_mm with workpiece")
        if self.points_xy_mm is not None and self.workpiece is None:
            raise ValueError("points_xy_mm are lifted onto a workpiece: name it (workpiece)")
        points = self.points_mm if self.points_mm is not None else self.points_xy_mm
        if not points:
            raise ValueError("give at least one weld point")
        return self


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


class CircleCurveSpec(_FiniteVec):
    """A circle of ``radius_mm`` about ``center_mm`` in the plane normal to ``normal``, or an
    arc of it: from ``start_direction`` (None: the world x axis, or y where x lies near the
    normal) round ``sweep_deg`` right-handed about ``normal``."""

    type: Literal["circle"]
    name: str = "curve"
    center_mm: Vec3
    radius_mm: float = Field(gt=0)
    normal: Vec3 = (0.0, 0.0, 1.0)
    start_direction: Vec3 | None = None
    sweep_deg: float = Field(default=360.0, gt=0, le=360)


class PolylineCurveSpec(_FiniteVec):
    type: Literal["polyline"]
    name: str = "curve"
    points_mm: list[Vec3] = Field(min_length=2)
    closed: bool = False


CurveSpec = Annotated[
    PlaneSectionCurveSpec | ParametricCurveSpec | CircleCurveSpec | PolylineCurveSpec,
    Field(discriminator="type"),
]


class TraceTaskSpec(_Strict):
    """Task 2: the curve the fingertip follows and the largest distance of the continuous tool
    path from it (``tolerance_mm``; None: :data:`~armpath.tolerances.TRACE_TOLERANCE_MM`)."""

    curve: CurveSpec
    tolerance_mm: float | None = None

    _tolerance = field_validator("tolerance_mm")(_trace_tolerance)


class TasksSpec(_Strict):
    reach: ReachTaskSpec | None = None
    trace: TraceTaskSpec | None = None
    spotweld: SpotweldTaskSpec | None = None


class PlacementSpec(_FiniteVec):
    """A rigid transform: a position (mm) and a rotation vector (deg; its direction is the
    axis, its length the angle)."""

    position_mm: Vec3 = (0.0, 0.0, 0.0)
    rotation_deg: Vec3 = (0.0, 0.0, 0.0)


class ToolSpec(PlacementSpec):
    """The tool centre point as a transform from the flange (the last joint's frame), the
    radius of the tool's capsule (default: the last link's) and its approach axis in the tool
    frame (where it points; default z)."""

    radius_mm: float | None = Field(default=None, ge=0)
    approach_axis: Vec3 = (0.0, 0.0, 1.0)


class ArmSpec(_FiniteVec):
    """The arm that works in the cell: a built-in model or a robot file (relative to the scene
    file; ``tip_link``: a URDF's tool link), where it stands (``base``), its tool, its home
    pose (deg, or mm for prismatic joints), link radii (mm: one number, or the fixed base then
    one per joint) and command lattice (``tick``: deg or mm per joint, one number or one per
    joint; ``max_ticks``: the most ticks a command, one number or one per joint;
    ``steps_per_tick``: a stepper controller's motor steps per tick; ``command_period_s``: the
    time one command takes)."""

    _counts: ClassVar[frozenset[str]] = frozenset({"max_ticks", "steps_per_tick"})

    model: str = "seed"
    tip_link: str | None = None
    base: PlacementSpec | None = None
    tool: ToolSpec | None = None
    home_deg: list[float] | None = None
    link_radii_mm: float | list[float] | None = None
    tick: float | list[float] | None = None
    max_ticks: int | list[int] | None = None
    steps_per_tick: int | list[int] | None = None
    command_period_s: float | None = None


class SceneFile(_Strict):
    """Schema of a scene file (TOML or YAML)."""

    name: str
    description: str = ""
    clearance: ClearanceSpec = ClearanceSpec()
    obstacles: list[ObstacleSpec] = []
    arm: ArmSpec | None = None
    tasks: TasksSpec = TasksSpec()
