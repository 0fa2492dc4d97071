"""Waypoints in the openings of hollow obstacles, for motions that must pass through them.

A motion from outside a hollow workpiece to a point inside it (a spot weld on its inner wall)
must carry the tool point through an opening (:meth:`CollisionWorld.openings`). The straight
joint motion often drives a link through the rim instead, and a sampling-based search then
finds a way round that costs many commands more than the straight motion would (the seed's
Task 3: 71 to 100 commands into the workpiece where the straight motion needs 64). Clear
lattice states with the tool point in and just outside each opening are the waypoints of
motions made of two straight parts (:func:`~armpath.planning.motion.plan_motion` with
``waypoints``): through the right one such a motion needs no more commands than the straight
motion (64 on the seed's Task 3).
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from armpath.budget import check_time
from armpath.geometry.world import CollisionWorld
from armpath.ik.family import GenericFamily, shift_into_limits
from armpath.ik.solve import complete_solver
from armpath.ik.target import ToolTarget
from armpath.model.lattice import unique_states
from armpath.model.serial_arm import SerialArm

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Levels of the tool points about an opening, as fractions of its radius along its normal
#: (outside it, in it, inside the solid).
LEVELS = (0.25, 0.0, -0.35)
#: Spacing of the tool points over an opening's disc (a square grid, within 0.95 of its
#: radius), as a fraction of its radius.
SPACING = 0.25
#: Tool orientations sampled at each point (every inverse-kinematics solution of each).
ROTATIONS = 200
#: Most waypoints kept (evenly over those found).
MAX_WAYPOINTS = 100_000


def passage_points(world: CollisionWorld) -> FloatArray:
    """Tool points ``(P, 3)`` (length unit) in and about every opening of ``world``: a square
    grid over each opening's disc (:data:`SPACING`) at each of :data:`LEVELS`."""
    out = []
    for hole in world.openings():
        r = hole.radius
        xy, points = hole.square_grid(SPACING * r)
        disc = points[np.hypot(xy[:, 0], xy[:, 1]) <= 0.95 * r]
        for level in LEVELS:
            out.append(disc + level * r * hole.normal)
    return np.vstack(out) if out else np.zeros((0, 3))


def passage_waypoints(arm: SerialArm, world: CollisionWorld, near_ticks: IntArray) -> IntArray:
    """Lattice states ``(W, n)`` within the joint limits that keep the clearance rule with
    the tool point at :func:`passage_points`: the solution family at each point over
    :data:`ROTATIONS` tool orientations (every solution of the complete solver; the numerical
    family's samples for an arm without one), turned nearest ``near_ticks`` and rounded to the
    lattice; at most :data:`MAX_WAYPOINTS`, none where ``world`` has no openings."""
    grid = arm.lattice
    near = grid.to_joint(np.asarray(near_ticks, dtype=np.int64))
    points = passage_points(world)
    found = [np.zeros((0, arm.n_joints), dtype=np.int64)]
    solver = complete_solver(arm)
    rng = np.random.default_rng(0)
    if solver is not None and points.shape[0]:
        rotations = ToolTarget(points[0], None).rotations(ROTATIONS, rng)
        per_batch = max(1, 4096 // rotations.shape[0])
        for k in range(0, points.shape[0], per_batch):
            check_time("sampling waypoints in the openings")
            chunk = points[k : k + per_batch]
            T = np.broadcast_to(np.eye(4), (chunk.shape[0], rotations.shape[0], 4, 4)).copy()
            T[..., :3, :3] = rotations
            T[..., :3, 3] = chunk[:, None, :]
            q = solver.solve_batch(T.reshape(-1, 4, 4)).solutions.reshape(-1, arm.n_joints)
            q = shift_into_limits(arm, q[np.all(np.isfinite(q), axis=1)], near)
            found.append(grid.nearest_ticks(q))
    else:
        for point in points:
            check_time("sampling waypoints in the openings")
            family = GenericFamily(arm, ToolTarget(point, None))
            q = family.samples(near=near, rotations=ROTATIONS, starts=ROTATIONS // 2, rng=rng)
            found.append(grid.nearest_ticks(q))
    states = unique_states(np.vstack(found))
    q = grid.to_joint(states)
    states = states[arm.within_limits(q) & world.satisfied(arm, q)]
    if states.shape[0] > MAX_WAYPOINTS:
        pick = np.linspace(0, states.shape[0] - 1, MAX_WAYPOINTS).round().astype(np.int64)
        states = states[pick]
    return np.asarray(states, dtype=np.int64)


def passage_source(
    arm: SerialArm, world: CollisionWorld, near_ticks: IntArray
) -> Callable[[], IntArray] | None:
    """:func:`passage_waypoints`, sampled on the first call and kept (what
    :func:`~armpath.planning.motion.plan_motion` takes as ``waypoints``); None where ``world``
    has no openings."""
    if not world.openings():
        return None
    return functools.cache(lambda: passage_waypoints(arm, world, near_ticks))
