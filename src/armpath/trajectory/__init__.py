"""Smooth joint trajectories: minimum-snap / minimum-jerk piecewise polynomials."""

from armpath.trajectory.minsnap import ORDERS, PiecewisePolynomial, allocate_times, minimum_snap

__all__ = ["ORDERS", "PiecewisePolynomial", "allocate_times", "minimum_snap"]
