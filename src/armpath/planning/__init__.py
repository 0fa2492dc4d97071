"""Planning on the command lattice: reach a point, check continuous motions."""

from armpath.planning.motion_check import MotionClearance, motion_clearance
from armpath.planning.reach import LowerBound, ReachOptions, ReachResult, plan_reach

__all__ = [
    "LowerBound",
    "MotionClearance",
    "ReachOptions",
    "ReachResult",
    "motion_clearance",
    "plan_reach",
]
