"""Inverse kinematics."""

from armpath.ik.seed_position import (
    FIXED_PAIRS,
    family_from_wrist,
    fingertip,
    solve_with_fixed_pair,
)

__all__ = ["FIXED_PAIRS", "family_from_wrist", "fingertip", "solve_with_fixed_pair"]
