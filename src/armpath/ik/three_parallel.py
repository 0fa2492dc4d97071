"""Closed-form IK (all solutions) of arms with three consecutive parallel axes (UR type).

Applies to six-revolute arms whose axes 2, 3, 4 are parallel and whose axes 5, 6 meet (UR3/5/10,
many cobots), or, read from the tool backwards, whose axes 3, 4, 5 are parallel and axes 1, 2
meet. With ``h`` the common direction of the parallel axes, in the frame of joint 1:

1. The parallel joints move the arm in planes normal to ``h``, so the height ``h . P`` of the
   point ``P`` where axes 5 and 6 meet is a constant of the arm. The target fixes ``P``; rotating
   it back by ``q1`` must give that height: ``a cos q1 + b sin q1 = c``, two roots.
2. The parallel joints turn ``h`` into itself, so ``h`` seen from the tool,
   ``m = (Rz(-q1) R)^T h``, must equal what joints 5 and 6 make of the arm's constant
   ``g = R4^T (R1 R2 R3)^T h``: ``Rz(q6) m = R5^T Rz(-q5) g``. Its component along axis 6 is one
   equation in ``q5`` (two roots); then ``q6`` follows.
3. The rest is a rotation about ``h`` by ``q2 +- q3 +- q4`` (signs from the axes' senses) and a
   planar two-link problem for the origin of joint 4's frame: the law of cosines gives ``q3``
   (two roots), then ``q2``, and ``q4`` closes the angle.

Up to 8 solutions. Each gets Newton steps on the full pose and is verified by forward
kinematics. Poses where ``P`` lies on axis 1 or axis 6 is parallel to ``h`` are one-parameter
families: one member is returned, flagged near-singular.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from armpath.errors import InvalidInputError
from armpath.ik.compiled import CompiledSolver, KernelOutput, padded_outputs
from armpath.ik.kernels import keep_solution, newton_polish, sort_solutions
from armpath.ik.result import chain_length_scale
from armpath.jit import njit, prange, threads_pay_off
from armpath.kinematics import z_axis_chain
from armpath.model.serial_arm import JointKind, SerialArm

FloatArray = NDArray[np.float64]
_CAP = 16
_ALL_REVOLUTE = np.zeros(6, dtype=np.bool_)


def _axes(C: FloatArray) -> list[tuple[FloatArray, FloatArray]]:
    """(point, unit direction) of each joint axis at zero joint values, in the base frame."""
    F = C[0].copy()
    out = []
    for i in range(6):
        out.append((F[:3, 3].copy(), F[:3, 2].copy()))
        F = F @ C[i + 1]
    return out


def _rigid_inverse(T: FloatArray) -> FloatArray:
    out = np.eye(4)
    out[:3, :3] = T[:3, :3].T
    out[:3, 3] = -T[:3, :3].T @ T[:3, 3]
    return out


def _layout_fits(C: FloatArray, tol: float) -> bool:
    """Axes 2, 3, 4 parallel, axes 5 and 6 meeting, and none of the arm's degenerate cases
    (axis 1 or 5 parallel to the others, zero link lengths between the parallel axes)."""
    axes = _axes(C)
    scale = max(1.0, float(np.max(np.abs(C[:, :3, 3]))))
    (_, z1), (_, z2), (_, z3), (_, z4) = axes[0], axes[1], axes[2], axes[3]
    (o5, z5), (o6, z6) = axes[4], axes[5]
    if np.linalg.norm(np.cross(z2, z3)) > tol or np.linalg.norm(np.cross(z2, z4)) > tol:
        return False
    n = np.cross(z5, z6)
    if np.linalg.norm(n) < 1e-6 or abs((o6 - o5) @ n) / np.linalg.norm(n) > tol * scale:
        return False
    if np.linalg.norm(np.cross(z1, z2)) < 1e-6 or np.linalg.norm(np.cross(z5, z2)) < 1e-6:
        return False
    t2, t3 = C[2, :2, 3], C[3, :2, 3]  # link lengths in the plane of the parallel axes
    return bool(np.linalg.norm(t2) > 1e-9 * scale and np.linalg.norm(t3) > 1e-9 * scale)


def _reversed_chain(C: FloatArray) -> FloatArray:
    """The chain read from the tool: ``T^-1 = C'0 Z(-q6) C'1 ... Z(-q1) C'6``, C'k = C(6-k)^-1."""
    return np.array([_rigid_inverse(C[6 - k]) for k in range(7)])


def three_parallel_layout(arm: SerialArm, tol: float = 1e-9) -> str | None:
    """``"forward"`` (axes 2-4 parallel, 5 and 6 meet), ``"reversed"`` (axes 3-5 parallel, 1 and
    2 meet) or None when the closed form does not apply."""
    if arm.n_joints != 6 or any(j.kind is not JointKind.REVOLUTE for j in arm.joints):
        return None
    C = z_axis_chain(arm)
    if _layout_fits(C, tol):
        return "forward"
    if _layout_fits(_reversed_chain(C), tol):
        return "reversed"
    return None


@njit(cache=True)
def _two_roots(a: float, b: float, c: float, out: FloatArray) -> tuple[int, bool]:
    """Roots of ``a cos x + b sin x = c`` into ``out``; (count, near-double)."""
    amp = np.hypot(a, b)
    if amp == 0.0 or abs(c) > amp * (1.0 + 1e-9):
        return 0, False
    base = np.arctan2(b, a)
    off = np.arccos(min(1.0, max(-1.0, c / amp)))
    out[0] = base + off
    out[1] = base - off
    return 2, off < 1e-6


@njit(cache=True)
def _through_wrist(
    M: FloatArray,
    C5: FloatArray,
    c5: float,
    s5: float,
    c6: float,
    s6: float,
    x0: float,
    x1: float,
    x2: float,
    with_t5: float,
) -> tuple[float, float, float]:
    """``M Rz(-q6) R5^T (Rz(-q5) x + with_t5 * t5)``: a vector (0) or point (1) of joint 5's
    frame carried out to the frame of joint 1."""
    u0 = c5 * x0 + s5 * x1 + with_t5 * C5[0, 3]
    u1 = -s5 * x0 + c5 * x1 + with_t5 * C5[1, 3]
    u2 = x2 + with_t5 * C5[2, 3]
    w0 = C5[0, 0] * u0 + C5[1, 0] * u1 + C5[2, 0] * u2
    w1 = C5[0, 1] * u0 + C5[1, 1] * u1 + C5[2, 1] * u2
    w2 = C5[0, 2] * u0 + C5[1, 2] * u1 + C5[2, 2] * u2
    w0, w1 = c6 * w0 + s6 * w1, -s6 * w0 + c6 * w1
    return (
        M[0, 0] * w0 + M[0, 1] * w1 + M[0, 2] * w2,
        M[1, 0] * w0 + M[1, 1] * w1 + M[1, 2] * w2,
        M[2, 0] * w0 + M[2, 1] * w1 + M[2, 2] * w2,
    )


@njit(cache=True)
def _solve_pose(
    Cs: FloatArray,
    Cf: FloatArray,
    geo: FloatArray,
    reverse: bool,
    T: FloatArray,
    accept: float,
    out_q: FloatArray,
    out_res: FloatArray,
    out_flags: NDArray[np.int64],
) -> int:
    """All solutions of one pose (lengths scaled); ``Cs`` is the chain solved (the arm's, or
    reversed), ``Cf`` the arm's own for the Newton polish. ``geo``: h (3), sigma3, sigma4, s6,
    height k, g (3), e1 (3), R4^T G^T e1 (3), R4^T t4 (3)."""
    # Target of the solved chain, then T' = C0^-1 T C6^-1 (rotation Rp, translation pp).
    Rt = np.empty((3, 3))
    pt = np.empty(3)
    if reverse:
        for i in range(3):
            for j in range(3):
                Rt[i, j] = T[j, i]
        for i in range(3):
            pt[i] = -(Rt[i, 0] * T[0, 3] + Rt[i, 1] * T[1, 3] + Rt[i, 2] * T[2, 3])
    else:
        for i in range(3):
            for j in range(3):
                Rt[i, j] = T[i, j]
            pt[i] = T[i, 3]
    C0, C1, C2, C3, C5, C6 = Cs[0], Cs[1], Cs[2], Cs[3], Cs[5], Cs[6]
    R = np.empty((3, 3))  # C0^T Rt
    p = np.empty(3)
    for i in range(3):
        for j in range(3):
            R[i, j] = C0[0, i] * Rt[0, j] + C0[1, i] * Rt[1, j] + C0[2, i] * Rt[2, j]
        p[i] = (
            C0[0, i] * (pt[0] - C0[0, 3])
            + C0[1, i] * (pt[1] - C0[1, 3])
            + C0[2, i] * (pt[2] - C0[2, 3])
        )
    Rp = np.empty((3, 3))  # R C6^T
    pp = np.empty(3)
    for i in range(3):
        for j in range(3):
            Rp[i, j] = R[i, 0] * C6[j, 0] + R[i, 1] * C6[j, 1] + R[i, 2] * C6[j, 2]
    for i in range(3):
        pp[i] = p[i] - (Rp[i, 0] * C6[0, 3] + Rp[i, 1] * C6[1, 3] + Rp[i, 2] * C6[2, 3])
    h0, h1, h2 = geo[0], geo[1], geo[2]
    sig3, sig4, s6, k = geo[3], geo[4], geo[5], geo[6]
    g0, g1, g2 = geo[7], geo[8], geo[9]
    e0, e1, e2 = geo[10], geo[11], geo[12]
    f0, f1, f2 = h1 * e2 - h2 * e1, h2 * e0 - h0 * e2, h0 * e1 - h1 * e0  # h x e
    # P, where axes 5 and 6 meet, from the target.
    P0 = Rp[0, 2] * s6 + pp[0]
    P1 = Rp[1, 2] * s6 + pp[1]
    P2 = Rp[2, 2] * s6 + pp[2]
    size = 1.0 + abs(P0) + abs(P1) + abs(P2)
    q1s = np.empty(2)
    q5s = np.empty(2)
    q3s = np.empty(2)
    a = h0 * P0 + h1 * P1
    b = h0 * P1 - h1 * P0
    c = k - h2 * P2
    flag1 = 0
    if np.hypot(a, b) < 1e-9 * size:
        if abs(c) > 1e-9 * size:
            return 0
        n1, dbl1 = 1, False
        q1s[0] = 0.0
        flag1 = 2  # P on axis 1: q1 is free
    else:
        n1, dbl1 = _two_roots(a, b, c, q1s)
    M = np.empty((3, 3))
    q = np.empty(6)
    qf = np.empty(6)
    scratch = np.empty((3, 6, 6))
    r0, r1, r2 = C5[0, 2], C5[1, 2], C5[2, 2]  # axis 6 in the frame of joint 5
    kept = 0
    for i1 in range(n1):
        q1 = q1s[i1]
        cq, sq = np.cos(q1), np.sin(q1)
        for j in range(3):
            M[0, j] = cq * Rp[0, j] + sq * Rp[1, j]
            M[1, j] = -sq * Rp[0, j] + cq * Rp[1, j]
            M[2, j] = Rp[2, j]
        o0 = cq * pp[0] + sq * pp[1]
        o1 = -sq * pp[0] + cq * pp[1]
        o2 = pp[2]
        m0 = M[0, 0] * h0 + M[1, 0] * h1 + M[2, 0] * h2
        m1 = M[0, 1] * h0 + M[1, 1] * h1 + M[2, 1] * h2
        m2 = M[0, 2] * h0 + M[1, 2] * h1 + M[2, 2] * h2
        n5, dbl5 = _two_roots(r0 * g0 + r1 * g1, r0 * g1 - r1 * g0, m2 - r2 * g2, q5s)
        for i5 in range(n5):
            q5 = q5s[i5]
            c5, s5 = np.cos(q5), np.sin(q5)
            z0, z1 = c5 * g0 + s5 * g1, -s5 * g0 + c5 * g1
            y0 = C5[0, 0] * z0 + C5[1, 0] * z1 + C5[2, 0] * g2
            y1 = C5[0, 1] * z0 + C5[1, 1] * z1 + C5[2, 1] * g2
            flag6 = 0
            if np.hypot(m0, m1) < 1e-9:
                q6 = 0.0
                flag6 = 2  # axis 6 parallel to the others: q6 trades against q2..q4
            else:
                q6 = np.arctan2(y1, y0) - np.arctan2(m1, m0)
            c6, s6_ = np.cos(q6), np.sin(q6)
            # Angle about h: N e1 with N = M Rz(-q6) R5^T Rz(-q5) R4^T G^T.
            n0, n1_, n2 = _through_wrist(M, C5, c5, s5, c6, s6_, geo[13], geo[14], geo[15], 0.0)
            theta = np.arctan2(f0 * n0 + f1 * n1_ + f2 * n2, e0 * n0 + e1 * n1_ + e2 * n2)
            # Origin of joint 4's frame: o - M Rz(-q6) R5^T (Rz(-q5) R4^T t4 + t5).
            d0, d1, d2 = _through_wrist(M, C5, c5, s5, c6, s6_, geo[16], geo[17], geo[18], 1.0)
            x0 = o0 - d0 - C1[0, 3]
            x1 = o1 - d1 - C1[1, 3]
            x2 = o2 - d2 - C1[2, 3]
            # ... in the frame of joint 2: y = C1^-1 o = Z(q2) (C2 Z(q3) t3).
            y0 = C1[0, 0] * x0 + C1[1, 0] * x1 + C1[2, 0] * x2
            y1 = C1[0, 1] * x0 + C1[1, 1] * x1 + C1[2, 1] * x2
            # Law of cosines in the plane: |Q Rz(q3) t3 + t2|^2 = |y|^2 (Q = R2's plane block).
            a0, a1 = C3[0, 3], C3[1, 3]
            t20, t21 = C2[0, 3], C2[1, 3]
            v0 = C2[0, 0] * t20 + C2[1, 0] * t21
            v1 = C2[0, 1] * t20 + C2[1, 1] * t21
            rhs = 0.5 * (y0 * y0 + y1 * y1 - a0 * a0 - a1 * a1 - t20 * t20 - t21 * t21)
            n3, dbl3 = _two_roots(v0 * a0 + v1 * a1, v1 * a0 - v0 * a1, rhs, q3s)
            for i3 in range(n3):
                q3 = q3s[i3]
                c3, s3 = np.cos(q3), np.sin(q3)
                b0, b1 = c3 * a0 - s3 * a1, s3 * a0 + c3 * a1
                wx = C2[0, 0] * b0 + C2[0, 1] * b1 + t20
                wy = C2[1, 0] * b0 + C2[1, 1] * b1 + t21
                flag2 = 0
                if np.hypot(y0, y1) < 1e-9:
                    q2 = 0.0
                    flag2 = 2
                else:
                    q2 = np.arctan2(y1, y0) - np.arctan2(wy, wx)
                q4 = sig4 * (theta - q2 - sig3 * q3)
                q[0], q[1], q[2], q[3], q[4], q[5] = q1, q2, q3, q4, q5, q6
                for i in range(6):
                    qf[i] = -q[5 - i] if reverse else q[i]
                pos, rot, jr = newton_polish(Cf, _ALL_REVOLUTE, T, qf, 2, scratch)
                if not (pos <= accept and rot <= accept):
                    continue
                double = dbl1 or dbl5 or dbl3
                flags = flag1 | flag6 | flag2 | (2 if jr < 1e-6 else 0) | (1 if double else 0)
                kept, _ = keep_solution(
                    qf, _ALL_REVOLUTE, pos, rot, flags, out_q, out_res, out_flags, kept
                )
    sort_solutions(out_q, out_res, out_flags, kept)
    return kept


@njit(cache=True)
def _solve_serial(
    Cs: FloatArray,
    Cf: FloatArray,
    geo: FloatArray,
    reverse: bool,
    Ts: FloatArray,
    accept: float,
    out_q: FloatArray,
    out_res: FloatArray,
    out_flags: NDArray[np.int64],
    out_count: NDArray[np.int64],
) -> None:
    for n in range(Ts.shape[0]):
        out_count[n] = _solve_pose(
            Cs, Cf, geo, reverse, Ts[n], accept, out_q[n], out_res[n], out_flags[n]
        )


@njit(cache=True, parallel=True)
def _solve_parallel(
    Cs: FloatArray,
    Cf: FloatArray,
    geo: FloatArray,
    reverse: bool,
    Ts: FloatArray,
    accept: float,
    out_q: FloatArray,
    out_res: FloatArray,
    out_flags: NDArray[np.int64],
    out_count: NDArray[np.int64],
) -> None:
    for n in prange(Ts.shape[0]):
        out_count[n] = _solve_pose(
            Cs, Cf, geo, reverse, Ts[n], accept, out_q[n], out_res[n], out_flags[n]
        )


class ThreeParallelSolver(CompiledSolver):
    """Closed-form IK (all solutions) of a 6R arm with axes 2-4 parallel and axes 5, 6 meeting
    (or, reversed, axes 3-5 parallel and axes 1, 2 meeting)."""

    def __init__(self, arm: SerialArm, *, accept: float = 1e-8):
        layout = three_parallel_layout(arm)
        if layout is None:
            raise InvalidInputError(
                f"model {arm.name!r}: the three-parallel-axes solver needs six revolute joints "
                "with axes 2-4 parallel and axes 5, 6 meeting (or axes 3-5 parallel and 1, 2 "
                "meeting)"
            )
        self.arm = arm
        self.layout = layout
        self.method_names = ("three-parallel" + (" (reversed)" if layout == "reversed" else ""),)
        C = z_axis_chain(arm)
        self.length_scale = chain_length_scale(C)
        C[:, :3, 3] /= self.length_scale
        self._Cf = np.ascontiguousarray(C)
        Cs = _reversed_chain(C) if layout == "reversed" else C
        self._Cs = np.ascontiguousarray(Cs)
        self._reverse = layout == "reversed"
        R1, R2, R3, R4 = Cs[1, :3, :3], Cs[2, :3, :3], Cs[3, :3, :3], Cs[4, :3, :3]
        h = R1[:, 2]
        sig3 = float(np.sign((R1 @ R2)[:, 2] @ h))
        sig4 = float(np.sign((R1 @ R2 @ R3)[:, 2] @ h))
        # Where axes 5 and 6 meet: (0, 0, s6) after Z(q6), (0, 0, s5) after Z(q5).
        t5, z6 = Cs[5, :3, 3], Cs[5, :3, 2]
        s6 = float(-(t5 @ z6 - t5[2] * z6[2]) / (1.0 - z6[2] ** 2))
        P5 = Cs[5] @ np.array([0.0, 0.0, s6, 1.0])
        P1 = Cs[1] @ Cs[2] @ Cs[3] @ Cs[4] @ P5  # frame 1, all joints at zero
        G = R1 @ R2 @ R3
        g = R4.T @ G.T @ h
        e1 = np.cross(h, [1.0, 0.0, 0.0])
        if np.linalg.norm(e1) < 0.5:
            e1 = np.cross(h, [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        self._geo = np.concatenate(
            [h, [sig3, sig4, s6, float(h @ P1[:3])], g, e1, R4.T @ G.T @ e1, R4.T @ Cs[4, :3, 3]]
        )
        self.accept = accept

    def _run(self, T: FloatArray) -> KernelOutput:
        N = T.shape[0]
        q, res, flags, count = padded_outputs(N, _CAP)
        kernel = _solve_parallel if threads_pay_off(N, 64) else _solve_serial
        kernel(self._Cs, self._Cf, self._geo, self._reverse, T, self.accept, q, res, flags, count)
        zero = np.zeros(N, dtype=np.int64)
        return q, res, flags, count, zero, zero
