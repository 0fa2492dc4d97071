"""Levenberg-Marquardt of :meth:`~armpath.ik.family.GenericFamily.refine`, one compiled loop
(and :func:`project_point`, the tracer's Newton projection onto the tool point).

The numpy form steps every row of a batch together, a forward pass, a Jacobian and a batched
solve an iteration, and costs a fraction of a millisecond an iteration in Python's overhead
however few rows it holds; a 7-joint arm's trace calls it thousands of times on a handful of
rows (the track cell's: 32 s of its 61). Rows are independent of each other, so this kernel
takes each row through its iterations on its own: the same damped steps, acceptance, damping
schedule, limits and stop rules, the normal equations solved by Cholesky (``J^T J + lambda I``
is positive definite).

Modes: the tool point alone (0), with each row's full tool rotation (1), or with each row's
direction of the approach axis (2). An orientation rule (a cone) stays with the numpy form.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from armpath.jit import njit, parallel_kernel_lock, prange, threads_pay_off
from armpath.kinematics import _chain_into, jacobian_column, landmark_scratch

POSITION, ROTATION, AXIS = 0, 1, 2
#: Rows of a batch from which it is refined on numba's threads.
PARALLEL_ROWS = 32


@njit(cache=True)
def _residual(
    q: np.ndarray,
    mode: int,
    target: np.ndarray,
    rot: np.ndarray,
    axis_goal: np.ndarray,
    approach: np.ndarray,
    size: float,
    T_world_base: np.ndarray,
    T_parent_joint: np.ndarray,
    axes: np.ndarray,
    prismatic: np.ndarray,
    T_flange_tool: np.ndarray,
    scratch: np.ndarray,
    err: np.ndarray,
    jac: np.ndarray,
) -> float:  # pragma: no cover - compiled
    """The residual ``err`` and its Jacobian ``jac`` at ``q`` (as the numpy form's
    ``errors``); returns the squared residual."""
    n = q.shape[0]
    pos = _chain_into(q, T_world_base, T_parent_joint, axes, prismatic, T_flange_tool, scratch)
    tool = pos[n + 1]
    px, py, pz = tool[0, 3], tool[1, 3], tool[2, 3]
    err[0] = (target[0] - px) / size
    err[1] = (target[1] - py) / size
    err[2] = (target[2] - pz) / size
    # the approach axis in the world (mode 2)
    a0 = tool[0, 0] * approach[0] + tool[0, 1] * approach[1] + tool[0, 2] * approach[2]
    a1 = tool[1, 0] * approach[0] + tool[1, 1] * approach[1] + tool[1, 2] * approach[2]
    a2 = tool[2, 0] * approach[0] + tool[2, 1] * approach[1] + tool[2, 2] * approach[2]
    for i in range(n):
        z0, z1, z2, v0, v1, v2 = jacobian_column(pos[i + 1], axes[i], prismatic[i], px, py, pz)
        jac[0, i], jac[1, i], jac[2, i] = v0 / size, v1 / size, v2 / size
        if prismatic[i]:
            z0 = z1 = z2 = 0.0
        if mode == 1:
            jac[3, i], jac[4, i], jac[5, i] = z0, z1, z2
        elif mode == 2:
            # d(axis) = w x axis = -[axis]x w
            jac[3, i] = -(a1 * z2 - a2 * z1)
            jac[4, i] = -(a2 * z0 - a0 * z2)
            jac[5, i] = -(a0 * z1 - a1 * z0)
    if mode == 1:
        e0 = e1 = e2 = 0.0
        for c in range(3):  # 0.5 * sum over columns of R[:, c] x R_goal[:, c]
            r0, r1, r2 = tool[0, c], tool[1, c], tool[2, c]
            g0, g1, g2 = rot[0, c], rot[1, c], rot[2, c]
            e0 += r1 * g2 - r2 * g1
            e1 += r2 * g0 - r0 * g2
            e2 += r0 * g1 - r1 * g0
        err[3], err[4], err[5] = 0.5 * e0, 0.5 * e1, 0.5 * e2
    elif mode == 2:
        err[3], err[4], err[5] = axis_goal[0] - a0, axis_goal[1] - a1, axis_goal[2] - a2
    total = 0.0
    for k in range(err.shape[0]):
        total += err[k] * err[k]
    return total


@njit(cache=True)
def _damped_step(
    jac: np.ndarray, err: np.ndarray, scale: np.ndarray, lam: float, A: np.ndarray, out: np.ndarray
) -> None:  # pragma: no cover - compiled
    """``out = scale * solve(Js^T Js + lam I, Js^T err)`` with ``Js = jac * scale`` (columns),
    by Cholesky in ``A``."""
    m, n = jac.shape
    for i in range(n):
        s = 0.0
        for k in range(m):
            s += jac[k, i] * scale[i] * err[k]
        out[i] = s
        for j in range(i + 1):
            s = 0.0
            for k in range(m):
                s += jac[k, i] * jac[k, j]
            A[i, j] = s * scale[i] * scale[j]
        A[i, i] += lam
    for j in range(n):  # Cholesky, lower triangle in place
        s = A[j, j]
        for k in range(j):
            s -= A[j, k] * A[j, k]
        d = np.sqrt(s)
        A[j, j] = d
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s -= A[i, k] * A[j, k]
            A[i, j] = s / d
    for i in range(n):  # forward
        s = out[i]
        for k in range(i):
            s -= A[i, k] * out[k]
        out[i] = s / A[i, i]
    for i in range(n - 1, -1, -1):  # backward
        s = out[i]
        for k in range(i + 1, n):
            s -= A[k, i] * out[k]
        out[i] = s / A[i, i]
    for i in range(n):
        out[i] *= scale[i]


@njit(cache=True)
def _refine_row(
    r: int,
    q: np.ndarray,
    iterations: int,
    mode: int,
    target: np.ndarray,
    rot_rows: np.ndarray,
    axis_rows: np.ndarray,
    approach: np.ndarray,
    lo_rows: np.ndarray,
    hi_rows: np.ndarray,
    scale_rows: np.ndarray,
    size: float,
    on_target: float,
    stall_window: int,
    stall_fraction: float,
    T_world_base: np.ndarray,
    T_parent_joint: np.ndarray,
    axes: np.ndarray,
    prismatic: np.ndarray,
    T_flange_tool: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """Row ``r`` of ``q`` through its iterations, in place (see :func:`refine_rows_serial`),
    with its own working arrays (a thread's rows share none)."""
    n = q.shape[1]
    m = 3 if mode == 0 else 6
    scratch = landmark_scratch(n)
    err = np.empty(m)
    jac = np.empty((m, n))
    err_new = np.empty(m)
    jac_new = np.empty((m, n))
    A = np.empty((n, n))
    dq = np.empty(n)
    q_new = np.empty(n)
    cost = _residual(
        q[r], mode, target, rot_rows[r], axis_rows[r], approach, size,
        T_world_base, T_parent_joint, axes, prismatic, T_flange_tool, scratch, err, jac,
    )  # fmt: skip
    if cost < on_target:
        return
    lam = 1e-3
    window_cost = cost
    for step in range(iterations):
        if step > 0 and step % stall_window == 0:
            if not cost < (1.0 - stall_fraction) * window_cost:
                break
            window_cost = cost
        _damped_step(jac, err, scale_rows[r], lam, A, dq)
        for i in range(n):
            v = q[r, i] + dq[i]
            q_new[i] = min(max(v, lo_rows[r, i]), hi_rows[r, i])
        cost_new = _residual(
            q_new, mode, target, rot_rows[r], axis_rows[r], approach, size,
            T_world_base, T_parent_joint, axes, prismatic, T_flange_tool, scratch,
            err_new, jac_new,
        )  # fmt: skip
        if cost_new < cost:
            for i in range(n):
                q[r, i] = q_new[i]
            for k in range(m):
                err[k] = err_new[k]
                for i in range(n):
                    jac[k, i] = jac_new[k, i]
            cost = cost_new
            lam = max(lam / 5.0, 1e-12)
        else:
            lam = min(lam * 5.0, 1e8)
        if cost < on_target:
            break


@njit(cache=True)
def refine_rows_serial(
    q: np.ndarray,
    iterations: int,
    mode: int,
    target: np.ndarray,
    rot_rows: np.ndarray,
    axis_rows: np.ndarray,
    approach: np.ndarray,
    lo_rows: np.ndarray,
    hi_rows: np.ndarray,
    scale_rows: np.ndarray,
    size: float,
    on_target: float,
    stall_window: int,
    stall_fraction: float,
    T_world_base: np.ndarray,
    T_parent_joint: np.ndarray,
    axes: np.ndarray,
    prismatic: np.ndarray,
    T_flange_tool: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """Refine every row of ``q (M, n)`` in place (see the module): ``rot_rows (M, 3, 3)``
    (mode 1) or ``axis_rows (M, 3)`` (mode 2) each row's goal, ``lo_rows``/``hi_rows`` its
    box, ``scale_rows`` its damping scale (0: the joint held)."""
    for r in range(q.shape[0]):
        _refine_row(
            r, q, iterations, mode, target, rot_rows, axis_rows, approach, lo_rows, hi_rows,
            scale_rows, size, on_target, stall_window, stall_fraction,
            T_world_base, T_parent_joint, axes, prismatic, T_flange_tool,
        )  # fmt: skip


@njit(cache=True, parallel=True)
def refine_rows_parallel(
    q: np.ndarray,
    iterations: int,
    mode: int,
    target: np.ndarray,
    rot_rows: np.ndarray,
    axis_rows: np.ndarray,
    approach: np.ndarray,
    lo_rows: np.ndarray,
    hi_rows: np.ndarray,
    scale_rows: np.ndarray,
    size: float,
    on_target: float,
    stall_window: int,
    stall_fraction: float,
    T_world_base: np.ndarray,
    T_parent_joint: np.ndarray,
    axes: np.ndarray,
    prismatic: np.ndarray,
    T_flange_tool: np.ndarray,
) -> None:  # pragma: no cover - compiled
    """:func:`refine_rows_serial` with the rows on numba's threads (each row's steps are its
    own, so the result is the same)."""
    for r in prange(q.shape[0]):
        _refine_row(
            r, q, iterations, mode, target, rot_rows, axis_rows, approach, lo_rows, hi_rows,
            scale_rows, size, on_target, stall_window, stall_fraction,
            T_world_base, T_parent_joint, axes, prismatic, T_flange_tool,
        )  # fmt: skip


@njit(cache=True)
def project_point(
    q: np.ndarray,
    target: np.ndarray,
    moving: np.ndarray,
    iterations: int,
    T_world_base: np.ndarray,
    T_parent_joint: np.ndarray,
    axes: np.ndarray,
    prismatic: np.ndarray,
    T_flange_tool: np.ndarray,
) -> np.ndarray:  # pragma: no cover - compiled
    """A configuration near ``q`` (not changed) with the tool point at ``target``: at most
    ``iterations`` minimum-norm Newton steps (the pseudo-inverse of the tool point's Jacobian
    in the joints ``moving``, the others held), stopping within 1e-9 of it."""
    n = q.shape[0]
    out = q.copy()
    scratch = landmark_scratch(n)
    k = 0
    for i in range(n):
        if moving[i]:
            k += 1
    J = np.empty((3, k))
    e = np.empty(3)
    for _ in range(iterations):
        pos = _chain_into(
            out, T_world_base, T_parent_joint, axes, prismatic, T_flange_tool, scratch
        )
        tool = pos[n + 1]
        px, py, pz = tool[0, 3], tool[1, 3], tool[2, 3]
        e[0], e[1], e[2] = target[0] - px, target[1] - py, target[2] - pz
        if np.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) < 1e-9:
            break
        c = 0
        for i in range(n):
            if moving[i]:
                _, _, _, v0, v1, v2 = jacobian_column(pos[i + 1], axes[i], prismatic[i], px, py, pz)
                J[0, c], J[1, c], J[2, c] = v0, v1, v2
                c += 1
        step = np.linalg.pinv(J) @ e
        c = 0
        for i in range(n):
            if moving[i]:
                out[i] += step[c]
                c += 1
    return out


def refine_rows(q: np.ndarray, *args: Any) -> None:
    """:func:`refine_rows_serial` (same arguments), on numba's threads where the rows are many
    enough to pay for them (:func:`~armpath.jit.threads_pay_off`)."""
    if not threads_pay_off(q.shape[0], PARALLEL_ROWS):
        refine_rows_serial(q, *args)
        return
    with parallel_kernel_lock:
        refine_rows_parallel(q, *args)


__all__ = [
    "AXIS",
    "POSITION",
    "ROTATION",
    "project_point",
    "refine_rows",
    "refine_rows_parallel",
    "refine_rows_serial",
]
