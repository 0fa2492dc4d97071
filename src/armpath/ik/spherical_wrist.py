"""Closed-form IK of arms with a spherical wrist (Pieper): every solution, no iteration.

Applies when the last three joint axes meet in one point (the wrist centre) and the first three
joints are revolute, revolute, revolute-or-prismatic (the seed arm, seed 003's RRP welder,
PUMA 560, most industrial 6-axis arms). The pose splits in two:

* **Position** of the wrist centre from joints 1-3. Rotating about axis 1 keeps the squared
  distance and the height along axis 1, so ``F1(q2, q3) = |v|^2`` and ``F2(q2, q3) = v_z`` must
  match the target's. Both are of degree one in ``cos q2, sin q2``; eliminating them leaves one
  equation in ``q3``: a trigonometric polynomial of degree 4 (revolute) or a polynomial of
  degree 4 (prismatic), whose real roots give up to four positions. Coefficients are measured
  on small grids, not derived symbolically.
* **Orientation** from joints 4-6 with any twists (the oblique wrists of painting robots too):
  the direction of axis 6 fixes ``q4`` through ``a cos q4 + b sin q4 = c`` (two roots), then
  ``q5`` and ``q6`` follow in closed form.

Every candidate gets two Newton steps on the full pose and is verified by forward kinematics.
A wrist centre on axis 1 or aligned axes 4 and 6 are one-parameter families: one member is
returned, flagged near-singular.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from armpath.errors import InvalidInputError
from armpath.ik.general6r import (
    _SCAN,
    _SCAN_COS,
    _SCAN_SIN,
    _lu_solve,
    _mm,
    _trig_roots,
    _wrap,
    fk_error_jacobian,
    prepare_targets,
)
from armpath.ik.result import IKResult, chain_length_scale, solved_poses
from armpath.kinematics import z_axis_chain
from armpath.model.serial_arm import JointKind, SerialArm

FloatArray = NDArray[np.float64]
_CAP = 16


@njit(cache=True)
def _motion(T: FloatArray, value: float, prismatic: bool) -> FloatArray:
    """``T @ Rz(value)`` or ``T @ Tz(value)``."""
    out = T.copy()
    if prismatic:
        for i in range(3):
            out[i, 3] += T[i, 2] * value
        return out
    c, s = np.cos(value), np.sin(value)
    for i in range(3):
        out[i, 0] = T[i, 0] * c + T[i, 1] * s
        out[i, 1] = -T[i, 0] * s + T[i, 1] * c
    return out


@njit(cache=True)
def _mv(R: FloatArray, x: FloatArray) -> FloatArray:
    """3x3 (any layout) times a 3-vector, without BLAS."""
    out = np.empty(3)
    for i in range(3):
        out[i] = R[i, 0] * x[0] + R[i, 1] * x[1] + R[i, 2] * x[2]
    return out


@njit(cache=True)
def _m3(A: FloatArray, B: FloatArray) -> FloatArray:
    """3x3 times 3x3 (any layout), without BLAS."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]
    return out


@njit(cache=True)
def _polish(
    C: FloatArray, prismatic: NDArray[np.bool_], T: FloatArray, q: FloatArray, steps: int
) -> tuple[float, float, float]:
    """Newton steps on the full pose; (position error, rotation error, Jacobian ratio)."""
    err = np.empty(6)
    J = np.empty((6, 6))
    fk_error_jacobian(C, prismatic, q, T, err, J)
    for _ in range(steps):
        if np.sqrt(np.sum(err * err)) < 1e-13:
            break  # closed-form candidates are usually exact already
        dq, det = _lu_solve(J.copy(), err.copy())
        if det == 0.0:
            break
        q += dq
        fk_error_jacobian(C, prismatic, q, T, err, J)
    norms = 1.0
    for i in range(6):
        norms *= max(np.sqrt(np.sum(J[:, i] * J[:, i])), 1e-300)
    ratio = abs(_lu_solve(J.copy(), err.copy())[1]) / norms
    pos = np.sqrt(err[0] ** 2 + err[1] ** 2 + err[2] ** 2)
    rot = np.sqrt(err[3] ** 2 + err[4] ** 2 + err[5] ** 2)
    return pos, rot, ratio


@njit(cache=True)
def _v(
    C: FloatArray, prismatic: NDArray[np.bool_], q2: float, q3: float, c4: FloatArray, h: float
) -> FloatArray:
    """Wrist centre in the frame of joint 1 before its rotation (C1 Z2 C2 Z3 C3 c4), measured
    from the point ``(0, 0, h)`` of axis 1 nearest to axis 2."""
    A = _mm(_motion(C[1], q2, prismatic[1]), C[2])
    A = _mm(_motion(A, q3, prismatic[2]), C[3])
    out = _mv(A[:3, :3], c4) + A[:3, 3]
    out[2] -= h
    return out


@njit(cache=True)
def _abc(
    C: FloatArray,
    prismatic: NDArray[np.bool_],
    q3: float,
    c4: FloatArray,
    h: float,
    t: FloatArray,
) -> tuple[float, float, float, float, float, float]:
    """Coefficients of F1 - |t|^2 and F2 - t_z in (cos q2, sin q2, 1) at joint value q3."""
    f = np.empty((3, 2))
    for i in range(3):
        q2 = i * 2.0 * np.pi / 3.0
        v = _v(C, prismatic, q2, q3, c4, h)
        f[i, 0] = np.sum(v * v) - np.sum(t * t)
        f[i, 1] = v[2] - t[2]
    # Exact inversion of the 3-point grid {0, 120, 240} deg for {1, cos, sin}.
    out = np.empty((2, 3))
    for k in range(2):
        c0 = (f[0, k] + f[1, k] + f[2, k]) / 3.0
        ca = (2.0 * f[0, k] - f[1, k] - f[2, k]) / 3.0
        sb = (f[1, k] - f[2, k]) / np.sqrt(3.0)
        out[k, 0] = ca
        out[k, 1] = sb
        out[k, 2] = c0
    return out[0, 0], out[0, 1], out[0, 2], out[1, 0], out[1, 1], out[1, 2]


@njit(cache=True)
def _residual(
    C: FloatArray,
    prismatic: NDArray[np.bool_],
    q3: float,
    c4: FloatArray,
    h: float,
    t: FloatArray,
) -> float:
    a1, b1, c1, a2, b2, c2 = _abc(C, prismatic, q3, c4, h, t)
    d = a1 * b2 - a2 * b1
    x = b1 * c2 - b2 * c1
    y = c1 * a2 - c2 * a1
    return x * x + y * y - d * d


@njit(cache=True)
def _poly_real_roots(coef: FloatArray, lo: float, hi: float, out: FloatArray) -> int:
    """Real roots in [lo, hi] of the polynomial sum coef[k] x^k, by bisection on
    the monotone pieces between the roots of its derivative (found the same way)."""
    deg = coef.shape[0] - 1
    while deg > 0 and abs(coef[deg]) <= 1e-14 * np.max(np.abs(coef)):
        deg -= 1
    if deg == 0:
        return 0
    if deg == 1:
        x = -coef[0] / coef[1]
        if lo <= x <= hi:
            out[0] = x
            return 1
        return 0
    d = np.empty(deg)
    for k in range(1, deg + 1):
        d[k - 1] = k * coef[k]
    crit = np.empty(deg)
    nc = _poly_real_roots(d, lo, hi, crit)
    pts = np.empty(nc + 2)
    pts[0] = lo
    for i in range(nc):
        pts[i + 1] = crit[i]
    pts[nc + 1] = hi
    count = 0
    for i in range(nc + 1):
        a, b = pts[i], pts[i + 1]
        fa = 0.0
        fb = 0.0
        for k in range(deg, -1, -1):
            fa = fa * a + coef[k]
            fb = fb * b + coef[k]
        if fa == 0.0:
            if count == 0 or abs(out[count - 1] - a) > 1e-12 * (1.0 + abs(a)):
                out[count] = a
                count += 1
            continue
        if (fa < 0.0) == (fb < 0.0):
            continue
        for _ in range(200):
            m = 0.5 * (a + b)
            fm = 0.0
            for k in range(deg, -1, -1):
                fm = fm * m + coef[k]
            if (fm < 0.0) == (fa < 0.0):
                a, fa = m, fm
            else:
                b = m
            if b - a <= 1e-15 * (1.0 + abs(m)):
                break
        out[count] = 0.5 * (a + b)
        count += 1
    return count


@njit(cache=True)
def _solve_pose(
    C: FloatArray,
    prismatic: NDArray[np.bool_],
    c4: FloatArray,
    h: float,
    c6: FloatArray,
    q3_range: FloatArray,
    mode: int,
    T: FloatArray,
    accept: float,
    out_q: FloatArray,
    out_res: FloatArray,
    out_flags: NDArray[np.int64],
) -> int:
    """All solutions of one pose (lengths scaled). Flags: bit 1 near-singular family member."""
    # Wrist centre: target frame, back through the tool constant, point c6 on axis 6.
    C6inv_p = np.empty(3)
    R6 = C[6][:3, :3]
    for i in range(3):
        C6inv_p[i] = -(R6[0, i] * C[6][0, 3] + R6[1, i] * C[6][1, 3] + R6[2, i] * C[6][2, 3])
    p_w = _mv(T[:3, :3], _mv(R6.T, c6) + C6inv_p) + T[:3, 3]
    # ... in the frame of joint 1 before its rotation.
    R0 = C[0][:3, :3]
    t = _mv(R0.T, p_w - C[0][:3, 3])
    t[2] -= h
    roots = np.empty(_CAP)
    doubles = np.zeros(_CAP, dtype=np.bool_)
    if mode > 0:
        # One equation ignores q2 (mode 1: |v|, when axes 1 and 2 meet; mode 2: the height):
        # it alone fixes q3. Degree one in (cos q3, sin q3), or a quadratic in a prismatic q3.
        k = 2 if mode == 1 else 5
        ys3 = np.empty(3)
        xs3 = np.empty(3)
        for i in range(3):
            xs3[i] = (
                (q3_range[0] + (q3_range[1] - q3_range[0]) * i / 2.0)
                if prismatic[2]
                else (i * 2.0 * np.pi / 3.0)
            )
            ys3[i] = _abc(C, prismatic, xs3[i], c4, h, t)[k]
        nroots = 0
        if prismatic[2]:
            V = np.empty((3, 3))
            for r in range(3):
                for j in range(3):
                    V[r, j] = xs3[r] ** j
            coef, _ = _lu_solve(V, ys3.copy())
            nroots = _poly_real_roots(coef, q3_range[0], q3_range[1], roots)
        else:
            c0 = (ys3[0] + ys3[1] + ys3[2]) / 3.0
            ca = (2.0 * ys3[0] - ys3[1] - ys3[2]) / 3.0
            sb = (ys3[1] - ys3[2]) / np.sqrt(3.0)
            amp = np.hypot(ca, sb)
            if amp > 0.0 and abs(c0) <= amp * (1.0 + 1e-12):
                base = np.arctan2(sb, ca)
                off = np.arccos(min(1.0, max(-1.0, -c0 / amp)))
                roots[0] = base + off
                roots[1] = base - off
                doubles[0] = doubles[1] = off < 1e-6
                nroots = 2
    elif prismatic[2]:
        # Degree <= 6 in q3 (|v|^2 is quadratic, the height linear): 7 samples fix it.
        xs = np.empty(7)
        ys = np.empty(7)
        lo, hi = q3_range[0], q3_range[1]
        mid = 0.5 * (lo + hi)
        half = 0.5 * (hi - lo)
        for k in range(7):
            xs[k] = np.cos(np.pi * (k + 0.5) / 7.0)  # Chebyshev nodes on [-1, 1]
            ys[k] = _residual(C, prismatic, mid + half * xs[k], c4, h, t)
        V = np.empty((7, 7))
        for r in range(7):
            for k in range(7):
                V[r, k] = xs[r] ** k
        coef, _ = _lu_solve(V, ys.copy())
        nroots = _poly_real_roots(coef, -1.0, 1.0, roots)
        for r in range(nroots):
            roots[r] = mid + half * roots[r]
    else:
        a = np.zeros(5)
        b = np.zeros(5)
        for n in range(9):
            phi = n * 2.0 * np.pi / 9.0
            y = _residual(C, prismatic, phi, c4, h, t)
            for k in range(5):
                f = 1.0 / 9.0 if k == 0 else 2.0 / 9.0
                a[k] += f * y * np.cos(k * phi)
                b[k] += f * y * np.sin(k * phi)
        nroots = _trig_roots(
            a,
            b,
            np.ascontiguousarray(_SCAN_COS[:, :5]),
            np.ascontiguousarray(_SCAN_SIN[:, :5]),
            _SCAN,
            roots,
            doubles,
        )
        if nroots < 0:
            nroots = 0
    kept = 0
    q = np.empty(6)
    pairs = np.empty((2 * nroots, 2))
    npairs = 0
    pair_root = np.empty(2 * nroots, dtype=np.int64)
    for r in range(nroots):
        q3 = roots[r]
        a1, b1, c1, a2, b2, c2 = _abc(C, prismatic, q3, c4, h, t)
        d = a1 * b2 - a2 * b1
        n1 = np.hypot(a1, b1)
        n2 = np.hypot(a2, b2)
        size = 1.0 + np.sum(t * t)
        if n1 > 1e-10 * size and n2 > 1e-10 * size and abs(d) > 1e-7 * n1 * n2:
            pairs[npairs, 0] = q3
            pairs[npairs, 1] = np.arctan2((c1 * a2 - c2 * a1) / d, (b1 * c2 - b2 * c1) / d)
            pair_root[npairs] = r
            npairs += 1
            continue
        # Dependent equations (e.g. axes 1 and 2 meet, so |v| ignores q2): the stronger one,
        # a cos q2 + b sin q2 = -c, has two roots.
        if n1 >= n2:
            aa, bb, cc0, nn = a1, b1, c1, n1
        else:
            aa, bb, cc0, nn = a2, b2, c2, n2
        if nn < 1e-12 or abs(cc0) > nn * (1.0 + 1e-9):
            continue
        base = np.arctan2(bb, aa)
        off = np.arccos(min(1.0, max(-1.0, -cc0 / nn)))
        for sg in (-1.0, 1.0):
            pairs[npairs, 0] = q3
            pairs[npairs, 1] = base + sg * off
            pair_root[npairs] = r
            npairs += 1
    for pi in range(npairs):
        q3 = pairs[pi, 0]
        q2 = pairs[pi, 1]
        r = pair_root[pi]
        v = _v(C, prismatic, q2, q3, c4, h)
        flag = 0
        if np.hypot(v[0], v[1]) < 1e-9 or np.hypot(t[0], t[1]) < 1e-9:
            q1 = 0.0
            flag = 2  # wrist centre on axis 1: q1 is free
        else:
            q1 = np.arctan2(t[1], t[0]) - np.arctan2(v[1], v[0])
        A = _motion(C[0], q1, prismatic[0])
        A = _mm(A, C[1])
        A = _mm(_motion(A, q2, prismatic[1]), C[2])
        A = _mm(_motion(A, q3, prismatic[2]), C[3])
        # W = rotation of joints 4..6: Rz(q4) R4 Rz(q5) R5 Rz(q6) = A^T R_T R6^T
        W = _m3(_m3(A[:3, :3].T, T[:3, :3]), R6.T)
        R4 = C[4][:3, :3]
        R5 = C[5][:3, :3]
        u = R5[:, 2]
        w = W[:, 2]
        rr = R4[:, 2]
        ca = rr[0] * w[0] + rr[1] * w[1]
        cb = rr[0] * w[1] - rr[1] * w[0]
        cc = u[2] - rr[2] * w[2]
        amp = np.hypot(ca, cb)
        if amp < 1e-9:
            q4s = np.array([0.0])
            wflag = 2  # axes 4 and 6 aligned: q4 + q6 only is determined
        else:
            ratio = cc / amp
            if abs(ratio) > 1.0 + 1e-9:
                continue
            ratio = min(1.0, max(-1.0, ratio))
            base = np.arctan2(cb, ca)
            off = np.arccos(ratio)
            q4s = np.array([base + off, base - off])
            wflag = 0
        for q4 in q4s:
            c, s = np.cos(q4), np.sin(q4)
            Rz4t = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
            yw = _mv(_m3(R4.T, Rz4t), w)
            q5 = np.arctan2(yw[1], yw[0]) - np.arctan2(u[1], u[0])
            c5, s5 = np.cos(q5), np.sin(q5)
            Rz5 = np.array([[c5, -s5, 0.0], [s5, c5, 0.0], [0.0, 0.0, 1.0]])
            M = _m3(_m3(_m3(_m3(Rz4t.T, R4), Rz5), R5).T, W)
            q6 = np.arctan2(M[1, 0], M[0, 0])
            q[0], q[1], q[2], q[3], q[4], q[5] = q1, q2, q3, q4, q5, q6
            pos, rot, jr = _polish(C, prismatic, T, q, 2)
            if not (pos <= accept and rot <= accept):
                continue
            for i in range(6):
                if not prismatic[i]:
                    q[i] = _wrap(q[i])
            dup = False
            for m in range(kept):
                same = True
                for i in range(6):
                    diff = q[i] - out_q[m, i]
                    if not prismatic[i]:
                        diff = _wrap(diff)
                    if abs(diff) > 1e-6:
                        same = False
                        break
                if same:
                    dup = True
                    break
            if dup or kept >= out_q.shape[0]:
                continue
            out_q[kept] = q
            out_res[kept, 0] = pos
            out_res[kept, 1] = rot
            out_flags[kept] = flag | wflag | (2 if jr < 1e-6 else 0) | (1 if doubles[r] else 0)
            kept += 1
    return kept


@njit(cache=True)
def _solve_serial(
    C: FloatArray,
    prismatic: NDArray[np.bool_],
    c4: FloatArray,
    h: float,
    c6: FloatArray,
    q3_range: FloatArray,
    mode: int,
    Ts: FloatArray,
    accept: float,
    out_q: FloatArray,
    out_res: FloatArray,
    out_flags: NDArray[np.int64],
    out_count: NDArray[np.int64],
) -> None:
    for n in range(Ts.shape[0]):
        out_count[n] = _solve_pose(
            C,
            prismatic,
            c4,
            h,
            c6,
            q3_range,
            mode,
            Ts[n],
            accept,
            out_q[n],
            out_res[n],
            out_flags[n],
        )


@njit(cache=True, parallel=True)
def _solve_parallel(
    C: FloatArray,
    prismatic: NDArray[np.bool_],
    c4: FloatArray,
    h: float,
    c6: FloatArray,
    q3_range: FloatArray,
    mode: int,
    Ts: FloatArray,
    accept: float,
    out_q: FloatArray,
    out_res: FloatArray,
    out_flags: NDArray[np.int64],
    out_count: NDArray[np.int64],
) -> None:
    for n in prange(Ts.shape[0]):
        out_count[n] = _solve_pose(
            C,
            prismatic,
            c4,
            h,
            c6,
            q3_range,
            mode,
            Ts[n],
            accept,
            out_q[n],
            out_res[n],
            out_flags[n],
        )


def wrist_center(arm: SerialArm, tol: float = 1e-9) -> FloatArray | None:
    """The point where axes 4, 5, 6 meet, in the frame of joint 4's axis (None if they don't).

    Returned as the point on the local z axis of joint 4 (``(0, 0, z)``) and, second row, on the
    local z axis of joint 6, both in the model unit.
    """
    if arm.n_joints != 6:
        return None
    C = z_axis_chain(arm)
    # Axis i (1-based) at zero: frame after C[i-1] products: origin and z.
    F = C[0].copy()
    axes = []
    for i in range(6):
        axes.append((F[:3, 3].copy(), F[:3, 2].copy()))
        F = F @ C[i + 1]
    (o4, z4), (o5, z5), (o6, z6) = axes[3], axes[4], axes[5]
    # Point on axis 4 closest to axis 5, then check it lies on axis 6 too.
    scale = max(1.0, float(np.max(np.abs(C[1:6, :3, 3]))))
    n = np.cross(z4, z5)
    if np.linalg.norm(n) < 1e-9:
        return None
    s4 = np.dot(np.cross(o5 - o4, z5), n) / np.dot(n, n)
    p = o4 + s4 * z4
    for o, z in ((o5, z5), (o6, z6)):
        r = p - o
        if np.linalg.norm(r - np.dot(r, z) * z) > tol * scale:
            return None
    return np.array([[0.0, 0.0, s4], [0.0, 0.0, float(np.dot(p - o6, z6))]])


class SphericalWristSolver:
    """Closed-form IK (all solutions) of a 6-joint arm whose last three axes meet in a point."""

    def __init__(self, arm: SerialArm, *, accept: float = 1e-8):
        kinds = [j.kind for j in arm.joints]
        if (
            arm.n_joints != 6
            or kinds[0] is not JointKind.REVOLUTE
            or kinds[1] is not JointKind.REVOLUTE
            or any(k is not JointKind.REVOLUTE for k in kinds[3:])
        ):
            raise InvalidInputError(
                f"model {arm.name!r}: the spherical-wrist solver needs joints R, R, R|P, R, R, R"
            )
        centre = wrist_center(arm)
        if centre is None:
            raise InvalidInputError(f"model {arm.name!r}: axes 4, 5 and 6 do not meet in a point")
        self.arm = arm
        C = z_axis_chain(arm)
        shifts = [float(np.linalg.norm(C[k, :3, 3])) for k in range(7)]
        self.length_scale = chain_length_scale(C)
        C[:, :3, 3] /= self.length_scale
        self._C = np.ascontiguousarray(C)
        self._prismatic = np.array([k is JointKind.PRISMATIC for k in kinds])
        self._c4 = centre[0] / self.length_scale
        # Point of axis 1 (local z through the origin) nearest to axis 2 (o2 + u z2).
        o2, z2 = self._C[1, :3, 3], self._C[1, :3, 2]
        ez = np.array([0.0, 0.0, 1.0])
        cz = float(z2 @ ez)
        self._h = (
            0.0
            if abs(1.0 - cz * cz) < 1e-12
            else float((o2 @ ez - cz * (o2 @ z2)) / (1.0 - cz * cz))
        )
        self._c6 = centre[1] / self.length_scale
        lo, hi = arm.joints[2].limits
        if self._prismatic[2]:
            reach = 10.0 * (1.0 + float(np.sum(shifts)) / self.length_scale)
            lo = max(lo / self.length_scale, -reach) if np.isfinite(lo) else -reach
            hi = min(hi / self.length_scale, reach) if np.isfinite(hi) else reach
        self._q3_range = np.array([lo, hi], dtype=np.float64)
        self.accept = accept
        # Does |v| (or the height) ignore q2 for every q3? Then the elimination squares a
        # factor and its roots turn double: solve that equation alone instead.
        zero = np.zeros(3)
        coefs = np.array(
            [
                _abc(self._C, self._prismatic, x, self._c4, self._h, zero)
                for x in np.linspace(self._q3_range[0], self._q3_range[1], 5)
                if np.isfinite(x)
            ]
            if self._prismatic[2]
            else [
                _abc(self._C, self._prismatic, x, self._c4, self._h, zero)
                for x in (0.3, 1.7, 2.9, -2.1)
            ]
        )
        size = 1.0 + float(np.max(np.abs(coefs)))
        self._mode = 0
        if np.max(np.abs(coefs[:, 0:2])) <= 1e-10 * size:
            self._mode = 1
        elif np.max(np.abs(coefs[:, 3:5])) <= 1e-10 * size:
            self._mode = 2

    def solve_batch(self, Ts: FloatArray) -> list[IKResult]:
        T = prepare_targets(Ts, self.length_scale)
        N = T.shape[0]
        q = np.zeros((N, _CAP, 6))
        res = np.zeros((N, _CAP, 2))
        flags = np.zeros((N, _CAP), dtype=np.int64)
        count = np.zeros(N, dtype=np.int64)
        kernel = _solve_parallel if N >= 256 else _solve_serial
        kernel(
            self._C,
            self._prismatic,
            self._c4,
            self._h,
            self._c6,
            self._q3_range,
            self._mode,
            T,
            self.accept,
            q,
            res,
            flags,
            count,
        )
        q[:, :, self._prismatic] *= self.length_scale
        return solved_poses(
            q,
            res,
            flags,
            count,
            self.length_scale,
            ["spherical-wrist"] * N,
            ["no real solution: the pose is out of reach"] * N,
        )

    def solve(self, T: FloatArray) -> IKResult:
        return self.solve_batch(np.asarray(T, dtype=np.float64)[None])[0]
