"""The physical links of a serial chain: capsules between the distinct points where it turns.

A joint frame placed at ``T_parent_joint`` from the previous frame is reached in two straight
legs: first square to the joint's axis, to the *corner* (the point of the axis nearest the
previous frame's origin), then along the axis to the frame's origin. For D-H tables (standard or
modified) these are exactly the table's ``a_{i-1}`` and ``d_i`` legs, so the segments run through
every physical corner of the arm rather than cutting across it. The tool point is reached the
same way, its approach axis (the tool frame's z) taking the place of a joint axis, where the
first leg runs square to the last joint's axis or along it (a D-H table's last ``a``, an
offset gripper); otherwise the tool is one straight leg from the last joint frame's origin to
the tool point (:func:`~armpath.model.serial_arm.tool_corner`: the corner of a tilted torch's
axis may lie off the torch altogether).

**Link k** (``k = 0``: the fixed base; ``k = 1 .. n``: the part moved by joint k) holds the legs
from frame k's origin to frame k + 1's (the last link to the tool point); its capsule radius is
``radii[k]``. A leg of zero length is dropped and its two ends are one point, so no link has zero
length and links meeting at a point share its landmark (the rule that excludes neighbours from
self-collision checking, :mod:`armpath.geometry.world`). A leg along a prismatic joint's axis
changes length with the joint and is kept. Base legs (link 0) stand on the mounting surface:
they are checked against the moving links only, not against obstacles. ``pedestal`` adds a base
column of that length below the base frame (along its -z), for models whose base frame sits
above the mounting surface (PUMA 560's is at the shoulder).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

from armpath.errors import InvalidInputError
from armpath.model.serial_arm import Joint, JointKind, Landmark, Link, tool_corner

#: Legs shorter than this (length unit) are dropped: their ends are one point.
ZERO_LENGTH = 1e-9


def link_radii(radii: float | Sequence[float] | ArrayLike, n_joints: int, what: str) -> list[float]:
    """``n_joints + 1`` radii (base, then the link moved by each joint) from one number for every
    link or a list of ``n_joints + 1``; each finite and ``>= 0``."""
    arr = np.asarray(radii, dtype=np.float64)
    if arr.ndim == 0:
        arr = np.full(n_joints + 1, float(arr))
    if arr.shape != (n_joints + 1,):
        raise InvalidInputError(
            f"{what} must be one radius for every link or a list of {n_joints + 1} "
            f"(the fixed base, then the link each of the {n_joints} joints moves), got "
            f"{arr.size} values"
        )
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise InvalidInputError(f"{what} must be finite and >= 0, got {arr.tolist()}")
    return [float(r) for r in arr]


def physical_links(
    joints: Sequence[Joint],
    T_flange_tool: ArrayLike,
    frame_names: Sequence[str],
    radii: Sequence[float],
    *,
    pedestal: float = 0.0,
) -> tuple[tuple[Landmark, ...], tuple[Link, ...]]:
    """Landmarks and links of the physical skeleton (see the module docstring).

    Parameters
    ----------
    joints:
        The chain, base to tip.
    T_flange_tool:
        4x4 transform from the last joint frame to the tool frame.
    frame_names:
        Names of frames ``0 .. n + 1`` (base, each joint, tool); they become the first ``n + 2``
        landmarks, each a frame origin, in that order, whether a link uses it or not.
    radii:
        ``n + 1`` capsule radii: the base (link 0), then the link moved by each joint.
    pedestal:
        Length of a base column below the base frame (length unit, 0 for none).

    Returns
    -------
    The landmarks (frame origins, then the corners and the pedestal's foot that links use) and
    the links, base to tip, named ``L{k}`` (``L{k}a``, ``L{k}b`` when link k has two legs,
    ``L0p`` for the pedestal).
    """
    n = len(joints)
    if len(frame_names) != n + 2 or len(radii) != n + 1:
        raise InvalidInputError("physical_links needs n + 2 frame names and n + 1 radii")
    if not (np.isfinite(pedestal) and pedestal >= 0):
        raise InvalidInputError(f"pedestal must be a length >= 0, got {pedestal}")
    landmarks = [Landmark(str(name), k) for k, name in enumerate(frame_names)]
    legs: list[tuple[int, int, int]] = []  # (body, start landmark, end landmark)
    if pedestal > ZERO_LENGTH:
        landmarks.append(Landmark("mount", 0, (0.0, 0.0, -float(pedestal))))
        legs.append((0, len(landmarks) - 1, 0))
    current = 0  # landmark where the skeleton has got to
    T_tool = np.asarray(T_flange_tool, dtype=np.float64)
    for k in range(1, n + 2):
        if k <= n:
            joint = joints[k - 1]
            T, axis, prismatic = joint.T_parent_joint, joint.axis, joint.kind is JointKind.PRISMATIC
        else:
            T, axis, prismatic = T_tool, np.array([0.0, 0.0, 1.0]), False
        t = T[:3, 3]
        u = T[:3, :3] @ axis  # the axis in frame k - 1
        if k > n and n > 0 and tool_corner(T, joints[-1].axis, ZERO_LENGTH) is None:
            # the tool is one straight leg to its point (see tool_corner)
            u = t / max(float(np.linalg.norm(t)), ZERO_LENGTH)
        along = float(t @ u)
        corner = t - along * u
        body = k - 1
        if prismatic:
            lo, hi = joints[k - 1].limits
            has_along = max(abs(along + lo), abs(along + hi)) > ZERO_LENGTH
        else:
            has_along = abs(along) > ZERO_LENGTH
        if float(np.linalg.norm(corner)) > ZERO_LENGTH:
            if has_along:  # the corner is a point of its own
                offset = (float(corner[0]), float(corner[1]), float(corner[2]))
                landmarks.append(Landmark(f"{frame_names[k]}'", k - 1, offset))
                legs.append((body, current, len(landmarks) - 1))
                current = len(landmarks) - 1
            else:  # the corner is frame k's origin
                legs.append((body, current, k))
                current = k
        if has_along:
            legs.append((body, current, k))
            current = k
    by_body: dict[int, list[tuple[int, int]]] = {}
    for body, a, b in legs:
        by_body.setdefault(body, []).append((a, b))
    links = []
    if pedestal > ZERO_LENGTH:
        a, b = by_body[0].pop(0)
        links.append(Link("L0p", a, b, radii[0], checked=False))
    for body in sorted(by_body):
        pieces = by_body[body]
        for j, (a, b) in enumerate(pieces):
            suffix = "ab"[j] if len(pieces) == 2 else ""
            links.append(Link(f"L{body}{suffix}", a, b, radii[body], checked=body > 0))
    return tuple(landmarks), tuple(links)
