"""Rotations and poses as users hold them, turned into matrices once at the boundary.

Accepted forms (the conventions of numpy, ``scipy.spatial.transform`` and spatialmath):

* a ``3x3`` rotation matrix, or a ``4x4`` homogeneous transform (position in mm: where a
  target is given too, the transform's position must be the target or zero);
* a quaternion with its component order spelled out: ``("wxyz", [w, x, y, z])`` (scalar
  first, as ROS's tf2 does not but Eigen and spatialmath do) or ``("xyzw", [x, y, z, w])``
  (scalar last, as scipy and ROS messages do); a bare 4-vector is refused, since either order
  could be meant;
* a ``scipy.spatial.transform.Rotation``;
* a spatialmath ``SO3`` or ``SE3`` (anything with an ``A`` matrix attribute), when installed.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from armpath.errors import InvalidInputError

FloatArray = NDArray[np.float64]

#: Largest deviation of ``R^T R`` from the identity accepted for a rotation matrix.
ORTHONORMAL_TOLERANCE = 1e-6
QUATERNION_ORDERS = ("wxyz", "xyzw")


def _checked_rotation(r: FloatArray) -> FloatArray:
    if not np.all(np.isfinite(r)):
        raise InvalidInputError("a rotation matrix must be finite")
    if np.abs(r.T @ r - np.eye(3)).max() > ORTHONORMAL_TOLERANCE or np.linalg.det(r) <= 0:
        raise InvalidInputError(
            "a rotation matrix must be orthonormal with determinant +1 "
            f"(to {ORTHONORMAL_TOLERANCE:g})"
        )
    return r


def _quaternion(order: str, values: Any) -> FloatArray:
    from scipy.spatial.transform import Rotation

    if order not in QUATERNION_ORDERS:
        raise InvalidInputError(
            f"a quaternion's order must be one of {', '.join(QUATERNION_ORDERS)}, got {order!r}"
        )
    q = np.asarray(values, dtype=np.float64)
    if q.shape != (4,) or not np.all(np.isfinite(q)):
        raise InvalidInputError(f"a quaternion needs four finite numbers, got {values!r}")
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > 1e-3:
        raise InvalidInputError(f"a quaternion must have unit length, got length {norm:.6g}")
    xyzw = q if order == "xyzw" else np.roll(q, -1)
    return np.asarray(Rotation.from_quat(xyzw).as_matrix(), dtype=np.float64)


def pose_matrix(pose: Any) -> FloatArray:
    """A ``4x4`` transform of ``pose`` (any form of the module's description; a rotation
    alone gets position 0)."""
    if isinstance(pose, tuple) and len(pose) == 2 and isinstance(pose[0], str):
        out = np.eye(4)
        out[:3, :3] = _quaternion(pose[0], pose[1])
        return out
    if hasattr(pose, "as_matrix") and callable(pose.as_matrix):  # scipy Rotation
        r = np.asarray(pose.as_matrix(), dtype=np.float64)
        if r.shape != (3, 3):
            raise InvalidInputError(f"expected one rotation, got a stack of shape {r.shape}")
        out = np.eye(4)
        out[:3, :3] = _checked_rotation(r)
        return out
    if hasattr(pose, "A") and not isinstance(pose, np.ndarray):  # spatialmath SO3 / SE3
        return pose_matrix(np.asarray(pose.A, dtype=np.float64))
    try:
        m = np.asarray(pose, dtype=np.float64)
    except (TypeError, ValueError):
        raise InvalidInputError(
            "a pose must be a 3x3 rotation, a 4x4 transform, (order, quaternion) or a "
            f"scipy Rotation; got {pose!r}"
        ) from None
    if m.shape == (3, 3):
        out = np.eye(4)
        out[:3, :3] = _checked_rotation(m)
        return out
    if m.shape == (4, 4):
        if not np.allclose(m[3], [0.0, 0.0, 0.0, 1.0]) or not np.all(np.isfinite(m)):
            raise InvalidInputError("a 4x4 pose must be finite with last row 0 0 0 1")
        _checked_rotation(m[:3, :3])
        return m.copy()
    if m.shape == (4,):
        raise InvalidInputError('a quaternion must say its order: ("wxyz", q) or ("xyzw", q)')
    raise InvalidInputError(
        "a pose must be a 3x3 rotation, a 4x4 transform, (order, quaternion) or a "
        f"scipy Rotation; got shape {m.shape}"
    )


def rotation_matrix(pose: Any) -> FloatArray:
    """The ``3x3`` rotation of ``pose`` (any form of the module's description)."""
    return np.asarray(pose_matrix(pose)[:3, :3])


__all__ = ["QUATERNION_ORDERS", "pose_matrix", "rotation_matrix"]
