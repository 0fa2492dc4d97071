"""Collision geometry: analytic obstacle solids and arm clearance."""

from armpath.geometry.primitives import (
    HalfSpace,
    HollowFrustum,
    Obstacle,
    SolidOfRevolution,
    WallThickness,
    hollow_frustum,
)
from armpath.geometry.world import CollisionWorld, Part

__all__ = [
    "CollisionWorld",
    "HalfSpace",
    "HollowFrustum",
    "Obstacle",
    "Part",
    "SolidOfRevolution",
    "WallThickness",
    "hollow_frustum",
]
