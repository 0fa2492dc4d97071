"""Inverse kinematics: seed-arm position families, closed forms (spherical wrist, three parallel
axes), Raghavan-Roth, numerical."""

from typing import TYPE_CHECKING

from armpath.lazy import lazy_exports

if TYPE_CHECKING:
    from armpath.ik.general6r import General6RSolver
    from armpath.ik.numerical import solve_numerical
    from armpath.ik.result import IKBatch, IKResult
    from armpath.ik.seed_position import (
        FIXED_PAIRS,
        family_from_wrist,
        fingertip,
        solve_with_fixed_pair,
    )
    from armpath.ik.solve import (
        METHODS,
        complete_solver,
        into_limits,
        limits_mask,
        require_complete_solver,
        solve_ik,
    )
    from armpath.ik.spherical_wrist import SphericalWristSolver, wrist_center
    from armpath.ik.three_parallel import ThreeParallelSolver, three_parallel_layout

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "general6r": ("General6RSolver",),
        "numerical": ("solve_numerical",),
        "result": (
            "IKBatch",
            "IKResult",
        ),
        "seed_position": (
            "FIXED_PAIRS",
            "family_from_wrist",
            "fingertip",
            "solve_with_fixed_pair",
        ),
        "solve": (
            "METHODS",
            "complete_solver",
            "into_limits",
            "limits_mask",
            "require_complete_solver",
            "solve_ik",
        ),
        "spherical_wrist": (
            "SphericalWristSolver",
            "wrist_center",
        ),
        "three_parallel": (
            "ThreeParallelSolver",
            "three_parallel_layout",
        ),
    },
)

__all__ = [
    "FIXED_PAIRS",
    "METHODS",
    "General6RSolver",
    "IKBatch",
    "IKResult",
    "SphericalWristSolver",
    "ThreeParallelSolver",
    "complete_solver",
    "family_from_wrist",
    "fingertip",
    "into_limits",
    "limits_mask",
    "require_complete_solver",
    "solve_ik",
    "solve_numerical",
    "solve_with_fixed_pair",
    "three_parallel_layout",
    "wrist_center",
]
