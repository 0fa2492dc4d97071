"""How far the tool point can get from a point of an arm's own frame: a proven largest distance.

The carriage bound (:mod:`armpath.planning.bounds.carriage`) needs a ball, fixed to the
carriage, that holds every tool point the arm on it can take. The lengths of the chain summed
give one (every revolute joint keeps the lengths of the transforms after it), but offsets at
right angles add up there as if in a line: a UR5 with a 120 mm torch, 1218 mm summed, reaches
about 1130 mm. This module finds the largest distance itself, proven, by branch and bound over
the joints after the carriage.

Over a box of joint values (centre ``c``, half widths ``h``) the squared distance
``G(q) = |p(q) - o|^2`` from the centre ``o`` to the tool point ``p`` is at most

    G(c) + sum_i |dG/dq_i (c)| h_i + 0.5 * B,
    B = 2 * ((sum_i r_i h_i)^2 + D * sum_ij r_max(i,j) h_i h_j),

from Taylor's theorem: each first derivative of the tool point is a joint's twist applied to it,
at most ``r_i`` long (the distance from the tool point to joint ``i``'s axis, at most
:func:`~armpath.kinematics.displacement_bounds`; 1 for a prismatic joint), each second
derivative ``d2p/dq_i dq_j`` is the earlier joint's rotation applied to the later one's
twist, at most ``r_max(i,j)`` (the later joint's bound) long, and ``D`` is an upper bound of
``|p - o|`` (the summed lengths). Boxes whose bound is within :data:`DISTANCE_SLACK` of the
largest distance found at a centre are dropped, the others split across the joint that
contributes most; the largest bound of all the boxes, dropped or left, is the proven
distance. A budget of boxes ends the search: its result stays a proof, only less tight.

The centre is put on the axis of the first revolute joint after the carriage (that joint then
leaves every distance as it is and drops out), where the largest sampled distance is least.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from armpath.kinematics import (
    displacement_bounds,
    forward_frames,
    jacobian_from_frames,
    lengths_after,
    tool_point_joints,
)
from armpath.model.serial_arm import JointKind, SerialArm

FloatArray = NDArray[np.float64]

#: The search stops when its proven distance is within this of the largest distance found
#: (model length units; mm for the arms the carriage bound takes).
DISTANCE_SLACK = 0.5
#: Most boxes evaluated in all (each one forward pass and Jacobian of the arm).
MAX_BOXES = 2_000_000
#: Boxes evaluated in one batch.
_BATCH = 100_000
#: Joint configurations sampled to place the centre along the axis.
_CENTRE_SAMPLES = 4000


@dataclass(frozen=True)
class FarthestReach:
    """The proven largest distance ``radius`` from ``centre`` to the tool point, over every
    value of the joints after joint ``after`` within their limits (model units). ``centre`` is
    a point fixed to joint ``after``'s moving frame, given in the world with that joint and
    those before it at zero; ``found`` the largest distance met at a configuration
    (``radius - found`` is what the search left open), ``boxes`` how many boxes it took."""

    after: int
    centre: FloatArray
    radius: float
    found: float
    boxes: int


def _search_ranges(arm: SerialArm, first: int) -> tuple[FloatArray, FloatArray]:
    """Per joint from ``first`` on, the values the search covers: the limits, a revolute
    joint's no wider than one turn."""
    lo = arm.lower[first:].astype(np.float64).copy()
    hi = arm.upper[first:].astype(np.float64).copy()
    for k, joint in enumerate(arm.joints[first:]):
        if joint.kind is JointKind.REVOLUTE and (
            not (np.isfinite(lo[k]) and np.isfinite(hi[k])) or hi[k] - lo[k] >= 2 * np.pi
        ):
            lo[k], hi[k] = -np.pi, np.pi
    return lo, hi


def _tool_points(arm: SerialArm, q: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Tool points ``(M, 3)`` and their Jacobians ``(M, 3, n)`` at configurations ``(M, n)``."""
    frames = forward_frames(arm, q)
    return frames[:, -1, :3, 3], jacobian_from_frames(arm, frames)[:, :3, :]


def farthest_tool_point(
    arm: SerialArm, after: int = 0, max_boxes: int = MAX_BOXES
) -> FarthestReach | None:
    """The proven largest distance from a point of joint ``after``'s moving frame to the tool
    point, over the values of the joints after it (see the module). None where a later
    prismatic joint is unlimited (the tool point has no farthest place). Computed once per
    arm (a second of search or more; cached on the arm)."""
    cache: dict[tuple[int, int], FarthestReach | None] = arm.__dict__.setdefault(
        "_farthest_tool_point", {}
    )
    key = (int(after), int(max_boxes))
    if key not in cache:
        cache[key] = _search(arm, after, max_boxes)
    return cache[key]


def _search(arm: SerialArm, after: int, max_boxes: int) -> FarthestReach | None:
    """:func:`farthest_tool_point`, searched."""
    n = arm.n_joints
    first = after + 1
    lo, hi = _search_ranges(arm, first)
    if not np.all(np.isfinite(lo) & np.isfinite(hi)):
        return None
    # configurations with joint ``after`` (and those before it) at zero: the frame it moves
    # stays where it is at zero, and distances in it are the same at any of its values
    q_fixed = np.zeros(n)
    frames0 = forward_frames(arm, q_fixed[None])[0]
    T_after = frames0[after + 1]  # the world frame of joint ``after`` after its motion, at zero
    moving = np.zeros(n, dtype=bool)
    moving[first:] = True
    moving &= tool_point_joints(arm)
    rng = np.random.default_rng(0)
    sample = np.tile(q_fixed, (_CENTRE_SAMPLES, 1))
    sample[:, first:] = rng.uniform(lo, hi, (_CENTRE_SAMPLES, n - first))
    P = _tool_points(arm, sample)[0]
    centre_world = T_after[:3, 3].copy()
    if first < n and arm.joints[first].kind is JointKind.REVOLUTE:
        # on the next revolute axis: that joint then keeps every distance
        axis_frame = frames0[first + 1]  # its frame turns about its own axis
        a_point, a_dir = axis_frame[:3, 3], axis_frame[:3, :3] @ arm.joints[first].axis
        a_dir = a_dir / np.linalg.norm(a_dir)
        d = P - a_point
        along, sq = d @ a_dir, np.einsum("ij,ij->i", d, d)
        # largest squared distance from a_point + t a_dir: max(sq - 2 t along + t^2), convex in t
        lo_t, hi_t = float(along.min()), float(along.max())
        for _ in range(80):
            m1, m2 = lo_t + (hi_t - lo_t) / 3, hi_t - (hi_t - lo_t) / 3
            f1 = np.max(sq - 2 * m1 * along) + m1 * m1
            f2 = np.max(sq - 2 * m2 * along) + m2 * m2
            lo_t, hi_t = (lo_t, m2) if f1 <= f2 else (m1, hi_t)
        centre_world = a_point + 0.5 * (lo_t + hi_t) * a_dir
        moving[first] = False
    free = np.flatnonzero(moving)
    found = float(np.sqrt(np.max(np.einsum("ij,ij->i", P - centre_world, P - centre_world))))
    # bounds of the derivatives (see the module)
    r = displacement_bounds(arm)[free]
    ahead = np.maximum.outer(np.arange(free.size), np.arange(free.size))
    r_pair = r[ahead]  # the later joint's bound, per pair
    D = float(np.linalg.norm(centre_world - T_after[:3, 3])) + lengths_after(arm, after)
    box_lo = lo[free - first][None, :].copy()
    box_hi = hi[free - first][None, :].copy()
    best_sq = found * found
    slack_sq = (found + DISTANCE_SLACK) ** 2 - found**2  # a box within it is not split
    boxes = 0
    dropped_sq = best_sq  # the largest bound of a box dropped (the found distance's own)
    open_sq = np.inf  # the largest bound of the boxes not yet dropped (none evaluated: inf)
    while box_lo.shape[0]:
        if boxes + box_lo.shape[0] > max_boxes:
            break
        boxes += box_lo.shape[0]
        upper = np.empty(box_lo.shape[0])
        grad_part = np.empty_like(box_lo)
        for start in range(0, box_lo.shape[0], _BATCH):
            sl = slice(start, start + _BATCH)
            c, h = 0.5 * (box_lo[sl] + box_hi[sl]), 0.5 * (box_hi[sl] - box_lo[sl])
            q = np.tile(q_fixed, (c.shape[0], 1))
            q[:, free] = c
            p, J = _tool_points(arm, q)
            e = p - centre_world
            G = np.einsum("ij,ij->i", e, e)
            best_sq = max(best_sq, float(G.max()))
            grad = 2.0 * np.einsum("ij,ijk->ik", e, J[:, :, free])
            lin = np.abs(grad) * h
            first_order = h @ r
            second = np.einsum("mi,ij,mj->m", h, r_pair, h)
            upper[sl] = G + lin.sum(axis=1) + (first_order**2 + D * second)
            # what each joint adds: its linear part and its share of the quadratic one
            grad_part[sl] = lin + h * (r * first_order[:, None] + D * (h @ r_pair))
        keep = upper > best_sq + slack_sq
        if np.any(~keep):
            dropped_sq = max(dropped_sq, float(upper[~keep].max()))
        if not np.any(keep):
            open_sq = -np.inf
            box_lo = box_lo[:0]
            break
        # the kept boxes' halves are within their bounds, whether split again or not
        open_sq = float(upper[keep].max())
        box_lo, box_hi, grad_part = box_lo[keep], box_hi[keep], grad_part[keep]
        # split each box in two across the joint that adds most
        k = np.argmax(grad_part, axis=1)
        rows = np.arange(box_lo.shape[0])
        mid = 0.5 * (box_lo[rows, k] + box_hi[rows, k])
        lo_a, hi_a = box_lo.copy(), box_hi.copy()
        hi_a[rows, k] = mid
        lo_b, hi_b = box_lo.copy(), box_hi.copy()
        lo_b[rows, k] = mid
        box_lo, box_hi = np.concatenate([lo_a, lo_b]), np.concatenate([hi_a, hi_b])
    # every box is dropped or open (the budget ran out): the largest of their bounds
    proven_sq = max(dropped_sq, open_sq)
    return FarthestReach(
        after=after,
        centre=centre_world,
        radius=float(min(np.sqrt(proven_sq), D)),  # D: no box evaluated within the budget
        found=float(np.sqrt(best_sq)),
        boxes=boxes,
    )


__all__ = ["DISTANCE_SLACK", "MAX_BOXES", "FarthestReach", "farthest_tool_point"]
