"""Collision geometry: analytic obstacle solids, arm clearance, and curves to trace."""

import sys
from typing import TYPE_CHECKING, TypeGuard

from armpath.lazy import lazy_exports

if TYPE_CHECKING:
    from armpath.geometry.curves import (
        CircularArc,
        ConeSection,
        Curve,
        ParametricCurve,
        Polyline,
        seed_crack,
    )
    from armpath.geometry.expressions import parse_expression
    from armpath.geometry.mesh import MeshObstacle
    from armpath.geometry.primitives import (
        Box,
        Capsule,
        HalfSpace,
        HollowFrustum,
        Obstacle,
        SolidOfRevolution,
        Sphere,
        WallThickness,
        cone_frustum,
        cylinder,
        hollow_frustum,
    )
    from armpath.geometry.world import ClearancePair, CollisionWorld, Part

__getattr__, __dir__ = lazy_exports(
    __name__,
    {
        "curves": (
            "CircularArc",
            "ConeSection",
            "Curve",
            "ParametricCurve",
            "Polyline",
            "seed_crack",
        ),
        "expressions": ("parse_expression",),
        "primitives": (
            "Box",
            "Capsule",
            "HalfSpace",
            "HollowFrustum",
            "Obstacle",
            "SolidOfRevolution",
            "Sphere",
            "WallThickness",
            "cone_frustum",
            "cylinder",
            "hollow_frustum",
        ),
        "world": (
            "ClearancePair",
            "CollisionWorld",
            "Part",
        ),
    },
)


def is_mesh_obstacle(obstacle: object) -> TypeGuard["MeshObstacle"]:
    """Whether ``obstacle`` is a mesh obstacle, asked without importing
    :mod:`armpath.geometry.mesh`, which needs the optional packages of ``armpath[mesh]``: a
    mesh obstacle exists only once that module has been imported, so a module that is not
    loaded means none is."""
    mesh = sys.modules.get("armpath.geometry.mesh")
    return mesh is not None and isinstance(obstacle, mesh.MeshObstacle)


__all__ = [
    "Box",
    "Capsule",
    "CircularArc",
    "ClearancePair",
    "CollisionWorld",
    "ConeSection",
    "Curve",
    "HalfSpace",
    "HollowFrustum",
    "Obstacle",
    "ParametricCurve",
    "Part",
    "Polyline",
    "SolidOfRevolution",
    "Sphere",
    "WallThickness",
    "cone_frustum",
    "cylinder",
    "hollow_frustum",
    "is_mesh_obstacle",
    "parse_expression",
    "seed_crack",
]
