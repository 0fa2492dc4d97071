"""Fixed-point rotation (seed 003 section 2): the tool tip stays on a point while the tool turns.

The wrist centre runs round a circle on the sphere of radius ``d6`` (the tool length) about the
point ``C0``; at each of ``n_points`` wrist positions the tool axis points from the wrist to C0
and the tool's rotation is the Rodrigues rotation taking z onto that axis (as in the report).
The all-solutions IK gives every joint solution there; the one nearest to the previous
waypoint is kept (a continuous branch), and a minimum-snap trajectory joins the waypoints. The
tip then leaves C0 only between waypoints: its deviation along the smooth trajectory is
reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath.budget import MAX_WAYPOINTS, check_size, check_time
from armpath.errors import InvalidInputError
from armpath.ik import limits_mask, require_complete_solver
from armpath.kinematics import tool_pose
from armpath.model.serial_arm import JointKind, SerialArm
from armpath.trajectory.minsnap import ORDERS, PiecewisePolynomial, minimum_snap

FloatArray = NDArray[np.float64]
#: Most instants at which the smooth trajectory's tip deviation is measured.
MAX_CHECK_SAMPLES = 1_000_000


def rodrigues_z_to(k: FloatArray) -> FloatArray:
    """The rotation about ``z x k`` taking the z axis onto the unit vector ``k`` (Rodrigues);
    a half turn about x when ``k = -z``."""
    k = np.asarray(k, dtype=np.float64) / np.linalg.norm(k)
    axis = np.cross([0.0, 0.0, 1.0], k)
    s, c = np.linalg.norm(axis), float(k[2])
    if s < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    u = axis / s
    K = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return np.asarray(np.eye(3) + s * K + (1.0 - c) * (K @ K))


@dataclass(frozen=True)
class FixedPointRotation:
    """The planned rotation: ``wrist_points`` ``(K, 3)`` (model unit) on the sphere about
    ``centre``, the joint ``waypoints`` ``(K + 1, n)`` (closing the loop), the trajectory, and
    the tool point's largest distance from the centre along it (``max_tip_deviation``, model
    unit; ``waypoint_tip_error`` at the waypoints themselves)."""

    centre: FloatArray
    radius: float
    wrist_points: FloatArray
    waypoints: FloatArray
    trajectory: PiecewisePolynomial
    max_tip_deviation: float
    waypoint_tip_error: float


def fixed_point_rotation(
    arm: SerialArm,
    centre: ArrayLike,
    *,
    circle_axis: ArrayLike = (1.0, 0.0, 0.0),
    cone_deg: float = 90.0,
    n_points: int = 24,
    duration_s: float = 8.0,
    kind: str = "snap",
    check_samples: int = 4000,
) -> FixedPointRotation:
    """Rotate the tool about its tip held at ``centre`` (model unit). The wrist centre runs once
    round the circle of points at angle ``cone_deg`` from ``circle_axis`` on the sphere of radius
    ``d6`` (90 deg: a great circle; the report's circle with theta fixed is the great circle
    normal to ``(-sin theta0, cos theta0, 0)``). A circle whose tool axis passes along axis 4
    (the wrist singularity) makes the wrist flip between waypoints; the deviation shows it.

    At most ``MAX_WAYPOINTS`` points (``n_points + 1`` waypoints) and ``MAX_CHECK_SAMPLES``
    check samples, refused before any work."""
    if isinstance(n_points, bool) or not isinstance(n_points, int | np.integer) or n_points < 3:
        raise InvalidInputError(f"the circle needs at least 3 points, got {n_points}")
    check_size(n_points + 1, MAX_WAYPOINTS, "waypoints of the circle (points + 1)", "the points")
    if not (0.0 < cone_deg <= 90.0):
        raise InvalidInputError(f"cone angle must be in (0, 90] deg, got {cone_deg}")
    if not (np.isfinite(duration_s) and duration_s > 0):
        raise InvalidInputError(f"the duration must be > 0 s, got {duration_s}")
    if kind not in ORDERS:
        raise InvalidInputError(f"kind must be one of {tuple(ORDERS)}, got {kind!r}")
    if not 2 <= check_samples <= MAX_CHECK_SAMPLES:
        raise InvalidInputError(
            f"check_samples must be in 2..{MAX_CHECK_SAMPLES}, got {check_samples}"
        )
    c0 = np.asarray(centre, dtype=np.float64).reshape(3)
    a = np.asarray(circle_axis, dtype=np.float64).reshape(3)
    if not (np.all(np.isfinite(c0)) and np.all(np.isfinite(a))):
        raise InvalidInputError("the centre and the circle's axis must be finite")
    if not np.any(a):
        raise InvalidInputError("the circle's axis must not be zero")
    a = a / np.max(np.abs(a))  # no overflow or underflow in the norm
    a /= np.linalg.norm(a)
    solver = require_complete_solver(arm, "turning the tool about a fixed point")
    # the tool length: distance from the wrist centre to the tool point at any pose
    flange_to_tip = float(np.linalg.norm(arm.T_flange_tool[:3, 3]))
    last = arm.joints[-1].T_parent_joint[:3, 3]
    radius = flange_to_tip if flange_to_tip > 0 else float(np.linalg.norm(last))
    if radius <= 0:
        raise InvalidInputError(f"model {arm.name!r} has no tool length to rotate about")
    e1 = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    phi = 2.0 * np.pi * np.arange(n_points) / n_points
    cone = np.radians(cone_deg)
    dirs = np.cos(cone) * a + np.sin(cone) * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
    wrist = c0 + radius * dirs
    T = np.zeros((n_points, 4, 4))
    for k in range(n_points):
        T[k, :3, :3] = rodrigues_z_to(c0 - wrist[k])
        T[k, :3, 3] = c0
        T[k, 3, 3] = 1.0
    batch = solver.solve_batch(T)
    prismatic = np.array([j.kind is JointKind.PRISMATIC for j in arm.joints])
    chosen = np.zeros((n_points, arm.n_joints))
    previous: FloatArray | None = None
    for k in range(n_points):
        if k % 256 == 0:
            check_time("choosing the joint solutions round the circle")
        sols = batch[k].solutions
        sols = sols[limits_mask(arm, sols)]
        if sols.shape[0] == 0:
            where = ", ".join(f"{v:.1f}" for v in wrist[k])
            centre = ", ".join(f"{v:g}" for v in c0)
            raise InvalidInputError(
                f"no configuration within the joint limits has the tool on ({centre}) mm with "
                f"the wrist at ({where}) mm (point {k + 1} of {n_points} round the circle): "
                f"the centre is not a dexterous point of {arm.name} for a circle "
                f"{cone_deg:g} deg from this axis; try a centre nearer the middle of its "
                "workspace (--centre), or a smaller angle (--cone)"
            )
        if previous is None:
            pick = sols[0]
        else:
            diff = sols - previous
            diff[:, ~prismatic] = (diff[:, ~prismatic] + np.pi) % (2 * np.pi) - np.pi
            pick = previous + diff[np.argmin(np.linalg.norm(diff, axis=1))]
        chosen[k] = pick
        previous = pick
    # close the loop on the same branch (the revolute angles may have gone round a whole turn)
    diff = chosen[0] - chosen[-1]
    diff[~prismatic] = (diff[~prismatic] + np.pi) % (2 * np.pi) - np.pi
    waypoints = np.vstack([chosen, chosen[-1] + diff])
    times = np.linspace(0.0, duration_s, n_points + 1)
    traj = minimum_snap(waypoints, times, kind=kind)
    t = np.linspace(0.0, duration_s, check_samples)
    tips = tool_pose(arm, traj.evaluate(t))[:, :3, 3]
    at_waypoints = tool_pose(arm, waypoints)[:, :3, 3]
    return FixedPointRotation(
        c0,
        radius,
        wrist,
        waypoints,
        traj,
        float(np.max(np.linalg.norm(tips - c0, axis=1))),
        float(np.max(np.linalg.norm(at_waypoints - c0, axis=1))),
    )
