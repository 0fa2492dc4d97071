"""Write an arm as a URDF: its kinematic chain, limits and tool, in metres and radians.

The chain is ``world -> base -> link_1 -> ... -> link_n -> tool``: a fixed joint places the base
(``T_world_base``), each moving joint keeps its placement, axis, kind and limits, and a fixed
joint carries the tool frame (``T_flange_tool``). Reading the file back with
:func:`armpath.model.urdf.arm_from_urdf` (tool link ``tool``) gives the same forward kinematics;
what URDF has no place for (the command lattice, the home pose, capsule radii) is not written.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
from numpy.typing import NDArray

from armpath.model.serial_arm import JointKind, SerialArm

#: Stand-in bounds of an unlimited prismatic joint (URDF requires limits for one): +-1 km.
_UNLIMITED_PRISMATIC_M = 1000.0


def _rpy(R: NDArray[np.float64]) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw (fixed axes x, y, z: ``R = Rz(yaw) Ry(pitch) Rx(roll)``)."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.hypot(R[0, 0], R[1, 0]) < 1e-12:  # gimbal lock: put the whole turn in roll
        return math.atan2(-R[1, 2], R[1, 1]), pitch, 0.0
    return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])


def _origin(parent: ET.Element, T: NDArray[np.float64], to_m: float) -> None:
    xyz = " ".join(repr(float(v) * to_m) for v in T[:3, 3])
    rpy = " ".join(repr(v) for v in _rpy(np.asarray(T[:3, :3], dtype=np.float64)))
    ET.SubElement(parent, "origin", xyz=xyz, rpy=rpy)


def arm_to_urdf(arm: SerialArm) -> str:
    """The URDF text of ``arm`` (see the module's description)."""
    to_m = arm.mm_per_unit / 1000.0
    robot = ET.Element("robot", name=arm.name.replace(" ", "_"))
    names = ["world", "base", *(f"link_{i + 1}" for i in range(arm.n_joints)), "tool"]
    for name in names:
        ET.SubElement(robot, "link", name=name)

    def fixed(name: str, parent: str, child: str, T: NDArray[np.float64]) -> None:
        joint = ET.SubElement(robot, "joint", name=name, type="fixed")
        _origin(joint, T, to_m)
        ET.SubElement(joint, "parent", link=parent)
        ET.SubElement(joint, "child", link=child)

    fixed("world_to_base", "world", "base", np.asarray(arm.T_world_base, dtype=np.float64))
    for i, j in enumerate(arm.joints):
        lo, hi = j.limits
        prismatic = j.kind == JointKind.PRISMATIC
        if prismatic:
            kind = "prismatic"
        else:
            kind = "continuous" if not (np.isfinite(lo) or np.isfinite(hi)) else "revolute"
        joint = ET.SubElement(robot, "joint", name=j.name, type=kind)
        _origin(joint, np.asarray(j.T_parent_joint, dtype=np.float64), to_m)
        ET.SubElement(joint, "parent", link=names[i + 1])
        ET.SubElement(joint, "child", link=names[i + 2])
        ET.SubElement(joint, "axis", xyz=" ".join(repr(float(v)) for v in j.axis))
        if kind != "continuous":
            scale = to_m if prismatic else 1.0
            big = _UNLIMITED_PRISMATIC_M if prismatic else 4.0 * math.pi
            lower = lo * scale if np.isfinite(lo) else -big
            upper = hi * scale if np.isfinite(hi) else big
            ET.SubElement(
                joint, "limit", lower=repr(lower), upper=repr(upper), effort="0", velocity="0"
            )
    fixed("flange_to_tool", names[-2], "tool", np.asarray(arm.T_flange_tool, dtype=np.float64))
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


__all__ = ["arm_to_urdf"]
