"""Planning on the command lattice: reach a point, plan around obstacles, tour points, trace a
curve, check continuous motions."""

from armpath.planning.motion_check import MotionClearance, motion_clearance
from armpath.planning.reach import LowerBound, ReachOptions, ReachResult, plan_reach
from armpath.planning.trace import (
    CurveReachability,
    TraceOptions,
    TraceResult,
    curve_reachability,
    plan_trace,
)

__all__ = [
    "CurveReachability",
    "LowerBound",
    "MotionClearance",
    "ReachOptions",
    "ReachResult",
    "TraceOptions",
    "TraceResult",
    "curve_reachability",
    "motion_clearance",
    "plan_reach",
    "plan_trace",
]
