"""Closed-form IK of arms with a spherical wrist (Pieper): every solution, no iteration.

Applies when the last three joint axes meet in one point (the wrist centre) and the first three
joints are revolute, revolute, revolute-or-prismatic (the seed arm, seed 003's RRP welder,
PUMA 560, most industrial 6-axis arms). The pose splits in two:

* **Position** of the wrist centre from joints 1-3. Rotating about axis 1 keeps the squared
  distance and the height along axis 1, so ``F1(q2, q3) = |v|^2`` and ``F2(q2, q3) = v_z`` must
  match the target's. Both are of degree one in ``cos q2, sin q2``; eliminating them leaves one
  equation in ``q3``: a trigonometric polynomial of degree 4 (revolute) or a polynomial of
  degree 6 (prismatic), whose real roots give the positions. The six coefficient functions of
  ``q3`` are measured once per arm on small grids (not derived symbolically); a pose only
  shifts two of them (by ``|t|^2`` and ``t_z``), so solving a pose allocates almost nothing.
* **Orientation** from joints 4-6 with any twists (the oblique wrists of painting robots too):
  the direction of axis 6 fixes ``q4`` through ``a cos q4 + b sin q4 = c`` (two roots), then
  ``q5`` and ``q6`` follow in closed form.

Every candidate gets two Newton steps on the full pose and is verified by forward kinematics.
A wrist centre on axis 1 or aligned axes 4 and 6 are one-parameter families: one member is
returned, flagged near-singular.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from armpath.errors import InvalidInputError
from armpath.ik.compiled import CompiledSolver, KernelOutput, padded_outputs
from armpath.ik.kernels import (
    keep_solution,
    newton_polish,
    scan_tables,
    sort_solutions,
    trig_roots,
)
from armpath.ik.result import chain_length_scale
from armpath.jit import njit, prange, threads_pay_off
from armpath.kinematics import z_axis_chain
from armpath.model.serial_arm import JointKind, SerialArm

FloatArray = NDArray[np.float64]
_CAP = 16
#: Root scan of the degree-4 trigonometric polynomial in q3 (3 deg steps; close pairs of roots
#: are still separated by the critical points, see :func:`armpath.ik.kernels.trig_roots`).
_SCAN, _SCAN_COS, _SCAN_SIN = scan_tables(120, 5)
#: q3 samples of the revolute residual (9: harmonics 0..4) and their discrete Fourier transform
#: (rows a0..a4, b1..b4).
_RES_PHI = np.asarray(np.arange(9) * (2.0 * np.pi / 9.0), dtype=np.float64)
_RES_FIT_R = np.asarray(
    np.vstack(
        [
            np.cos(np.outer(np.arange(5), _RES_PHI)) * np.array([1.0, 2, 2, 2, 2])[:, None] / 9.0,
            np.sin(np.outer(np.arange(1, 5), _RES_PHI)) * 2.0 / 9.0,
        ]
    ),
    dtype=np.float64,
)
#: Chebyshev nodes on [-1, 1] for the prismatic residual (a polynomial of degree <= 6).
_RES_X_P = np.asarray(np.cos(np.pi * (np.arange(7) + 0.5) / 7.0), dtype=np.float64)
_RES_FIT_P = np.asarray(np.linalg.inv(np.vander(_RES_X_P, 7, increasing=True)), dtype=np.float64)
#: Three samples for the single equations (modes 1, 2): {0, 120, 240} deg -> (c0, cos, sin), or
#: x in {-1, 0, 1} -> polynomial coefficients.
_MODE_PHI: FloatArray = np.array([0.0, 2.0 * np.pi / 3.0, 4.0 * np.pi / 3.0])
_MODE_FIT_R = np.asarray(
    np.linalg.inv(np.stack([np.ones(3), np.cos(_MODE_PHI), np.sin(_MODE_PHI)], axis=1)),
    dtype=np.float64,
)
_MODE_X_P: FloatArray = np.array([-1.0, 0.0, 1.0])
_MODE_FIT_P = np.asarray(np.linalg.inv(np.vander(_MODE_X_P, 3, increasing=True)), dtype=np.float64)


def _joint(T: FloatArray, value: float, prismatic: bool) -> FloatArray:
    """``T @ Rz(value)`` or ``T @ Tz(value)`` (set-up only)."""
    M = np.eye(4)
    if prismatic:
        M[2, 3] = value
    else:
        c, s = np.cos(value), np.sin(value)
        M[:2, :2] = [[c, -s], [s, c]]
    return T @ M


def _position_functions(
    C: FloatArray, prismatic: NDArray[np.bool_], c4: FloatArray, h: float, q3: float
) -> FloatArray:
    """The six functions (a1, b1, c1, a2, b2, c2) of ``q3`` for a target at the origin:
    ``|v|^2 = a1 cos q2 + b1 sin q2 + c1`` and ``v_z = a2 cos q2 + b2 sin q2 + c2`` for the wrist
    centre ``v = C1 Z(q2) C2 Z(q3) C3 c4`` measured from ``(0, 0, h)`` (set-up only)."""
    f = np.empty((3, 2))
    for i, q2 in enumerate(_MODE_PHI):
        A = _joint(_joint(C[1], q2, False) @ C[2], q3, bool(prismatic[2])) @ C[3]
        v = A[:3, :3] @ c4 + A[:3, 3]
        v[2] -= h
        f[i] = v @ v, v[2]
    c0, ca, sb = _MODE_FIT_R @ f  # rows: constant, cos, sin
    return np.array([ca[0], sb[0], c0[0], ca[1], sb[1], c0[1]])


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
def _turn_then(A: FloatArray, phi: float, turn: bool, R: FloatArray, out: FloatArray) -> None:
    """``out = A Rz(phi) R`` on the 3x3 rotation parts (``A R`` without ``turn``)."""
    c, s = (np.cos(phi), np.sin(phi)) if turn else (1.0, 0.0)
    for i in range(3):
        x = A[i, 0] * c + A[i, 1] * s
        y = -A[i, 0] * s + A[i, 1] * c
        z = A[i, 2]
        for j in range(3):
            out[i, j] = x * R[0, j] + y * R[1, j] + z * R[2, j]


@njit(cache=True)
def _solve_pose(
    C: FloatArray,
    prismatic: NDArray[np.bool_],
    geometry: FloatArray,
    coef: FloatArray,
    res_tab: FloatArray,
    res_fit: FloatArray,
    mode_tab: FloatArray,
    mode_fit: FloatArray,
    mode: int,
    T: FloatArray,
    accept: float,
    out_q: FloatArray,
    out_res: FloatArray,
    out_flags: NDArray[np.int64],
) -> int:
    """All solutions of one pose (lengths scaled). Flags: bit 0 near-double, bit 1 near-singular.

    ``geometry`` = (k6 (3): wrist centre in the tool frame, p3 (3): wrist centre in the frame
    after joint 3, h, q3 mid, q3 half-range); ``coef`` (5, 6): the six position functions of q3
    in the basis (1, cos, sin, cos 2, sin 2) or, prismatic, (1, x, x^2) with
    x = (q3 - mid) / half; ``res_tab``/``mode_tab`` the same functions at the residual's and the
    single equation's samples, ``res_fit``/``mode_fit`` the maps from samples to coefficients.
    """
    h = geometry[6]
    mid = geometry[7]
    half = geometry[8]
    prism3 = prismatic[2]
    # Wrist centre in the frame of joint 1 before its rotation, from (0, 0, h).
    t = np.empty(3)
    for i in range(3):
        t[i] = T[i, 0] * geometry[0] + T[i, 1] * geometry[1] + T[i, 2] * geometry[2] + T[i, 3]
    t0 = t[0] - C[0, 0, 3]
    t1 = t[1] - C[0, 1, 3]
    t2 = t[2] - C[0, 2, 3]
    for i in range(3):
        t[i] = C[0, 0, i] * t0 + C[0, 1, i] * t1 + C[0, 2, i] * t2
    t[2] -= h
    tt = t[0] * t[0] + t[1] * t[1] + t[2] * t[2]
    tz = t[2]
    roots = np.empty(_CAP)
    doubles = np.zeros(_CAP, dtype=np.bool_)
    nroots = 0
    if mode > 0:
        # One equation ignores q2 (mode 1: |v|, when axes 1 and 2 meet; mode 2: the height):
        # it alone fixes q3. Degree one in (cos q3, sin q3), or a quadratic in a prismatic q3.
        k = 2 if mode == 1 else 5
        shift = tt if mode == 1 else tz
        c3 = np.zeros(3)
        for r in range(3):
            for i in range(3):
                c3[r] += mode_fit[r, i] * (mode_tab[i, k] - shift)
        if prism3:
            nroots = _poly_real_roots(c3, -1.0, 1.0, roots)
        else:
            amp = np.hypot(c3[1], c3[2])
            if amp > 0.0 and abs(c3[0]) <= amp * (1.0 + 1e-12):
                base = np.arctan2(c3[2], c3[1])
                off = np.arccos(min(1.0, max(-1.0, -c3[0] / amp)))
                roots[0] = base + off
                roots[1] = base - off
                doubles[0] = doubles[1] = off < 1e-6
                nroots = 2
    else:
        # Residual x^2 + y^2 - d^2 of eliminating (cos q2, sin q2) at the samples.
        m = res_tab.shape[0]
        ys = np.empty(m)
        for n in range(m):
            a1, b1, c1, a2, b2, c2 = (
                res_tab[n, 0],
                res_tab[n, 1],
                res_tab[n, 2] - tt,
                res_tab[n, 3],
                res_tab[n, 4],
                res_tab[n, 5] - tz,
            )
            d = a1 * b2 - a2 * b1
            x = b1 * c2 - b2 * c1
            y = c1 * a2 - c2 * a1
            ys[n] = x * x + y * y - d * d
        fit = np.zeros(res_fit.shape[0])
        for r in range(res_fit.shape[0]):
            for n in range(m):
                fit[r] += res_fit[r, n] * ys[n]
        if prism3:
            nroots = _poly_real_roots(fit, -1.0, 1.0, roots)
        else:
            a = np.zeros(5)
            b = np.zeros(5)
            for i in range(5):  # element by element: slice assignment is slow to compile
                a[i] = fit[i]
                if i > 0:
                    b[i] = fit[4 + i]
            nroots = max(0, trig_roots(a, b, _SCAN_COS, _SCAN_SIN, _SCAN, roots, doubles))
    if prism3:
        for r in range(nroots):
            roots[r] = mid + half * roots[r]
    # (q3, q2) pairs.
    pairs = np.empty((2 * nroots, 2))
    pair_root = np.empty(2 * nroots, dtype=np.int64)
    npairs = 0
    size = 1.0 + tt
    for r in range(nroots):
        q3 = roots[r]
        if prism3:
            x = (q3 - mid) / half
            b0, b1_, b2_, b3, b4 = 1.0, x, x * x, 0.0, 0.0
        else:
            c, s = np.cos(q3), np.sin(q3)
            b0, b1_, b2_, b3, b4 = 1.0, c, s, c * c - s * s, 2.0 * s * c
        f = np.empty(6)
        for j in range(6):
            f[j] = (
                coef[0, j] * b0
                + coef[1, j] * b1_
                + coef[2, j] * b2_
                + coef[3, j] * b3
                + coef[4, j] * b4
            )
        a1, b1, c1, a2, b2, c2 = f[0], f[1], f[2] - tt, f[3], f[4], f[5] - tz
        d = a1 * b2 - a2 * b1
        n1 = np.hypot(a1, b1)
        n2 = np.hypot(a2, b2)
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
    q = np.empty(6)
    S1 = np.empty((3, 3))
    S2 = np.empty((3, 3))
    W = np.empty((3, 3))
    scratch = np.empty((3, 6, 6))
    R4 = C[4]
    R5 = C[5]
    R6 = C[6]
    kept = 0
    for pi in range(npairs):
        q3 = pairs[pi, 0]
        q2 = pairs[pi, 1]
        r = pair_root[pi]
        # Wrist centre v = C1 Z(q2) C2 Z(q3) p3 - (0, 0, h), for q1.
        p0, p1, p2 = geometry[3], geometry[4], geometry[5]
        if prism3:
            p2 += q3
        else:
            c, s = np.cos(q3), np.sin(q3)
            p0, p1 = c * p0 - s * p1, s * p0 + c * p1
        w0 = C[2, 0, 0] * p0 + C[2, 0, 1] * p1 + C[2, 0, 2] * p2 + C[2, 0, 3]
        w1 = C[2, 1, 0] * p0 + C[2, 1, 1] * p1 + C[2, 1, 2] * p2 + C[2, 1, 3]
        w2 = C[2, 2, 0] * p0 + C[2, 2, 1] * p1 + C[2, 2, 2] * p2 + C[2, 2, 3]
        c, s = np.cos(q2), np.sin(q2)
        w0, w1 = c * w0 - s * w1, s * w0 + c * w1
        v0 = C[1, 0, 0] * w0 + C[1, 0, 1] * w1 + C[1, 0, 2] * w2 + C[1, 0, 3]
        v1 = C[1, 1, 0] * w0 + C[1, 1, 1] * w1 + C[1, 1, 2] * w2 + C[1, 1, 3]
        flag = 0
        if np.hypot(v0, v1) < 1e-9 or np.hypot(t[0], t[1]) < 1e-9:
            q1 = 0.0
            flag = 2  # wrist centre on axis 1: q1 is free
        else:
            q1 = np.arctan2(t[1], t[0]) - np.arctan2(v1, v0)
        # Rotation of joints 1-3, then W = rotation of joints 4..6 = A^T R_T R6^T.
        _turn_then(C[0], q1, True, C[1], S1)
        _turn_then(S1, q2, True, C[2], S2)
        _turn_then(S2, q3, not prism3, C[3], S1)
        for i in range(3):
            for j in range(3):
                S2[i, j] = S1[0, i] * T[0, j] + S1[1, i] * T[1, j] + S1[2, i] * T[2, j]
        for i in range(3):
            for j in range(3):
                W[i, j] = S2[i, 0] * R6[j, 0] + S2[i, 1] * R6[j, 1] + S2[i, 2] * R6[j, 2]
        # Rz(q4) R4 Rz(q5) R5 Rz(q6) = W. Axis 6's direction: (R4 z)^T Rz(-q4) w = (R5 z)_z.
        u0, u1, u2 = R5[0, 2], R5[1, 2], R5[2, 2]
        x0, x1, x2 = W[0, 2], W[1, 2], W[2, 2]
        ca = R4[0, 2] * x0 + R4[1, 2] * x1
        cb = R4[0, 2] * x1 - R4[1, 2] * x0
        cc = u2 - R4[2, 2] * x2
        amp = np.hypot(ca, cb)
        nq4 = 1
        q4a = 0.0
        q4b = 0.0
        wflag = 0
        if amp < 1e-9:
            wflag = 2  # axes 4 and 6 aligned: q4 + q6 only is determined
        else:
            ratio = cc / amp
            if abs(ratio) > 1.0 + 1e-9:
                continue
            base = np.arctan2(cb, ca)
            off = np.arccos(min(1.0, max(-1.0, ratio)))
            q4a = base + off
            q4b = base - off
            nq4 = 2
        for j4 in range(nq4):
            q4 = q4a if j4 == 0 else q4b
            c, s = np.cos(q4), np.sin(q4)
            # y = R4^T Rz(-q4) w = Rz(q5) u
            z0, z1 = c * x0 + s * x1, -s * x0 + c * x1
            y0 = R4[0, 0] * z0 + R4[1, 0] * z1 + R4[2, 0] * x2
            y1 = R4[0, 1] * z0 + R4[1, 1] * z1 + R4[2, 1] * x2
            q5 = np.arctan2(y1, y0) - np.arctan2(u1, u0)
            # First column of R5^T Rz(-q5) R4^T Rz(-q4) W = Rz(q6): (cos q6, sin q6, 0).
            e0, e1, e2 = W[0, 0], W[1, 0], W[2, 0]
            e0, e1 = c * e0 + s * e1, -s * e0 + c * e1
            g0 = R4[0, 0] * e0 + R4[1, 0] * e1 + R4[2, 0] * e2
            g1 = R4[0, 1] * e0 + R4[1, 1] * e1 + R4[2, 1] * e2
            g2 = R4[0, 2] * e0 + R4[1, 2] * e1 + R4[2, 2] * e2
            c5, s5 = np.cos(q5), np.sin(q5)
            g0, g1 = c5 * g0 + s5 * g1, -s5 * g0 + c5 * g1
            k0 = R5[0, 0] * g0 + R5[1, 0] * g1 + R5[2, 0] * g2
            k1 = R5[0, 1] * g0 + R5[1, 1] * g1 + R5[2, 1] * g2
            q6 = np.arctan2(k1, k0)
            q[0], q[1], q[2], q[3], q[4], q[5] = q1, q2, q3, q4, q5, q6
            pos, rot, jr = newton_polish(C, prismatic, T, q, 2, scratch)
            if not (pos <= accept and rot <= accept):
                continue
            flags = flag | wflag | (2 if jr < 1e-6 else 0) | (1 if doubles[r] else 0)
            kept, _ = keep_solution(q, prismatic, pos, rot, flags, out_q, out_res, out_flags, kept)
    sort_solutions(out_q, out_res, out_flags, kept)
    return kept


@njit(cache=True)
def _solve_serial(
    C: FloatArray,
    prismatic: NDArray[np.bool_],
    geometry: FloatArray,
    coef: FloatArray,
    res_tab: FloatArray,
    res_fit: FloatArray,
    mode_tab: FloatArray,
    mode_fit: FloatArray,
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
            geometry,
            coef,
            res_tab,
            res_fit,
            mode_tab,
            mode_fit,
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
    geometry: FloatArray,
    coef: FloatArray,
    res_tab: FloatArray,
    res_fit: FloatArray,
    mode_tab: FloatArray,
    mode_fit: FloatArray,
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
            geometry,
            coef,
            res_tab,
            res_fit,
            mode_tab,
            mode_fit,
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


class SphericalWristSolver(CompiledSolver):
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
        self.method_names = ("spherical-wrist",)
        C = z_axis_chain(arm)
        shifts = [float(np.linalg.norm(C[k, :3, 3])) for k in range(7)]
        self.length_scale = chain_length_scale(C)
        C[:, :3, 3] /= self.length_scale
        self._C = np.ascontiguousarray(C)
        self._prismatic = np.array([k is JointKind.PRISMATIC for k in kinds])
        # read-only like the other solvers' constant: the kernels they share compile once
        self._prismatic.setflags(write=False)
        self._any_prismatic = bool(self._prismatic.any())
        c4 = centre[0] / self.length_scale
        c6 = centre[1] / self.length_scale
        # Point of axis 1 (local z through the origin) nearest to axis 2 (o2 + u z2).
        o2, z2 = self._C[1, :3, 3], self._C[1, :3, 2]
        cz = float(z2[2])
        h = 0.0 if abs(1.0 - cz * cz) < 1e-12 else float((o2[2] - cz * (o2 @ z2)) / (1.0 - cz * cz))
        lo, hi = arm.joints[2].limits
        if self._prismatic[2]:
            reach = 10.0 * (1.0 + float(np.sum(shifts)) / self.length_scale)
            lo = max(lo / self.length_scale, -reach) if np.isfinite(lo) else -reach
            hi = min(hi / self.length_scale, reach) if np.isfinite(hi) else reach
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        R6, t6 = self._C[6, :3, :3], self._C[6, :3, 3]
        R3, t3 = self._C[3, :3, :3], self._C[3, :3, 3]
        self._geometry = np.concatenate([R6.T @ (c6 - t6), R3 @ c4 + t3, [h, mid, half]])
        self.accept = accept

        # The six position functions of q3, measured on grids (exact: their degree is known).
        def functions(q3s: FloatArray) -> FloatArray:
            return np.array(
                [_position_functions(self._C, self._prismatic, c4, h, float(x)) for x in q3s]
            )

        if self._prismatic[2]:
            xs: FloatArray = np.array([-1.0, 0.0, 1.0])
            self._coef: FloatArray = np.zeros((5, 6))
            self._coef[:3] = np.linalg.solve(
                np.vander(xs, 3, increasing=True), functions(mid + half * xs)
            )
            self._res_tab = functions(mid + half * _RES_X_P)
            self._res_fit = _RES_FIT_P
            self._mode_tab = functions(mid + half * _MODE_X_P)
            self._mode_fit = _MODE_FIT_P
        else:
            phi = np.asarray(np.arange(5) * (2.0 * np.pi / 5.0), dtype=np.float64)
            basis = np.asarray(
                np.stack(
                    [np.ones(5), np.cos(phi), np.sin(phi), np.cos(2 * phi), np.sin(2 * phi)], 1
                ),
                dtype=np.float64,
            )
            self._coef = np.asarray(np.linalg.solve(basis, functions(phi)), dtype=np.float64)
            self._res_tab = functions(_RES_PHI)
            self._res_fit = _RES_FIT_R
            self._mode_tab = functions(_MODE_PHI)
            self._mode_fit = _MODE_FIT_R
        # Does |v| (or the height) ignore q2 for every q3? Then the elimination squares a
        # factor and its roots turn double: solve that equation alone instead.
        coefs = np.abs(self._coef)
        size = 1.0 + float(np.max(coefs))
        self._mode = 0
        if np.max(coefs[:, 0:2]) <= 1e-10 * size:
            self._mode = 1
        elif np.max(coefs[:, 3:5]) <= 1e-10 * size:
            self._mode = 2

    def _run(self, T: FloatArray) -> KernelOutput:
        N = T.shape[0]
        q, res, flags, count = padded_outputs(N, _CAP)
        kernel = _solve_parallel if threads_pay_off(N, 64) else _solve_serial
        kernel(
            self._C,
            self._prismatic,
            self._geometry,
            self._coef,
            self._res_tab,
            self._res_fit,
            self._mode_tab,
            self._mode_fit,
            self._mode,
            T,
            self.accept,
            q,
            res,
            flags,
            count,
        )
        if self._any_prismatic:
            q[:, :, self._prismatic] *= self.length_scale
        zero = np.zeros(N, dtype=np.int64)
        return q, res, flags, count, zero, zero
