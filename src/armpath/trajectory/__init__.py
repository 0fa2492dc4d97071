"""Smooth joint trajectories: minimum-snap / minimum-jerk piecewise polynomials (with or without
motion limits), their retiming (uniform scaling, bounded QP, toppra, ruckig) and their commands on
the controller's lattice."""

from typing import TYPE_CHECKING

from armpath.lazy import lazy_exports

if TYPE_CHECKING:
    from armpath.trajectory.minsnap import (
        ORDERS,
        QP_SOLVERS,
        InfeasibleLimitsError,
        MotionLimits,
        PiecewisePolynomial,
        QPSolverError,
        allocate_times,
        minimum_snap,
    )
    from armpath.trajectory.quantize import (
        QuantizedTrajectory,
        joint_ticks,
        lattice_motion,
        quantize,
        tip_deviation,
    )
    from armpath.trajectory.retime import (
        RETIMING_METHODS,
        JointTrajectory,
        Retimed,
        compare_retimings,
        ruckig_retime,
        scaled,
        shortest_bounded,
        toppra_retime,
    )

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "minsnap": (
            "ORDERS",
            "QP_SOLVERS",
            "InfeasibleLimitsError",
            "MotionLimits",
            "PiecewisePolynomial",
            "QPSolverError",
            "allocate_times",
            "minimum_snap",
        ),
        "quantize": (
            "QuantizedTrajectory",
            "joint_ticks",
            "lattice_motion",
            "quantize",
            "tip_deviation",
        ),
        "retime": (
            "RETIMING_METHODS",
            "JointTrajectory",
            "Retimed",
            "compare_retimings",
            "ruckig_retime",
            "scaled",
            "shortest_bounded",
            "toppra_retime",
        ),
    },
)

__all__ = [
    "ORDERS",
    "QP_SOLVERS",
    "RETIMING_METHODS",
    "InfeasibleLimitsError",
    "JointTrajectory",
    "MotionLimits",
    "PiecewisePolynomial",
    "QPSolverError",
    "QuantizedTrajectory",
    "Retimed",
    "allocate_times",
    "compare_retimings",
    "joint_ticks",
    "lattice_motion",
    "minimum_snap",
    "quantize",
    "ruckig_retime",
    "scaled",
    "shortest_bounded",
    "tip_deviation",
    "toppra_retime",
]
