"""Collision geometry: analytic obstacle solids and arm clearance."""

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
from armpath.geometry.world import CollisionWorld, Part

__all__ = [
    "Box",
    "Capsule",
    "CollisionWorld",
    "HalfSpace",
    "HollowFrustum",
    "Obstacle",
    "Part",
    "SolidOfRevolution",
    "Sphere",
    "WallThickness",
    "cone_frustum",
    "cylinder",
    "hollow_frustum",
]
