"""Building a scene's solids from their specifications."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel

from armpath.errors import InvalidInputError
from armpath.geometry import (
    Box,
    Capsule,
    HalfSpace,
    HollowFrustum,
    Obstacle,
    Sphere,
    WallThickness,
    cone_frustum,
    cylinder,
    hollow_frustum,
)
from armpath.scenes.schema import (
    BoxSpec,
    CapsuleSpec,
    ConeFrustumSpec,
    CylinderSpec,
    HalfSpaceSpec,
    HollowFrustumSpec,
    MeshSpec,
    SphereSpec,
    Vec3,
)


def rebuild_frustum(f: HollowFrustum, conv: WallThickness) -> HollowFrustum:
    return hollow_frustum(
        f.name,
        f.origin,
        f.height,
        f.r_bottom,
        f.r_top,
        f.wall,
        conv,
        open_top=f.open_top,
        closed_bottom=f.closed_bottom,
        axis=f.axis,
    )


def rotation_matrix(rotvec_deg: Vec3) -> NDArray[np.float64]:
    from scipy.spatial.transform import Rotation

    return np.asarray(Rotation.from_rotvec(np.radians(rotvec_deg)).as_matrix())


def build_obstacle(spec: BaseModel, base_dir: Path | None) -> Obstacle:
    if isinstance(spec, HalfSpaceSpec):
        return HalfSpace(spec.name, np.array(spec.point), np.array(spec.normal))
    if isinstance(spec, SphereSpec):
        return Sphere(spec.name, np.array(spec.center), spec.radius)
    if isinstance(spec, CapsuleSpec):
        return Capsule(spec.name, np.array(spec.start), np.array(spec.end), spec.radius)
    if isinstance(spec, BoxSpec):
        return Box(
            spec.name,
            np.array(spec.center),
            np.array(spec.size) / 2,
            rotation_matrix(spec.rotation_deg),
        )
    if isinstance(spec, CylinderSpec):
        return cylinder(spec.name, spec.base_center, spec.axis, spec.radius, spec.height)
    if isinstance(spec, ConeFrustumSpec):
        return cone_frustum(
            spec.name, spec.base_center, spec.axis, spec.r_bottom, spec.r_top, spec.height
        )
    if isinstance(spec, MeshSpec):
        try:
            from armpath.geometry.mesh import load_mesh
        except ImportError as exc:
            raise InvalidInputError(f"obstacle {spec.name!r}: {exc}") from None

        path = Path(spec.file)
        if not path.is_absolute() and base_dir is not None:
            path = base_dir / path
        T = np.eye(4)
        T[:3, :3] = rotation_matrix(spec.rotation_deg)
        T[:3, 3] = spec.translation
        return load_mesh(path, spec.name, spec.scale, T)
    assert isinstance(spec, HollowFrustumSpec)
    return hollow_frustum(
        spec.name,
        spec.base_center,
        spec.height,
        spec.r_bottom,
        spec.r_top,
        spec.wall,
        spec.wall_thickness,
        open_top=spec.open_top,
        closed_bottom=spec.closed_bottom,
        axis=spec.axis,
    )
