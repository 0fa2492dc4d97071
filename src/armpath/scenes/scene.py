"""A validated scene: the collision world, the arm that works in it (if the file names one) and
its tasks."""

from __future__ import annotations

import copy
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from armpath.errors import InvalidInputError, SceneError
from armpath.geometry import CollisionWorld, HollowFrustum, SolidOfRevolution, WallThickness
from armpath.geometry.curves import CircularArc, Curve, ParametricCurve, Polyline, plane_section
from armpath.scenes.build import rebuild_frustum
from armpath.scenes.schema import (
    ArmSpec,
    CircleCurveSpec,
    ParametricCurveSpec,
    PlaneSectionCurveSpec,
    SpotweldTaskSpec,
    TraceTaskSpec,
)
from armpath.tolerances import POINT_TOLERANCE_MM, TRACE_TOLERANCE_MM


@dataclass(frozen=True, repr=False)
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
    #: The scene's ``[arm]`` (None: the file names no arm).
    arm_spec: ArmSpec | None = None
    #: The folder the scene file is in (robot and mesh files are relative to it).
    base_dir: str | None = None
    #: ``[tasks.reach] tolerance_mm`` (None: the file gives none).
    reach_tolerance_mm: float | None = None

    def tolerance_mm(self, task: str, given: float | None = None) -> float:
        """The largest tool point error of the scene's ``task`` (``"reach"``, ``"spotweld"``:
        at the goal point; ``"trace"``: of the continuous tool path from the curve), mm:
        ``given`` (the caller's), else its ``[tasks.<task>] tolerance_mm``, else the task's
        default (:mod:`armpath.tolerances`)."""
        if given is not None:
            return given
        if task == "reach":
            given = self.reach_tolerance_mm
        elif task == "spotweld":
            given = None if self.spotweld is None else self.spotweld.tolerance_mm
        elif task == "trace":
            given = None if self.trace is None else self.trace.tolerance_mm
        else:
            raise ValueError(f"no task {task!r}: reach, trace or spotweld")
        if given is not None:
            return given
        return TRACE_TOLERANCE_MM if task == "trace" else POINT_TOLERANCE_MM

    def spotweld_targets_mm(self) -> NDArray[np.float64]:
        """Task 3's points ``(N, 3)`` mm: the 3-D points given, or each xy projection lifted
        onto the inner (under the scene's wall convention) or outer face of the named workpiece.
        """
        if self.spotweld is None:
            raise SceneError(
                f"scene {self.source} defines no [tasks.spotweld]: give a scene file that "
                "does (--scene; the repository's examples/ur5_cell.toml has one), or the "
                "welds to armpath.spotweld"
            )
        spec = self.spotweld
        if spec.points_mm is not None:
            return np.array(spec.points_mm, dtype=np.float64)
        assert spec.points_xy_mm is not None
        found = [o for o in self.world.obstacles if o.name == spec.workpiece]
        if not found:
            names = ", ".join(repr(o.name) for o in self.world.obstacles) or "none"
            raise SceneError(
                f"scene {self.source}: tasks.spotweld.workpiece {spec.workpiece!r} is not an "
                f"obstacle of the scene (obstacles: {names})"
            )
        if not isinstance(found[0], HollowFrustum):
            raise SceneError(
                f"scene {self.source}: tasks.spotweld.workpiece {spec.workpiece!r} is a "
                f"{found[0].describe()['type']}, not a hollow_frustum: points_xy_mm are lifted "
                "onto a hollow_frustum's wall only; give the welds as 3-D points (points_mm)"
            )
        w = found[0]
        lift = w.outer_wall_point if spec.surface == "outer" else w.inner_wall_point
        try:
            return np.array([lift(x, y) for x, y in spec.points_xy_mm])
        except InvalidInputError as exc:
            raise SceneError(f"scene {self.source}: tasks.spotweld: {exc}") from None

    def trace_curve(self) -> Curve:
        """Task 2's curve, built against the scene's obstacles (mm)."""
        if self.trace is None:
            raise SceneError(
                f"scene {self.source} defines no [tasks.trace]: give a scene file with a "
                "[tasks.trace.curve] (--scene; the repository's examples/ur5_cell.toml has "
                "one), or the curve's points (trace --curve FILE; armpath.trace's curve)"
            )
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
            if isinstance(spec, CircleCurveSpec):
                return CircularArc(
                    spec.name, np.array(spec.center_mm), spec.radius_mm, np.array(spec.normal),
                    None if spec.start_direction is None else np.array(spec.start_direction),
                    spec.sweep_deg,
                )  # fmt: skip
            return Polyline(spec.name, np.array(spec.points_mm), spec.closed)
        except SceneError:
            raise
        except InvalidInputError as exc:
            raise SceneError(f"scene {self.source}: tasks.trace.curve: {exc}") from None

    def __repr__(self) -> str:
        names = ", ".join(self.world.obstacle_names) or "no obstacles"
        return f"Scene({self.name!r}, {names}; from {self.source})"

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
            rebuild_frustum(o, conv) if isinstance(o, HollowFrustum) else o
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
