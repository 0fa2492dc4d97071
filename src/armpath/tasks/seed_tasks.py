"""The seed scene's tasks: 1, fetch the tool from the tool box in the fewest commands; 2, go
once around the crack on the workpiece's outer face; 3, spot welds on the workpiece's inner wall,
reached through the open top."""

from __future__ import annotations

from collections.abc import Callable

from armpath.errors import SceneError
from armpath.model.seed_arm import seed_arm
from armpath.model.serial_arm import SerialArm
from armpath.planning.motion import MotionOptions
from armpath.planning.reach import ReachOptions, ReachResult, plan_reach
from armpath.planning.tour import TourResult, plan_tour
from armpath.planning.trace import TraceOptions, TraceResult, plan_trace
from armpath.scenes import Scene

#: The seed tasks implemented so far, in SPEC order: (key, title).
SEED_TASKS: tuple[tuple[str, str], ...] = (
    ("reach", "Task 1: reach the tool box"),
    ("trace", "Task 2: trace the crack"),
    ("spotweld", "Task 3: spot welds inside the workpiece"),
)


def reach_task(
    scene: Scene, arm: SerialArm | None = None, options: ReachOptions | None = None
) -> ReachResult:
    """Task 1: from the arm's initial pose to the scene's reach target, fewest commands first."""
    if scene.reach_target_mm is None:
        raise SceneError(f"scene {scene.source} defines no [tasks.reach] target_mm")
    model = arm or seed_arm()
    start = model.lattice.to_ticks(model.home, "initial pose")
    return plan_reach(model, scene.world, start, scene.reach_target_mm, options)


def spotweld_task(
    scene: Scene,
    arm: SerialArm | None = None,
    order: str = "auto",
    return_to_start: bool = False,
    tolerance_mm: float = 0.05,
    options: MotionOptions | None = None,
    on_progress: Callable[[str], None] | None = None,
) -> TourResult:
    """Task 3: from the arm's initial pose through every spot weld of the scene, best order."""
    model = arm or seed_arm()
    start = model.lattice.to_ticks(model.home, "initial pose")
    return plan_tour(
        model,
        scene.world,
        start,
        scene.spotweld_targets_mm(),
        order=order,
        return_to_start=return_to_start,
        tolerance_mm=tolerance_mm,
        options=options,
        on_progress=on_progress,
    )


def trace_task(
    scene: Scene,
    arm: SerialArm | None = None,
    options: TraceOptions | None = None,
    on_progress: Callable[[str], None] | None = None,
) -> TraceResult:
    """Task 2: from the arm's initial pose, trace every reachable part of the scene's curve."""
    model = arm or seed_arm()
    start = model.lattice.to_ticks(model.home, "initial pose")
    return plan_trace(model, scene.world, start, scene.trace_curve(), options, on_progress)
