"""Inverse kinematics: seed-arm position families, closed forms, Raghavan-Roth, numerical."""

from armpath.ik.general6r import General6RSolver
from armpath.ik.numerical import solve_numerical
from armpath.ik.result import IKResult
from armpath.ik.seed_position import (
    FIXED_PAIRS,
    family_from_wrist,
    fingertip,
    solve_with_fixed_pair,
)
from armpath.ik.solve import METHODS, complete_solver, into_limits, solve_ik
from armpath.ik.spherical_wrist import SphericalWristSolver, wrist_center

__all__ = [
    "FIXED_PAIRS",
    "METHODS",
    "General6RSolver",
    "IKResult",
    "SphericalWristSolver",
    "complete_solver",
    "family_from_wrist",
    "fingertip",
    "into_limits",
    "solve_ik",
    "solve_numerical",
    "solve_with_fixed_pair",
    "wrist_center",
]
