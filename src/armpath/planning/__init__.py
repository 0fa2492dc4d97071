"""Planning on the command lattice: reach a point, plan around obstacles, tour points, trace a
curve, check continuous motions."""

from typing import TYPE_CHECKING

from armpath.lazy import lazy_exports

if TYPE_CHECKING:
    from armpath.planning.bounds import CommandBound, tour_bound, trace_bound
    from armpath.planning.motion_check import MotionClearance, motion_clearance
    from armpath.planning.reach import (
        LowerBound,
        ReachOptions,
        ReachResult,
        plan_reach,
        plan_to_point,
    )
    from armpath.planning.trace import (
        CurveReachability,
        TraceOptions,
        TraceResult,
        curve_reachability,
        plan_trace,
    )

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "bounds": ("CommandBound", "tour_bound", "trace_bound"),
        "motion_check": (
            "MotionClearance",
            "motion_clearance",
        ),
        "reach": (
            "LowerBound",
            "ReachOptions",
            "ReachResult",
            "plan_reach",
            "plan_to_point",
        ),
        "trace": (
            "CurveReachability",
            "TraceOptions",
            "TraceResult",
            "curve_reachability",
            "plan_trace",
        ),
    },
)

__all__ = [
    "CommandBound",
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
    "plan_to_point",
    "plan_trace",
    "tour_bound",
    "trace_bound",
]
