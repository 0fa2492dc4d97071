"""Batched forward kinematics and position Jacobians of serial arms.

All functions take joint arrays of shape ``(..., n)`` (rad for revolute joints, the model's length
unit for prismatic ones) and return arrays with the same leading batch shape. A single
configuration is the batch of one.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from armpath import jit
from armpath.errors import InvalidInputError
from armpath.jit import in_slices, njit
from armpath.model.serial_arm import JointKind, SerialArm, check_arm

FloatArray = NDArray[np.float64]


def _as_joint_array(arm: SerialArm, q: ArrayLike) -> FloatArray:
    check_arm(arm)
    qa = np.asarray(q, dtype=np.float64)
    if qa.ndim == 0 or qa.shape[-1] != arm.n_joints:
        raise InvalidInputError(
            f"model {arm.name!r} has {arm.n_joints} joints; got joint array of shape {qa.shape}"
        )
    if not np.all(np.isfinite(qa)):
        raise InvalidInputError("joint values must be finite numbers (got NaN or inf)")
    return qa


_EYE3 = np.eye(3)
_EYE3.setflags(write=False)
#: The cross-product matrix K of each joint axis met, and K @ K (by the axis's bytes): what
#: Rodrigues' formula needs of an axis, computed once rather than at every pose.
_AXIS_MATRICES: dict[bytes, tuple[FloatArray, FloatArray]] = {}


def _axis_matrices(axis: FloatArray) -> tuple[FloatArray, FloatArray]:
    key = np.asarray(axis, dtype=np.float64).tobytes()
    found = _AXIS_MATRICES.get(key)
    if found is None:
        K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
        found = (K, K @ K)
        if len(_AXIS_MATRICES) < 4096:  # a process meets a few arms' axes
            _AXIS_MATRICES[key] = found
    return found


def _joint_motion(axis: FloatArray, kind: JointKind, value: FloatArray) -> FloatArray:
    """4x4 motion of one joint for a batch of values: rotation about / translation along axis."""
    T = np.zeros((*value.shape, 4, 4))
    T[..., 3, 3] = 1.0
    if kind is JointKind.PRISMATIC:
        T[..., 0, 0] = T[..., 1, 1] = T[..., 2, 2] = 1.0
        T[..., :3, 3] = value[..., None] * axis
        return T
    K, KK = _axis_matrices(axis)
    s = np.sin(value)[..., None, None]
    c = np.cos(value)[..., None, None]
    T[..., :3, :3] = _EYE3 + s * K + (1.0 - c) * KK
    return T


def forward_frames(arm: SerialArm, q: ArrayLike) -> FloatArray:
    """World poses of every frame, shape ``(..., n + 2, 4, 4)``.

    Index 0 is the base, index ``i`` (1..n) joint ``i`` after its motion, index ``n + 1`` the tool.
    A compiled loop for more than a few poses, numpy for a few.
    """
    qa = _as_joint_array(arm, q)
    if _compiled_pays(qa):
        out = _compiled_frames(arm, qa.reshape(-1, arm.n_joints))
        return np.asarray(out.reshape(*qa.shape[:-1], arm.n_joints + 2, 4, 4))
    return _forward_frames_numpy(arm, qa)


def pose_frames(arm: SerialArm, q: FloatArray) -> FloatArray:
    """:func:`forward_frames` of one configuration ``(n,)`` rad by the compiled loop whatever
    the batch size, ``(n + 2, 4, 4)``: for solvers that evaluate single poses thousands of
    times (about a tenth of numpy's cost per pose; equal to it to rounding)."""
    return np.asarray(_compiled_frames(arm, np.asarray(q, np.float64).reshape(1, arm.n_joints))[0])


def tool_point_with_jacobian(arm: SerialArm, q: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The tool point ``(3,)`` and its Jacobian ``(3, n)`` at one configuration ``q (n,)``
    rad by the compiled loop (:func:`pose_frames`): for solvers that ask both of single poses
    thousands of times (about 16 us against 0.8 ms through :func:`tool_position` and
    :func:`position_jacobian`; equal to them to rounding)."""
    F = pose_frames(arm, q)
    return F[-1, :3, 3].copy(), np.asarray(jacobian_from_frames(arm, F[None])[0][:3])


def _compiled_frames(arm: SerialArm, q: FloatArray) -> FloatArray:
    """Every frame ``(N, n + 2, 4, 4)`` of configurations ``q (N, n)`` by the compiled loop."""
    return _frames_in_slices(arm, q, True)


#: Fewest configurations whose frames (:func:`forward_frames`, :func:`tool_pose`, compiled)
#: are split between threads, one slice per core, where a core is free.
FRAMES_THREAD_BATCH = 4_096


def _frames_in_slices(arm: SerialArm, q: FloatArray, every: bool) -> FloatArray:
    """:func:`_frames_kernel` of configurations ``q (N, n)``: every frame or the tool's, a
    large batch in slices on threads (:func:`~armpath.jit.in_slices`)."""
    flat = np.ascontiguousarray(q, dtype=np.float64)
    chain = compiled_chain(arm)[:5]

    def part(a: int, b: int) -> FloatArray:
        return np.asarray(_frames_kernel(flat[a:b], *chain, every))

    return np.concatenate(in_slices(part, flat.shape[0], FRAMES_THREAD_BATCH))


def _compiled_pays(qa: FloatArray) -> bool:
    """Whether joint arrays ``qa`` take the compiled kinematics: batches of more than
    :data:`NUMPY_LANDMARK_BATCH` poses. A few poses keep numpy's arithmetic (the planners'
    single-pose Newton steps and projections give the same numbers as before), and loading
    numba would cost more than they do (``armpath fk``)."""
    return bool(qa.size > NUMPY_LANDMARK_BATCH * qa.shape[-1])


def _forward_frames_numpy(arm: SerialArm, qa: FloatArray) -> FloatArray:
    batch = qa.shape[:-1]
    frames = np.empty((*batch, arm.n_joints + 2, 4, 4))
    T = np.broadcast_to(arm.T_world_base, (*batch, 4, 4))
    frames[..., 0, :, :] = T
    for i, joint in enumerate(arm.joints):
        T = (T @ joint.T_parent_joint) @ _joint_motion(joint.axis, joint.kind, qa[..., i])
        frames[..., i + 1, :, :] = T
    frames[..., -1, :, :] = T @ arm.T_flange_tool
    return frames


def landmark_positions(arm: SerialArm, q: ArrayLike) -> FloatArray:
    """Positions of the arm's landmarks (A..E for the seed arm), shape ``(..., L, 3)``: each
    landmark's offset carried by its frame.

    The hot path of collision checking: a compiled loop over the batch (about 0.2 us per
    configuration for the seed arm), equal to :func:`forward_frames` to rounding.
    """
    qa = _as_joint_array(arm, q)
    # contiguous and writable whatever the caller's array: one compiled signature of the kernel
    flat = np.require(qa.reshape(-1, arm.n_joints), requirements=("C", "W"))
    if len(flat) <= NUMPY_LANDMARK_BATCH and not jit.numba_loaded():
        # a few poses in a process that has run no kernel yet (``armpath fk``): numpy is
        # quicker than loading numba
        frames = _forward_frames_numpy(arm, flat)
        index = [lm.frame for lm in arm.landmarks]
        offsets = np.array([lm.offset for lm in arm.landmarks], dtype=np.float64).reshape(-1, 3)
        picked = frames[:, index]
        pts = picked[..., :3, 3] + np.einsum("clij,lj->cli", picked[..., :3, :3], offsets)
        return np.asarray(pts.reshape(*qa.shape[:-1], len(arm.landmarks), 3))
    chain = compiled_chain(arm)
    out = _landmarks_kernel(flat, *chain)
    return np.asarray(out.reshape(*qa.shape[:-1], len(arm.landmarks), 3))


#: Batches up to this many poses take the numpy path of :func:`landmark_positions` while numba
#: is not loaded yet.
NUMPY_LANDMARK_BATCH = 8


def compiled_chain(
    arm: SerialArm,
) -> tuple[
    FloatArray, FloatArray, FloatArray, NDArray[np.bool_], FloatArray, NDArray[np.int64], FloatArray
]:
    """The arm as flat arrays for :func:`_landmarks_kernel` (cached on the arm)."""
    cached = arm.__dict__.get("compiled_chain")
    if cached is None:
        cached = (
            np.ascontiguousarray(arm.T_world_base, dtype=np.float64),
            np.ascontiguousarray(np.stack([j.T_parent_joint for j in arm.joints])),
            np.ascontiguousarray(np.stack([j.axis for j in arm.joints])),
            np.array([j.kind is JointKind.PRISMATIC for j in arm.joints]),
            np.ascontiguousarray(arm.T_flange_tool, dtype=np.float64),
            np.array([lm.frame for lm in arm.landmarks], dtype=np.int64),
            np.array([lm.offset for lm in arm.landmarks], dtype=np.float64).reshape(-1, 3),
        )
        arm.__dict__["compiled_chain"] = cached
    return cached  # type: ignore[no-any-return,unused-ignore]


@njit(cache=True)
def _affine_mul(A: np.ndarray, B: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    """``out = A @ B`` for rigid 4x4 transforms (last row 0 0 0 1), without BLAS overhead."""
    for i in range(3):
        a0, a1, a2 = A[i, 0], A[i, 1], A[i, 2]
        for j in range(4):
            out[i, j] = a0 * B[0, j] + a1 * B[1, j] + a2 * B[2, j]
        out[i, 3] += A[i, 3]
    out[3, 0] = out[3, 1] = out[3, 2] = 0.0
    out[3, 3] = 1.0


@njit(cache=True)
def _landmarks_kernel(
    q: np.ndarray,
    T_world_base: np.ndarray,
    T_parent_joint: np.ndarray,
    axes: np.ndarray,
    prismatic: np.ndarray,
    T_flange_tool: np.ndarray,
    frames: np.ndarray,
    offsets: np.ndarray,
) -> np.ndarray:  # pragma: no cover - compiled
    n_cfg, n_j = q.shape
    out = np.empty((n_cfg, frames.shape[0], 3))
    scratch = landmark_scratch(n_j)
    for c in range(n_cfg):
        landmarks_into(
            q[c],
            T_world_base,
            T_parent_joint,
            axes,
            prismatic,
            T_flange_tool,
            frames,
            offsets,
            scratch,
            out[c],
        )
    return out


@njit(cache=True)
def _joint_motion_into(
    axis: np.ndarray, prismatic: bool, v: float, M: np.ndarray
) -> None:  # pragma: no cover - compiled
    """The rigid motion of one joint at value ``v`` into the rows 0-2 of ``M`` (4x4): a turn
    about the unit ``axis`` (Rodrigues) or a shift along it."""
    kx, ky, kz = axis[0], axis[1], axis[2]
    if prismatic:
        for r in range(3):
            for k in range(3):
                M[r, k] = 1.0 if r == k else 0.0
        M[0, 3], M[1, 3], M[2, 3] = v * kx, v * ky, v * kz
    else:
        s, co = np.sin(v), np.cos(v)
        t = 1.0 - co
        M[0, 0] = co + t * kx * kx
        M[0, 1] = t * kx * ky - s * kz
        M[0, 2] = t * kx * kz + s * ky
        M[1, 0] = t * kx * ky + s * kz
        M[1, 1] = co + t * ky * ky
        M[1, 2] = t * ky * kz - s * kx
        M[2, 0] = t * kx * kz - s * ky
        M[2, 1] = t * ky * kz + s * kx
        M[2, 2] = co + t * kz * kz
        M[0, 3] = M[1, 3] = M[2, 3] = 0.0


@njit(cache=True)
def landmark_scratch(n_joints: int) -> np.ndarray:  # pragma: no cover - compiled
    """Work space of :func:`_chain_into` for an arm of ``n_joints``: three 4x4 transforms
    and every frame's rotation and origin, ``(3 * 4 + (n + 2) * 3, 4)``."""
    scratch = np.zeros((12 + (n_joints + 2) * 3, 4))
    for i in range(4):
        scratch[8 + i, i] = 1.0
    return scratch


@njit(cache=True)
def landmarks_into(
    q: np.ndarray,
    T_world_base: np.ndarray,
    T_parent_joint: np.ndarray,
    axes: np.ndarray,
    prismatic: np.ndarray,
    T_flange_tool: np.ndarray,
    frames: np.ndarray,
    offsets: np.ndarray,
    scratch: np.ndarray,
    out: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """Landmark positions ``out (L, 3)`` of one configuration ``q (n,)`` (the arm as
    :func:`compiled_chain` flattens it; ``scratch`` from :func:`landmark_scratch`)."""
    pos = _chain_into(q, T_world_base, T_parent_joint, axes, prismatic, T_flange_tool, scratch)
    for m in range(frames.shape[0]):
        f = frames[m]
        o0, o1, o2 = offsets[m, 0], offsets[m, 1], offsets[m, 2]
        for k in range(3):
            out[m, k] = pos[f, k, 3] + pos[f, k, 0] * o0 + pos[f, k, 1] * o1 + pos[f, k, 2] * o2


@njit(cache=True)
def _chain_into(
    q: np.ndarray,
    T_world_base: np.ndarray,
    T_parent_joint: np.ndarray,
    axes: np.ndarray,
    prismatic: np.ndarray,
    T_flange_tool: np.ndarray,
    scratch: np.ndarray,
) -> np.ndarray:  # pragma: no cover - compiled
    """Every frame of one configuration ``q (n,)`` as rotation | origin rows ``(n + 2, 3, 4)``
    (base, each joint after its motion, tool), a view into ``scratch``
    (:func:`landmark_scratch`)."""
    n_j = q.shape[0]
    T = scratch[0:4]
    A = scratch[4:8]
    M = scratch[8:12]
    pos = scratch[12:].reshape(n_j + 2, 3, 4)
    copy_into(T_world_base, T)
    copy_into(T, pos[0])
    for i in range(n_j):
        _affine_mul(T, T_parent_joint[i], A)
        _joint_motion_into(axes[i], prismatic[i], q[i], M)
        _affine_mul(A, M, T)
        copy_into(T, pos[i + 1])
    _affine_mul(T, T_flange_tool, A)
    copy_into(A, pos[n_j + 1])
    return pos


@njit(cache=True)
def copy_into(src: np.ndarray, dst: np.ndarray) -> None:  # pragma: no cover - compiled
    """Copy the rows and columns that 2-D ``src`` and ``dst`` share (the smaller of their
    sizes), element by element: numba compiles slice assignment through its general
    broadcasting code, seconds for every kernel using it."""
    for i in range(min(src.shape[0], dst.shape[0])):
        for j in range(min(src.shape[1], dst.shape[1])):
            dst[i, j] = src[i, j]


@njit(cache=True, nogil=True)
def _frames_kernel(
    q: np.ndarray,
    T_world_base: np.ndarray,
    T_parent_joint: np.ndarray,
    axes: np.ndarray,
    prismatic: np.ndarray,
    T_flange_tool: np.ndarray,
    every: bool,
) -> np.ndarray:  # pragma: no cover - compiled
    """Every frame ``(N, n + 2, 4, 4)`` of configurations ``q (N, n)`` (``every``), or only the
    tool's ``(N, 1, 4, 4)``: :func:`_chain_into` with the last rows 0 0 0 1 added."""
    n_cfg, n_j = q.shape
    first = 0 if every else n_j + 1
    out = np.zeros((n_cfg, n_j + 2 - first, 4, 4))
    scratch = landmark_scratch(n_j)
    for c in range(n_cfg):
        pos = _chain_into(
            q[c], T_world_base, T_parent_joint, axes, prismatic, T_flange_tool, scratch
        )
        for f in range(first, n_j + 2):
            copy_into(pos[f], out[c, f - first])
            out[c, f - first, 3, 3] = 1.0
    return out


def tool_pose(arm: SerialArm, q: ArrayLike) -> FloatArray:
    """World pose of the tool frame, shape ``(..., 4, 4)``.

    Unlike :func:`forward_frames` it keeps only the running transform, so it is the one to use
    for large batches.
    """
    qa = _as_joint_array(arm, q)
    if _compiled_pays(qa):
        out = _frames_in_slices(arm, qa.reshape(-1, arm.n_joints), False)
        return np.asarray(out.reshape(*qa.shape[:-1], 4, 4))
    T = np.broadcast_to(arm.T_world_base, (*qa.shape[:-1], 4, 4))
    for i, joint in enumerate(arm.joints):
        T = (T @ joint.T_parent_joint) @ _joint_motion(joint.axis, joint.kind, qa[..., i])
    return np.asarray(T @ arm.T_flange_tool)


def tool_position(arm: SerialArm, q: ArrayLike) -> FloatArray:
    """World position of the tool point (the fingertip), shape ``(..., 3)``."""
    return tool_pose(arm, q)[..., :3, 3]


def joints_that_move(
    arm: SerialArm, points: Callable[[SerialArm, FloatArray], FloatArray], q: FloatArray
) -> NDArray[np.bool_]:
    """Per joint, whether moving it by 0.3 (rad, or model units if prismatic) from any of the
    configurations ``q (M, n)`` moves any of ``points(arm, q)`` (tool point, landmarks)."""
    base = points(arm, q)
    moves = np.zeros(arm.n_joints, dtype=bool)
    for i in range(arm.n_joints):
        dq = np.zeros(arm.n_joints)
        dq[i] = 0.3
        moves[i] = np.abs(points(arm, q + dq) - base).max() > 1e-9
    return moves


def tool_point_joints(arm: SerialArm) -> NDArray[np.bool_]:
    """Joints that move the tool point: False for one whose axis runs through it (a SCARA's
    last joint, a wrist whose tool sits on the last axis), which only turns the tool about it.
    Judged at eight configurations drawn inside the limits (:func:`joints_that_move`)."""
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (8, arm.n_joints))
    return joints_that_move(arm, tool_position, np.clip(q, arm.lower, arm.upper))


def last_axis_in_tool(arm: SerialArm) -> FloatArray | None:
    """The last joint's axis in the tool frame (a unit vector, fixed: the tool rides on the last
    link), pointing from the joint to the tool point where that lies along it, or None for a
    prismatic last joint."""
    if arm.joints[-1].kind is not JointKind.REVOLUTE:
        return None
    F = forward_frames(arm, arm.home)
    n = arm.n_joints
    axis = F[n, :3, :3] @ np.asarray(arm.joints[-1].axis, dtype=np.float64)
    along = float((F[n + 1, :3, 3] - F[n, :3, 3]) @ axis)
    c = F[n + 1, :3, :3].T @ axis
    return np.asarray((-c if along < 0.0 else c) / np.linalg.norm(c), dtype=np.float64)


#: How near 1 the cosine between the tool's approach axis and the last joint's axis must be for
#: the two to count as one.
ALONG_AXIS_COS = 1.0 - 1e-9


def last_axis_across_approach(arm: SerialArm) -> FloatArray | None:
    """The last joint's axis in the tool frame (:func:`last_axis_in_tool`) where the tool's
    approach axis lies across it (a URDF tip frame whose x is the flange's normal, z across
    it), else None (the two are one axis, or the last joint is prismatic)."""
    c = last_axis_in_tool(arm)
    if c is None or abs(float(c @ np.asarray(arm.approach_axis))) > ALONG_AXIS_COS:
        return None
    return c


def self_motion_axis_rates(arm: SerialArm, q: ArrayLike, joints: ArrayLike) -> FloatArray:
    """How fast the tool's approach axis turns along the tool point's self-motion at each
    configuration ``q (M, n)``: the singular values ``(M, k - 3)`` (rad of the axis per rad of
    the joints, largest first) of the axis's derivative over the null space of the tool
    point's Jacobian, both restricted to ``joints`` (a mask of ``k`` joints, the others held).
    A small value is a direction of the self-motion that barely turns the tool."""
    mask = np.asarray(joints, dtype=bool)
    qq = np.atleast_2d(np.asarray(q, dtype=np.float64))
    F = forward_frames(arm, qq)
    J = jacobian_from_frames(arm, F)[:, :, mask]  # (M, 6, k)
    axis = F[:, -1, :3, :3] @ np.asarray(arm.approach_axis)  # (M, 3)
    _, _, vt = np.linalg.svd(J[:, :3, :])  # point Jacobian (M, 3, k)
    null = np.swapaxes(vt[:, 3:, :], 1, 2)  # (M, k, k - 3)
    turn = np.cross(np.swapaxes(J[:, 3:, :], 1, 2), axis[:, None, :])  # (M, k, 3): w_i x a
    return np.asarray(np.linalg.svd(np.swapaxes(turn, 1, 2) @ null, compute_uv=False))


def tick_jacobian(arm: SerialArm, q: FloatArray) -> FloatArray:
    """How far the tool point moves per tick of each joint at ``q (n,)``, ``(3, n)`` (length
    unit per tick of the arm's lattice, linearised)."""
    F = forward_frames(arm, np.asarray(q, dtype=np.float64)[None])
    return np.asarray(jacobian_from_frames(arm, F)[0][:3] * arm.lattice.tick)


def position_jacobian(arm: SerialArm, q: ArrayLike) -> FloatArray:
    """Jacobian of the tool position w.r.t. the joints, shape ``(..., 3, n)``.

    Column ``i`` is ``z_i x (p_tool - p_i)`` for a revolute joint (length unit per rad) and ``z_i``
    for a prismatic one, with ``z_i`` the joint axis in the world.
    """
    return jacobian_from_frames(arm, forward_frames(arm, q))[..., :3, :]


def displacement_bounds(arm: SerialArm) -> FloatArray:
    """Per joint, how far any landmark or link point can move per unit of that joint's motion.

    For a revolute joint this is an upper bound on the distance from the joint axis to any point of
    the arm beyond it (sum of the fixed offsets along the chain; length unit per rad), for a
    prismatic joint it is 1. So a motion ``dq`` moves every point of the arm by at most
    ``sum_i |dq_i| * bound_i`` (for any straight joint-space motion of that size).
    """
    return np.array(
        [
            1.0 if j.kind is JointKind.PRISMATIC else lengths_after(arm, i)
            for i, j in enumerate(arm.joints)
        ]
    )


def lengths_after(arm: SerialArm, i: int) -> float:
    """The lengths of the fixed transforms after joint ``i`` (0-based; -1: all of them) and
    the tool's summed, a distal prismatic joint's larger limit added (it can lengthen the
    chain that far): no point of the arm beyond joint ``i`` is farther than this from joint
    ``i``'s origin (inf where such a prismatic joint is unlimited)."""
    later = arm.joints[i + 1 :]
    offsets = [float(np.linalg.norm(j.T_parent_joint[:3, 3])) for j in later]
    offsets.append(float(np.linalg.norm(arm.T_flange_tool[:3, 3])))
    slides = [
        max(abs(j.limits[0]), abs(j.limits[1])) for j in later if j.kind is JointKind.PRISMATIC
    ]
    return sum(offsets) + sum(slides)


def geometric_jacobian(arm: SerialArm, q: ArrayLike) -> FloatArray:
    """Geometric Jacobian ``[v; w]`` of the tool frame, shape ``(..., 6, n)``.

    Rows 0-2: tool-point velocity (length unit per rad, or unitless for prismatic joints); rows
    3-5: angular velocity (rad per rad, zero for prismatic joints), all in the world frame.
    """
    return jacobian_from_frames(arm, forward_frames(arm, q))


def jacobian_from_frames(arm: SerialArm, frames: FloatArray) -> FloatArray:
    """:func:`geometric_jacobian` from frames already computed by :func:`forward_frames`."""
    if jit.numba_loaded():
        flat = np.ascontiguousarray(frames.reshape(-1, *frames.shape[-3:]), dtype=np.float64)
        chain = compiled_chain(arm)
        out = _jacobian_kernel(flat, chain[2], chain[3])
        return np.asarray(out.reshape(*frames.shape[:-3], 6, arm.n_joints))
    p_tool = frames[..., -1, :3, 3]
    J = np.zeros((*frames.shape[:-3], 6, arm.n_joints))
    for i, joint in enumerate(arm.joints):
        z = frames[..., i + 1, :3, :3] @ joint.axis
        if joint.kind is JointKind.PRISMATIC:
            J[..., :3, i] = z
        else:
            J[..., :3, i] = np.cross(z, p_tool - frames[..., i + 1, :3, 3])
            J[..., 3:, i] = z
    return J


@njit(cache=True)
def _jacobian_kernel(
    frames: np.ndarray, axes: np.ndarray, prismatic: np.ndarray
) -> np.ndarray:  # pragma: no cover - compiled
    """:func:`jacobian_from_frames` of frames ``(N, n + 2, 4, 4)``: ``(N, 6, n)``."""
    n_cfg, n_j = frames.shape[0], axes.shape[0]
    out = np.zeros((n_cfg, 6, n_j))
    for c in range(n_cfg):
        px, py, pz = frames[c, n_j + 1, 0, 3], frames[c, n_j + 1, 1, 3], frames[c, n_j + 1, 2, 3]
        for i in range(n_j):
            z0, z1, z2, v0, v1, v2 = jacobian_column(
                frames[c, i + 1], axes[i], prismatic[i], px, py, pz
            )
            out[c, 0, i], out[c, 1, i], out[c, 2, i] = v0, v1, v2
            if not prismatic[i]:
                out[c, 3, i], out[c, 4, i], out[c, 5, i] = z0, z1, z2
    return out


@njit(cache=True)
def jacobian_column(
    F: np.ndarray, axis: np.ndarray, prismatic: bool, px: float, py: float, pz: float
) -> tuple[float, float, float, float, float, float]:  # pragma: no cover - compiled
    """A joint's axis in the world and the tool point's velocity per unit of it, from its
    frame ``F`` (rows 0-2: rotation | origin) and its own ``axis``, the tool point at
    ``px, py, pz``: ``z x (p - origin)`` for a revolute joint, ``z`` for a prismatic one."""
    z0 = F[0, 0] * axis[0] + F[0, 1] * axis[1] + F[0, 2] * axis[2]
    z1 = F[1, 0] * axis[0] + F[1, 1] * axis[1] + F[1, 2] * axis[2]
    z2 = F[2, 0] * axis[0] + F[2, 1] * axis[1] + F[2, 2] * axis[2]
    if prismatic:
        return z0, z1, z2, z0, z1, z2
    r0, r1, r2 = px - F[0, 3], py - F[1, 3], pz - F[2, 3]
    return z0, z1, z2, z1 * r2 - z2 * r1, z2 * r0 - z0 * r2, z0 * r1 - z1 * r0


def _rotation_taking_z_to(axis: FloatArray) -> FloatArray:
    """A rotation R with ``R @ ez = axis`` (unit axis); the identity for ``axis = ez``."""
    z = np.array([0.0, 0.0, 1.0])
    v = np.cross(z, axis)
    s = float(np.linalg.norm(v))
    c = float(axis @ z)
    if s < 1e-15:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    K = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.asarray(np.eye(3) + K + K @ K * ((1.0 - c) / s**2), dtype=np.float64)


def z_axis_chain(arm: SerialArm) -> FloatArray:
    """The arm as ``C0 Rz(q1) C1 Rz(q2) ... Rz(qn) Cn``, shape ``(n + 1, 4, 4)``.

    Every joint turns about (or slides along) its local z; the constants absorb base, joint
    placements, axis directions and tool, so that the product equals :func:`tool_pose`.
    """
    n = arm.n_joints
    C = np.empty((n + 1, 4, 4))
    Ra = []
    for joint in arm.joints:
        T = np.eye(4)
        T[:3, :3] = _rotation_taking_z_to(joint.axis)
        Ra.append(T)
    C[0] = arm.T_world_base @ arm.joints[0].T_parent_joint @ Ra[0]
    for i in range(1, n):
        C[i] = Ra[i - 1].T @ arm.joints[i].T_parent_joint @ Ra[i]
    C[n] = Ra[n - 1].T @ arm.T_flange_tool
    return C
