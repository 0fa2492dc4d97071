"""Tracing curves with the tool point, for any arm: reachability, reference path, tracer,
deviation certificate and the plan that joins them (see :mod:`armpath.planning.trace.plan`)."""

from typing import TYPE_CHECKING

from armpath.lazy import lazy_exports

if TYPE_CHECKING:
    from armpath.planning.trace.certificate import certified_deviation
    from armpath.planning.trace.family import (
        AxisRule,
        CurveFamily,
        GenericCurveFamily,
        SeedCurveFamily,
        Verdict,
        curve_family,
    )
    from armpath.planning.trace.plan import (
        TraceOptions,
        TracePass,
        TraceResult,
        Transit,
        plan_trace,
        trace_plan_bound,
    )
    from armpath.planning.trace.reachability import (
        CurveArc,
        CurveReachability,
        UnreachableArc,
        curve_reachability,
    )
    from armpath.planning.trace.tracer import Tracer

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "certificate": ("certified_deviation",),
        "family": (
            "AxisRule",
            "CurveFamily",
            "GenericCurveFamily",
            "SeedCurveFamily",
            "Verdict",
            "curve_family",
        ),
        "plan": (
            "TraceOptions",
            "TracePass",
            "TraceResult",
            "Transit",
            "plan_trace",
            "trace_plan_bound",
        ),
        "reachability": (
            "CurveArc",
            "CurveReachability",
            "UnreachableArc",
            "curve_reachability",
        ),
        "tracer": ("Tracer",),
    },
)

__all__ = [
    "AxisRule",
    "CurveArc",
    "CurveFamily",
    "CurveReachability",
    "GenericCurveFamily",
    "SeedCurveFamily",
    "TraceOptions",
    "TracePass",
    "TraceResult",
    "Tracer",
    "Transit",
    "UnreachableArc",
    "Verdict",
    "certified_deviation",
    "curve_family",
    "curve_reachability",
    "plan_trace",
    "trace_plan_bound",
]
