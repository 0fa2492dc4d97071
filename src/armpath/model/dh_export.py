"""Any arm as a Denavit-Hartenberg table (standard or modified), for robot files and peers.

Every serial chain of revolute and prismatic joints has D-H parameters: the joint axes are
lines in space, and consecutive lines are related by their common normal. From the axes at
zero joint values this module places the D-H frames (on parallel axes the normal is taken
through the previous frame's origin, so that ``d`` is 0; on intersecting axes ``a`` is 0 and
``x`` is the axes' cross product), reads off ``a, alpha, d, theta`` and returns the base and
tool transforms that make :func:`armpath.model.dh.dh_arm` reproduce the arm's tool pose for
every joint value. What a D-H table has no place for (the command lattice, capsule radii) is
not written; the collision links of an arm read back are the table's skeleton.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from armpath.errors import InvalidInputError
from armpath.model.serial_arm import JointKind, SerialArm

FloatArray = NDArray[np.float64]

#: Two axes closer than this to parallel (sine of their angle) are taken as parallel.
PARALLEL_SINE = 1e-9
#: Feet of a common normal closer than this (mm) are taken as one point (intersecting axes).
MEETING_MM = 1e-9


def _unit(v: FloatArray) -> FloatArray:
    return np.asarray(v / np.linalg.norm(v), dtype=np.float64)


def _angle_about(a: FloatArray, b: FloatArray, axis: FloatArray) -> float:
    """Signed angle from ``a`` to ``b`` about ``axis`` (all unit, a and b perpendicular to it)."""
    return math.atan2(float(np.cross(a, b) @ axis), float(a @ b))


def _normal(
    p0: FloatArray, z0: FloatArray, p1: FloatArray, z1: FloatArray, x_before: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The common normal from line ``(p0, z0)`` to line ``(p1, z1)``: its foot on each line and
    its direction (``x_before``, made perpendicular, when the lines coincide). On parallel lines
    the normal goes through ``p0``."""
    cross = np.cross(z0, z1)
    if np.linalg.norm(cross) <= PARALLEL_SINE:
        foot0 = p0
        foot1 = p1 + ((p0 - p1) @ z1) * z1
    else:
        # closest points of the two lines
        w = p0 - p1
        b = float(z0 @ z1)
        d, e = float(z0 @ w), float(z1 @ w)
        den = 1.0 - b * b
        s = (b * e - d) / den
        t = (e - b * d) / den
        foot0, foot1 = p0 + s * z0, p1 + t * z1
    gap = foot1 - foot0
    if np.linalg.norm(cross) > PARALLEL_SINE:
        # skew or meeting lines: the normal is along z0 x z1 exactly, turned to point from
        # the first line to the second (the gap's own direction is rounding where the lines
        # nearly meet: a URDF pitch of 1.5707963268 made it 9e-6 rad off and the table's
        # tool pose 0.007 mm off)
        x = _unit(cross)
        return foot0, foot1, -x if float(gap @ x) < 0.0 else x
    if np.linalg.norm(gap) > MEETING_MM:
        return foot0, foot1, _unit(gap)
    x = x_before - (x_before @ z0) * z0
    return foot0, foot1, _unit(x)


def _frame(origin: FloatArray, x: FloatArray, z: FloatArray) -> FloatArray:
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, np.cross(z, x), z, origin
    return T


def _axes(arm: SerialArm) -> tuple[list[FloatArray], list[FloatArray], FloatArray]:
    """Each joint's axis at zero joint values (a point and a unit direction, world), and the
    flange frame there."""
    T = np.asarray(arm.T_world_base, dtype=np.float64)
    points, dirs = [], []
    for joint in arm.joints:
        T = T @ np.asarray(joint.T_parent_joint, dtype=np.float64)
        points.append(T[:3, 3].copy())
        dirs.append(_unit(T[:3, :3] @ np.asarray(joint.axis, dtype=np.float64)))
    return points, dirs, T


def _row(arm: SerialArm, i: int, a: float, alpha: float, d: float, theta: float) -> dict[str, Any]:
    """One row of the robot file (mm, rad); limits in the joint's unit (rad or mm)."""
    joint = arm.joints[i]
    prismatic = joint.kind == JointKind.PRISMATIC
    scale = arm.mm_per_unit if prismatic else 1.0
    lo, hi = joint.limits[0] * scale, joint.limits[1] * scale
    row: dict[str, Any] = {"a": a, "alpha": alpha, "d": d}
    if prismatic:
        row["type"] = "prismatic"
        row["theta"] = theta
    else:
        row["offset"] = theta
    row["limits"] = (
        None
        if not (np.isfinite(lo) or np.isfinite(hi))
        else [
            float(lo) if np.isfinite(lo) else None,
            float(hi) if np.isfinite(hi) else None,
        ]
    )
    return row


def dh_document(arm: SerialArm, convention: str = "standard") -> dict[str, Any]:
    """A JSON robot file of ``arm`` in ``convention`` (``"standard"`` or ``"modified"``):
    mm and rad, with the base and tool transforms that keep every tool pose."""
    if convention not in ("standard", "modified"):
        raise InvalidInputError(f"convention must be standard or modified, got {convention!r}")
    scale = arm.mm_per_unit
    points, dirs, flange = _axes(arm)
    points = [p * scale for p in points]
    flange = flange.copy()
    flange[:3, 3] *= scale
    tool = np.array(arm.T_flange_tool, dtype=np.float64)
    tool[:3, 3] *= scale
    tool_world = flange @ tool
    n = arm.n_joints
    base_T = np.asarray(arm.T_world_base, dtype=np.float64)
    # a perpendicular to start from: the base's own x (or y), off the first axis
    x_seed = base_T[:3, 0] if abs(base_T[:3, 0] @ dirs[0]) < 0.9 else base_T[:3, 1]
    x_seed = _unit(x_seed - (x_seed @ dirs[0]) * dirs[0])
    o_first = points[0] + ((base_T[:3, 3] * scale - points[0]) @ dirs[0]) * dirs[0]
    rows = []
    if convention == "standard":
        # frame i - 1 on joint i's axis; frame n on a line along the last axis through the flange
        lines = [(points[i], dirs[i]) for i in range(n)] + [(flange[:3, 3], dirs[-1])]
        origin, x, z = o_first, x_seed, dirs[0]
        base = _frame(origin, x, z)
        for i in range(n):
            p_next, z_next = lines[i + 1]
            foot, foot_next, x_next = _normal(origin, z, p_next, z_next, x)
            d = float((foot - origin) @ z)
            theta = _angle_about(x, x_next, z)
            a = float((foot_next - foot) @ x_next)
            alpha = _angle_about(z, z_next, x_next)
            rows.append(_row(arm, i, a, alpha, d, theta))
            origin, x, z = foot_next, x_next, z_next
        tool = np.linalg.inv(_frame(origin, x, z)) @ tool_world
    else:
        # frame i on joint i's axis, its x along the normal to the next axis; frame 0 = frame 1
        origin, z = o_first, dirs[0]
        frames = []
        x_prev = x_seed
        for i in range(n):
            if i + 1 < n:
                foot, foot_next, x = _normal(origin, z, points[i + 1], dirs[i + 1], x_prev)
            else:
                foot, foot_next, x = origin, origin, _unit(x_prev - (x_prev @ z) * z)
            frames.append((foot, x, z))
            x_prev = x
            if i + 1 < n:
                origin, z = foot_next, dirs[i + 1]
        base = _frame(*frames[0])
        rows.append(_row(arm, 0, 0.0, 0.0, 0.0, 0.0))
        for i in range(1, n):
            o0, x0, z0 = frames[i - 1]
            o1, x1, z1 = frames[i]
            hit = o0 + ((o1 - o0) @ x0) * x0  # where frame i-1's x meets axis i
            a = float((hit - o0) @ x0)
            alpha = _angle_about(z0, z1, x0)
            d = float((o1 - hit) @ z1)
            theta = _angle_about(x0, x1, z1)
            rows.append(_row(arm, i, a, alpha, d, theta))
        tool = np.linalg.inv(_frame(*frames[-1])) @ tool_world
    home = np.asarray(arm.home, dtype=np.float64).copy()
    prismatic = np.array([j.kind == JointKind.PRISMATIC for j in arm.joints])
    home[prismatic] *= scale
    return {
        "name": arm.name,
        "convention": convention,
        "units": {"length": "mm", "angle": "rad"},
        "links": rows,
        "base": base.tolist(),
        "tool": tool.tolist(),
        "home": home.tolist(),
    }


__all__ = ["dh_document"]
