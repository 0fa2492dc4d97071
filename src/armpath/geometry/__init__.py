"""Collision geometry: analytic obstacle solids, arm clearance, and curves to trace."""

from typing import TYPE_CHECKING

from armpath.lazy import lazy_exports

if TYPE_CHECKING:
    from armpath.geometry.curves import ConeSection, Curve, ParametricCurve, Polyline, seed_crack
    from armpath.geometry.expressions import parse_expression
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

__all__ = [
    "Box",
    "Capsule",
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
    "parse_expression",
    "seed_crack",
]
