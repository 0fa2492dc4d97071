"""The seed scene's tasks: 1, fetch the tool from the tool box in the fewest commands; 2, go
once around the crack on the workpiece's outer face; 3, spot welds on the workpiece's inner wall,
reached through the open top."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from armpath.errors import InvalidInputError, SceneError
from armpath.geometry.curves import Curve
from armpath.ik.target import AxisCone, Orientation
from armpath.model.seed_arm import seed_arm
from armpath.model.serial_arm import SerialArm
from armpath.planning.motion import MotionOptions
from armpath.planning.reach import ReachOptions, ReachResult, plan_reach
from armpath.planning.tour import TourResult, plan_tour
from armpath.planning.trace import AxisRule, TraceOptions, TraceResult, plan_trace
from armpath.scenes import Scene

IntArray = NDArray[np.int64]
FloatArray = NDArray[np.float64]

#: Farthest a weld may lie from an obstacle's surface for the tool axis to follow the surface's
#: normal there (mm): a weld a torch's standoff off the face (the track cell's lie 1 mm off it)
#: takes the nearest face's normal; one in free space has no surface to follow.
WELD_SURFACE_MM = 5.0

#: The seed tasks implemented so far, in SPEC order: (key, title).
SEED_TASKS: tuple[tuple[str, str], ...] = (
    ("reach", "Task 1: reach the tool box"),
    ("trace", "Task 2: trace the crack"),
    ("spotweld", "Task 3: spot welds inside the workpiece"),
)


def _start(model: SerialArm, start_ticks: IntArray | None) -> IntArray:
    """The task's start: the given lattice state, else the arm's initial (home) pose."""
    if start_ticks is not None:
        return np.asarray(start_ticks, dtype=np.int64)
    return model.lattice.to_ticks(model.home, "initial pose")


def reach_task(
    scene: Scene,
    arm: SerialArm | None = None,
    options: ReachOptions | None = None,
    start_ticks: IntArray | None = None,
    seed: int = 0,
) -> ReachResult:
    """Task 1: from the arm's initial pose (or ``start_ticks``) to the scene's reach target,
    fewest commands first (``seed``: of the random parts of the search); ``options`` None: the
    defaults with the scene's tolerance (:meth:`~armpath.scenes.Scene.tolerance_mm`)."""
    if scene.reach_target_mm is None:
        raise SceneError(f"scene {scene.source} defines no [tasks.reach] target_mm")
    model = arm or seed_arm()
    start = _start(model, start_ticks)
    if options is None:
        options = ReachOptions(tolerance_mm=scene.tolerance_mm("reach"))
    return plan_reach(model, scene.world, start, scene.reach_target_mm, options, seed=seed)


def spotweld_task(
    scene: Scene,
    arm: SerialArm | None = None,
    order: str = "auto",
    return_to_start: bool = False,
    tolerance_mm: float | None = None,
    options: MotionOptions | None = None,
    on_progress: Callable[[str], None] | None = None,
    tool_axis: AxisRule | None = None,
    start_ticks: IntArray | None = None,
    targets_mm: FloatArray | None = None,
    bound: bool = True,
    bound_samples: int | None = None,
    pools: bool = True,
) -> TourResult:
    """Task 3: from the arm's initial pose (or ``start_ticks``) through every spot weld of the
    scene (or the points ``targets_mm (K, 3)``), best order, each within ``tolerance_mm``
    (None: the scene's, :meth:`~armpath.scenes.Scene.tolerance_mm`). ``tool_axis``: the torch
    within a cone about the nearest surface's inward normal at each weld (a rule with
    ``normal``; each weld within :data:`WELD_SURFACE_MM` of an obstacle's surface, else
    :class:`InvalidInputError`) or about a fixed direction. ``bound``: prove the tour's lower
    bound (False: the plan only), its search holding up to ``bound_samples`` live samples.
    ``pools``: plan the cheapest orders through pools of goal states as well
    (:mod:`~armpath.planning.tour_pool`; False: the guided orders' goal states only, sooner)."""
    model = arm or seed_arm()
    start = _start(model, start_ticks)
    targets = scene.spotweld_targets_mm() if targets_mm is None else targets_mm
    rules: list[Orientation | None] | None = None
    if tool_axis is not None:
        rules = []
        for p in targets:
            if tool_axis.normal:
                if not scene.world.obstacles:
                    raise SceneError(
                        "a tool axis along the surface normal needs the welds on a surface; "
                        f"scene {scene.source} has no obstacles"
                    )
                away = [abs(float(o.signed_distance(p))) for o in scene.world.obstacles]
                surface = scene.world.obstacles[int(np.argmin(away))]
                off = min(away)
                if off > WELD_SURFACE_MM:
                    where = ", ".join(f"{v:g}" for v in p)
                    raise InvalidInputError(
                        "a tool axis along the surface normal needs each weld on an obstacle's "
                        f"surface (within {WELD_SURFACE_MM:g} mm); the weld at ({where}) mm lies "
                        f"{off:.1f} mm from the nearest, {surface.name}"
                    )
                direction = -surface.outward_normal(p)
            else:
                direction = np.asarray(tool_axis.direction, dtype=np.float64)
            rules.append(
                AxisCone(direction, tool_axis.tolerance_rad, np.asarray(model.approach_axis))
            )
    return plan_tour(
        model,
        scene.world,
        start,
        targets,
        order=order,
        return_to_start=return_to_start,
        tolerance_mm=scene.tolerance_mm("spotweld", tolerance_mm),
        options=options,
        on_progress=on_progress,
        orientations=rules,
        bound=bound,
        bound_samples=bound_samples,
        pools=pools,
    )


def trace_task(
    scene: Scene,
    arm: SerialArm | None = None,
    options: TraceOptions | None = None,
    on_progress: Callable[[str], None] | None = None,
    start_ticks: IntArray | None = None,
    curve: Curve | None = None,
) -> TraceResult:
    """Task 2: from the arm's initial pose (or ``start_ticks``), trace every reachable part of
    the scene's curve (or ``curve``); ``options`` None: the defaults with the scene's tolerance
    (:meth:`~armpath.scenes.Scene.tolerance_mm`)."""
    model = arm or seed_arm()
    start = _start(model, start_ticks)
    path = scene.trace_curve() if curve is None else curve
    if options is None:
        options = TraceOptions(tolerance_mm=scene.tolerance_mm("trace"))
    return plan_trace(model, scene.world, start, path, options, on_progress)
