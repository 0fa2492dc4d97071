"""Smooth joint trajectories: minimum-snap / minimum-jerk piecewise polynomials, and their
commands on the controller's lattice."""

from armpath.trajectory.minsnap import (
    ORDERS,
    QP_SOLVERS,
    MotionLimits,
    PiecewisePolynomial,
    allocate_times,
    minimum_snap,
)
from armpath.trajectory.quantize import QuantizedTrajectory, quantize, tip_deviation

__all__ = [
    "ORDERS",
    "QP_SOLVERS",
    "MotionLimits",
    "PiecewisePolynomial",
    "QuantizedTrajectory",
    "allocate_times",
    "minimum_snap",
    "quantize",
    "tip_deviation",
]
