"""Numerical IK: Levenberg-Marquardt (damped least squares) from many seeds at once.

Works for any serial arm (revolute and prismatic joints, redundant or not), for full poses or
positions only, inside the joint limits. It finds the solutions its seeds lead to, so it is the
fallback where no complete method applies (arms with other than six joints, degenerate
eliminations), not a proof that no other solution exists.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from armpath.budget import MAX_IK_SEEDS, check_time
from armpath.errors import InvalidInputError
from armpath.ik.result import IKResult
from armpath.kinematics import forward_frames, jacobian_from_frames
from armpath.model.serial_arm import JointKind, SerialArm

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def _errors_and_jacobians(
    arm: SerialArm, q: FloatArray, T: FloatArray, position_only: bool
) -> tuple[FloatArray, FloatArray]:
    frames = forward_frames(arm, q)
    tool = frames[:, -1]
    J = jacobian_from_frames(arm, frames)
    p = tool[:, :3, 3]
    S = q.shape[0]
    err = np.zeros((S, 6))
    err[:, :3] = T[:3, 3] - p
    if not position_only:
        err[:, 3:] = 0.5 * np.sum(
            np.cross(tool[:, :3, :3], T[:3, :3], axisa=1, axisb=0, axisc=1), axis=2
        )
    if position_only:
        return err[:, :3], J[:, :3]
    return err, J


#: Most random starts of one numerical solve (:data:`armpath.budget.MAX_IK_SEEDS`).
MAX_SEEDS = MAX_IK_SEEDS

#: A converged solution puts the tool within this distance of the target (mm) ...
POSITION_TOLERANCE_MM = 1e-6
#: ... and its frame within this angle of the target's (rad).
ROTATION_TOLERANCE_RAD = 1e-8
#: When no start converges, the search draws this many times more fresh starts, up to
#: ``MAX_RETRY_SEEDS`` in all (arms whose reachable poses few random starts lead to).
RETRY_GROWTH = 4
MAX_RETRY_SEEDS = 3072


def solve_numerical(
    arm: SerialArm,
    T_target: FloatArray,
    *,
    position_only: bool = False,
    seeds: int = 48,
    rng_seed: int = 0,
    initial: FloatArray | None = None,
    max_iterations: int = 200,
    position_tolerance_mm: float = POSITION_TOLERANCE_MM,
    rotation_tolerance_rad: float = ROTATION_TOLERANCE_RAD,
    retry: bool = True,
) -> IKResult:
    """Solutions of one target found by LM from ``seeds`` random starts (plus ``initial``).

    ``T_target`` is a 4x4 pose, or a 3-vector position when ``position_only``. Seeds are drawn
    uniformly inside the joint limits (:meth:`~armpath.model.serial_arm.SerialArm.sampling_box`
    where unlimited) with ``rng_seed``. A start has converged when the tool is within
    ``position_tolerance_mm`` of the target (in mm whatever the model's length unit) and, for a
    pose, its frame within ``rotation_tolerance_rad``. Steps are projected onto the joint
    limits. When no start converges and ``retry`` is set, the search draws ``RETRY_GROWTH``
    times more fresh starts, again and again, until one converges or ``MAX_RETRY_SEEDS``
    starts have been tried; only then does it answer that no solution was found.
    """
    n = arm.n_joints
    if not 1 <= seeds <= MAX_SEEDS:
        raise InvalidInputError(
            f"seeds of the numerical IK must be in [1, {MAX_SEEDS}], got {seeds}"
        )
    for name, value in (
        ("position_tolerance_mm", position_tolerance_mm),
        ("rotation_tolerance_rad", rotation_tolerance_rad),
    ):
        if not (np.isfinite(value) and value > 0.0):
            raise InvalidInputError(f"{name} must be a positive number, got {value}")
    if position_only:
        p = np.asarray(T_target, dtype=np.float64).reshape(-1)
        if p.shape != (3,) or not np.isfinite(p).all():
            raise InvalidInputError("a position target needs three finite numbers")
        T = np.eye(4)
        T[:3, 3] = p
    else:
        T = np.asarray(T_target, dtype=np.float64)
        if T.shape != (4, 4) or not np.isfinite(T).all():
            raise InvalidInputError("a pose target must be a finite 4x4 matrix")
    lo, hi = arm.sampling_box()
    prismatic = np.array([j.kind is JointKind.PRISMATIC for j in arm.joints])
    position_tol = position_tolerance_mm / arm.mm_per_unit
    size = 1.0 + float(np.max(np.abs(forward_frames(arm, arm.home)[:, :3, 3])))
    rng = np.random.default_rng(rng_seed)
    starts = rng.uniform(lo, hi, size=(seeds, n))
    if initial is not None:
        starts = np.vstack([np.asarray(initial, dtype=np.float64).reshape(1, n), starts])
    tried = 0
    while True:
        tried += starts.shape[0]
        q, pos_err, rot_err = _descend(
            arm,
            starts,
            T,
            position_only,
            size,
            max_iterations,
            position_tol,
            rotation_tolerance_rad,
        )
        ok = (pos_err <= position_tol) & (rot_err <= rotation_tolerance_rad)
        more = min(starts.shape[0] * RETRY_GROWTH, MAX_RETRY_SEEDS - tried)
        if np.any(ok) or not retry or more <= 0:
            break
        check_time()
        starts = rng.uniform(lo, hi, size=(more, n))
    method = "levenberg-marquardt" + (" (position only)" if position_only else "")
    if not np.any(ok):
        best = int(np.argmin(pos_err / position_tol + rot_err / rotation_tolerance_rad))
        return IKResult.empty(
            n,
            method,
            f"no start converged ({tried} starts): the closest reached "
            + (
                f"{pos_err[best]:.4g} {arm.length_unit} from the target (tolerance "
                f"{position_tolerance_mm:g} mm)"
                if position_only
                else f"{pos_err[best]:.4g} {arm.length_unit} and "
                f"{np.degrees(rot_err[best]):.4g} deg from the target (tolerances "
                f"{position_tolerance_mm:g} mm, {np.degrees(rotation_tolerance_rad):.2g} deg)"
            ),
        )
    kept = distinct_solutions(q[ok], prismatic, SAME_SOLUTION)
    sols = q[ok][kept]
    # revolute angles wrapped to (-pi, pi] as the complete solvers give them (the descent
    # wanders by whole turns); into_limits then shifts them into the joint limits
    sols = np.where(prismatic, sols, np.pi - np.mod(np.pi - sols, 2.0 * np.pi))
    order = np.lexsort(sols.T[::-1])
    false = np.zeros(kept.size, dtype=bool)
    return IKResult(
        sols[order], pos_err[ok][kept][order], rot_err[ok][kept][order], false, false.copy(), method
    )


#: Two solutions closer than this in every joint (rad, or length unit; angles compared modulo
#: a turn) are one.
SAME_SOLUTION = 1e-6


def distinct_solutions(q: FloatArray, prismatic: NDArray[np.bool_], within: float) -> IntArray:
    """Indices of the rows of ``q`` kept when each row, in order, is dropped if a kept one lies
    within ``within`` of it in every joint (revolute joints modulo a turn). A k-d tree finds the
    neighbours, so a position-only solve of 100,000 starts, each converging to its own member of
    the family, is not compared pairwise (it took minutes)."""
    from scipy.spatial import cKDTree

    wrapped = np.where(prismatic, q, (q + np.pi) % (2.0 * np.pi) - np.pi)  # in [-pi, pi)
    tree = cKDTree(wrapped)
    near_seam = np.abs(np.abs(wrapped) - np.pi) < within  # a neighbour may lie a turn away
    dropped = np.zeros(q.shape[0], dtype=bool)
    kept: list[int] = []
    for k in range(q.shape[0]):
        if dropped[k]:
            continue
        kept.append(k)
        points = [wrapped[k]]
        for j in np.flatnonzero(near_seam[k] & ~prismatic):
            points += [p + np.where(np.arange(q.shape[1]) == j, -2.0 * np.pi * np.sign(p[j]), 0.0)
                       for p in points]  # fmt: skip
        for p in points:
            dropped[tree.query_ball_point(p, within, p=np.inf, eps=0.0)] = True
    return np.array(kept, dtype=np.int64)


def _descend(
    arm: SerialArm,
    starts: FloatArray,
    T: FloatArray,
    position_only: bool,
    size: float,
    max_iterations: int,
    position_tol: float,
    rotation_tol: float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """LM from every start at once; the final joints, position and rotation errors."""
    n = arm.n_joints
    q = starts.copy()
    lam = np.full(q.shape[0], 1e-2)
    err, J = _errors_and_jacobians(arm, q, T, position_only)
    w = np.ones(err.shape[1])
    w[:3] = 1.0 / size  # position in units of the arm size, rotation in rad
    cost = np.sum((err * w) ** 2, axis=1)
    # Stop once every start is well inside both tolerances (or stuck).
    done_cost = min(position_tol / size, rotation_tol) ** 2 * 1e-4
    for _ in range(max_iterations):
        Jw = J * w[None, :, None]
        ew = err * w
        JtJ = np.swapaxes(Jw, 1, 2) @ Jw
        g = np.einsum("sji,sj->si", Jw, ew)
        A = JtJ + lam[:, None, None] * np.eye(n)
        dq = np.linalg.solve(A, g[..., None])[..., 0]
        q_new = np.clip(q + dq, arm.lower, arm.upper)
        err_new, J_new = _errors_and_jacobians(arm, q_new, T, position_only)
        cost_new = np.sum((err_new * w) ** 2, axis=1)
        better = cost_new < cost
        q[better] = q_new[better]
        err[better] = err_new[better]
        J[better] = J_new[better]
        cost[better] = cost_new[better]
        lam = np.where(better, np.maximum(lam / 3.0, 1e-12), np.minimum(lam * 4.0, 1e8))
        if np.all(cost < done_cost):
            break
    pos_err = np.linalg.norm(err[:, :3], axis=1)
    rot_err = np.zeros(q.shape[0]) if position_only else np.linalg.norm(err[:, 3:], axis=1)
    return q, pos_err, rot_err


def _angle_diff(d: FloatArray, prismatic: NDArray[np.bool_]) -> FloatArray:
    out = d.copy()
    out[~prismatic] = (out[~prismatic] + np.pi) % (2.0 * np.pi) - np.pi
    return out
