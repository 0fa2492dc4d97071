"""Task 1 of the seed scene: fetch the tool from the tool box in the fewest commands.

(Tasks 2, trace the crack, and 3, spot welds inside the workpiece, are added by later issues.)
"""

from __future__ import annotations

import numpy as np

from armpath.commands import deg_to_ticks
from armpath.errors import SceneError
from armpath.model.seed_arm import seed_arm
from armpath.model.serial_arm import SerialArm
from armpath.planning.reach import ReachOptions, ReachResult, plan_reach
from armpath.scenes import Scene

#: The seed tasks implemented so far, in SPEC order: (key, title).
SEED_TASKS: tuple[tuple[str, str], ...] = (("reach", "Task 1: reach the tool box"),)


def reach_task(
    scene: Scene, arm: SerialArm | None = None, options: ReachOptions | None = None
) -> ReachResult:
    """Task 1: from the arm's initial pose to the scene's reach target, fewest commands first."""
    if scene.reach_target_mm is None:
        raise SceneError(f"scene {scene.source} defines no [tasks.reach] target_mm")
    model = arm or seed_arm()
    start = deg_to_ticks(np.degrees(model.home), what="initial pose")
    return plan_reach(model, scene.world, start, scene.reach_target_mm, options)
