"""Triangle meshes of the scene's obstacles for display (mm): solids of revolution revolved,
boxes, spheres, capsules, a square patch of each half-space, and mesh obstacles as they are."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from armpath.errors import InvalidInputError
from armpath.geometry import is_mesh_obstacle
from armpath.geometry.primitives import (
    Box,
    Capsule,
    HalfSpace,
    Obstacle,
    SolidOfRevolution,
    Sphere,
    orthonormal_frame,
)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
TriangleMesh = tuple[FloatArray, IntArray]


def revolve(
    origin: FloatArray, axis: FloatArray, profile: FloatArray, n_theta: int = 64
) -> TriangleMesh:
    """The surface swept by the profile polygon's edges ``(r, z)`` revolved about ``axis``
    through ``origin``; edges lying on the axis (both ends at r = 0) are skipped."""
    u, v = orthonormal_frame(axis / np.linalg.norm(axis))
    theta = np.linspace(0.0, 2.0 * np.pi, n_theta, endpoint=False)
    ring = np.cos(theta)[:, None] * u + np.sin(theta)[:, None] * v  # (n, 3)
    vertices, faces = [], []
    count = 0
    k = np.arange(n_theta)
    k1 = (k + 1) % n_theta
    for a, b in zip(profile, np.roll(profile, -1, axis=0), strict=True):
        if a[0] == 0.0 and b[0] == 0.0:
            continue
        for r, z in (a, b):
            vertices.append(origin + r * ring + z * axis)
        lo, hi = count + k, count + n_theta + k
        lo1, hi1 = count + k1, count + n_theta + k1
        faces.append(np.stack([lo, lo1, hi1], axis=1))
        faces.append(np.stack([lo, hi1, hi], axis=1))
        count += 2 * n_theta
    return np.vstack(vertices), np.vstack(faces).astype(np.int64)


def box_mesh(box: Box) -> TriangleMesh:
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    vertices = box.center + (signs * box.half_extents) @ box.rotation.T
    faces = np.array(
        [
            [0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5],  # -x, +x
            [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6],  # -y, +y
            [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3],  # -z, +z
        ],
        dtype=np.int64,
    )  # fmt: skip
    return vertices, faces


def sphere_mesh(centre: FloatArray, radius: float, n: int = 24) -> TriangleMesh:
    """A UV sphere: ``n`` meridians, ``n // 2`` parallels."""
    polar = np.linspace(0.0, np.pi, n // 2 + 1)
    profile = np.column_stack([radius * np.sin(polar), -radius * np.cos(polar)])
    return revolve(np.asarray(centre, dtype=float), np.array([0.0, 0.0, 1.0]), profile, n)


def capsule_mesh(capsule: Capsule, n: int = 24) -> TriangleMesh:
    axis = capsule.end - capsule.start
    length = float(np.linalg.norm(axis))
    r = capsule.radius
    if length < 1e-9:
        return sphere_mesh(capsule.start, r, n)
    half = np.linspace(0.0, np.pi / 2, n // 4 + 1)
    bottom = np.column_stack([r * np.sin(half), -r * np.cos(half)])
    top = np.column_stack([r * np.cos(half), length + r * np.sin(half)])
    profile = np.vstack([bottom, top])
    return revolve(capsule.start, axis / length, profile, n)


def half_space_patch(plane: HalfSpace, centre: FloatArray, half_size: float) -> TriangleMesh:
    """A square of side ``2 half_size`` on the half-space's boundary plane, centred on the
    projection of ``centre``."""
    n = plane.normal / np.linalg.norm(plane.normal)
    c = centre - float(np.dot(centre - plane.point, n)) * n
    u, v = orthonormal_frame(n)
    corners = np.array(
        [c + half_size * (su * u + sv * v) for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    )
    return corners, np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int64)


def obstacle_mesh(obstacle: Obstacle, centre: FloatArray, half_size: float) -> TriangleMesh:
    """The display mesh (mm) of any obstacle; half-spaces become a square patch of side
    ``2 half_size`` around ``centre``."""
    if isinstance(obstacle, SolidOfRevolution):
        return revolve(obstacle.origin, obstacle.axis, obstacle.profile)
    if isinstance(obstacle, Box):
        return box_mesh(obstacle)
    if isinstance(obstacle, Sphere):
        return sphere_mesh(obstacle.center, obstacle.radius)
    if isinstance(obstacle, Capsule):
        return capsule_mesh(obstacle)
    if isinstance(obstacle, HalfSpace):
        return half_space_patch(obstacle, centre, half_size)
    if is_mesh_obstacle(obstacle):
        return np.asarray(obstacle.vertices, dtype=float), np.asarray(
            obstacle.faces, dtype=np.int64
        )
    raise InvalidInputError(f"no display mesh for obstacle type {type(obstacle).__name__}")
